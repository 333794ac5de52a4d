//! The MCAP container (mcap.dev specification, version 0), as rosbag2's `mcap` storage plugin
//! writes it: magic, a header record, the data section (schemas, channels and messages, loose or
//! inside chunks compressed with zstd or lz4), `DataEnd`, an optional summary, a footer, magic.
//!
//! The reader scans the data section from the start and ignores the summary and every index:
//! a replay wants all messages anyway, and a recording cut short has no summary. Each record is
//! an opcode (u8), a length (u64) and a body; lengths are checked against the bytes left, chunk
//! sizes against the chunk, and a chunk's CRC (when non-zero) against its decompressed records.
//! O(file size + decompressed size).

use super::BagError;
use std::io::Read;

/// The 8 bytes at both ends of an MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

pub(crate) mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const STATISTICS: u8 = 0x0B;
    pub const DATA_END: u8 = 0x0F;
}

/// A message schema (rosbag2: the type name, `ros2msg`, and the definition text).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Schema {
    /// Its id in the file (a channel's schema id 0 means no schema, so a schema's is ≥ 1).
    pub id: u16,
    /// The message type (`nav_msgs/msg/OccupancyGrid`).
    pub name: String,
    /// How `data` is written: `ros2msg` for rosbag2.
    pub encoding: String,
    /// The definition text (`.msg` text with its dependencies, rosbag2's concatenation).
    pub data: Vec<u8>,
}

/// A channel: one topic with one schema.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Channel {
    /// Its id in the file.
    pub id: u16,
    /// The schema of its messages.
    pub schema_id: u16,
    /// The topic name (`/map`).
    pub topic: String,
    /// `cdr` for rosbag2.
    pub message_encoding: String,
    /// Key-value pairs rosbag2 stores per channel (QoS profiles, offered type hash).
    pub metadata: Vec<(String, String)>,
}

/// One recorded message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Message {
    /// The channel it was recorded on.
    pub channel_id: u16,
    /// The writer's sequence number (0 when it kept none).
    pub sequence: u32,
    /// When it was recorded, nanoseconds (rosbag2: receive time).
    pub log_time_ns: u64,
    /// When it was published, nanoseconds (rosbag2: the same as `log_time_ns` or the send time).
    pub publish_time_ns: u64,
    /// The serialised message (CDR for rosbag2).
    pub data: Vec<u8>,
}

/// Everything an MCAP file holds that a replay reads, messages sorted by log time (stable).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Mcap {
    /// `ros2` for rosbag2.
    pub profile: String,
    /// The writer's name and version.
    pub library: String,
    /// Every schema, in file order.
    pub schemas: Vec<Schema>,
    /// Every channel, in file order.
    pub channels: Vec<Channel>,
    /// Every message, sorted by `log_time_ns` (records with equal times in file order).
    pub messages: Vec<Message>,
}

/// A bounds-checked cursor over one record body; `base` is the body's offset in the file (for
/// messages).
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    base: u64,
    name: &'a str,
}

impl<'a> Body<'a> {
    fn err(&self, detail: String) -> BagError {
        BagError::Malformed { name: self.name.to_string(), offset: self.base + self.pos as u64, detail }
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], BagError> {
        match self.pos.checked_add(n).filter(|&e| e <= self.bytes.len()) {
            Some(end) => {
                let out = &self.bytes[self.pos..end];
                self.pos = end;
                Ok(out)
            }
            None => Err(self.err(format!("{what} runs past the end of its record ({n} bytes, {} left)", self.bytes.len() - self.pos))),
        }
    }

    fn u16(&mut self, what: &str) -> Result<u16, BagError> {
        let b = self.take(2, what)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }

    fn u32(&mut self, what: &str) -> Result<u32, BagError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, what: &str) -> Result<u64, BagError> {
        let b = self.take(8, what)?;
        Ok(u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
    }

    fn len_u32(&mut self, what: &str) -> Result<usize, BagError> {
        Ok(self.u32(what)? as usize)
    }

    fn string(&mut self, what: &str) -> Result<String, BagError> {
        let n = self.len_u32(what)?;
        let b = self.take(n, what)?;
        String::from_utf8(b.to_vec()).map_err(|_| self.err(format!("{what} is not UTF-8")))
    }

    fn rest(&mut self) -> &'a [u8] {
        let out = &self.bytes[self.pos..];
        self.pos = self.bytes.len();
        out
    }
}

/// Splits `bytes` into records: (opcode, body, body offset in the file).
fn records<'a>(bytes: &'a [u8], base: u64, name: &str, in_chunk: bool) -> impl Iterator<Item = Result<(u8, &'a [u8], u64), BagError>> {
    let name = name.to_string();
    let mut pos = 0usize;
    let mut failed = false;
    std::iter::from_fn(move || {
        if failed || pos >= bytes.len() {
            return None;
        }
        let at = base + pos as u64;
        let where_ = if in_chunk { " inside a chunk" } else { "" };
        let Some(head) = bytes.get(pos..pos + 9) else {
            failed = true;
            return Some(Err(BagError::Truncated {
                name: name.clone(),
                offset: at,
                detail: format!("a record header{where_} is cut off"),
            }));
        };
        let opcode = head[0];
        let len = u64::from_le_bytes([head[1], head[2], head[3], head[4], head[5], head[6], head[7], head[8]]);
        let left = (bytes.len() - pos - 9) as u64;
        if len > left {
            failed = true;
            return Some(Err(BagError::Truncated {
                name: name.clone(),
                offset: at,
                detail: format!("record {opcode:#04x}{where_} declares {len} bytes but only {left} follow"),
            }));
        }
        let start = pos + 9;
        pos = start + len as usize;
        Some(Ok((opcode, &bytes[start..pos], base + start as u64)))
    })
}

impl Mcap {
    /// Reads an MCAP file. `name` is used in errors only.
    pub fn parse(bytes: &[u8], name: &str) -> Result<Self, BagError> {
        if bytes.starts_with(b"SQLite format 3\0") {
            return Err(BagError::NotMcap {
                name: name.into(),
                detail: "a rosbag2 SQLite3 (.db3) bag, not MCAP: convert it with `ros2 bag convert` to storage_id mcap".into(),
            });
        }
        if !bytes.starts_with(MAGIC) {
            let detail = if bytes.is_empty() { "empty file".to_string() } else { "does not start with the MCAP magic bytes".to_string() };
            return Err(BagError::NotMcap { name: name.into(), detail });
        }
        let mut out = Mcap::default();
        let mut seen_header = false;
        let mut ended = false;
        for rec in records(&bytes[8..], 8, name, false) {
            let (opcode, body, at) = rec?;
            let mut b = Body { bytes: body, pos: 0, base: at, name };
            if !seen_header {
                if opcode != op::HEADER {
                    return Err(b.err(format!("first record is {opcode:#04x}, not the header (0x01)")));
                }
                out.profile = b.string("header profile")?;
                out.library = b.string("header library")?;
                seen_header = true;
                continue;
            }
            match opcode {
                op::CHUNK => out.read_chunk(&mut b)?,
                op::DATA_END | op::FOOTER => {
                    ended = true;
                    break;
                }
                _ => out.read_data_record(opcode, &mut b)?,
            }
        }
        if !seen_header {
            return Err(BagError::Truncated { name: name.into(), offset: 8, detail: "no header record after the magic".into() });
        }
        if !ended {
            return Err(BagError::Truncated {
                name: name.into(),
                offset: bytes.len() as u64,
                detail: "ends without a data-end record or footer (recording cut short? `mcap recover` can repair it)".into(),
            });
        }
        for m in &out.messages {
            if !out.channels.iter().any(|c| c.id == m.channel_id) {
                return Err(BagError::Malformed {
                    name: name.into(),
                    offset: 0,
                    detail: format!("a message on channel {} that no channel record defines", m.channel_id),
                });
            }
        }
        out.messages.sort_by_key(|m| m.log_time_ns);
        Ok(out)
    }

    /// A schema, channel or message record (loose or in a chunk); others are skipped.
    fn read_data_record(&mut self, opcode: u8, b: &mut Body) -> Result<(), BagError> {
        match opcode {
            op::SCHEMA => {
                let id = b.u16("schema id")?;
                let name = b.string("schema name")?;
                let encoding = b.string("schema encoding")?;
                let n = b.len_u32("schema data")?;
                let data = b.take(n, "schema data")?.to_vec();
                if !self.schemas.iter().any(|s| s.id == id) {
                    self.schemas.push(Schema { id, name, encoding, data });
                }
            }
            op::CHANNEL => {
                let id = b.u16("channel id")?;
                let schema_id = b.u16("channel schema id")?;
                let topic = b.string("channel topic")?;
                let message_encoding = b.string("channel message encoding")?;
                let map_len = b.len_u32("channel metadata")?;
                let map = b.take(map_len, "channel metadata")?;
                let mut m = Body { bytes: map, pos: 0, base: b.base, name: b.name };
                let mut metadata = Vec::new();
                while m.pos < map.len() {
                    metadata.push((m.string("metadata key")?, m.string("metadata value")?));
                }
                if !self.channels.iter().any(|c| c.id == id) {
                    self.channels.push(Channel { id, schema_id, topic, message_encoding, metadata });
                }
            }
            op::MESSAGE => {
                let channel_id = b.u16("message channel id")?;
                let sequence = b.u32("message sequence")?;
                let log_time_ns = b.u64("message log time")?;
                let publish_time_ns = b.u64("message publish time")?;
                self.messages.push(Message { channel_id, sequence, log_time_ns, publish_time_ns, data: b.rest().to_vec() });
            }
            _ => {}
        }
        Ok(())
    }

    fn read_chunk(&mut self, b: &mut Body) -> Result<(), BagError> {
        let _start = b.u64("chunk start time")?;
        let _end = b.u64("chunk end time")?;
        let uncompressed_size = b.u64("chunk uncompressed size")?;
        let crc = b.u32("chunk CRC")?;
        let compression = b.string("chunk compression")?;
        let size = b.u64("chunk records size")?;
        let records_at = b.base + b.pos as u64;
        let left = (b.bytes.len() - b.pos) as u64;
        if size > left {
            return Err(b.err(format!("chunk declares {size} bytes of records but its record holds {left}")));
        }
        let data = b.take(size as usize, "chunk records")?;
        let name = b.name;
        let bad = |detail: String| BagError::Decompress { name: name.into(), offset: records_at, compression: compression.clone(), detail };
        let decoded: Vec<u8> = match compression.as_str() {
            "" => data.to_vec(),
            "zstd" => read_at_most(ruzstd::decoding::StreamingDecoder::new(data).map_err(|e| bad(e.to_string()))?, uncompressed_size)
                .map_err(|e| bad(e.to_string()))?,
            "lz4" => read_at_most(lz4_flex::frame::FrameDecoder::new(data), uncompressed_size).map_err(|e| bad(e.to_string()))?,
            other => return Err(BagError::Compression { name: name.into(), offset: records_at, compression: other.into() }),
        };
        if decoded.len() as u64 != uncompressed_size {
            return Err(bad(format!("chunk holds {} bytes of records, its header says {uncompressed_size}", decoded.len())));
        }
        if crc != 0 && crc32fast::hash(&decoded) != crc {
            return Err(bad("CRC of the decompressed records does not match the chunk's".into()));
        }
        for rec in records(&decoded, 0, name, true) {
            let (opcode, body, _) = rec.map_err(|e| e.at_chunk(records_at))?;
            let mut inner = Body { bytes: body, pos: 0, base: records_at, name };
            match opcode {
                op::CHUNK => return Err(inner.err("a chunk inside a chunk".into())),
                _ => self.read_data_record(opcode, &mut inner)?,
            }
        }
        Ok(())
    }

    /// The channel of `id`.
    pub fn channel(&self, id: u16) -> Option<&Channel> {
        self.channels.iter().find(|c| c.id == id)
    }

    /// The schema (type) name of a channel, or "" when it has none.
    pub fn type_of(&self, channel: &Channel) -> &str {
        self.schemas.iter().find(|s| s.id == channel.schema_id).map_or("", |s| s.name.as_str())
    }
}

/// Reads a decoder to its end, or to one byte past `limit` (then the size check fails): memory
/// stays bounded by what the chunk header declares, whatever the compressed bytes say.
fn read_at_most(r: impl Read, limit: u64) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    r.take(limit.saturating_add(1)).read_to_end(&mut out)?;
    Ok(out)
}

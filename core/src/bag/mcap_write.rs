//! An MCAP writer in rosbag2's layout: the `ros2` profile, schemas in `ros2msg` encoding,
//! channels with `cdr` messages, uncompressed chunks of about [`CHUNK_BYTES`] each followed by
//! their message indexes, then a summary (schemas, channels, chunk indexes, statistics) and the
//! footer that points to it, so that indexed readers (rosbags, the mcap CLI, Foxglove) and
//! scanning ones ([`super::Mcap::parse`]) both open it.
//!
//! The writer holds the whole file in memory and returns its bytes from [`McapWriter::finish`]:
//! the core does no file I/O. O(bytes written).

use super::mcap::{MAGIC, op};
use fitslam_msgs::RosMessage;
use fitslam_msgs::definitions::schema;

/// A chunk is closed once its records reach this size, bytes.
pub const CHUNK_BYTES: usize = 1 << 20;

fn put_u16(out: &mut Vec<u8>, v: u16) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_len(out: &mut Vec<u8>, n: usize) {
    put_u32(out, u32::try_from(n).unwrap_or(u32::MAX));
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    put_len(out, s.len());
    out.extend_from_slice(s.as_bytes());
}

fn put_record(out: &mut Vec<u8>, opcode: u8, body: &[u8]) {
    out.push(opcode);
    put_u64(out, body.len() as u64);
    out.extend_from_slice(body);
}

struct OpenChunk {
    records: Vec<u8>,
    start_ns: u64,
    end_ns: u64,
    /// Per channel id: (log time, offset in `records`) of its messages.
    index: Vec<(u16, Vec<(u64, u64)>)>,
}

impl OpenChunk {
    fn new() -> Self {
        Self { records: Vec::new(), start_ns: u64::MAX, end_ns: 0, index: Vec::new() }
    }
}

/// Writes one MCAP file in memory.
pub struct McapWriter {
    out: Vec<u8>,
    schemas: Vec<Vec<u8>>,
    channels: Vec<(String, Vec<u8>)>,
    chunk: OpenChunk,
    chunk_indexes: Vec<Vec<u8>>,
    counts: Vec<u64>,
    start_ns: u64,
    end_ns: u64,
}

impl McapWriter {
    /// A file with its magic and header written (`library` names the writer).
    pub fn new(library: &str) -> Self {
        let mut out = MAGIC.to_vec();
        let mut body = Vec::new();
        put_str(&mut body, "ros2");
        put_str(&mut body, library);
        put_record(&mut out, op::HEADER, &body);
        Self {
            out,
            schemas: Vec::new(),
            channels: Vec::new(),
            chunk: OpenChunk::new(),
            chunk_indexes: Vec::new(),
            counts: Vec::new(),
            start_ns: u64::MAX,
            end_ns: 0,
        }
    }

    /// The channel of `topic` with messages of type `M` (added on first use), its id. Its
    /// schema is `M`'s ROS 2 definition ([`fitslam_msgs::definitions`]; empty for a type
    /// without one there, which readers that decode by schema cannot read).
    pub fn channel<M: RosMessage>(&mut self, topic: &str) -> u16 {
        if let Some(i) = self.channels.iter().position(|(t, _)| t == topic) {
            return (i + 1) as u16;
        }
        let name = M::ros_type();
        let schema_id = match self.schemas.iter().position(|s| s.get(2..).is_some_and(|b| b.starts_with(&name_prefix(&name)))) {
            Some(i) => (i + 1) as u16,
            None => {
                let id = (self.schemas.len() + 1) as u16;
                let mut body = Vec::new();
                put_u16(&mut body, id);
                put_str(&mut body, &name);
                put_str(&mut body, "ros2msg");
                put_str(&mut body, &schema::<M>().unwrap_or_default());
                put_record(&mut self.out, op::SCHEMA, &body);
                self.schemas.push(body);
                id
            }
        };
        let id = (self.channels.len() + 1) as u16;
        let mut body = Vec::new();
        put_u16(&mut body, id);
        put_u16(&mut body, schema_id);
        put_str(&mut body, topic);
        put_str(&mut body, "cdr");
        let mut meta = Vec::new();
        put_str(&mut meta, "offered_qos_profiles");
        put_str(&mut meta, "");
        put_len(&mut body, meta.len());
        body.extend_from_slice(&meta);
        put_record(&mut self.out, op::CHANNEL, &body);
        self.channels.push((topic.to_string(), body));
        self.counts.push(0);
        id
    }

    /// Adds one message on `channel` recorded at `log_time_ns` (times need not be ordered).
    pub fn message(&mut self, channel: u16, log_time_ns: u64, cdr: &[u8]) {
        let c = &mut self.chunk;
        let offset = c.records.len() as u64;
        let mut body = Vec::with_capacity(22 + cdr.len());
        put_u16(&mut body, channel);
        put_u32(&mut body, 0);
        put_u64(&mut body, log_time_ns);
        put_u64(&mut body, log_time_ns);
        body.extend_from_slice(cdr);
        put_record(&mut c.records, op::MESSAGE, &body);
        c.start_ns = c.start_ns.min(log_time_ns);
        c.end_ns = c.end_ns.max(log_time_ns);
        match c.index.iter_mut().find(|(id, _)| *id == channel) {
            Some((_, v)) => v.push((log_time_ns, offset)),
            None => c.index.push((channel, vec![(log_time_ns, offset)])),
        }
        if let Some(n) = self.counts.get_mut(usize::from(channel).wrapping_sub(1)) {
            *n += 1;
        }
        self.start_ns = self.start_ns.min(log_time_ns);
        self.end_ns = self.end_ns.max(log_time_ns);
        if self.chunk.records.len() >= CHUNK_BYTES {
            self.close_chunk();
        }
    }

    fn close_chunk(&mut self) {
        let c = std::mem::replace(&mut self.chunk, OpenChunk::new());
        if c.records.is_empty() {
            return;
        }
        let chunk_start = self.out.len() as u64;
        let mut body = Vec::with_capacity(c.records.len() + 48);
        put_u64(&mut body, c.start_ns);
        put_u64(&mut body, c.end_ns);
        put_u64(&mut body, c.records.len() as u64);
        put_u32(&mut body, crc32fast::hash(&c.records));
        put_str(&mut body, "");
        put_u64(&mut body, c.records.len() as u64);
        body.extend_from_slice(&c.records);
        put_record(&mut self.out, op::CHUNK, &body);
        let chunk_len = self.out.len() as u64 - chunk_start;
        let mut index_offsets = Vec::new();
        let index_start = self.out.len() as u64;
        let mut index = c.index;
        index.sort_by_key(|(id, _)| *id);
        for (id, entries) in &index {
            put_u16(&mut index_offsets, *id);
            put_u64(&mut index_offsets, self.out.len() as u64);
            let mut b = Vec::new();
            put_u16(&mut b, *id);
            put_len(&mut b, entries.len() * 16);
            for &(t, o) in entries {
                put_u64(&mut b, t);
                put_u64(&mut b, o);
            }
            put_record(&mut self.out, op::MESSAGE_INDEX, &b);
        }
        let mut ci = Vec::new();
        put_u64(&mut ci, c.start_ns);
        put_u64(&mut ci, c.end_ns);
        put_u64(&mut ci, chunk_start);
        put_u64(&mut ci, chunk_len);
        put_len(&mut ci, index_offsets.len());
        ci.extend_from_slice(&index_offsets);
        put_u64(&mut ci, self.out.len() as u64 - index_start);
        put_str(&mut ci, "");
        put_u64(&mut ci, c.records.len() as u64);
        put_u64(&mut ci, c.records.len() as u64);
        self.chunk_indexes.push(ci);
    }

    /// Closes the last chunk, writes the summary, the footer and the closing magic; the file.
    pub fn finish(mut self) -> Vec<u8> {
        self.close_chunk();
        put_record(&mut self.out, op::DATA_END, &0u32.to_le_bytes());
        let summary_start = self.out.len() as u64;
        for s in &self.schemas {
            put_record(&mut self.out, op::SCHEMA, s);
        }
        for (_, c) in &self.channels {
            put_record(&mut self.out, op::CHANNEL, c);
        }
        for ci in &self.chunk_indexes {
            put_record(&mut self.out, op::CHUNK_INDEX, ci);
        }
        let total: u64 = self.counts.iter().sum();
        let mut st = Vec::new();
        put_u64(&mut st, total);
        put_u16(&mut st, self.schemas.len() as u16);
        put_len(&mut st, self.channels.len());
        put_u32(&mut st, 0); // attachments
        put_u32(&mut st, 0); // metadata
        put_len(&mut st, self.chunk_indexes.len());
        put_u64(&mut st, if total == 0 { 0 } else { self.start_ns });
        put_u64(&mut st, self.end_ns);
        put_len(&mut st, self.counts.len() * 10);
        for (i, n) in self.counts.iter().enumerate() {
            put_u16(&mut st, (i + 1) as u16);
            put_u64(&mut st, *n);
        }
        put_record(&mut self.out, op::STATISTICS, &st);
        let mut footer = Vec::new();
        put_u64(&mut footer, summary_start);
        put_u64(&mut footer, 0); // no summary offset section
        put_u32(&mut footer, 0); // no summary CRC
        put_record(&mut self.out, op::FOOTER, &footer);
        self.out.extend_from_slice(MAGIC);
        self.out
    }
}

/// The bytes a schema record body holds after its id: the length-prefixed name.
fn name_prefix(name: &str) -> Vec<u8> {
    let mut v = Vec::new();
    put_str(&mut v, name);
    v
}

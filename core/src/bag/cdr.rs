//! OMG CDR (XCDR1), as ROS 2 serialises messages: a 4-byte encapsulation header (`00 01` little-
//! endian, `00 00` big-endian, then two option bytes), then the fields in declaration order, each
//! primitive aligned to its own size (at most 8) relative to the first byte after the header.
//! Strings are a `u32` length counting the terminating NUL, the bytes, the NUL; sequences a `u32`
//! count then the elements; fixed arrays the elements only.
//!
//! [`CdrReader`] never panics: every read is bounds-checked and a sequence count is checked
//! against the bytes left before anything is reserved. O(bytes read).

use thiserror::Error;

/// Why CDR bytes could not be decoded.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum CdrError {
    /// Fewer than the 4 bytes of the encapsulation header.
    #[error("{len} bytes: too short for the 4-byte CDR encapsulation header")]
    NoHeader { len: usize },
    /// An encapsulation other than plain CDR (XCDR2, parameter lists).
    #[error("CDR encapsulation {kind:#06x} is not supported (expected plain CDR, 0x0000 or 0x0001)")]
    Encapsulation { kind: u16 },
    /// The message ends inside a field.
    #[error("ends inside {what} (byte {at} of {len} after the header)")]
    Truncated { what: &'static str, at: usize, len: usize },
    /// A string that is not UTF-8 or lacks its terminating NUL.
    #[error("{what}: {detail}")]
    BadString { what: &'static str, detail: &'static str },
    /// A sequence count larger than the bytes left could hold.
    #[error("{what}: {count} elements do not fit in the {left} bytes left")]
    SequenceTooLong { what: &'static str, count: u32, left: usize },
}

/// A cursor over one CDR message.
#[derive(Clone, Debug)]
pub struct CdrReader<'a> {
    body: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl<'a> CdrReader<'a> {
    /// Reads the encapsulation header; the cursor then stands on the first field.
    pub fn new(bytes: &'a [u8]) -> Result<Self, CdrError> {
        let [a, b, _, _, ..] = *bytes else { return Err(CdrError::NoHeader { len: bytes.len() }) };
        let kind = u16::from_be_bytes([a, b]);
        let big_endian = match kind {
            0x0000 => true,
            0x0001 => false,
            _ => return Err(CdrError::Encapsulation { kind }),
        };
        Ok(Self { body: &bytes[4..], pos: 0, big_endian })
    }

    /// Bytes left after the cursor.
    pub fn remaining(&self) -> usize {
        self.body.len().saturating_sub(self.pos)
    }

    fn take(&mut self, n: usize, align: usize, what: &'static str) -> Result<&'a [u8], CdrError> {
        let start = self.pos.div_ceil(align) * align;
        let end = start.checked_add(n).filter(|&e| e <= self.body.len());
        let Some(end) = end else { return Err(CdrError::Truncated { what, at: start, len: self.body.len() }) };
        self.pos = end;
        Ok(&self.body[start..end])
    }

    fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], CdrError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, N, what)?);
        if self.big_endian {
            out.reverse();
        }
        Ok(out)
    }

    pub fn u8(&mut self, what: &'static str) -> Result<u8, CdrError> {
        Ok(self.take(1, 1, what)?[0])
    }

    pub fn i8(&mut self, what: &'static str) -> Result<i8, CdrError> {
        Ok(self.u8(what)? as i8)
    }

    /// A `bool`: any non-zero byte is true.
    pub fn bool(&mut self, what: &'static str) -> Result<bool, CdrError> {
        Ok(self.u8(what)? != 0)
    }

    pub fn u16(&mut self, what: &'static str) -> Result<u16, CdrError> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    pub fn u32(&mut self, what: &'static str) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub fn i32(&mut self, what: &'static str) -> Result<i32, CdrError> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub fn f32(&mut self, what: &'static str) -> Result<f32, CdrError> {
        Ok(f32::from_le_bytes(self.array(what)?))
    }

    pub fn f64(&mut self, what: &'static str) -> Result<f64, CdrError> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    /// A string: length with the NUL, bytes, NUL. A length of 0 (some writers' empty string) is
    /// accepted too.
    pub fn string(&mut self, what: &'static str) -> Result<String, CdrError> {
        let n = self.u32(what)? as usize;
        if n == 0 {
            return Ok(String::new());
        }
        let bytes = self.take(n, 1, what)?;
        let Some((&0, text)) = bytes.split_last() else {
            return Err(CdrError::BadString { what, detail: "no terminating NUL" });
        };
        String::from_utf8(text.to_vec()).map_err(|_| CdrError::BadString { what, detail: "not UTF-8" })
    }

    /// A sequence's element count, checked against the bytes left at `min_size` bytes per
    /// element (so a hostile count reserves nothing).
    pub fn sequence_len(&mut self, min_size: usize, what: &'static str) -> Result<usize, CdrError> {
        let count = self.u32(what)?;
        let left = self.remaining();
        if (count as usize).saturating_mul(min_size.max(1)) > left {
            return Err(CdrError::SequenceTooLong { what, count, left });
        }
        Ok(count as usize)
    }

    /// A `uint8[]` / `int8[]` sequence as bytes.
    pub fn bytes(&mut self, what: &'static str) -> Result<&'a [u8], CdrError> {
        let n = self.sequence_len(1, what)?;
        self.take(n, 1, what)
    }
}

/// Builds one little-endian CDR message (the writer of [`CdrReader`]'s format).
#[derive(Clone, Debug)]
pub struct CdrWriter {
    out: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// A message with the little-endian encapsulation header written.
    pub fn new() -> Self {
        Self { out: vec![0, 1, 0, 0] }
    }

    fn align(&mut self, n: usize) {
        while !(self.out.len() - 4).is_multiple_of(n) {
            self.out.push(0);
        }
    }

    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.out.push(v);
        self
    }

    pub fn i8(&mut self, v: i8) -> &mut Self {
        self.u8(v as u8)
    }

    pub fn bool(&mut self, v: bool) -> &mut Self {
        self.u8(u8::from(v))
    }

    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.out.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.out.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.align(4);
        self.out.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.out.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// Writes a sequence length; lengths above `u32::MAX` saturate (no message is that large).
    pub fn len(&mut self, n: usize) -> &mut Self {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX))
    }

    pub fn string(&mut self, s: &str) -> &mut Self {
        self.len(s.len() + 1);
        self.out.extend_from_slice(s.as_bytes());
        self.out.push(0);
        self
    }

    /// A `uint8[]` / `int8[]` sequence.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.len(b.len());
        self.out.extend_from_slice(b);
        self
    }

    pub fn finish(self) -> Vec<u8> {
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_is_relative_to_the_end_of_the_header() {
        // u8 1, pad to 4, u32 2, pad to 8, f64 0.5, string "ab".
        let mut bytes = vec![0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0];
        bytes.extend_from_slice(&0.5f64.to_le_bytes());
        bytes.extend_from_slice(&[3, 0, 0, 0, b'a', b'b', 0]);
        let mut r = CdrReader::new(&bytes).unwrap();
        assert_eq!(r.u8("a").unwrap(), 1);
        assert_eq!(r.u32("b").unwrap(), 2);
        assert_eq!(r.f64("c").unwrap(), 0.5);
        assert_eq!(r.string("d").unwrap(), "ab");
        assert_eq!(r.remaining(), 0);
        let mut w = CdrWriter::new();
        w.u8(1).u32(2).f64(0.5).string("ab");
        assert_eq!(w.finish(), bytes);
    }

    #[test]
    fn big_endian_messages_read_too() {
        let bytes = [0, 0, 0, 0, 0, 0, 0, 7, 0x3f, 0x80, 0, 0];
        let mut r = CdrReader::new(&bytes).unwrap();
        assert_eq!(r.u32("n").unwrap(), 7);
        assert_eq!(r.f32("x").unwrap(), 1.0);
    }

    #[test]
    fn bad_input_gives_typed_errors() {
        assert_eq!(CdrReader::new(&[0, 1]).unwrap_err(), CdrError::NoHeader { len: 2 });
        assert!(matches!(CdrReader::new(&[0, 7, 0, 0]).unwrap_err(), CdrError::Encapsulation { kind: 7 }));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 1, 0]).unwrap();
        assert!(matches!(r.u32("width").unwrap_err(), CdrError::Truncated { what: "width", .. }));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff]).unwrap();
        assert!(matches!(r.bytes("data").unwrap_err(), CdrError::SequenceTooLong { .. }));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b']).unwrap();
        assert!(matches!(r.string("frame").unwrap_err(), CdrError::BadString { .. }));
    }
}

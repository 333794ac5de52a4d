//! OMG CDR (XCDR1), as ROS 2 serialises messages, as a serde format: [`to_vec`] and
//! [`from_bytes`] work for every message type of this crate (and any serde struct laid out like
//! a `.msg`), with no code per type.
//!
//! The rules: a 4-byte encapsulation header (`00 01` little-endian, `00 00` big-endian, then two
//! option bytes); then the fields in declaration order, each primitive aligned to its own size
//! (at most 8) relative to the first byte after the header. A `bool` is one byte (any non-zero
//! byte reads as true). A string is a `u32` length counting the terminating NUL, the bytes, the
//! NUL (a length of 0, some writers' empty string, reads too). A sequence (`Vec`) is a `u32`
//! count then the elements; a fixed array (a tuple, or `[T; N]` through serde's tuple form)
//! the elements only. Structs add nothing. Written messages are little-endian.
//!
//! [`from_bytes`] never panics on hostile bytes: every read is bounds-checked, a sequence's
//! count is checked against the bytes left before anything is reserved, and every error names
//! the field it stopped in. Bytes after the last field (RTPS padding) are ignored. O(bytes).
//!
//! `uint8[]` and `int8[]` fields marked `#[serde(with = "crate::octets")]` (map cells, cloud
//! data) go through serde's byte-buffer path: one bounds check and one copy for the whole
//! field, in this codec and in RustDDS's alike (the wire bytes are the same).

mod de;
mod ser;
#[cfg(test)]
mod tests;

use thiserror::Error;

/// Why a value could not be encoded or decoded as CDR.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum CdrError {
    /// Fewer than the 4 bytes of the encapsulation header.
    #[error("{len} bytes: too short for the 4-byte CDR encapsulation header")]
    NoHeader {
        /// Bytes given.
        len: usize,
    },
    /// An encapsulation other than plain CDR (XCDR2, parameter lists).
    #[error("CDR encapsulation {kind:#06x} is not supported (expected plain CDR, 0x0000 or 0x0001)")]
    Encapsulation {
        /// The representation identifier, the header's first two bytes read big-endian.
        kind: u16,
    },
    /// The message ends inside a field.
    #[error("ends inside {field} (byte {at} of {len} after the header)")]
    Truncated {
        /// Dotted path of the field, e.g. `header.frame_id` (`message` at the top level).
        field: String,
        /// Where the read that ran past the end starts (after alignment padding), in bytes from
        /// the end of the header.
        at: usize,
        /// Bytes after the header.
        len: usize,
    },
    /// A string that is not UTF-8 or lacks its terminating NUL.
    #[error("{field}: {detail}")]
    BadString {
        /// Dotted path of the field (`message` at the top level).
        field: String,
        /// What is wrong: `no terminating NUL` or `not UTF-8`.
        detail: &'static str,
    },
    /// A sequence count larger than the bytes left could hold.
    #[error("{field}: {count} elements do not fit in the {left} bytes left")]
    SequenceTooLong {
        /// Dotted path of the field (`message` at the top level).
        field: String,
        /// Element count the message declares.
        count: u32,
        /// Bytes left after the count.
        left: usize,
    },
    /// A string or sequence too long for CDR's `u32` length.
    #[error("a string or sequence of {len} elements is too long for CDR (at most {max})", max = u32::MAX - 1)]
    TooLong {
        /// Elements of the sequence, or bytes of the string with its terminating NUL.
        len: usize,
    },
    /// A serde type with no CDR form in a ROS 2 message (maps, options, enums, `char`,
    /// sequences of unknown length, untyped values).
    #[error("{0} has no CDR form in a ROS 2 message")]
    Unsupported(&'static str),
    /// What a type's own `Deserialize` or `Serialize` refused (e.g. a fixed array too short).
    #[error("{0}")]
    Invalid(String),
}

impl serde::de::Error for CdrError {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        CdrError::Invalid(msg.to_string())
    }
}

impl serde::ser::Error for CdrError {
    fn custom<T: std::fmt::Display>(msg: T) -> Self {
        CdrError::Invalid(msg.to_string())
    }
}

/// Encodes `value` as one little-endian CDR message, encapsulation header included.
pub fn to_vec<T: serde::Serialize + ?Sized>(value: &T) -> Result<Vec<u8>, CdrError> {
    let mut e = ser::Encoder::new();
    value.serialize(&mut e)?;
    Ok(e.finish())
}

/// Decodes one CDR message (either byte order), encapsulation header included. Strings and
/// byte slices may borrow from `bytes`.
pub fn from_bytes<'de, T: serde::Deserialize<'de>>(bytes: &'de [u8]) -> Result<T, CdrError> {
    let [a, b, _, _, ..] = *bytes else { return Err(CdrError::NoHeader { len: bytes.len() }) };
    let kind = u16::from_be_bytes([a, b]);
    let big_endian = match kind {
        0x0000 => true,
        0x0001 => false,
        _ => return Err(CdrError::Encapsulation { kind }),
    };
    let mut d = de::Decoder::new(&bytes[4..], big_endian);
    T::deserialize(&mut d)
}

//! Serde for `uint8[]` and `int8[]` fields (map cells, cloud and image data) as one byte
//! buffer, `#[serde(with = "crate::octets")]`: CDR codecs (this crate's and RustDDS's) then read
//! and write the field with one bounds check and one copy instead of one call per element. The
//! wire bytes are the same (a `u32` count, then the octets); human-readable formats (JSON) still
//! see a plain sequence of numbers.

use serde::de::{SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::borrow::Cow;
use std::fmt;
use std::marker::PhantomData;

/// A one-byte element: `u8` or `i8`.
pub trait Octet: Copy + Serialize + for<'de> Deserialize<'de> {
    /// The element with the bits of `b` (reinterpreted for `i8`: 255 is −1).
    fn from_u8(b: u8) -> Self;
    /// The elements as bytes (borrowed for `u8`).
    fn as_bytes(v: &[Self]) -> Cow<'_, [u8]>;
    /// A byte buffer as elements (moved for `u8`).
    fn from_bytes(v: Vec<u8>) -> Vec<Self>;
}

impl Octet for u8 {
    fn from_u8(b: u8) -> Self {
        b
    }
    fn as_bytes(v: &[u8]) -> Cow<'_, [u8]> {
        Cow::Borrowed(v)
    }
    fn from_bytes(v: Vec<u8>) -> Vec<u8> {
        v
    }
}

impl Octet for i8 {
    fn from_u8(b: u8) -> Self {
        b as i8
    }
    fn as_bytes(v: &[i8]) -> Cow<'_, [u8]> {
        Cow::Owned(v.iter().map(|&b| b as u8).collect())
    }
    fn from_bytes(v: Vec<u8>) -> Vec<i8> {
        v.into_iter().map(|b| b as i8).collect()
    }
}

/// Writes a `uint8[]` / `int8[]` field: one byte buffer for binary formats (CDR), a sequence of
/// numbers for human-readable ones (JSON).
pub fn serialize<S: Serializer, T: Octet>(v: &[T], s: S) -> Result<S::Ok, S::Error> {
    if s.is_human_readable() { v.serialize(s) } else { s.serialize_bytes(&T::as_bytes(v)) }
}

/// Reads a `uint8[]` / `int8[]` field: a byte buffer from binary formats, a sequence of numbers
/// from human-readable ones (or from binary formats that give the elements one by one).
pub fn deserialize<'de, D: Deserializer<'de>, T: Octet>(d: D) -> Result<Vec<T>, D::Error> {
    if d.is_human_readable() { Vec::<T>::deserialize(d) } else { d.deserialize_byte_buf(Octets(PhantomData)) }
}

struct Octets<T>(PhantomData<T>);

impl<'de, T: Octet> Visitor<'de> for Octets<T> {
    type Value = Vec<T>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a sequence of octets")
    }

    fn visit_bytes<E>(self, v: &[u8]) -> Result<Vec<T>, E> {
        Ok(v.iter().map(|&b| T::from_u8(b)).collect())
    }

    fn visit_byte_buf<E>(self, v: Vec<u8>) -> Result<Vec<T>, E> {
        Ok(T::from_bytes(v))
    }

    /// Formats that give the elements one by one.
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
        let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 20));
        while let Some(b) = seq.next_element()? {
            out.push(b);
        }
        Ok(out)
    }
}

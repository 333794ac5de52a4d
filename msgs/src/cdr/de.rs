//! The CDR decoder: a bounds-checked cursor over a message's body, as a serde `Deserializer`.
//! Structs are positional (their fields are visited as a sequence, named only for errors).

use super::CdrError;
use serde::de::{self, DeserializeSeed, SeqAccess, Visitor};

/// A cursor over one message's body (the bytes after the encapsulation header).
pub(super) struct Decoder<'de> {
    body: &'de [u8],
    pos: usize,
    big_endian: bool,
    /// The struct fields being decoded, outermost first (for error messages only).
    path: Vec<&'static str>,
}

impl<'de> Decoder<'de> {
    pub(super) fn new(body: &'de [u8], big_endian: bool) -> Self {
        Self { body, pos: 0, big_endian, path: Vec::new() }
    }

    /// The field being decoded, e.g. `header.frame_id` (`message` at the top level).
    fn field(&self) -> String {
        if self.path.is_empty() { "message".into() } else { self.path.join(".") }
    }

    fn remaining(&self) -> usize {
        self.body.len().saturating_sub(self.pos)
    }

    /// `n` bytes after padding to `align`, a power of two (relative to the body's start).
    #[inline]
    fn take(&mut self, n: usize, align: usize) -> Result<&'de [u8], CdrError> {
        let start = (self.pos + align - 1) & !(align - 1);
        match start.checked_add(n).filter(|&end| end <= self.body.len()) {
            Some(end) => {
                self.pos = end;
                Ok(&self.body[start..end])
            }
            None => Err(CdrError::Truncated { field: self.field(), at: start, len: self.body.len() }),
        }
    }

    /// A primitive of `N` bytes, aligned to `N`, in the message's byte order as little-endian.
    #[inline]
    fn primitive<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, N)?);
        if self.big_endian {
            out.reverse();
        }
        Ok(out)
    }

    fn u32(&mut self) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.primitive()?))
    }

    /// A sequence's element count, checked against the bytes left (every element of a ROS
    /// message takes at least one byte), so that a hostile count reserves nothing.
    fn count(&mut self) -> Result<usize, CdrError> {
        let count = self.u32()?;
        let left = self.remaining();
        if count as usize > left {
            return Err(CdrError::SequenceTooLong { field: self.field(), count, left });
        }
        Ok(count as usize)
    }

    fn str(&mut self) -> Result<&'de str, CdrError> {
        let n = self.u32()? as usize;
        if n == 0 {
            return Ok("");
        }
        let bytes = self.take(n, 1)?;
        let Some((&0, text)) = bytes.split_last() else {
            return Err(CdrError::BadString { field: self.field(), detail: "no terminating NUL" });
        };
        std::str::from_utf8(text).map_err(|_| CdrError::BadString { field: self.field(), detail: "not UTF-8" })
    }
}

macro_rules! primitive {
    ($method:ident, $visit:ident, $t:ty) => {
        fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
            visitor.$visit(<$t>::from_le_bytes(self.primitive()?))
        }
    };
}

macro_rules! unsupported {
    ($($method:ident($($arg:ty),*) $what:literal;)*) => {
        $(fn $method<V: Visitor<'de>>(self, $(_: $arg,)* _visitor: V) -> Result<V::Value, CdrError> {
            Err(CdrError::Unsupported($what))
        })*
    };
}

impl<'de> de::Deserializer<'de> for &mut Decoder<'de> {
    type Error = CdrError;

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_bool(self.take(1, 1)?[0] != 0)
    }

    primitive!(deserialize_i8, visit_i8, i8);
    primitive!(deserialize_u8, visit_u8, u8);
    primitive!(deserialize_i16, visit_i16, i16);
    primitive!(deserialize_u16, visit_u16, u16);
    primitive!(deserialize_i32, visit_i32, i32);
    primitive!(deserialize_u32, visit_u32, u32);
    primitive!(deserialize_i64, visit_i64, i64);
    primitive!(deserialize_u64, visit_u64, u64);
    primitive!(deserialize_f32, visit_f32, f32);
    primitive!(deserialize_f64, visit_f64, f64);

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_borrowed_str(self.str()?)
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        self.deserialize_str(visitor)
    }

    /// A `uint8[]` / `int8[]` sequence in one piece.
    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        let n = self.count()?;
        visitor.visit_borrowed_bytes(self.take(n, 1)?)
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        self.deserialize_bytes(visitor)
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_unit()
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(self, _name: &'static str, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_unit()
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(self, _name: &'static str, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, CdrError> {
        let left = self.count()?;
        visitor.visit_seq(Elements { d: self, left, fields: None, next: 0 })
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, CdrError> {
        visitor.visit_seq(Elements { d: self, left: len, fields: None, next: 0 })
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(self, _name: &'static str, len: usize, visitor: V) -> Result<V::Value, CdrError> {
        self.deserialize_tuple(len, visitor)
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, CdrError> {
        visitor.visit_seq(Elements { d: self, left: fields.len(), fields: Some(fields), next: 0 })
    }

    unsupported! {
        deserialize_any() "a self-describing value";
        deserialize_ignored_any() "a skipped value";
        deserialize_char() "char";
        deserialize_option() "Option";
        deserialize_map() "a map";
        deserialize_identifier() "an identifier";
        deserialize_enum(&'static str, &'static [&'static str]) "an enum";
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}

/// The elements of a sequence, a fixed array or a struct (its `fields`, named in errors).
struct Elements<'a, 'de> {
    d: &'a mut Decoder<'de>,
    left: usize,
    fields: Option<&'static [&'static str]>,
    next: usize,
}

impl<'de> SeqAccess<'de> for Elements<'_, 'de> {
    type Error = CdrError;

    fn next_element_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<Option<T::Value>, CdrError> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left -= 1;
        let Some(name) = self.fields.and_then(|f| f.get(self.next)) else { return seed.deserialize(&mut *self.d).map(Some) };
        self.next += 1;
        // Restored on error too: a type's own Deserialize may go on after an error (a result
        // of an older distribution that ends early).
        let depth = self.d.path.len();
        self.d.path.push(name);
        let value = seed.deserialize(&mut *self.d);
        self.d.path.truncate(depth);
        value.map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.left)
    }
}

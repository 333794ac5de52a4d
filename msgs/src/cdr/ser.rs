//! The CDR encoder: little-endian, a serde `Serializer` appending to one buffer.

use super::CdrError;
use serde::Serialize;
use serde::ser::{self, Impossible};

/// One message being written, its encapsulation header first.
pub(super) struct Encoder {
    out: Vec<u8>,
}

/// Bytes of the encapsulation header: alignment counts from its end.
const HEADER: usize = 4;

impl Encoder {
    pub(super) fn new() -> Self {
        Self { out: vec![0, 1, 0, 0] }
    }

    pub(super) fn finish(self) -> Vec<u8> {
        self.out
    }

    /// Pads to a multiple of `n`, a power of two, counted from the end of the header.
    #[inline]
    fn align(&mut self, n: usize) {
        let len = self.out.len() - HEADER;
        let padded = (len + n - 1) & !(n - 1);
        self.out.resize(padded + HEADER, 0);
    }

    #[inline]
    fn primitive<const N: usize>(&mut self, le_bytes: [u8; N]) {
        self.align(N);
        self.out.extend_from_slice(&le_bytes);
    }

    /// A string's or sequence's length prefix.
    fn length(&mut self, n: usize) -> Result<(), CdrError> {
        let n = u32::try_from(n).ok().filter(|&n| n < u32::MAX).ok_or(CdrError::TooLong { len: n })?;
        self.primitive(n.to_le_bytes());
        Ok(())
    }
}

macro_rules! primitive {
    ($($method:ident($t:ty);)*) => {
        $(fn $method(self, v: $t) -> Result<(), CdrError> {
            self.primitive(v.to_le_bytes());
            Ok(())
        })*
    };
}

macro_rules! unsupported {
    ($($method:ident($($arg:ty),*) -> $ret:ty, $what:literal;)*) => {
        $(fn $method(self, $(_: $arg),*) -> Result<$ret, CdrError> {
            Err(CdrError::Unsupported($what))
        })*
    };
}

impl ser::Serializer for &mut Encoder {
    type Ok = ();
    type Error = CdrError;
    type SerializeSeq = Self;
    type SerializeTuple = Self;
    type SerializeTupleStruct = Self;
    type SerializeStruct = Self;
    type SerializeTupleVariant = Impossible<(), CdrError>;
    type SerializeMap = Impossible<(), CdrError>;
    type SerializeStructVariant = Impossible<(), CdrError>;

    fn serialize_bool(self, v: bool) -> Result<(), CdrError> {
        self.out.push(u8::from(v));
        Ok(())
    }

    primitive! {
        serialize_i8(i8);
        serialize_u8(u8);
        serialize_i16(i16);
        serialize_u16(u16);
        serialize_i32(i32);
        serialize_u32(u32);
        serialize_i64(i64);
        serialize_u64(u64);
        serialize_f32(f32);
        serialize_f64(f64);
    }

    fn serialize_str(self, v: &str) -> Result<(), CdrError> {
        self.length(v.len() + 1)?;
        self.out.extend_from_slice(v.as_bytes());
        self.out.push(0);
        Ok(())
    }

    /// A `uint8[]` / `int8[]` sequence in one piece.
    fn serialize_bytes(self, v: &[u8]) -> Result<(), CdrError> {
        self.length(v.len())?;
        self.out.extend_from_slice(v);
        Ok(())
    }

    fn serialize_unit(self) -> Result<(), CdrError> {
        Ok(())
    }

    fn serialize_unit_struct(self, _name: &'static str) -> Result<(), CdrError> {
        Ok(())
    }

    fn serialize_newtype_struct<T: Serialize + ?Sized>(self, _name: &'static str, value: &T) -> Result<(), CdrError> {
        value.serialize(self)
    }

    fn serialize_seq(self, len: Option<usize>) -> Result<Self, CdrError> {
        self.length(len.ok_or(CdrError::Unsupported("a sequence of unknown length"))?)?;
        Ok(self)
    }

    fn serialize_tuple(self, _len: usize) -> Result<Self, CdrError> {
        Ok(self)
    }

    fn serialize_tuple_struct(self, _name: &'static str, _len: usize) -> Result<Self, CdrError> {
        Ok(self)
    }

    fn serialize_struct(self, _name: &'static str, _len: usize) -> Result<Self, CdrError> {
        Ok(self)
    }

    unsupported! {
        serialize_char(char) -> (), "char";
        serialize_none() -> (), "Option";
        serialize_unit_variant(&'static str, u32, &'static str) -> (), "an enum";
        serialize_tuple_variant(&'static str, u32, &'static str, usize) -> Impossible<(), CdrError>, "an enum";
        serialize_struct_variant(&'static str, u32, &'static str, usize) -> Impossible<(), CdrError>, "an enum";
        serialize_map(Option<usize>) -> Impossible<(), CdrError>, "a map";
    }

    fn serialize_some<T: Serialize + ?Sized>(self, _value: &T) -> Result<(), CdrError> {
        Err(CdrError::Unsupported("Option"))
    }

    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
        _value: &T,
    ) -> Result<(), CdrError> {
        Err(CdrError::Unsupported("an enum"))
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}

/// Sequences, fixed arrays and structs: their elements in order, nothing else.
macro_rules! compound {
    ($($trait:ident::$method:ident($($key:ty)?);)*) => {
        $(impl ser::$trait for &mut Encoder {
            type Ok = ();
            type Error = CdrError;

            fn $method<T: Serialize + ?Sized>(&mut self, $(_: $key,)? value: &T) -> Result<(), CdrError> {
                value.serialize(&mut **self)
            }

            fn end(self) -> Result<(), CdrError> {
                Ok(())
            }
        })*
    };
}

compound! {
    SerializeSeq::serialize_element();
    SerializeTuple::serialize_element();
    SerializeTupleStruct::serialize_field();
    SerializeStruct::serialize_field(&'static str);
}

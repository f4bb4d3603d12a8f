//! Test support: the ROS field layout of a Rust message, read through serde, to compare with `.msg` files.

use serde::{ser, Serialize};

/// `(field name, ROS type)` of each top-level field of `m`, e.g. `("stamp", "builtin_interfaces/Time")`.
pub(crate) fn fields<M: Serialize>(m: &M) -> Vec<(String, String)> {
    let mut l = Layout::default();
    m.serialize(&mut l).expect("layout");
    l.fields
}

#[derive(Default)]
struct Layout {
    fields: Vec<(String, String)>,
}

#[derive(Debug)]
struct E(String);
impl std::fmt::Display for E {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for E {}
impl ser::Error for E {
    fn custom<T: std::fmt::Display>(m: T) -> Self {
        E(m.to_string())
    }
}

fn not_struct() -> E {
    E("top level must be a struct".into())
}

macro_rules! not_struct {
    ($($f:ident: $t:ty),*) => {
        $(fn $f(self, _: $t) -> Result<(), E> { Err(not_struct()) })*
    };
}

/// Serializes one value into the name of its ROS type.
struct TypeName;

macro_rules! prim {
    ($($f:ident: $t:ty => $n:literal),*) => {
        $(fn $f(self, _: $t) -> Result<String, E> { Ok($n.into()) })*
    };
}

impl ser::Serializer for TypeName {
    type Ok = String;
    type Error = E;
    type SerializeSeq = SeqType;
    type SerializeTuple = ser::Impossible<String, E>;
    type SerializeTupleStruct = ser::Impossible<String, E>;
    type SerializeTupleVariant = ser::Impossible<String, E>;
    type SerializeMap = ser::Impossible<String, E>;
    type SerializeStruct = NamedStruct;
    type SerializeStructVariant = ser::Impossible<String, E>;
    prim!(serialize_bool: bool => "bool", serialize_i8: i8 => "int8", serialize_i16: i16 => "int16",
          serialize_i32: i32 => "int32", serialize_i64: i64 => "int64", serialize_u8: u8 => "uint8",
          serialize_u16: u16 => "uint16", serialize_u32: u32 => "uint32", serialize_u64: u64 => "uint64",
          serialize_f32: f32 => "float32", serialize_f64: f64 => "float64", serialize_char: char => "char",
          serialize_str: &str => "string", serialize_bytes: &[u8] => "uint8[]");
    fn serialize_none(self) -> Result<String, E> {
        Err(E("Option".into()))
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<String, E> {
        Err(E("Option".into()))
    }
    fn serialize_unit(self) -> Result<String, E> {
        Err(E("unit".into()))
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<String, E> {
        Err(E("unit struct".into()))
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<String, E> {
        Err(E("enum".into()))
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<String, E> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<String, E> {
        Err(E("enum".into()))
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<SeqType, E> {
        Ok(SeqType(None))
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, E> {
        Err(E("tuple".into()))
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, E> {
        Err(E("tuple struct".into()))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, E> {
        Err(E("enum".into()))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, E> {
        Err(E("map".into()))
    }
    fn serialize_struct(self, name: &'static str, _: usize) -> Result<NamedStruct, E> {
        Ok(NamedStruct(name))
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, E> {
        Err(E("enum".into()))
    }
}

/// A sequence: `elem[]`, the element type taken from the first element (give the test one).
struct SeqType(Option<String>);
impl ser::SerializeSeq for SeqType {
    type Ok = String;
    type Error = E;
    fn serialize_element<T: ?Sized + Serialize>(&mut self, v: &T) -> Result<(), E> {
        if self.0.is_none() {
            self.0 = Some(v.serialize(TypeName)?);
        }
        Ok(())
    }
    fn end(self) -> Result<String, E> {
        self.0
            .map(|t| format!("{t}[]"))
            .ok_or_else(|| E("give sequences one element to see their type".into()))
    }
}

/// A nested message: its type is `package/Name`, known for the types this crate nests.
struct NamedStruct(&'static str);
impl ser::SerializeStruct for NamedStruct {
    type Ok = String;
    type Error = E;
    fn serialize_field<T: ?Sized + Serialize>(&mut self, _: &'static str, _: &T) -> Result<(), E> {
        Ok(())
    }
    fn end(self) -> Result<String, E> {
        Ok(match self.0 {
            "Time" => "builtin_interfaces/Time".into(),
            "Header" => "std_msgs/Header".into(),
            other => other.into(),
        })
    }
}

impl ser::Serializer for &mut Layout {
    type Ok = ();
    type Error = E;
    type SerializeSeq = ser::Impossible<(), E>;
    type SerializeTuple = ser::Impossible<(), E>;
    type SerializeTupleStruct = ser::Impossible<(), E>;
    type SerializeTupleVariant = ser::Impossible<(), E>;
    type SerializeMap = ser::Impossible<(), E>;
    type SerializeStruct = Self;
    type SerializeStructVariant = ser::Impossible<(), E>;
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, E> {
        Ok(self)
    }
    not_struct!(serialize_bool: bool, serialize_i8: i8, serialize_i16: i16, serialize_i32: i32,
                serialize_i64: i64, serialize_u8: u8, serialize_u16: u16, serialize_u32: u32,
                serialize_u64: u64, serialize_f32: f32, serialize_f64: f64, serialize_char: char,
                serialize_str: &str, serialize_bytes: &[u8]);
    fn serialize_none(self) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_unit(self) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: &T,
    ) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), E> {
        Err(not_struct())
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, E> {
        Err(not_struct())
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, E> {
        Err(not_struct())
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, E> {
        Err(not_struct())
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, E> {
        Err(not_struct())
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, E> {
        Err(not_struct())
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, E> {
        Err(not_struct())
    }
}

impl ser::SerializeStruct for &mut Layout {
    type Ok = ();
    type Error = E;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        v: &T,
    ) -> Result<(), E> {
        let ty = v.serialize(TypeName)?;
        self.fields.push((key.to_owned(), ty));
        Ok(())
    }
    fn end(self) -> Result<(), E> {
        Ok(())
    }
}

/// `(name, type)` of the fields of a `.msg` file (constants and comments skipped).
pub(crate) fn msg_file_fields(text: &str) -> Vec<(String, String)> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty() && !l.contains('='))
        .map(|l| {
            let mut it = l.split_whitespace();
            let ty = it.next().unwrap_or_default().to_owned();
            let name = it.next().unwrap_or_default().to_owned();
            (name, ty)
        })
        .collect()
}

/// `(NAME, value)` of the constants of a `.msg` file.
pub(crate) fn msg_file_constants(text: &str) -> Vec<(String, String)> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| l.contains('='))
        .map(|l| {
            let (lhs, v) = l.split_once('=').unwrap();
            let name = lhs.split_whitespace().last().unwrap_or_default().to_owned();
            (name, v.trim().to_owned())
        })
        .collect()
}

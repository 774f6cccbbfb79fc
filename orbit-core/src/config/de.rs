//! A serde [`Deserializer`](serde::Deserializer) over [`Node`]s that remembers where it is, so
//! every error names the file, line, column and field path of the offending value.

use std::fmt;

use serde::de::value::BorrowedStrDeserializer;
use serde::de::{
    self, DeserializeOwned, DeserializeSeed, Expected, MapAccess, SeqAccess, Unexpected, Visitor,
};

use super::error::ConfigError;
use super::node::{Node, NodeKind, Span};
use super::path::{Segment, format_path};

mod variant;

use variant::{Content, Enum};

/// Deserialises a `T` from `node`.
pub(crate) fn from_node<T: DeserializeOwned>(node: &Node) -> Result<T, ConfigError> {
    let root = Path::Root;
    let result = T::deserialize(NodeDe { node, path: &root });
    result.map_err(|e| {
        let (span, path) = e
            .location
            .unwrap_or_else(|| (node.span.clone(), String::new()));
        ConfigError::Invalid {
            file: span.file.to_path_buf(),
            line: span.line,
            col: span.col,
            path,
            message: e.message,
        }
    })
}

/// The path from the root to the node being deserialised, as a linked list on the stack.
#[derive(Clone, Copy)]
enum Path<'a> {
    Root,
    Field(&'a Path<'a>, &'a str),
    Index(&'a Path<'a>, usize),
    Key(&'a Path<'a>, &'a Node),
}

impl Path<'_> {
    fn segments(&self, out: &mut Vec<Segment>) {
        match *self {
            Path::Root => {}
            Path::Field(parent, name) => {
                parent.segments(out);
                out.push(Segment::Field(name.to_string()));
            }
            Path::Index(parent, i) => {
                parent.segments(out);
                out.push(Segment::Index(i));
            }
            Path::Key(parent, key) => {
                parent.segments(out);
                out.push(Segment::Key(key.key_text()));
            }
        }
    }
}

impl fmt::Display for Path<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut segments = Vec::new();
        self.segments(&mut segments);
        f.write_str(&format_path(&segments))
    }
}

/// A serde error, with the location of the innermost node that saw it.
#[derive(Debug)]
pub(crate) struct DeError {
    message: String,
    location: Option<(Span, String)>,
}

impl DeError {
    /// Records `span` and `path` as the error's location unless an inner node already did.
    fn locate(mut self, span: &Span, path: &Path<'_>) -> Self {
        if self.location.is_none() {
            self.location = Some((span.clone(), path.to_string()));
        }
        self
    }
}

impl fmt::Display for DeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for DeError {}

impl de::Error for DeError {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        DeError {
            message: msg.to_string(),
            location: None,
        }
    }
}

type Result<T, E = DeError> = std::result::Result<T, E>;

/// Deserialises `node` at `path` with `seed`, locating unlocated errors at `node`.
fn child<'de, S: DeserializeSeed<'de>>(
    seed: S,
    node: &'de Node,
    path: &Path<'_>,
) -> Result<S::Value> {
    seed.deserialize(NodeDe { node, path })
        .map_err(|e| e.locate(&node.span, path))
}

fn invalid_type(node: &Node, expected: &dyn Expected) -> DeError {
    de::Error::invalid_type(Unexpected::Other(&node.describe()), expected)
}

/// Integers go to the visitor as `u64`/`i64` when they fit (serde's primitive visitors then
/// check the range of the target type), else as 128-bit values.
fn visit_int<'de, V: Visitor<'de>>(i: i128, visitor: V) -> Result<V::Value> {
    if let Ok(u) = u64::try_from(i) {
        visitor.visit_u64(u)
    } else if let Ok(s) = i64::try_from(i) {
        visitor.visit_i64(s)
    } else if let Ok(u) = u128::try_from(i) {
        visitor.visit_u128(u)
    } else {
        visitor.visit_i128(i)
    }
}

/// Visits `items` as a sequence, requiring the visitor to consume all of them.
fn visit_items<'de, V: Visitor<'de>>(
    items: &'de [Node],
    path: &Path<'_>,
    visitor: V,
) -> Result<V::Value> {
    let mut seq = Items {
        items: items.iter(),
        index: 0,
        path,
    };
    let value = visitor.visit_seq(&mut seq)?;
    if seq.items.len() > 0 {
        return Err(de::Error::invalid_length(
            items.len(),
            &ElementCount(seq.index),
        ));
    }
    Ok(value)
}

fn visit_fields<'de, V: Visitor<'de>>(
    fields: &'de [(String, Node)],
    path: &Path<'_>,
    visitor: V,
) -> Result<V::Value> {
    visitor.visit_map(Fields {
        fields: fields.iter(),
        pending: None,
        path,
    })
}

struct ElementCount(usize);

impl Expected for ElementCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} elements", self.0)
    }
}

#[derive(Clone, Copy)]
struct NodeDe<'de, 'p> {
    node: &'de Node,
    path: &'p Path<'p>,
}

macro_rules! integers {
    ($($method:ident)*) => {$(
        fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
            match self.node.kind {
                NodeKind::Int(i) => visit_int(i, visitor),
                _ => Err(invalid_type(self.node, &visitor)),
            }
        }
    )*};
}

/// The number a float field holds, refused where a 32-bit float would hold another: beyond
/// ±3.4e38 it would become infinite, and a non-zero value below 1.2e-38 would lose its
/// digits or become 0.
fn float_of(node: &Node, single: bool) -> Option<Result<f64>> {
    let value = match node.kind {
        NodeKind::Float(f) => f,
        NodeKind::Int(i) => i as f64,
        _ => return None,
    };
    if single && value.abs() > f64::from(f32::MAX) {
        return Some(Err(de::Error::custom(format!(
            "{value:e} is out of range: a 32-bit float holds magnitudes up to 3.4e38"
        ))));
    }
    if single && value != 0.0 && value.abs() < f64::from(f32::MIN_POSITIVE) {
        return Some(Err(de::Error::custom(format!(
            "{value:e} is out of range: a 32-bit float holds non-zero magnitudes from 1.2e-38 \
             (write 0 for zero)"
        ))));
    }
    Some(Ok(value))
}

macro_rules! floats {
    ($($method:ident $single:literal)*) => {$(
        fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
            match float_of(self.node, $single) {
                Some(value) => visitor.visit_f64(value?),
                None => Err(invalid_type(self.node, &visitor)),
            }
        }
    )*};
}

impl<'de> de::Deserializer<'de> for NodeDe<'de, '_> {
    type Error = DeError;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        if self.node.as_some().is_some() {
            return self.deserialize_option(visitor);
        }
        match &self.node.kind {
            NodeKind::Bool(b) => visitor.visit_bool(*b),
            NodeKind::Int(i) => visit_int(*i, visitor),
            NodeKind::Float(f) => visitor.visit_f64(*f),
            NodeKind::Str(s) => visitor.visit_borrowed_str(s),
            NodeKind::Char(c) => visitor.visit_char(*c),
            NodeKind::Unit(name) if name == "None" => visitor.visit_none(),
            NodeKind::Unit(name) => visitor.visit_borrowed_str(name),
            NodeKind::Tuple { items, .. } if items.is_empty() => visitor.visit_unit(),
            NodeKind::Tuple { items, .. } | NodeKind::List(items) => {
                visit_items(items, self.path, visitor)
            }
            NodeKind::Struct { fields, .. } => visit_fields(fields, self.path, visitor),
            NodeKind::Map(entries) => visitor.visit_map(Entries {
                entries: entries.iter(),
                pending: None,
                path: self.path,
            }),
        }
    }

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match self.node.kind {
            NodeKind::Bool(b) => visitor.visit_bool(b),
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    integers! {
        deserialize_i8 deserialize_i16 deserialize_i32 deserialize_i64 deserialize_i128
        deserialize_u8 deserialize_u16 deserialize_u32 deserialize_u64 deserialize_u128
    }

    floats! { deserialize_f32 true deserialize_f64 false }

    fn deserialize_char<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Char(c) => visitor.visit_char(*c),
            NodeKind::Str(s) if s.chars().count() == 1 => visitor.visit_borrowed_str(s),
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Str(s) => visitor.visit_borrowed_str(s),
            NodeKind::Char(c) => visitor.visit_char(*c),
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_str(visitor)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Str(s) => visitor.visit_borrowed_bytes(s.as_bytes()),
            NodeKind::List(items) => visit_items(items, self.path, visitor),
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_bytes(visitor)
    }

    /// `None`, `Some(x)`, or a bare `x` (taken as `Some(x)`).
    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match (&self.node.kind, self.node.as_some()) {
            (NodeKind::Unit(name), _) if name == "None" => visitor.visit_none(),
            (_, Some(inner)) => visitor
                .visit_some(NodeDe {
                    node: inner,
                    path: self.path,
                })
                .map_err(|e| e.locate(&inner.span, self.path)),
            _ => visitor.visit_some(self),
        }
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Tuple { items, .. } if items.is_empty() => visitor.visit_unit(),
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Unit(_) => visitor.visit_unit(),
            NodeKind::Struct { fields, .. } if fields.is_empty() => visitor.visit_unit(),
            _ => self.deserialize_unit(visitor),
        }
    }

    /// `Name(x)`, `(x)` or a bare `x`.
    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Tuple { name, items }
                if items.len() == 1 && name.as_deref() != Some("Some") =>
            {
                visitor.visit_newtype_struct(NodeDe {
                    node: &items[0],
                    path: self.path,
                })
            }
            _ => visitor.visit_newtype_struct(self),
        }
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Tuple { items, .. } | NodeKind::List(items) => {
                visit_items(items, self.path, visitor)
            }
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, _len: usize, visitor: V) -> Result<V::Value> {
        self.deserialize_seq(visitor)
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _len: usize,
        visitor: V,
    ) -> Result<V::Value> {
        self.deserialize_seq(visitor)
    }

    /// A `{k: v}` map, or a struct node read as a map with string keys.
    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Map(entries) => visitor.visit_map(Entries {
                entries: entries.iter(),
                pending: None,
                path: self.path,
            }),
            NodeKind::Struct { fields, .. } => visit_fields(fields, self.path, visitor),
            NodeKind::Tuple { items, .. } if items.is_empty() => {
                visit_fields(&[], self.path, visitor)
            }
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    /// Struct names are not checked: `Name(a: 1)` fits a struct of any name.
    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        self.deserialize_map(visitor)
    }

    /// Externally tagged: `Variant`, `Variant(x)`, `Variant(1, 2)`, `Variant(a: 1)`, `"Variant"`
    /// or `{"Variant": x}`.
    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        let (variant, content) = match &self.node.kind {
            NodeKind::Unit(name) | NodeKind::Str(name) => (name, Content::Unit),
            NodeKind::Tuple {
                name: Some(name),
                items,
            } => (name, Content::Items(items)),
            NodeKind::Struct {
                name: Some(name),
                fields,
            } => (name, Content::Fields(fields)),
            NodeKind::Map(entries) => match entries.as_slice() {
                [(key, value)] => match &key.kind {
                    NodeKind::Str(name) | NodeKind::Unit(name) => (name, Content::Value(value)),
                    _ => return Err(invalid_type(self.node, &visitor)),
                },
                _ => return Err(invalid_type(self.node, &visitor)),
            },
            _ => return Err(invalid_type(self.node, &visitor)),
        };
        visitor.visit_enum(Enum {
            variant,
            content,
            de: self,
        })
    }

    fn deserialize_identifier<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        match &self.node.kind {
            NodeKind::Str(name) | NodeKind::Unit(name) => visitor.visit_borrowed_str(name),
            _ => Err(invalid_type(self.node, &visitor)),
        }
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_unit()
    }
}

/// The items of a list or tuple.
struct Items<'de, 'p> {
    items: std::slice::Iter<'de, Node>,
    index: usize,
    path: &'p Path<'p>,
}

impl<'de> SeqAccess<'de> for Items<'de, '_> {
    type Error = DeError;

    fn next_element_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<Option<S::Value>> {
        let Some(node) = self.items.next() else {
            return Ok(None);
        };
        let path = Path::Index(self.path, self.index);
        self.index += 1;
        child(seed, node, &path).map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.items.len())
    }
}

/// The fields of a struct node, keyed by name.
struct Fields<'de, 'p> {
    fields: std::slice::Iter<'de, (String, Node)>,
    pending: Option<&'de (String, Node)>,
    path: &'p Path<'p>,
}

impl<'de> MapAccess<'de> for Fields<'de, '_> {
    type Error = DeError;

    /// Errors about the name itself (unknown fields) point at the field's value.
    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>> {
        let Some(entry) = self.fields.next() else {
            return Ok(None);
        };
        self.pending = Some(entry);
        let (name, value) = entry;
        seed.deserialize(BorrowedStrDeserializer::<DeError>::new(name))
            .map(Some)
            .map_err(|e| e.locate(&value.span, &Path::Field(self.path, name)))
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value> {
        let Some((name, value)) = self.pending.take() else {
            return Err(de::Error::custom(
                "a field value was requested before its name",
            ));
        };
        child(seed, value, &Path::Field(self.path, name))
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.fields.len())
    }
}

/// The entries of a `{k: v}` map.
struct Entries<'de, 'p> {
    entries: std::slice::Iter<'de, (Node, Node)>,
    pending: Option<&'de (Node, Node)>,
    path: &'p Path<'p>,
}

impl<'de> MapAccess<'de> for Entries<'de, '_> {
    type Error = DeError;

    /// Bare identifiers as keys read as strings.
    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>> {
        let Some(entry) = self.entries.next() else {
            return Ok(None);
        };
        self.pending = Some(entry);
        let key = &entry.0;
        let path = Path::Key(self.path, key);
        let result = match &key.kind {
            NodeKind::Unit(name) => seed.deserialize(BorrowedStrDeserializer::new(name)),
            _ => seed.deserialize(NodeDe {
                node: key,
                path: &path,
            }),
        };
        result.map(Some).map_err(|e| e.locate(&key.span, &path))
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value> {
        let Some((key, value)) = self.pending.take() else {
            return Err(de::Error::custom(
                "a map value was requested before its key",
            ));
        };
        child(seed, value, &Path::Key(self.path, key))
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.entries.len())
    }
}

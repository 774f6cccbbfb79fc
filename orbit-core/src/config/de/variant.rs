//! Enum variants: what follows a variant's name, and serde's access to it.

use serde::de::value::BorrowedStrDeserializer;
use serde::de::{self, DeserializeSeed, EnumAccess, Unexpected, VariantAccess, Visitor};

use super::{DeError, NodeDe, Result, child, visit_fields, visit_items};
use crate::config::node::Node;

/// What follows an enum variant's name.
#[derive(Clone, Copy)]
pub(super) enum Content<'de> {
    /// Nothing: `Variant`.
    Unit,
    /// `Variant(1, 2)`.
    Items(&'de [Node]),
    /// `Variant(a: 1)`.
    Fields(&'de [(String, Node)]),
    /// The value of `{"Variant": value}`.
    Value(&'de Node),
}

impl Content<'_> {
    fn unexpected(&self) -> Unexpected<'static> {
        match self {
            Content::Unit => Unexpected::UnitVariant,
            Content::Items([_]) => Unexpected::NewtypeVariant,
            Content::Items(_) => Unexpected::TupleVariant,
            Content::Fields(_) => Unexpected::StructVariant,
            Content::Value(_) => Unexpected::Other("map"),
        }
    }
}

/// An enum's variant and what follows its name, with the node they came from.
pub(super) struct Enum<'de, 'p> {
    pub(super) variant: &'de str,
    pub(super) content: Content<'de>,
    pub(super) de: NodeDe<'de, 'p>,
}

impl<'de, 'p> EnumAccess<'de> for Enum<'de, 'p> {
    type Error = DeError;
    type Variant = Self;

    fn variant_seed<S: DeserializeSeed<'de>>(self, seed: S) -> Result<(S::Value, Self)> {
        let value = seed.deserialize(BorrowedStrDeserializer::new(self.variant))?;
        Ok((value, self))
    }
}

impl<'de> VariantAccess<'de> for Enum<'de, '_> {
    type Error = DeError;

    fn unit_variant(self) -> Result<()> {
        match self.content {
            Content::Unit | Content::Items([]) => Ok(()),
            other => Err(de::Error::invalid_type(other.unexpected(), &"unit variant")),
        }
    }

    /// `Variant(x)`; `Variant(a: 1)` and `Variant(1, 2)` pass the whole node on, so the
    /// payload may be a struct or a tuple written without its own brackets.
    fn newtype_variant_seed<S: DeserializeSeed<'de>>(self, seed: S) -> Result<S::Value> {
        let path = self.de.path;
        match self.content {
            Content::Items([item]) | Content::Value(item) => child(seed, item, path),
            Content::Items(_) | Content::Fields(_) => child(seed, self.de.node, path),
            Content::Unit => Err(de::Error::invalid_type(
                Unexpected::UnitVariant,
                &"newtype variant",
            )),
        }
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        let path = self.de.path;
        match self.content {
            Content::Items(items) => visit_items(items, path, visitor),
            Content::Value(node) => {
                de::Deserializer::deserialize_tuple(NodeDe { node, path }, len, visitor)
            }
            other => Err(de::Error::invalid_type(other.unexpected(), &visitor)),
        }
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        let path = self.de.path;
        match self.content {
            Content::Fields(f) => visit_fields(f, path, visitor),
            Content::Unit | Content::Items([]) => visit_fields(&[], path, visitor),
            Content::Items([node]) | Content::Value(node) => {
                de::Deserializer::deserialize_struct(NodeDe { node, path }, "", fields, visitor)
            }
            other => Err(de::Error::invalid_type(other.unexpected(), &visitor)),
        }
    }
}

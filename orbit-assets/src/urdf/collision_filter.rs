//! The `<orbit_collision_filter link="NAME" groups="G" mask="M"/>` extension of URDF: a
//! collision filter for every collision shape of a link (see the parent module).

use std::collections::HashMap;

use orbit_core::scene::CollisionFilter;

use crate::error::AssetError;

/// Name of the collision-filter extension element.
const FILTER_ELEMENT: &[u8] = b"orbit_collision_filter";

/// Reads the `<orbit_collision_filter>` extension elements: link name → filter.
pub(super) fn read_collision_filters(
    text: &str,
    file: &str,
) -> Result<HashMap<String, CollisionFilter>, AssetError> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(text);
    let mut filters = HashMap::new();
    let invalid = |problem: String| AssetError::InvalidValue {
        file: file.to_string(),
        element: "<orbit_collision_filter>".to_string(),
        problem,
    };
    loop {
        let event = reader.read_event().map_err(|e| AssetError::Parse {
            file: file.to_string(),
            message: e.to_string(),
        })?;
        let element = match &event {
            Event::Start(e) | Event::Empty(e) if e.name().as_ref() == FILTER_ELEMENT => e,
            Event::Eof => break,
            _ => continue,
        };
        let mut attrs: HashMap<String, String> = HashMap::new();
        for attr in element.attributes() {
            let attr = attr.map_err(|e| invalid(e.to_string()))?;
            let value = attr
                .decode_and_unescape_value(reader.decoder())
                .map_err(|e| invalid(e.to_string()))?;
            attrs.insert(
                String::from_utf8_lossy(attr.key.as_ref()).into_owned(),
                value.into_owned(),
            );
        }
        let get = |name: &str| {
            attrs.get(name).ok_or_else(|| {
                invalid(format!(
                    "attribute `{name}` is missing; write \
                     <orbit_collision_filter link=\"...\" groups=\"...\" mask=\"...\"/>"
                ))
            })
        };
        let number = |name: &str| -> Result<u32, AssetError> {
            let raw = get(name)?.trim();
            let parsed = match raw.strip_prefix("0x").or_else(|| raw.strip_prefix("0X")) {
                Some(hex) => u32::from_str_radix(hex, 16),
                None => raw.parse::<u32>(),
            };
            parsed.map_err(|_| {
                invalid(format!(
                    "`{name}` is `{raw}`; expected a 32-bit unsigned integer (decimal or 0x hex)"
                ))
            })
        };
        let link = get("link")?.clone();
        let filter = CollisionFilter {
            groups: number("groups")?,
            mask: number("mask")?,
        };
        if filters.insert(link.clone(), filter).is_some() {
            return Err(invalid(format!(
                "link `{link}` has two collision filters; give one per link"
            )));
        }
    }
    Ok(filters)
}

//! MJCF `<default>` classes: attribute values an element takes from its class (the element's
//! `class`, else the nearest enclosing body's `childclass`, else `main`) and the class's
//! ancestors, unless the element sets them itself.

use std::collections::HashMap;

use super::xml::{Attrs, Element, mjcf_error};
use crate::error::AssetError;

/// The class every other class descends from.
pub(crate) const MAIN: &str = "main";

/// One class: its parent and the default attributes per element name.
struct Class {
    parent: Option<String>,
    elements: HashMap<String, Vec<(String, String)>>,
}

/// The default classes of a document.
pub(crate) struct Defaults {
    classes: HashMap<String, Class>,
}

impl Defaults {
    /// Reads the `<default>` elements below `<mujoco>`.
    pub fn read(root: &Element, file: &str) -> Result<Self, AssetError> {
        let mut defaults = Defaults {
            classes: HashMap::from([(
                MAIN.to_string(),
                Class {
                    parent: None,
                    elements: HashMap::new(),
                },
            )]),
        };
        for element in root.children.iter().filter(|c| c.name == "default") {
            defaults.read_class(element, None, file)?;
        }
        Ok(defaults)
    }

    fn read_class(
        &mut self,
        element: &Element,
        parent: Option<&str>,
        file: &str,
    ) -> Result<(), AssetError> {
        let own = element.attrs.iter().find(|(k, _)| k == "class");
        let name = match (own, parent) {
            (Some((_, name)), _) => name.clone(),
            (None, None) => MAIN.to_string(),
            (None, Some(_)) => {
                return Err(mjcf_error(
                    file,
                    element.line,
                    "default",
                    Some("class"),
                    "a nested `<default>` needs a `class` name".into(),
                ));
            }
        };
        if parent.is_some() && self.classes.contains_key(&name) {
            return Err(mjcf_error(
                file,
                element.line,
                "default",
                Some("class"),
                format!("class `{name}` is defined twice"),
            ));
        }
        let mut elements = HashMap::new();
        for child in element.children.iter().filter(|c| c.name != "default") {
            elements.insert(child.name.clone(), child.attrs.clone());
        }
        let parent = parent.map(str::to_string).filter(|p| *p != name);
        let class = self.classes.entry(name.clone()).or_insert(Class {
            parent: parent.clone(),
            elements: HashMap::new(),
        });
        class.parent = parent;
        class.elements.extend(elements);
        for child in element.children.iter().filter(|c| c.name == "default") {
            self.read_class(child, Some(&name), file)?;
        }
        Ok(())
    }

    /// `element`'s attributes: those of its class (`class`, else `inherited`) and the class's
    /// ancestors, then its own.
    pub fn attrs<'a>(
        &self,
        file: &'a str,
        element: &'a Element,
        inherited: &str,
    ) -> Result<Attrs<'a>, AssetError> {
        let own_class = element.attrs.iter().find(|(k, _)| k == "class");
        let class = own_class.map_or(inherited, |(_, c)| c.as_str());
        let mut chain = Vec::new();
        let mut next = Some(class.to_string());
        while let Some(name) = next {
            let found = self.classes.get(&name).ok_or_else(|| {
                mjcf_error(
                    file,
                    element.line,
                    &element.name,
                    Some("class"),
                    format!("class `{name}` is not defined in a `<default>`"),
                )
            })?;
            chain.push(found);
            next = found.parent.clone();
        }
        let mut values = HashMap::new();
        for class in chain.iter().rev() {
            if let Some(attrs) = class.elements.get(&element.name) {
                values.extend(attrs.iter().cloned());
            }
        }
        values.extend(element.attrs.iter().cloned());
        Ok(Attrs {
            file,
            element,
            values,
        })
    }
}

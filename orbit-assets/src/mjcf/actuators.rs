//! MJCF `<actuator>` motors (`<motor>`, and `<general>` with MuJoCo's default gain, bias and
//! dynamics, which makes it one) and `<contact>` exclusions.

use super::defaults::MAIN;
use super::xml::Element;
use super::{Importer, MjcfActuator};
use crate::error::AssetError;

impl<'a> Importer<'a> {
    /// The `<motor>`s and `<general>`s of `<actuator>` sections.
    pub(super) fn actuators(&self, root: &'a Element) -> Result<Vec<MjcfActuator>, AssetError> {
        let mut actuators = Vec::new();
        for element in self.section_elements(root, "actuator", &["motor", "general"])? {
            let a = self.defaults.attrs(self.file, element, MAIN)?;
            let joint = a.text("joint").ok_or_else(|| {
                a.error(Some("joint"), "a motor needs the `joint` it drives".into())
            })?;
            if !self.joints.contains(joint) {
                return Err(a.error(
                    Some("joint"),
                    format!("no hinge or slide joint is named `{joint}`"),
                ));
            }
            let gear = a.up_to("gear", 6)?.map_or(1.0, |g| g[0]) as f32;
            let ctrl_range = (a.limited_range("ctrllimited", "ctrlrange", "motor")?)
                .map(|[lo, hi]| [lo as f32, hi as f32]);
            actuators.push(MjcfActuator {
                name: a
                    .text("name")
                    .map_or_else(|| format!("motor{}", actuators.len()), str::to_string),
                joint: joint.to_string(),
                gear,
                ctrl_range,
            });
        }
        Ok(actuators)
    }

    /// The body pairs of `<contact><exclude>`.
    pub(super) fn excludes(&self, root: &'a Element) -> Result<Vec<[String; 2]>, AssetError> {
        let mut pairs = Vec::new();
        for element in self.section_elements(root, "contact", &["exclude"])? {
            let a = self.plain(element);
            let body = |key: &str| -> Result<String, AssetError> {
                let name = a.text(key).ok_or_else(|| {
                    a.error(Some(key), "an `<exclude>` names `body1` and `body2`".into())
                })?;
                if !self.links.iter().any(|l| l.name == name) {
                    return Err(a.error(Some(key), format!("no body is named `{name}`")));
                }
                Ok(name.to_string())
            };
            pairs.push([body("body1")?, body("body2")?]);
        }
        Ok(pairs)
    }

    /// The children of every `<section>` below `root`, each of which must be one of `elements`.
    fn section_elements(
        &self,
        root: &'a Element,
        section: &str,
        elements: &[&str],
    ) -> Result<Vec<&'a Element>, AssetError> {
        let children = (root.children.iter())
            .filter(|c| c.name == section)
            .flat_map(|s| &s.children);
        let mut found = Vec::new();
        for child in children {
            if !elements.contains(&child.name.as_str()) {
                let takes = elements
                    .iter()
                    .map(|e| format!("`<{e}>`"))
                    .collect::<Vec<_>>();
                return Err(self.unsupported(
                    child,
                    &format!(
                        "not supported; the importer takes {} in `<{section}>`",
                        takes.join(" or ")
                    ),
                ));
            }
            found.push(child);
        }
        Ok(found)
    }
}

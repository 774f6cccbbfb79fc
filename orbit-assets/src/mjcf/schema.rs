//! The attributes the importer takes on each MJCF element. An attribute outside an element's
//! lists is an error naming it and its line, so that a typo (`densty`) or an attribute the
//! importer cannot simulate never changes a model silently. Visual and bookkeeping attributes
//! are ignored (docs/configs.md lists them); MuJoCo's contact and solver settings that the
//! engines do not simulate are accepted with a warning that names each one and its lines.

use std::collections::BTreeMap;

use super::xml::{Element, mjcf_error};
use crate::error::AssetError;

/// An element's attributes: those the importer reads (with the pose attributes, if `posed`),
/// those it ignores (visual), those it accepts without simulating them (warned).
struct Schema {
    posed: bool,
    read: &'static [&'static str],
    ignored: &'static [&'static str],
    not_simulated: &'static [&'static str],
}

/// The position and orientation attributes of an element placed in its body's frame.
const POSE: &[&str] = &["pos", "quat", "euler", "axisangle", "zaxis", "xyaxes"];
/// Values of otherwise unsimulated attributes that the engines' model matches: frictional
/// contacts of three dimensions, no margin or gap, equal priority.
const SIMULATED_VALUES: &[(&str, &str)] = &[
    ("condim", "3"),
    ("margin", "0"),
    ("gap", "0"),
    ("priority", "0"),
];
/// The attributes of `<option><flag>`.
const FLAGS: &[&str] = &[
    "constraint",
    "equality",
    "frictionloss",
    "limit",
    "contact",
    "spring",
    "damper",
    "gravity",
    "clampctrl",
    "warmstart",
    "filterparent",
    "actuation",
    "refsafe",
    "sensor",
    "midphase",
    "eulerdamp",
    "autoreset",
    "nativeccd",
    "island",
    "override",
    "energy",
    "fwdinv",
    "invdiscrete",
    "multiccd",
    "sleep",
];
/// Attributes that only draw or label: MuJoCo's rendering groups, colours and user data.
const VISUAL: &[&str] = &["rgba", "material", "group", "user"];

/// The schema of the elements the importer reads; `None` for an element it does not read.
#[rustfmt::skip]
fn schema(element: &str) -> Option<Schema> {
    let s = |posed, read, ignored, not_simulated| {
        Some(Schema { posed, read, ignored, not_simulated })
    };
    match element {
        "mujoco" => s(false, &["model"], &[], &[]),
        "default" => s(false, &["class"], &[], &[]),
        "compiler" => s(false,
            &["angle", "inertiafromgeom", "eulerseq", "coordinate", "autolimits"],
            &["meshdir", "texturedir", "assetdir", "strippath", "discardvisual", "usethread"],
            &[]),
        "option" => s(false, &["timestep"], &[],
            &["integrator", "iterations", "ls_iterations", "solver", "tolerance", "cone",
              "impratio", "jacobian", "noslip_iterations", "gravity"]),
        // MuJoCo's simulation flags; the engines run with their own (MuJoCo's defaults).
        "flag" => s(false, &[], &[], FLAGS),
        "body" => s(true, &["name", "childclass"], &["user"], &[]),
        "joint" => s(false,
            &["name", "type", "pos", "axis", "limited", "range", "stiffness", "springref",
              "armature", "damping", "frictionloss"],
            &["group", "user"],
            &["solreflimit", "solimplimit", "solreffriction", "solimpfriction", "margin"]),
        "freejoint" => s(false, &["name"], &["group"], &[]),
        "geom" => s(true,
            &["name", "type", "size", "fromto", "contype", "conaffinity", "friction", "density",
              "mass"],
            VISUAL,
            &["condim", "priority", "solmix", "solref", "solimp", "margin", "gap"]),
        "site" => s(true, &["name"], &["type", "size", "fromto", "rgba", "material", "group", "user"], &[]),
        "inertial" => s(true, &["mass", "diaginertia", "fullinertia"], &[], &[]),
        // A `<general>` without gain, bias or dynamics attributes is a motor.
        "motor" | "general" => s(false, &["name", "joint", "gear", "ctrllimited", "ctrlrange"], &["group", "user"], &[]),
        "exclude" => s(false, &["name", "body1", "body2"], &[], &[]),
        _ => None,
    }
}

/// Attributes accepted without being simulated, with the lines they stand on, for one warning
/// per attribute at the end of an import.
#[derive(Debug, Default)]
pub(crate) struct Unsimulated(BTreeMap<(String, String), Vec<usize>>);

impl Unsimulated {
    /// Logs one warning per attribute, naming the element, the file and the lines.
    pub fn warn(&self, file: &str) {
        for ((element, attribute), lines) in &self.0 {
            let lines: Vec<String> = lines.iter().map(usize::to_string).collect();
            tracing::warn!(
                "{file}: `{attribute}` of `<{element}>` (line {}) is not simulated: the \
                 engines use their own contact and solver settings (docs/physics.md)",
                lines.join(", ")
            );
        }
    }
}

/// Checks `element`'s own attributes against its schema (`as_element`: the element whose
/// schema applies, for a `<default>`'s children). Elements the importer does not read pass.
pub(crate) fn check(
    file: &str,
    element: &Element,
    as_element: &str,
    unsimulated: &mut Unsimulated,
) -> Result<(), AssetError> {
    let Some(schema) = schema(as_element) else {
        return Ok(());
    };
    for (key, value) in &element.attrs {
        let key = key.as_str();
        // `class` selects a default class on every element that has one.
        let read = schema.read.contains(&key) || (schema.posed && POSE.contains(&key));
        if key == "class" || read || schema.ignored.contains(&key) {
            continue;
        }
        if schema.not_simulated.contains(&key) {
            if SIMULATED_VALUES.contains(&(key, value.trim())) {
                continue;
            }
            let lines = (unsimulated.0)
                .entry((as_element.to_string(), key.to_string()))
                .or_default();
            lines.push(element.line);
            continue;
        }
        let pose = if schema.posed { POSE } else { &[] };
        let mut known: Vec<&str> = (schema.read.iter().chain(pose).chain(schema.not_simulated))
            .copied()
            .collect();
        known.sort_unstable();
        return Err(mjcf_error(
            file,
            element.line,
            &element.name,
            Some(key),
            format!(
                "not an attribute the importer takes on `<{as_element}>`; it takes {}{}",
                known.join(", "),
                if schema.ignored.is_empty() {
                    String::new()
                } else {
                    format!(" (and ignores {})", schema.ignored.join(", "))
                }
            ),
        ));
    }
    Ok(())
}

/// Checks the attributes of every element the importer reads: `<compiler>`, `<option>`, the
/// world body's tree, motors, contact exclusions and the elements of `<default>` classes.
pub(crate) fn check_document(root: &Element, file: &str) -> Result<Unsimulated, AssetError> {
    let mut unsimulated = Unsimulated::default();
    check(file, root, "mujoco", &mut unsimulated)?;
    for section in &root.children {
        match section.name.as_str() {
            "compiler" => check(file, section, &section.name, &mut unsimulated)?,
            "option" => {
                check(file, section, "option", &mut unsimulated)?;
                for child in &section.children {
                    if child.name != "flag" {
                        return Err(mjcf_error(
                            file,
                            child.line,
                            &child.name,
                            None,
                            "not supported in `<option>`; the importer takes `<flag>`".into(),
                        ));
                    }
                    check(file, child, "flag", &mut unsimulated)?;
                }
            }
            "worldbody" | "default" => check_tree(file, section, &mut unsimulated)?,
            "actuator" | "contact" => {
                for element in &section.children {
                    check(file, element, &element.name, &mut unsimulated)?;
                }
            }
            _ => {}
        }
    }
    Ok(unsimulated)
}

/// [`check`] on `element` and every element below it.
fn check_tree(
    file: &str,
    element: &Element,
    unsimulated: &mut Unsimulated,
) -> Result<(), AssetError> {
    check(file, element, &element.name, unsimulated)?;
    for child in &element.children {
        check_tree(file, child, unsimulated)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `condim="3"` is the engines' own contact model and passes silently; a margin is warned
    /// with its line; a typo is an error.
    #[test]
    fn only_values_the_engines_do_not_simulate_are_warned() {
        let geom = |attrs: &[(&str, &str)]| Element {
            name: "geom".into(),
            attrs: attrs
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            children: Vec::new(),
            line: 7,
        };
        let mut unsimulated = Unsimulated::default();
        let e = geom(&[("condim", "3"), ("margin", "0.01"), ("rgba", "1 0 0 1")]);
        check("a.xml", &e, "geom", &mut unsimulated).unwrap();
        let warned: Vec<_> = unsimulated.0.iter().collect();
        assert_eq!(warned.len(), 1);
        assert_eq!(warned[0].0, &("geom".to_string(), "margin".to_string()));
        assert_eq!(warned[0].1, &vec![7]);
        assert!(check("a.xml", &geom(&[("densty", "3")]), "geom", &mut unsimulated).is_err());
    }

    /// `<option>`'s flags are warned (the engines keep their own), an unknown flag or another
    /// child of `<option>` is an error with its line.
    #[test]
    fn option_flags_are_warned_and_other_children_refused() {
        let doc = |option: &str| {
            let text = format!(
                "<mujoco>\n<option timestep=\"0.005\">\n{option}\n</option>\n<worldbody/>\n</mujoco>"
            );
            check_document(&super::super::xml::parse(&text, "o.xml").unwrap(), "o.xml")
        };
        let warned = doc("<flag eulerdamp=\"disable\"/>").unwrap();
        let warned: Vec<_> = warned.0.iter().collect();
        assert_eq!(warned.len(), 1);
        assert_eq!(warned[0].0, &("flag".to_string(), "eulerdamp".to_string()));
        assert_eq!(warned[0].1, &vec![3]);
        let e = doc("<flag eulrdamp=\"disable\"/>").unwrap_err().to_string();
        assert!(e.contains("o.xml:3: <flag> attribute `eulrdamp`"), "{e}");
        let e = doc("<gravity/>").unwrap_err().to_string();
        assert!(
            e.contains("o.xml:3: <gravity>: not supported in `<option>`"),
            "{e}"
        );
    }
}

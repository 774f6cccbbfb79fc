use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::Vec3;
use serde::Deserialize;
use serde::de::DeserializeOwned;

use super::*;

// ---- test types ----

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct Experiment {
    name: String,
    #[serde(default)]
    seed: u64,
    sim: Sim,
    #[serde(default)]
    joints: Vec<Joint>,
    #[serde(default)]
    init_pos: BTreeMap<String, f32>,
    #[serde(default)]
    actuators: BTreeMap<String, Actuator>,
    #[serde(default)]
    label: Option<String>,
    #[serde(default)]
    offset: Vec3,
    #[serde(default)]
    num_envs: usize,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct Sim {
    dt: f32,
    #[serde(default = "default_substeps")]
    substeps: u32,
    backend: Backend,
    #[serde(default)]
    gravity: Option<Vec3>,
}

fn default_substeps() -> u32 {
    4
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
enum Backend {
    Rapier,
    Mock(u32),
    Remote { host: String, port: u16 },
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct Joint {
    name: String,
    kind: JointKind,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
enum JointKind {
    Fixed,
    Revolute {
        axis: Vec3,
        limits: Option<(f32, f32)>,
    },
    Prismatic(Vec3),
    Spring(f32, f32),
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct Actuator {
    joints: Vec<String>,
    stiffness: PerJoint,
    #[serde(default)]
    damping: Option<PerJoint>,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
enum PerJoint {
    All(f32),
    ByName(BTreeMap<String, f32>),
}

const FULL: &str = r#"// A full experiment.
#![enable(implicit_some)]
Experiment(
    name: "reach",
    seed: 42,
    sim: Sim(dt: 0.005, backend: Remote(host: "gpu-01", port: 7000), gravity: Some((0.0, 0.0, -9.81))),
    joints: [
        (name: "base", kind: Fixed),
        Joint(name: "shoulder", kind: Revolute(axis: [0, 0, 1], limits: Some((-2.9, 2.9)))),
        (name: "slide", kind: Prismatic((1.0, 0.0, 0.0))),
        (name: "spring", kind: Spring(100, 2.5)),
    ],
    init_pos: {"panda_joint[1-4]": 0.5, "panda_finger.*": 0.04},
    actuators: {
        "arm": (joints: ["panda_joint.*"], stiffness: 400, damping: 40.0),
        "hand": (joints: ["panda_finger.*"], stiffness: {"panda_finger_1": 1e3, "panda_finger_2": 2_000.0}),
    },
    label: "first try", /* a bare value is taken as Some */
    offset: (1, 2.5, -3),
    num_envs: 0x10,
)
"#;

fn full_expected() -> Experiment {
    Experiment {
        name: "reach".into(),
        seed: 42,
        sim: Sim {
            dt: 0.005,
            substeps: 4,
            backend: Backend::Remote {
                host: "gpu-01".into(),
                port: 7000,
            },
            gravity: Some(Vec3::new(0.0, 0.0, -9.81)),
        },
        joints: vec![
            Joint {
                name: "base".into(),
                kind: JointKind::Fixed,
            },
            Joint {
                name: "shoulder".into(),
                kind: JointKind::Revolute {
                    axis: Vec3::Z,
                    limits: Some((-2.9, 2.9)),
                },
            },
            Joint {
                name: "slide".into(),
                kind: JointKind::Prismatic(Vec3::X),
            },
            Joint {
                name: "spring".into(),
                kind: JointKind::Spring(100.0, 2.5),
            },
        ],
        init_pos: map(&[("panda_joint[1-4]", 0.5), ("panda_finger.*", 0.04)]),
        actuators: BTreeMap::from([
            (
                "arm".to_string(),
                Actuator {
                    joints: vec!["panda_joint.*".into()],
                    stiffness: PerJoint::All(400.0),
                    damping: Some(PerJoint::All(40.0)),
                },
            ),
            (
                "hand".to_string(),
                Actuator {
                    joints: vec!["panda_finger.*".into()],
                    stiffness: PerJoint::ByName(map(&[
                        ("panda_finger_1", 1000.0),
                        ("panda_finger_2", 2000.0),
                    ])),
                    damping: None,
                },
            ),
        ]),
        label: Some("first try".into()),
        offset: Vec3::new(1.0, 2.5, -3.0),
        num_envs: 16,
    }
}

/// A minimal valid `sim` field, for documents that test something else.
const SIM: &str = "sim: (dt: 0.01, backend: Rapier)";

fn map(entries: &[(&str, f32)]) -> BTreeMap<String, f32> {
    entries.iter().map(|&(k, v)| (k.to_string(), v)).collect()
}

fn parse<T: DeserializeOwned>(text: &str) -> Result<T, ConfigError> {
    from_str(text, "test.ron", &[])
}

fn parse_with<T: DeserializeOwned>(text: &str, overrides: &[&str]) -> Result<T, ConfigError> {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    from_str(text, "test.ron", &overrides)
}

/// The error's display, asserting that loading failed.
fn error_text<T: DeserializeOwned + std::fmt::Debug>(text: &str) -> String {
    parse::<T>(text).expect_err(text).to_string()
}

fn document(text: &str) -> Node {
    include::load_text(text, "test.ron").unwrap()
}

/// Whether `message` contains `file:line:col: `.
fn has_location(message: &str, file: &str) -> bool {
    regex::Regex::new(&format!(r"{}:\d+:\d+: ", regex::escape(file)))
        .unwrap()
        .is_match(message)
}

/// A scratch directory under the system temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let name = format!("orbit-config-test-{}-{tag}-{n}", std::process::id());
        let dir = std::env::temp_dir().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn write(&self, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
        let path = self.0.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, contents).unwrap();
        path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

// ---- deserialisation ----

#[test]
fn full_document_deserializes() {
    let cfg: Experiment = parse(FULL).unwrap();
    assert_eq!(cfg, full_expected());
}

#[test]
fn per_joint_untagged_accepts_float_int_and_map() {
    for (text, expected) in [
        ("400.0", PerJoint::All(400.0)),
        ("400", PerJoint::All(400.0)),
        ("-3", PerJoint::All(-3.0)),
        (
            r#"{"a.*": 1.0, "b": 2}"#,
            PerJoint::ByName(map(&[("a.*", 1.0), ("b", 2.0)])),
        ),
        ("(panda: 5.0)", PerJoint::ByName(map(&[("panda", 5.0)]))),
    ] {
        assert_eq!(parse::<PerJoint>(text).unwrap(), expected, "{text}");
    }
    let message = error_text::<PerJoint>(r#""stiff""#);
    assert!(
        message.contains("did not match any variant of untagged enum PerJoint"),
        "{message}"
    );
}

#[test]
fn vec3_from_tuple_list_and_named_tuple() {
    for text in ["(1, 2.5, -3)", "[1, 2.5, -3]", "Vec3(1.0, 2.5, -3.0)"] {
        assert_eq!(
            parse::<Vec3>(text).unwrap(),
            Vec3::new(1.0, 2.5, -3.0),
            "{text}"
        );
    }
    // A newtype variant over a Vec3 accepts the tuple with or without its own brackets.
    assert_eq!(
        parse::<JointKind>("Prismatic(0, 1, 0)").unwrap(),
        JointKind::Prismatic(Vec3::Y)
    );
    assert!(error_text::<Vec3>("(1, 2)").contains("invalid length 2"));
    let message = error_text::<Vec3>("(1, 2, 3, 4)");
    assert!(
        message.contains("invalid length 4, expected 3 elements"),
        "{message}"
    );
}

#[test]
fn options_accept_none_some_and_bare_values() {
    #[derive(Debug, PartialEq, Deserialize)]
    struct Opts {
        a: Option<f32>,
        b: Option<f32>,
        c: Option<f32>,
        #[serde(default)]
        d: Option<f32>,
        e: Option<Vec3>,
        f: Option<JointKind>,
        g: Option<Option<u8>>,
    }
    let opts: Opts = parse(
        "(a: None, b: Some(1.5), c: 2, e: (1, 2, 3), f: Prismatic((1, 0, 0)), g: Some(None))",
    )
    .unwrap();
    assert_eq!(
        opts,
        Opts {
            a: None,
            b: Some(1.5),
            c: Some(2.0),
            d: None,
            e: Some(Vec3::new(1.0, 2.0, 3.0)),
            f: Some(JointKind::Prismatic(Vec3::X)),
            g: Some(None),
        }
    );
}

#[test]
fn defaults_fill_missing_fields() {
    let cfg: Experiment = parse(&format!("(name: \"x\", {SIM})")).unwrap();
    assert_eq!(cfg.sim.substeps, 4);
    assert_eq!(cfg.sim.gravity, None);
    assert_eq!(cfg.seed, 0);
    assert!(cfg.joints.is_empty() && cfg.actuators.is_empty());
    assert_eq!(cfg.offset, Vec3::ZERO);
}

#[test]
fn struct_names_are_ignored_but_variant_names_select() {
    let cfg: Experiment = parse(&format!("AnyName(name: \"x\", {SIM})")).unwrap();
    assert_eq!(cfg.sim.backend, Backend::Rapier);
    for (text, expected) in [
        ("Rapier", Backend::Rapier),
        ("\"Rapier\"", Backend::Rapier),
        ("Mock(3)", Backend::Mock(3)),
        ("{\"Mock\": 3}", Backend::Mock(3)),
        (
            "Remote(host: \"h\", port: 1)",
            Backend::Remote {
                host: "h".into(),
                port: 1,
            },
        ),
    ] {
        assert_eq!(parse::<Backend>(text).unwrap(), expected, "{text}");
    }
    assert_eq!(
        parse::<JointKind>("Spring(1, 2)").unwrap(),
        JointKind::Spring(1.0, 2.0)
    );
}

#[test]
fn newtype_structs_accept_wrapped_and_bare_values() {
    #[derive(Debug, PartialEq, Deserialize)]
    struct Meters(f32);
    for text in ["Meters(2.0)", "(2)", "2.0"] {
        assert_eq!(parse::<Meters>(text).unwrap(), Meters(2.0), "{text}");
    }
}

#[test]
fn deserialize_any_sees_the_natural_kind() {
    #[derive(Debug, PartialEq, Deserialize)]
    #[serde(untagged)]
    enum Loose {
        Bool(bool),
        Int(i64),
        Float(f64),
        Text(String),
        List(Vec<Loose>),
        Map(BTreeMap<String, Loose>),
    }
    use Loose::*;
    let value: Loose =
        parse(r#"[1, -2, 2.5, "s", true, Fixed, (3, 4), (a: 1), {"b": [2]}]"#).unwrap();
    let expected = List(vec![
        Int(1),
        Int(-2),
        Float(2.5),
        Text("s".into()),
        Bool(true),
        Text("Fixed".into()),
        List(vec![Int(3), Int(4)]),
        Map(BTreeMap::from([("a".into(), Int(1))])),
        Map(BTreeMap::from([("b".into(), List(vec![Int(2)]))])),
    ]);
    assert_eq!(value, expected);
}

#[test]
fn scene_cfg_loads_and_reports_bad_geometry_with_its_path() {
    let ok = "(rigid_objects: [(name: \"box\", shapes: [(geometry: Sphere(radius: 0.5))])])";
    let scene: crate::scene::SceneCfg = parse(ok).unwrap();
    assert_eq!(
        scene.rigid_objects[0].shapes[0].geometry,
        crate::scene::Geometry::Sphere { radius: 0.5 }
    );
    let bad = "(\n  rigid_objects: [\n    (name: \"box\", shapes: [(geometry: Cube(size: 1.0))]),\n  ],\n)";
    let message = error_text::<crate::scene::SceneCfg>(bad);
    assert!(
        message.starts_with(
            "test.ron:3:39: rigid_objects[0].shapes[0].geometry: unknown variant `Cube`, \
             expected one of `Sphere`, `Capsule`"
        ),
        "{message}"
    );
}

// ---- AST printing and lookup ----

#[test]
fn to_ron_round_trips() {
    let awkward = r##"Doc(
        s: "quote \" backslash \\ tab \t newline \n unicode \u{e9}\u00e8 ctrl \u{1}",
        raw: r#"no "escapes" \here"#,
        chars: ['a', '\'', '\n', '\\', 'é'],
        ints: [0, -1, 170141183460469231731687303715884105727, 0xff, -0b101, 0o17, 1_000],
        floats: [0.5, -0.0, 1e-7, 2.5E+20, .25, 3., 1e300],
        nested: [[], [[1]], {}, {1: "one", "k": [()]}],
        tuples: ((1), Foo(), Bar(1, "two"), Baz(x: None, y: Some(Some(true)))),
        units: [None, Revolute, true, false],
    )"##;
    for text in [FULL, awkward] {
        let tree = document(text);
        let printed = tree.to_ron();
        let reparsed = document(&printed);
        assert_eq!(tree, reparsed, "{printed}");
        assert_eq!(reparsed.to_ron(), printed);
    }
    let printed = document(FULL).to_ron();
    assert_eq!(parse::<Experiment>(&printed).unwrap(), full_expected());
    let tree = document(awkward);
    assert_eq!(
        node_at(&tree, "s").unwrap().kind,
        NodeKind::Str("quote \" backslash \\ tab \t newline \n unicode éè ctrl \u{1}".into())
    );
    assert_eq!(
        node_at(&tree, "ints[2]").unwrap().kind,
        NodeKind::Int(i128::MAX)
    );
    assert_eq!(node_at(&tree, "ints[4]").unwrap().kind, NodeKind::Int(-5));
    assert_eq!(
        node_at(&tree, "floats[4]").unwrap().kind,
        NodeKind::Float(0.25)
    );
}

#[test]
fn node_at_follows_fields_indices_keys_and_some() {
    let tree = document(FULL);
    let kind = |path: &str| node_at(&tree, path).map(|n| n.kind.clone());
    assert!(
        matches!(kind("sim.backend"), Some(NodeKind::Struct { name: Some(n), .. }) if n == "Remote")
    );
    assert_eq!(kind("sim.backend.port"), Some(NodeKind::Int(7000)));
    assert_eq!(kind("joints[0].kind"), Some(NodeKind::Unit("Fixed".into())));
    assert_eq!(
        kind(r#"init_pos["panda_finger.*"]"#),
        Some(NodeKind::Float(0.04))
    );
    assert_eq!(kind("actuators.arm.stiffness"), Some(NodeKind::Int(400)));
    assert_eq!(kind("sim.gravity[2]"), Some(NodeKind::Float(-9.81)));
    assert_eq!(kind("joints[9]"), None);
    assert_eq!(kind("sim.nope"), None);
    assert_eq!(kind("sim..dt"), None);
    assert_eq!(kind("sim.dt junk"), None);
    assert_eq!(node_at(&tree, "sim.dt").unwrap().span.line, 6);
}

// ---- includes ----

const BASE: &str = r#"// base config
Experiment(
    name: "base",
    sim: Sim(dt: 0.01, backend: Remote(host: "a", port: 1)),
    init_pos: {"j.*": 0.0},
)
"#;

#[test]
fn include_merges_base_and_variant() {
    let dir = TempDir::new("merge");
    let base = dir.write("base.ron", BASE);
    let variant = dir.write(
        "variant.ron",
        "#include \"base.ron\"\n(\n    sim: (dt: 0.002),\n    joints: [(name: \"j1\", kind: Fixed)],\n    init_pos: {\"k.*\": 1.0},\n)\n",
    );
    let cfg: Experiment = load(&variant, &[]).unwrap();
    assert_eq!(cfg.name, "base");
    assert_eq!(cfg.sim.dt, 0.002);
    assert_eq!(
        cfg.sim.backend,
        Backend::Remote {
            host: "a".into(),
            port: 1
        }
    );
    assert_eq!(cfg.joints.len(), 1);
    assert_eq!(cfg.init_pos, map(&[("j.*", 0.0), ("k.*", 1.0)]));

    // Spans follow the value that won.
    let tree = load_document(&variant, &[]).unwrap();
    let dt = node_at(&tree, "sim.dt").unwrap();
    assert_eq!(
        (dt.span.file.as_path(), dt.span.line),
        (variant.as_path(), 3)
    );
    let backend = node_at(&tree, "sim.backend").unwrap();
    assert_eq!(
        (backend.span.file.as_path(), backend.span.line),
        (base.as_path(), 4)
    );
}

#[test]
fn include_merges_same_variant_fieldwise_and_replaces_other_variants() {
    let dir = TempDir::new("variants");
    dir.write("base.ron", BASE);
    let same = dir.write(
        "same.ron",
        "#include \"base.ron\"\n(sim: (backend: Remote(port: 2)))",
    );
    let other = dir.write(
        "other.ron",
        "#include \"base.ron\"\n(sim: (backend: Mock(3)))",
    );
    let cfg: Experiment = load(&same, &[]).unwrap();
    assert_eq!(
        cfg.sim.backend,
        Backend::Remote {
            host: "a".into(),
            port: 2
        }
    );
    let cfg: Experiment = load(&other, &[]).unwrap();
    assert_eq!(cfg.sim.backend, Backend::Mock(3));
}

#[test]
fn include_chain_of_two_levels_is_relative_to_each_file() {
    let dir = TempDir::new("chain");
    dir.write("sub/leaf.ron", format!("(name: \"leaf\", seed: 1, {SIM})"));
    dir.write(
        "sub/mid.ron",
        "// includes are relative to this file\n#include \"leaf.ron\"\n(name: \"mid\", seed: 2)",
    );
    let top = dir.write("top.ron", "#include \"sub/mid.ron\"\n(seed: 3)\n");
    let include_only = dir.write("only.ron", "#include \"sub/mid.ron\"\n");
    let cfg: Experiment = load(&top, &[]).unwrap();
    assert_eq!((cfg.name.as_str(), cfg.seed, cfg.sim.dt), ("mid", 3, 0.01));
    let cfg: Experiment = load(&include_only, &[]).unwrap();
    assert_eq!((cfg.name.as_str(), cfg.seed), ("mid", 2));

    // The resolved document saved as RON loads to the same config.
    let saved = load_document(&top, &[]).unwrap().to_ron();
    assert!(!saved.contains("#include"));
    assert_eq!(
        parse::<Experiment>(&saved).unwrap(),
        load(&top, &[]).unwrap()
    );
}

#[test]
fn include_cycle_is_an_error_naming_both_files() {
    let dir = TempDir::new("cycle");
    let a = dir.write("a.ron", "#include \"b.ron\"\n(name: \"a\")");
    dir.write("b.ron", "// b\n#include \"a.ron\"\n(name: \"b\")");
    let err = load::<Experiment>(&a, &[]).unwrap_err();
    assert!(
        matches!(
            err,
            ConfigError::Include {
                line: 2,
                col: 1,
                ..
            }
        ),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(message.contains("include cycle"), "{message}");
    assert!(
        message.contains("a.ron -> ") && message.contains("b.ron -> "),
        "{message}"
    );
    assert!(has_location(&message, "b.ron"), "{message}");

    let selfish = dir.write("self.ron", "#include \"self.ron\"\n()");
    let message = load::<Experiment>(&selfish, &[]).unwrap_err().to_string();
    assert!(message.contains("include cycle"), "{message}");
}

#[test]
fn missing_include_is_an_io_error_naming_the_including_file_and_line() {
    let dir = TempDir::new("missing");
    let a = dir.write(
        "a.ron",
        "// comment\n\n#include \"nope.ron\"\n(name: \"a\")",
    );
    let err = load::<Experiment>(&a, &[]).unwrap_err();
    let ConfigError::Io {
        file,
        included_from: Some(from),
        ..
    } = &err
    else {
        panic!("expected an Io error, got {err:?}");
    };
    assert!(file.ends_with("nope.ron"));
    assert_eq!(
        (from.file.as_path(), from.line, from.col),
        (a.as_path(), 3, 1)
    );
    let message = err.to_string();
    assert!(
        has_location(&message, "a.ron") && message.contains("nope.ron"),
        "{message}"
    );

    let missing = dir.0.join("absent.ron");
    let err = load::<Experiment>(&missing, &[]).unwrap_err();
    assert!(matches!(
        err,
        ConfigError::Io {
            included_from: None,
            ..
        }
    ));
    assert!(err.to_string().contains("absent.ron"));
}

#[test]
fn values_from_an_include_are_reported_in_the_included_file() {
    let dir = TempDir::new("blame");
    let base = dir.write(
        "base.ron",
        format!("(\n  name: \"b\",\n  num_envs: -1,\n  {SIM},\n)"),
    );
    let top = dir.write("top.ron", "#include \"base.ron\"\n(seed: 1)");
    let message = load::<Experiment>(&top, &[]).unwrap_err().to_string();
    let expected = format!(
        "{}:3:13: num_envs: invalid value: integer `-1`, expected usize",
        base.display()
    );
    assert_eq!(message, expected);
}

// ---- overrides ----

#[test]
fn overrides_set_fields_indices_keys_and_tuples() {
    let cfg: Experiment = parse_with(
        FULL,
        &[
            "sim.dt=0.001",
            "sim.dt = 0.002", // later overrides win; spaces are fine
            "joints[1].kind=Fixed",
            "actuators.arm.stiffness=300",
            r#"init_pos["panda_finger.*"]=0.02"#,
            r#"init_pos["new.*"]=1"#,
            "offset=(0.0, 0.0, 0.1)",
            "sim.gravity[2]=-1.0", // through Some(..)
            "sim.backend=Mock(8)",
            "sim.substeps=8", // absent from the file, valid for the type
            "label=None",
        ],
    )
    .unwrap();
    assert_eq!(cfg.sim.dt, 0.002);
    assert_eq!(cfg.joints[1].kind, JointKind::Fixed);
    assert_eq!(cfg.actuators["arm"].stiffness, PerJoint::All(300.0));
    assert_eq!(cfg.init_pos["panda_finger.*"], 0.02);
    assert_eq!(cfg.init_pos["new.*"], 1.0);
    assert_eq!(cfg.offset, Vec3::new(0.0, 0.0, 0.1));
    assert_eq!(cfg.sim.gravity, Some(Vec3::new(0.0, 0.0, -1.0)));
    assert_eq!(cfg.sim.backend, Backend::Mock(8));
    assert_eq!(cfg.sim.substeps, 8);
    assert_eq!(cfg.label, None);
}

#[test]
fn overrides_apply_to_loaded_files() {
    let dir = TempDir::new("override-file");
    dir.write("base.ron", BASE);
    let top = dir.write("top.ron", "#include \"base.ron\"\n(seed: 1)");
    let overrides = [
        "sim.backend.port=9".to_string(),
        "offset=[1, 2, 3]".to_string(),
    ];
    let cfg: Experiment = load(&top, &overrides).unwrap();
    assert_eq!(
        cfg.sim.backend,
        Backend::Remote {
            host: "a".into(),
            port: 9
        }
    );
    assert_eq!(cfg.offset, Vec3::new(1.0, 2.0, 3.0));
    // `offset` is absent from the files, so `offset[1]` does not exist.
    let err = load::<Experiment>(&top, &["offset[1]=2".to_string()]).unwrap_err();
    assert_eq!(
        err.to_string(),
        "override `offset[1]=2`: `offset` does not exist, so it cannot be indexed"
    );
}

#[test]
fn override_adding_an_unknown_field_is_rejected_naming_the_override() {
    let err = parse_with::<Experiment>(FULL, &["sim.dt=0.1", "sim.substep=2"]).unwrap_err();
    let message = err.to_string();
    assert!(
        message.starts_with(
            "override `sim.substep=2`: sim.substep: unknown field `substep`, expected one of"
        ),
        "{message}"
    );

    // Missing intermediate structs are created, so serde reports what is missing in them.
    let message = parse_with::<Experiment>(FULL, &["actuators.leg.stiffness=1.0"])
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("actuators.leg: missing field `joints`")
            && message.contains("override `actuators.leg.stiffness=1.0`"),
        "{message}"
    );

    let message = parse_with::<Experiment>(FULL, &["sim.dt=\"fast\""])
        .unwrap_err()
        .to_string();
    assert_eq!(
        message,
        "override `sim.dt=\"fast\"`: sim.dt: invalid type: string \"fast\", expected f32"
    );
}

#[test]
fn malformed_overrides_are_override_errors() {
    for (text, expected) in [
        ("a.b", "missing `=`"),
        (
            "=3",
            "expected a field name at the start of the path (column 1), found `=`",
        ),
        (
            "a..b=1",
            "expected a field name after `.` (column 3), found `.`",
        ),
        ("a[x]=1", "expected an index or a quoted key after `[`"),
        ("a[0=1", "expected `]` at column 4, found `=`"),
        (r#"a["k=1"#, "unterminated string"),
        (
            "sim dt=1",
            "expected `=` after the path at column 5, found `d`",
        ),
        (
            "sim.dt=",
            "bad value at column 8: expected a value, found end of input",
        ),
        (
            "sim.dt=1 2",
            "bad value at column 10: expected end of input after the value",
        ),
        ("sim.dt=(1,", "bad value"),
        (
            "joints[9].name=\"x\"",
            "index 9 is out of range: `joints` has 4 elements",
        ),
        (
            "joints[4]=(name: \"x\", kind: Fixed)",
            "index 4 is out of range",
        ),
        (
            "sim.dt.x=1",
            "`sim.dt` is floating point `0.005`, which has no field `x`",
        ),
        (
            "name[0]=1",
            "`name` is string \"reach\", which has no index [0]",
        ),
        (r#"sim["not ident"]=1"#, "not a valid field name"),
    ] {
        let err = parse_with::<Experiment>(FULL, &[text]).unwrap_err();
        let ConfigError::Override {
            override_text,
            message,
        } = &err
        else {
            panic!("{text}: expected an Override error, got {err:?}");
        };
        assert_eq!(override_text, text);
        assert!(message.contains(expected), "{text}: {message}");
        assert!(
            err.to_string().starts_with(&format!("override `{text}`: ")),
            "{err}"
        );
    }
}

// ---- malformed input ----

#[test]
fn malformed_inputs_are_located_errors() {
    let deep = "[".repeat(10_000);
    let cases: Vec<(String, &str)> = vec![
        ("(name: \"abc".into(), "unterminated string"),
        (
            format!("(name: \"a\" {SIM})"),
            "expected `,` or `)` after field `name`, found `s`",
        ),
        (
            format!("(name \"a\", {SIM})"),
            "missing `:` after field name `name`?",
        ),
        (
            format!("(name: \"a\", {SIM}, seed 3)"),
            "expected `:` after field name `seed`",
        ),
        (
            "(name: \"a\", joints: [(name: \"b\", kind: Fixed)".into(),
            "expected `,` or `]` after list element, found end of input (the `[` at 1:21 is never closed)",
        ),
        (
            format!("(name: \"a\", {SIM}))"),
            "expected end of input after the value, found `)`",
        ),
        (
            format!("(name: \"a\", {SIM}, joints: [1, 2))"),
            "expected `,` or `]` after list element, found `)`",
        ),
        (
            format!("(name: 3, {SIM})"),
            "name: invalid type: integer `3`, expected a string",
        ),
        (
            "(name: \"a\", sim: (dt: 0.01, backend: Rapier, substep: 2))".into(),
            "sim.substep: unknown field `substep`, expected one of `dt`, `substeps`, `backend`, `gravity`",
        ),
        (
            "(name: \"a\", sim: (dt: 0.01, backend: Bullet))".into(),
            "sim.backend: unknown variant `Bullet`, expected one of `Rapier`, `Mock`, `Remote`",
        ),
        ("(name: \"a\")".into(), "missing field `sim`"),
        (
            format!("(name: \"a\", {SIM}, num_envs: -1)"),
            "invalid value: integer `-1`, expected usize",
        ),
        (
            format!("(name: \"a\", {SIM}, seed: 1.5)"),
            "invalid type: floating point `1.5`, expected u64",
        ),
        (
            format!("(name: \"a\", name: \"b\", {SIM})"),
            "duplicate field `name` (first at 1:2)",
        ),
        ("".into(), "empty document"),
        ("  // only a comment\n".into(), "empty document"),
        (
            "\u{0}\u{1}\u{7f}garbage\u{2}".into(),
            "expected a value, found `\\0`",
        ),
        ("\u{1b}[31m(".into(), "expected a value, found `\\u{1b}`"),
        (deep, "nesting too deep: more than 128 levels of brackets"),
        (
            format!("(name: \"a\", {SIM}, seed: 1000000000000000000000000000000000000000000)"),
            "does not fit in 128 bits",
        ),
        (
            format!("(name: \"a\", {SIM}, seed: 100000000000000000000000)"),
            "integer `100000000000000000000000` as u128, expected u64",
        ),
        (
            "(name: \"a\", sim: (dt: 1e999, backend: Rapier))".into(),
            "out of range for a 64-bit float",
        ),
        (
            "(name: \"a\", sim: (dt: 1e39, backend: Rapier))".into(),
            "sim.dt: 1e39 is out of range: a 32-bit float holds magnitudes up to 3.4e38",
        ),
        (
            "(name: \"a\", sim: (dt: 1e-50, backend: Rapier))".into(),
            "sim.dt: 1e-50 is out of range: a 32-bit float holds non-zero magnitudes from 1.2e-38",
        ),
        (
            format!("(name: \"a\", {SIM}, offset: (1, -4e38, 3))"),
            "-4e38 is out of range: a 32-bit float",
        ),
        ("(name: \"a\" /* open".into(), "unterminated block comment"),
        (
            format!("(name: \"a\\q\", {SIM})"),
            "unknown escape sequence `\\q`",
        ),
        (
            format!("(name: \"a\", {SIM}, joints: [(name: \"j\", kind: Ball)])"),
            "joints[0].kind: unknown variant `Ball`",
        ),
        (
            format!("(name: \"a\", {SIM}, offset: (1, 2))"),
            "offset: invalid length 2",
        ),
        (
            format!("(name: \"a\", {SIM}, offset: (1, 2, 3, 4))"),
            "offset: invalid length 4, expected 3 elements",
        ),
        (
            "(name: \"a\", sim: (dt: 0.01, backend: (x: 1)))".into(),
            "invalid type: struct, expected enum Backend",
        ),
        (
            format!("(name: \"a\", {SIM}, joints: [(name: \"j\", kind: Fixed(1))])"),
            "invalid type: newtype variant, expected unit variant",
        ),
        (
            format!("(name: \"a\", {SIM})\n#include \"x.ron\""),
            "`#include` lines must come before the value",
        ),
        (
            "#include base.ron\n()".into(),
            "expected a quoted path after `#include`",
        ),
        (
            format!("(name: \"a\", {SIM}, init_pos: {{\"a\" 1.0}})"),
            "expected `:` after map key",
        ),
        (
            format!("(name: \"a\", {SIM}, init_pos: {{\"a\": 1.0, \"a\": 2.0}})"),
            "duplicate map key `a`",
        ),
        (
            format!(
                "(name: \"a\", {SIM}, actuators: {{\"arm\": (joints: [], stiffness: \"stiff\")}})"
            ),
            "actuators.arm.stiffness: data did not match any variant of untagged enum PerJoint",
        ),
        (
            format!("(name: \"a\", {SIM}, seed: 1.2.3)"),
            "unexpected `.` in number",
        ),
        (
            format!("(name: 'ab', {SIM})"),
            "expected `'` to close the character literal",
        ),
        (
            format!("(name: robot, {SIM})"),
            "invalid type: identifier `robot`, expected a string",
        ),
        (
            format!("(name: \"a\", {SIM}, seed: -)"),
            "expected a digit, found `)`",
        ),
        (
            format!("(name: \"a\", {SIM}, seed: 12abc)"),
            "unexpected `a` in number",
        ),
        (
            "#![enable(implicit_some)\n()".into(),
            "unterminated `#![...]` header",
        ),
        ("(name: r#\"open)".into(), "unterminated raw string"),
        (
            format!("(name: \"\\u{{110000}}\", {SIM})"),
            "invalid unicode escape",
        ),
        (
            "[1, 2]".into(),
            "invalid type: list, expected struct Experiment",
        ),
        (
            "#include \"does/not/exist.ron\"\n()".into(),
            "cannot read included file",
        ),
    ];
    assert!(cases.len() >= 20);
    for (text, expected) in &cases {
        let message = error_text::<Experiment>(text);
        assert!(
            message.contains(expected),
            "input {text:?}\n  gave {message}"
        );
        assert!(
            has_location(&message, "test.ron"),
            "input {text:?}\n  gave {message}"
        );
    }
}

#[test]
fn error_locations_are_exact() {
    let cases = [
        ("(name: \"abc".to_string(), "test.ron:1:8: unterminated string".to_string()),
        (
            "(\n    name: \"a\"\n    sim: (dt: 0.01, backend: Rapier),\n)".into(),
            "test.ron:3:5: expected `,` or `)` after field `name`, found `s`".into(),
        ),
        (
            "(name: \"x\", seed 3)".into(),
            "test.ron:1:18: expected `:` after field name `seed`, found `3`".into(),
        ),
        (
            "(name: \"a\", sim: (dt: 0.01))".into(),
            "test.ron:1:18: sim: missing field `backend`".into(),
        ),
        (
            "(\n    name: \"a\",\n    sim: (dt: 0.01, backend: Rapier),\n    actuators: {\n        \"arm\": (joints: [], stiffness: 1.0, stifness: 2.0),\n    },\n)".into(),
            "test.ron:5:55: actuators.arm.stifness: unknown field `stifness`, expected one of `joints`, `stiffness`, `damping`".into(),
        ),
        (
            format!("(\n  name: \"a\",\n  {SIM},\n  joints: [\n    (name: \"j\", kind: Fixed),\n    (name: \"k\", kind: Revolute(axis: (0, 0, \"z\"), limits: None)),\n  ],\n)"),
            "test.ron:6:45: joints[1].kind.axis[2]: invalid type: string \"z\", expected f32".into(),
        ),
        (
            format!("(name: \"a\", {SIM}, init_pos: {{\"panda_joint.*\": true}})"),
            "test.ron:1:75: init_pos[\"panda_joint.*\"]: invalid type: boolean `true`, expected f32".into(),
        ),
        (
            "[".repeat(10_000),
            "test.ron:1:129: nesting too deep: more than 128 levels of brackets".into(),
        ),
    ];
    for (text, expected) in cases {
        assert_eq!(error_text::<Experiment>(&text), expected, "input {text:?}");
    }
}

#[test]
fn non_utf8_file_is_a_located_parse_error() {
    let dir = TempDir::new("utf8");
    let path = dir.write("bad.ron", b"(\n  name: \"a\xff\",\n)");
    let err = load::<Experiment>(&path, &[]).unwrap_err();
    assert!(
        matches!(
            err,
            ConfigError::Parse {
                line: 2,
                col: 11,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("invalid UTF-8 (byte 0xff)"),
        "{err}"
    );
    assert!(has_location(&err.to_string(), "bad.ron"));

    let path = dir.write("garbage.ron", [0x89u8, b'P', b'N', b'G', 0, 0, 0xff, 0xfe]);
    let err = load::<Experiment>(&path, &[]).unwrap_err();
    assert!(
        matches!(
            err,
            ConfigError::Parse {
                line: 1,
                col: 1,
                ..
            }
        ),
        "{err:?}"
    );
}

/// Every prefix of a valid document, and the document with any one character deleted, must
/// load or fail with a located error — never panic.
#[test]
fn damaged_documents_never_panic() {
    let boundaries: Vec<usize> = FULL.char_indices().map(|(i, _)| i).collect();
    for &cut in &boundaries {
        let truncated = &FULL[..cut];
        if let Err(e) = parse::<Experiment>(truncated) {
            assert!(
                has_location(&e.to_string(), "test.ron"),
                "{truncated:?}: {e}"
            );
        }
        let next = FULL[cut..].chars().next().map_or(0, char::len_utf8);
        let damaged = format!("{}{}", &FULL[..cut], &FULL[cut + next..]);
        if let Err(e) = parse::<Experiment>(&damaged) {
            assert!(has_location(&e.to_string(), "test.ron"), "{damaged:?}: {e}");
        }
    }
}

#[test]
fn load_reads_files_with_overrides() {
    let dir = TempDir::new("load");
    let path = dir.write("full.ron", FULL);
    let cfg: Experiment = load(&path, &["seed=7".to_string()]).unwrap();
    assert_eq!(cfg.seed, 7);
    assert_eq!(
        Experiment { seed: 42, ..cfg },
        full_expected(),
        "only the overridden field changes"
    );
    let tree = load_document(&path, &[]).unwrap();
    assert_eq!(*node_at(&tree, "name").unwrap().span.file, path);
}

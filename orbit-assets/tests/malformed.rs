//! Malformed URDF corpus (`tests/data/malformed/`): every file is rejected with the expected
//! error variant (never a panic), and the message names the file and the offending element.

use std::path::PathBuf;

use orbit_assets::{AssetError, UrdfOptions, model_from_urdf_file, model_from_urdf_file_with};

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/malformed")
        .join(name)
}

/// Loads a corpus file, expecting an error; checks that the message names the file and every
/// string in `mentions`.
fn expect_err(name: &str, mentions: &[&str]) -> AssetError {
    let p = path(name);
    let result = std::panic::catch_unwind(|| model_from_urdf_file(&p));
    let err = match result {
        Ok(Ok(model)) => panic!(
            "{name}: expected an error, got a model with {} links",
            model.links.len()
        ),
        Ok(Err(e)) => e,
        Err(_) => panic!("{name}: the importer panicked"),
    };
    let msg = err.to_string();
    assert!(
        msg.contains(name),
        "{name}: message does not name the file: {msg}"
    );
    for m in mentions {
        assert!(
            msg.contains(m),
            "{name}: message does not mention {m:?}: {msg}"
        );
    }
    err
}

#[test]
fn not_xml() {
    let e = expect_err("not_xml.urdf", &["not a valid URDF"]);
    assert!(matches!(e, AssetError::Parse { .. }), "{e:?}");
}

#[test]
fn truncated_xml() {
    let e = expect_err("truncated.urdf", &["not a valid URDF"]);
    assert!(matches!(e, AssetError::Parse { .. }), "{e:?}");
}

#[test]
fn missing_child_link() {
    let e = expect_err(
        "missing_child.urdf",
        &["joint `j2` names child link `link9`, which is not defined"],
    );
    assert!(
        matches!(&e, AssetError::MissingLink { role: "child", link, joint, .. } if link == "link9" && joint == "j2"),
        "{e:?}"
    );
}

#[test]
fn missing_parent_link() {
    let e = expect_err(
        "missing_parent.urdf",
        &["joint `j1` names parent link `bsae`, which is not defined"],
    );
    assert!(
        matches!(&e, AssetError::MissingLink { role: "parent", link, .. } if link == "bsae"),
        "{e:?}"
    );
}

#[test]
fn two_roots() {
    let e = expect_err("two_roots.urdf", &["`base`", "`stray`", "root"]);
    assert!(
        matches!(&e, AssetError::SeveralRoots { roots, .. } if roots == &["base", "stray"]),
        "{e:?}"
    );
}

#[test]
fn two_parents() {
    let e = expect_err("two_parents.urdf", &["`link2`", "`j2`", "`j3`"]);
    assert!(matches!(e, AssetError::TwoParents { .. }), "{e:?}");
}

#[test]
fn cycle_below_a_root() {
    let e = expect_err("cycle.urdf", &["cycle", "`loop_a`", "`loop_b`"]);
    assert!(
        matches!(&e, AssetError::Cycle { links, .. } if links.len() == 2),
        "{e:?}"
    );
}

#[test]
fn cycle_without_root() {
    let e = expect_err("cycle_no_root.urdf", &["cycle", "`a`", "`b`", "`c`"]);
    assert!(
        matches!(&e, AssetError::Cycle { links, .. } if links.len() == 3),
        "{e:?}"
    );
}

#[test]
fn floating_joint() {
    let e = expect_err("floating_joint.urdf", &["`world_to_base`", "`floating`"]);
    assert!(
        matches!(&e, AssetError::UnsupportedJoint { kind, .. } if kind == "floating"),
        "{e:?}"
    );
}

#[test]
fn planar_joint() {
    let e = expect_err("planar_joint.urdf", &["`slide_plane`", "`planar`"]);
    assert!(matches!(e, AssetError::UnsupportedJoint { .. }), "{e:?}");
}

#[test]
fn negative_mass() {
    let e = expect_err("negative_mass.urdf", &["`heavy_arm`", "mass -2.5"]);
    assert!(
        matches!(&e, AssetError::InvalidInertial { link, .. } if link == "heavy_arm"),
        "{e:?}"
    );
}

#[test]
fn nan_inertia() {
    let e = expect_err("nan_inertia.urdf", &["`arm`", "`ixy`", "NaN"]);
    assert!(matches!(e, AssetError::InvalidInertial { .. }), "{e:?}");
}

#[test]
fn negative_inertia() {
    let e = expect_err("negative_inertia.urdf", &["`arm`", "-0.01"]);
    assert!(matches!(e, AssetError::InvalidInertial { .. }), "{e:?}");
}

#[test]
fn zero_axis() {
    let e = expect_err("zero_axis.urdf", &["joint `elbow`", "axis"]);
    assert!(matches!(e, AssetError::ZeroAxis { .. }), "{e:?}");
}

#[test]
fn lower_above_upper() {
    let e = expect_err("lower_gt_upper.urdf", &["joint `wrist`", "1.5", "-1.5"]);
    assert!(
        matches!(e, AssetError::InvalidLimits { lower, upper, .. } if lower == 1.5 && upper == -1.5),
        "{e:?}"
    );
}

#[test]
fn revolute_without_limit() {
    let e = expect_err("missing_limit.urdf", &["joint `shoulder`", "<limit"]);
    assert!(matches!(e, AssetError::InvalidValue { .. }), "{e:?}");
}

#[test]
fn duplicate_link_names() {
    let e = expect_err("duplicate_link.urdf", &["two links are named `arm`"]);
    assert!(
        matches!(&e, AssetError::DuplicateName { kind: "link", name, .. } if name == "arm"),
        "{e:?}"
    );
}

#[test]
fn duplicate_joint_names() {
    let e = expect_err("duplicate_joint.urdf", &["two joints are named `j1`"]);
    assert!(
        matches!(e, AssetError::DuplicateName { kind: "joint", .. }),
        "{e:?}"
    );
}

#[test]
fn non_positive_box_size() {
    let e = expect_err(
        "bad_box_size.urdf",
        &["link `base`", "collision `plate`", "-0.2"],
    );
    assert!(matches!(e, AssetError::InvalidValue { .. }), "{e:?}");
}

#[test]
fn robot_without_links() {
    let e = expect_err("no_links.urdf", &["no links"]);
    assert!(matches!(e, AssetError::NoLinks { .. }), "{e:?}");
}

#[test]
fn collision_filter_for_unknown_link() {
    let e = expect_err(
        "bad_filter_link.urdf",
        &["orbit_collision_filter", "`bsae`"],
    );
    assert!(matches!(e, AssetError::InvalidValue { .. }), "{e:?}");
}

#[test]
fn missing_file() {
    let p = path("does_not_exist.urdf");
    let e = model_from_urdf_file(&p).unwrap_err();
    assert!(matches!(e, AssetError::Io { .. }), "{e:?}");
    assert!(e.to_string().contains("does_not_exist.urdf"), "{e}");
}

/// A mesh collision is an error naming the link's collision and the way out, never dropped
/// silently; with `skip_mesh_collisions` the file loads without those shapes.
#[test]
fn mesh_collision_is_an_error_unless_skipped() {
    let file = path("mesh_only_collision.urdf");
    let e = model_from_urdf_file(&file).unwrap_err();
    let message = e.to_string();
    assert!(matches!(e, AssetError::InvalidValue { .. }), "{e:?}");
    assert!(
        message.contains("mesh `") && message.contains("skip_mesh_collisions: true"),
        "{message}"
    );
    let options = UrdfOptions {
        skip_mesh_collisions: true,
    };
    let model = model_from_urdf_file_with(&file, options).expect("loads without the meshes");
    assert_eq!(model.links.len(), 2);
    assert!(model.links.iter().all(|l| l.shapes.is_empty()));
}

/// Every file in the corpus is covered by a test above.
#[test]
fn corpus_is_complete() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/malformed");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("corpus directory")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(names.len() >= 12, "{names:?}");
    let src = include_str!("malformed.rs");
    for n in &names {
        assert!(
            src.contains(&format!("\"{n}\"")),
            "corpus file {n} has no test"
        );
    }
}

//! Which file a config's model path loads: a bundled name is the bundled asset whatever lies
//! beside it; other paths are relative to the config file that names them (the working
//! directory for a command-line override), and a run records what it loaded with a hash.

use std::path::{Path, PathBuf};

use orbit_assets::{asset_record, bundled, compose_env_scene, load_model};
use orbit_core::config::{Node, NodeKind, load_document, node_at};
use orbit_core::scene::AssetSource;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("orbit-asset-paths-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path_at(doc: &Node, at: &str) -> String {
    match &node_at(doc, at).unwrap_or_else(|| panic!("{at}")).kind {
        NodeKind::Str(s) => s.clone(),
        other => panic!("{at}: {other:?}"),
    }
}

/// A `cartpole.urdf` beside the config (or in the working directory) does not replace the
/// bundled cart-pole: only an explicit `./cartpole.urdf` loads it.
#[test]
fn a_bundled_name_is_never_replaced_by_a_file_of_that_name() {
    let dir = temp_dir("bundled");
    let one_link = "<robot name=\"impostor\"><link name=\"only\"/></robot>";
    std::fs::write(dir.join("cartpole.urdf"), one_link).unwrap();
    let by_name = AssetSource::Urdf {
        path: "cartpole.urdf".into(),
        skip_mesh_collisions: false,
    };
    let model = load_model(&by_name, Some(&dir)).unwrap();
    assert_eq!(model.name, "cartpole");
    assert!(model.links.len() > 1);
    let explicit = AssetSource::Urdf {
        path: "./cartpole.urdf".into(),
        skip_mesh_collisions: false,
    };
    assert_eq!(load_model(&explicit, Some(&dir)).unwrap().name, "impostor");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Paths in a config file on disk become absolute paths beside that file, bundled names stay
/// names, and a path given as a command-line override is relative to the working directory.
#[test]
fn paths_are_anchored_to_the_file_that_names_them() {
    let dir = temp_dir("anchor");
    let config = dir.join("env.ron");
    std::fs::write(
        &config,
        "(scene: (articulations: [\
           (name: \"a\", spawn: Urdf(path: \"./robot.urdf\")),\
           (name: \"b\", spawn: Mjcf(path: \"models/ant.xml\")),\
           (name: \"c\", spawn: Urdf(path: \"cartpole.urdf\")),\
           (name: \"d\", spawn: Urdf(path: \"x.urdf\")),\
         ]))",
    )
    .unwrap();
    let overrides = ["scene.articulations[3].spawn.path=\"cli.urdf\"".to_string()];
    let doc = compose_env_scene(&load_document(&config, &overrides).unwrap()).unwrap();
    let absolute_dir = std::path::absolute(&dir).unwrap();
    let at = |i: usize| path_at(&doc, &format!("scene.articulations[{i}].spawn.path"));
    assert_eq!(Path::new(&at(0)), absolute_dir.join("./robot.urdf"));
    assert_eq!(Path::new(&at(1)), absolute_dir.join("models/ant.xml"));
    assert_eq!(at(2), "cartpole.urdf");
    let cwd = std::env::current_dir().unwrap();
    assert_eq!(Path::new(&at(3)), cwd.join("cli.urdf"));
    // Anchoring twice changes nothing: a run's `params/env.ron` reads back the same.
    assert_eq!(compose_env_scene(&doc).unwrap(), doc);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The record names each model file once, where it was loaded from, and the SHA-256 of its
/// bytes (FIPS 180-2's test vector for "abc"; the bundled file's hash of its text).
#[test]
fn the_asset_record_hashes_what_was_loaded() {
    let dir = temp_dir("record");
    let file = dir.join("abc.urdf");
    std::fs::write(&file, "abc").unwrap();
    let config = dir.join("env.ron");
    std::fs::write(
        &config,
        "(scene: (articulations: [\
           (name: \"a\", spawn: Urdf(path: \"abc.urdf\")),\
           (name: \"b\", spawn: Urdf(path: \"abc.urdf\")),\
           (name: \"c\", spawn: Urdf(path: \"cartpole.urdf\")),\
           (name: \"d\", spawn: Urdf(path: \"missing.urdf\")),\
         ]))",
    )
    .unwrap();
    let doc = compose_env_scene(&load_document(&config, &[]).unwrap()).unwrap();
    let record = asset_record(&doc);
    let abs = std::path::absolute(&file).unwrap().display().to_string();
    let abc = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
    assert!(
        record.contains(&format!(
            "(path: {abs:?}, loaded: {abs:?}, sha256: Some(\"{abc}\"))"
        )),
        "{record}"
    );
    assert_eq!(
        record.matches("abc.urdf").count(),
        2,
        "listed once: {record}"
    );
    assert!(bundled("cartpole.urdf").is_some());
    assert!(
        record.contains("loaded: \"<bundled>/cartpole.urdf\", sha256: Some(\""),
        "{record}"
    );
    assert!(record.contains("missing.urdf\", sha256: None)"), "{record}");
    std::fs::remove_dir_all(&dir).unwrap();
}

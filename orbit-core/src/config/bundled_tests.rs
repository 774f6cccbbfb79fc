//! Includes between bundled files (resolved in memory) and from files on disk into them.

use std::path::{Path, PathBuf};

use super::*;

/// A base, a variant beside it, an agent file one directory over, and a cycle.
fn files() -> Bundled {
    Bundled::new([
        (
            "task/env/base.ron",
            "(seed: 1, sim: (dt: 0.01, substeps: 2))",
        ),
        (
            "task/env/fast.ron",
            "// a variant: restates only what changes\n#include \"base.ron\"\n(sim: (dt: 0.005))",
        ),
        (
            "task/agents/ppo.ron",
            "#include \"../env/./fast.ron\"\n(seed: 7)",
        ),
        ("task/loop/a.ron", "#include \"b.ron\"\n(seed: 1)"),
        ("task/loop/b.ron", "#include \"a.ron\"\n(seed: 2)"),
        ("task/missing.ron", "\n#include \"nope.ron\"\n(seed: 1)"),
    ])
}

fn bundled(path: &str) -> PathBuf {
    Bundled::full_path(path)
}

fn value(doc: &Node, path: &str) -> String {
    node_at(doc, path).unwrap().to_ron().trim_end().to_string()
}

#[test]
fn bundled_variant_merges_over_the_base_beside_it() {
    let doc = load_document_with(&files(), bundled("task/env/fast.ron"), &[]).unwrap();
    assert_eq!(value(&doc, "sim.dt"), "0.005");
    assert_eq!(value(&doc, "sim.substeps"), "2");
    assert_eq!(value(&doc, "seed"), "1");
    // Errors name the bundled file that gave the value.
    let span = &node_at(&doc, "sim.substeps").unwrap().span;
    assert_eq!(*span.file, bundled("task/env/base.ron"));
}

#[test]
fn bundled_includes_follow_dot_and_parent_steps() {
    let doc = load_document_with(&files(), bundled("task/agents/ppo.ron"), &[]).unwrap();
    assert_eq!(value(&doc, "seed"), "7");
    assert_eq!(value(&doc, "sim.dt"), "0.005");
    let deps = dependencies(&files(), bundled("task/agents/ppo.ron")).unwrap();
    let expected: Vec<PathBuf> = [
        "task/agents/ppo.ron",
        "task/env/fast.ron",
        "task/env/base.ron",
    ]
    .iter()
    .map(|p| bundled(p))
    .collect();
    assert_eq!(deps, expected);
}

#[test]
fn bundled_cycle_and_missing_include_are_errors_naming_the_line() {
    let err = load_document_with(&files(), bundled("task/loop/a.ron"), &[]).unwrap_err();
    let message = err.to_string();
    assert!(message.contains("include cycle"), "{message}");
    assert!(
        message.starts_with(&format!("{}:1:1: ", bundled("task/loop/b.ron").display())),
        "{message}"
    );

    let err = load_document_with(&files(), bundled("task/missing.ron"), &[]).unwrap_err();
    let message = err.to_string();
    assert!(
        message.starts_with(&format!("{}:2:1: ", bundled("task/missing.ron").display())),
        "{message}"
    );
    assert!(message.contains("task/nope.ron"), "{message}");
}

#[test]
fn a_file_on_disk_includes_a_bundled_file_and_restates_a_field() {
    let dir = std::env::temp_dir().join(format!("orbit-bundled-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mine = dir.join("mine.ron");
    std::fs::write(&mine, "#include \"<bundled>/task/env/fast.ron\"\n(seed: 3)").unwrap();
    let doc = load_document_with(&files(), &mine, &[]);
    std::fs::remove_dir_all(&dir).unwrap();
    let doc = doc.unwrap();
    assert_eq!(value(&doc, "seed"), "3");
    assert_eq!(value(&doc, "sim.dt"), "0.005");
    assert_eq!(value(&doc, "sim.substeps"), "2");
    assert!(is_bundled(&bundled("x.ron")) && !is_bundled(Path::new("x.ron")));
}

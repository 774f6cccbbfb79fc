//! docs/writing_a_task.md walks through this crate: every listing marked
//! `<!-- file: tasks/box_to_spot/PATH -->` must be that file, byte for byte, so the tutorial
//! always compiles and passes its tests.

use std::path::Path;

#[test]
fn listings_match_the_crate() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc_path = crate_dir.join("../../docs/writing_a_task.md");
    let doc = std::fs::read_to_string(&doc_path).expect("docs/writing_a_task.md is readable");
    let marker = "<!-- file: tasks/box_to_spot/";
    let mut checked = Vec::new();
    for (at, _) in doc.match_indices(marker) {
        let rest = &doc[at + marker.len()..];
        let path = &rest[..rest.find(" -->").expect("marker ends with ` -->`")];
        // The listing is the next fenced block: from the line after its opening fence to its
        // closing fence.
        let open = rest.find("```").expect("a fenced block follows the marker");
        let body_start = open + rest[open..].find('\n').expect("fence line ends") + 1;
        let body_len = rest[body_start..]
            .find("```")
            .expect("fenced block is closed");
        let listing = &rest[body_start..body_start + body_len];
        let file = std::fs::read_to_string(crate_dir.join(path))
            .unwrap_or_else(|e| panic!("the tutorial lists `{path}`, which is not readable: {e}"));
        assert!(
            listing == file,
            "docs/writing_a_task.md's listing of `{path}` differs from the file; update one"
        );
        checked.push(path.to_string());
    }
    checked.sort();
    let expected = [
        "Cargo.toml",
        "config/agents/ppo.ron",
        "config/box_to_spot.ron",
        "src/lib.rs",
        "src/rewards.rs",
        "tests/env.rs",
    ];
    assert_eq!(
        checked, expected,
        "the tutorial lists these six files of the crate"
    );
}

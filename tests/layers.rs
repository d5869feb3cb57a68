//! The import order docs/DESIGN.md states holds in the library's code (tests aside): `cli →
//! settings → slam / nav / eval → features → gpu → image → error`, with slam, nav and eval
//! independent of one another, and the leaves (`rng`, `simd`, `moved`, `plot`, `synth`,
//! `output`) below the stages that use them.

use std::collections::BTreeSet;
use std::path::Path;

/// The top-level modules `crate::…` paths in a module's non-test code name.
fn imports(module: &str) -> BTreeSet<String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let dir = src.join(module);
    let files: Vec<std::path::PathBuf> = if dir.is_dir() {
        walk(&dir)
    } else {
        vec![src.join(format!("{module}.rs"))]
    };
    let mut out = BTreeSet::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        // Unit tests may reach anywhere; the layering is about the code they test.
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for (i, _) in line.match_indices("crate::") {
                let rest = &line[i + "crate::".len()..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if name != module && !name.is_empty() {
                    out.insert(name);
                }
            }
        }
    }
    out
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

#[test]
fn imports_run_downward_only() {
    // Each module and what it may import; anything else is an upward (or sideways) import.
    let allowed: &[(&str, &[&str])] = &[
        ("error", &[]),
        ("rng", &[]),
        ("simd", &[]),
        ("moved", &[]),
        ("shard", &["error"]),
        ("image", &["error"]),
        ("plot", &["error"]),
        ("gpu", &["error"]),
        ("features", &["error", "gpu", "image", "rng", "simd"]),
        ("synth", &["error", "features", "image", "rng"]),
        ("output", &["error", "features", "image"]),
        (
            "eval",
            &[
                "error", "features", "image", "output", "plot", "rng", "synth",
            ],
        ),
        (
            "slam",
            &[
                "error", "features", "image", "moved", "plot", "rng", "synth",
            ],
        ),
        (
            "nav",
            &[
                "error", "features", "gpu", "image", "moved", "plot", "rng", "simd", "synth",
            ],
        ),
        ("settings", &["error", "features", "nav", "slam"]),
        // ROS 2 bags feed SLAM and the replay and take their types; neither knows of bags.
        ("bag", &["error", "image", "nav", "slam"]),
    ];
    // The scanner sees imports at all: settings reads the stages' tables.
    assert!(
        imports("settings").contains("slam"),
        "{:?}",
        imports("settings")
    );
    let mut wrong = Vec::new();
    for (module, may) in allowed {
        for name in imports(module) {
            if !may.contains(&name.as_str()) {
                wrong.push(format!("{module} imports {name}"));
            }
        }
    }
    assert!(wrong.is_empty(), "upward imports: {wrong:?}");
}

//! sim-core in layers: every source file imports only from its own layer or the layers
//! below it (spatial → world → agent → engine → io), and names other layers only through
//! their curated `crate::<layer>::Item` paths.

use std::path::{Path, PathBuf};

const LAYERS: [&str; 5] = ["spatial", "world", "agent", "engine", "io"];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every `crate::<name>` in the text, with its line number.
fn crate_references(text: &str) -> Vec<(usize, String)> {
    let mut refs = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(i) = rest.find("crate::") {
            let after = &rest[i + "crate::".len()..];
            let name: String = if after.starts_with('{') {
                after.chars().take_while(|c| *c != '}').collect()
            } else {
                after.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect()
            };
            refs.push((n + 1, name));
            rest = after;
        }
    }
    refs
}

#[test]
fn no_file_imports_from_a_layer_above_its_own() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    assert!(
        files.len() > 30,
        "found only {} files under {}",
        files.len(),
        src.display()
    );
    let mut violations = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .into_owned();
        let Some(own) = LAYERS.iter().position(|l| *l == top) else {
            // lib.rs, error.rs, cache.rs and fs.rs sit below every layer and import none.
            let text = std::fs::read_to_string(file).unwrap();
            for (line, name) in crate_references(&text) {
                if LAYERS.contains(&name.as_str()) {
                    violations.push(format!(
                        "{}:{line}: the crate root imports crate::{name}",
                        rel.display()
                    ));
                }
            }
            continue;
        };
        let text = std::fs::read_to_string(file).unwrap();
        for (line, name) in crate_references(&text) {
            if let Some(list) = name.strip_prefix('{') {
                if list.split(',').all(|n| matches!(n.trim(), "Error" | "Result")) {
                    continue;
                }
                violations.push(format!(
                    "{}:{line}: grouped `crate::{{…}}` import (name each layer's path, so the layering stays checkable)",
                    rel.display()
                ));
            } else if let Some(other) = LAYERS.iter().position(|l| *l == name) {
                if other > own {
                    violations.push(format!(
                        "{}:{line}: layer {} imports from layer {} above it",
                        rel.display(),
                        LAYERS[own],
                        LAYERS[other]
                    ));
                }
            } else if !matches!(
                name.as_str(),
                "Error" | "Result" | "serde_state" | "cache" | "write_atomically" | "absolute"
            ) {
                // (`serde_state!` is exported at the crate root, as every exported macro is;
                // `cache` holds cache hints, `write_atomically` and `absolute` are files' helpers, below every
                // layer.)
                violations.push(format!("{}:{line}: crate::{name} is not a layer", rel.display()));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "upward or unchecked imports:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_checker_sees_an_upward_import() {
    let refs = crate_references("use crate::engine::Simulation;\nlet x = crate::world::Event::MapExplored;");
    assert_eq!(refs, vec![(1, "engine".to_owned()), (2, "world".to_owned())]);
}

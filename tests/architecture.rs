//! The library's modules are layers (ARCHITECTURE.md): each top-level module
//! of `src/` uses only the layers below it and the utilities, never one above
//! it or beside it, so that no import circle can form. Read from the source:
//! every `crate::NAME` path outside comments, in every file of a module,
//! its unit tests included.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The layers, top first. A module may use the modules of the layers after
/// its own, and the utilities.
const LAYERS: &[&[&str]] = &[
    &["session"],
    &["render"],
    &["gpu"],
    &["kernel"],
    &["pack"],
    &["lights", "environment"],
    &["accel"],
    &["scene"],
    &["kinds"],
    &["abi"],
];

/// Beside the layers, used by any of them; a utility uses only `abi` and the
/// utilities after it here.
const UTILITIES: &[&str] = &["shader", "stats", "output", "paths"];

fn rust_files(dir: &Path, files: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, files);
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
}

/// The top-level modules of the library and, for each, the modules its files
/// name as `crate::NAME` outside comments.
fn module_uses() -> Vec<(String, BTreeSet<String>)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let modules: Vec<String> = lib
        .lines()
        .filter_map(|line| line.strip_prefix("pub mod "))
        .map(|name| name.trim_end_matches(';').to_string())
        .collect();
    modules
        .iter()
        .map(|module| {
            let mut files = Vec::new();
            let file = src.join(format!("{module}.rs"));
            if file.exists() {
                files.push(file);
            }
            let dir = src.join(module);
            if dir.is_dir() {
                rust_files(&dir, &mut files);
            }
            assert!(!files.is_empty(), "module {module} has no source file");
            let mut uses = BTreeSet::new();
            for file in files {
                let text = std::fs::read_to_string(&file).unwrap();
                for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
                    for (i, _) in line.match_indices("crate::") {
                        let name: String = line[i + "crate::".len()..]
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        if modules.contains(&name) && &name != module {
                            uses.insert(name);
                        }
                    }
                }
            }
            (module.clone(), uses)
        })
        .collect()
}

/// A module's place: its layer's index, or `None` for a utility.
fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

#[test]
fn every_module_uses_only_layers_below_it_and_utilities() {
    let mut violations = Vec::new();
    for (module, uses) in module_uses() {
        let is_utility = UTILITIES.contains(&module.as_str());
        assert!(
            is_utility || layer_of(&module).is_some(),
            "src/{module} is in no layer: add it to LAYERS or UTILITIES here and to ARCHITECTURE.md"
        );
        for used in uses {
            let allowed = match (layer_of(&module), layer_of(&used)) {
                // A utility may use abi, and the utilities listed after it.
                (None, Some(layer)) => LAYERS[layer] == ["abi"],
                (None, None) => {
                    let position = |m: &str| UTILITIES.iter().position(|u| *u == m);
                    position(&used) > position(&module)
                }
                (Some(_), None) => true,
                (Some(own), Some(other)) => other > own,
            };
            if !allowed {
                violations.push(format!("{module} uses {used}"));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "modules using a layer above or beside their own (LAYERS in tests/architecture.rs):\n{}",
        violations.join("\n")
    );
}

/// The check reads real uses: the layers' known arrows are found.
#[test]
fn the_reading_finds_known_uses() {
    let uses = module_uses();
    let of = |m: &str| &uses.iter().find(|(name, _)| name == m).unwrap().1;
    assert!(of("render").contains("gpu"));
    assert!(of("pack").contains("scene"));
    assert!(of("scene").contains("kinds"));
    assert!(of("abi").is_empty());
}

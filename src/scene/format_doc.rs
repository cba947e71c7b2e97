//! docs/scene-format.md against the parser: every table, type and key the
//! TOML reader accepts is documented there (the kinds' types and keys as
//! their registrations list them). A kind or key added to the parser without
//! its documentation fails here.

use super::parse::{
    ALL_LIGHT_KEYS, CAMERA_KEYS, ENVIRONMENT_KEYS, LIGHT_TYPES, RENDER_KEYS, SCENE_KEYS, TOP_KEYS,
    object_keys, object_type_names,
};
use crate::kinds::filter::{FILTER_KEYS, filter_types};
use crate::kinds::{TEXTURE_KINDS, material_keys, material_types};

fn document() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scene-format.md");
    std::fs::read_to_string(path).expect("docs/scene-format.md")
}

/// The names of `names` that `document` does not show as `shown(name)`.
fn undocumented<'a>(
    document: &str,
    names: &[&'a str],
    shown: impl Fn(&str) -> Vec<String>,
) -> Vec<&'a str> {
    names
        .iter()
        .copied()
        .filter(|name| !shown(name).iter().any(|form| document.contains(form)))
        .collect()
}

#[test]
fn every_table_type_and_key_is_documented() {
    let document = document();
    let table = |name: &str| {
        vec![
            format!("`[{name}]"),
            format!("`[{name}."),
            format!("`[[{name}]]`"),
        ]
    };
    let type_name = |name: &str| vec![format!("`\"{name}\"`"), format!("`type = \"{name}\"`")];
    let key = |name: &str| vec![format!("`{name}`")];
    let texture_types: Vec<&str> = TEXTURE_KINDS.iter().map(|kind| kind.name).collect();
    let mut missing = Vec::new();
    missing.extend(
        undocumented(&document, TOP_KEYS, table)
            .into_iter()
            .map(|n| format!("table [{n}]")),
    );
    for types in [
        &filter_types()[..],
        &material_types(),
        LIGHT_TYPES,
        &object_type_names(),
        &texture_types,
    ] {
        missing.extend(
            undocumented(&document, types, type_name)
                .into_iter()
                .map(|n| format!("type \"{n}\"")),
        );
    }
    let texture_keys: Vec<&str> = TEXTURE_KINDS
        .iter()
        .flat_map(|kind| kind.all_keys())
        .collect();
    let filter_keys: Vec<&str> = FILTER_KEYS
        .iter()
        .flat_map(|(_, keys)| *keys)
        .copied()
        .collect();
    for keys in [
        &filter_keys[..],
        SCENE_KEYS,
        CAMERA_KEYS,
        RENDER_KEYS,
        ENVIRONMENT_KEYS,
        &material_keys(),
        ALL_LIGHT_KEYS,
        &object_keys(),
        &texture_keys,
    ] {
        missing.extend(
            undocumented(&document, keys, key)
                .into_iter()
                .map(|n| format!("key `{n}`")),
        );
    }
    assert!(
        missing.is_empty(),
        "docs/scene-format.md does not document: {}",
        missing.join(", ")
    );
}

/// The check can fail: a name the document lacks is found missing.
#[test]
fn an_undocumented_name_is_found() {
    let key = |name: &str| vec![format!("`{name}`")];
    assert_eq!(
        undocumented("`spp` and `seed`", &["spp", "seed", "zz"], key),
        ["zz"]
    );
}

//! docs/scene-format.md against the parser: every table, type and key the
//! TOML reader accepts is documented there (the kinds' types and keys as
//! their registrations list them). A kind or key added to the parser without
//! its documentation fails here, and so does a texture or light type whose
//! entry (the list item `type = "NAME"`: ...) does not name its own keys.

use super::parse::{
    CAMERA_KEYS, ENVIRONMENT_KEYS, RENDER_KEYS, SCENE_KEYS, TOP_KEYS, object_keys,
    object_type_names,
};
use crate::kinds::filter::{FILTER_KEYS, filter_types};
use crate::kinds::{
    LIGHT_TYPES, TEXTURE_KINDS, light_keys, light_types, material_keys, material_types,
};

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
        &light_types(),
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
        &light_keys(),
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

/// The entry of `document` for the type `name`: from its line, the list item
/// that starts with `type = "NAME"`, to the next item or paragraph.
fn entry<'a>(document: &'a str, name: &str) -> Option<&'a str> {
    let start = document.find(&format!("\n- `type = \"{name}\"`"))? + 1;
    let rest = &document[start..];
    let end = ["\n- ", "\n\n"]
        .iter()
        .filter_map(|next| rest.find(next))
        .min()
        .unwrap_or(rest.len());
    Some(&rest[..end])
}

/// Each texture and light type has an entry of its own that names its own
/// keys (those besides every texture's `type` and `to_uv`, every light's
/// `type`, `position` and `intensity`), as its registration lists them.
#[test]
fn each_texture_and_light_type_documents_its_keys() {
    let document = document();
    let textures = TEXTURE_KINDS.iter().map(|kind| (kind.name, kind.keys));
    let lights = LIGHT_TYPES.iter().map(|light| (light.name, light.keys));
    let mut missing = Vec::new();
    for (name, keys) in textures.chain(lights) {
        match entry(&document, name) {
            None => missing.push(format!("an entry `type = \"{name}\"`")),
            Some(entry) => missing.extend(
                undocumented(entry, keys, |key| vec![format!("`{key}`")])
                    .into_iter()
                    .map(|key| format!("key `{key}` in the entry of \"{name}\"")),
            ),
        }
    }
    assert!(
        missing.is_empty(),
        "docs/scene-format.md lacks: {}",
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
    let document = "text\n- `type = \"a\"`: `x`\n- `type = \"b\"`: `y`\n\nmore `z`";
    assert_eq!(entry(document, "a"), Some("- `type = \"a\"`: `x`"));
    assert_eq!(entry(document, "b"), Some("- `type = \"b\"`: `y`"));
    assert_eq!(entry(document, "c"), None);
}

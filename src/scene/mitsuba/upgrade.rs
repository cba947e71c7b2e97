//! Scenes older than Mitsuba 2 (`version` 0.x and 1.x), read as Mitsuba 3 reads
//! them: `upgrade_from_v1` in its `src/core/parser.cpp` renames every property
//! from camelCase to snake_case (`intIOR` → `int_ior`, `toWorld` → `to_world`,
//! `sampleCount` → `sample_count`), gives `diffuse` its `reflectance` for a
//! `diffuseReflectance`, and turns a texture's `uoffset`/`voffset`/`uscale`/`vscale`
//! into a `to_uv` transform. Mitsuba 3 no longer reads the `<lookAt>` and `<srgb>`
//! elements of those files; pathmix does (as `<lookat>` and a linear `<rgb>`), so the
//! published scenes render as published.

use super::{Elem, Result, excerpt, numbers};

/// The major versions whose files are upgraded.
pub(super) const UPGRADED_VERSIONS: [u32; 2] = [0, 1];

/// `elem` and everything in it as a Mitsuba 2+ element.
pub(super) fn upgrade(elem: &mut Elem) -> Result<()> {
    match elem.tag.as_str() {
        "lookAt" => elem.tag = "lookat".into(),
        "srgb" => srgb_to_rgb(elem)?,
        _ => {}
    }
    for child in &mut elem.children {
        upgrade(child)?;
        // A property's or a nested object's name; `id`s are the user's own.
        if let Some((_, name)) = child.attrs.iter_mut().find(|(n, _)| n == "name") {
            *name = camel_to_snake(name);
        }
    }
    if elem.tag == "bsdf" && elem.ty() == "diffuse" {
        for child in &mut elem.children {
            if let Some((_, name)) = child
                .attrs
                .iter_mut()
                .find(|(n, v)| n == "name" && v == "diffuse_reflectance")
            {
                *name = "reflectance".into();
            }
        }
    }
    uv_offsets_to_transform(elem)
}

/// Mitsuba 3's `camel_to_underscore_case`: an underscore before an upper-case
/// letter that follows a lower-case one, the run of capitals lower-cased with it.
fn camel_to_snake(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

/// Mitsuba 0.x's `<srgb name=".." value="r, g, b">` (gamma-encoded, 0..1) or
/// `value="#rrggbb"`, as the linear `<rgb>` it means.
fn srgb_to_rgb(elem: &mut Elem) -> Result<()> {
    let text = elem.require("value")?.trim().to_string();
    let encoded: Vec<f64> = match text.strip_prefix('#') {
        Some(hex) if hex.len() == 6 && hex.chars().all(|c| c.is_ascii_hexdigit()) => (0..3)
            .map(|i| f64::from(u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap()) / 255.0)
            .collect(),
        Some(_) => {
            return Err(elem.origin.error(format!(
                "`value=\"{}\"` is not a colour `#rrggbb`",
                excerpt(&text)
            )));
        }
        None => match numbers(elem, &text)?[..] {
            [g] => vec![g; 3],
            [r, g, b] => vec![r, g, b],
            ref other => {
                return Err(elem
                    .origin
                    .error(format!("expected 1 or 3 numbers, got {}", other.len())));
            }
        },
    };
    let linear: Vec<String> = encoded
        .iter()
        .map(|&c| srgb_decode(c).to_string())
        .collect();
    elem.tag = "rgb".into();
    for (name, value) in &mut elem.attrs {
        if name == "value" {
            *value = linear.join(", ");
        }
    }
    Ok(())
}

/// The sRGB transfer function's inverse.
fn srgb_decode(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// `uoffset`, `voffset`, `uscale`, `vscale` as Mitsuba 3 reads them: one `to_uv`
/// transform, the offset first, then the scale.
fn uv_offsets_to_transform(elem: &mut Elem) -> Result<()> {
    const NAMES: [&str; 4] = ["uoffset", "voffset", "uscale", "vscale"];
    let mut values = [0.0, 0.0, 1.0, 1.0];
    let mut origin = None;
    let mut i = 0;
    while i < elem.children.len() {
        let child = &elem.children[i];
        let Some(k) = NAMES.iter().position(|&n| child.name() == Some(n)) else {
            i += 1;
            continue;
        };
        if !matches!(child.tag.as_str(), "float" | "integer") {
            return Err(child
                .origin
                .error(format!("expected <float name=\"{}\">", NAMES[k])));
        }
        child.check_attrs(&["name", "value"])?;
        values[k] = super::number(child, child.require("value")?)?;
        origin.get_or_insert_with(|| child.origin.clone());
        elem.children.remove(i);
    }
    let Some(origin) = origin else {
        return Ok(());
    };
    let [u_offset, v_offset, u_scale, v_scale] = values;
    let op = |tag: &str, x: f64, y: f64, z: f64| Elem {
        tag: tag.into(),
        attrs: vec![
            ("x".into(), x.to_string()),
            ("y".into(), y.to_string()),
            ("z".into(), z.to_string()),
        ],
        children: Vec::new(),
        origin: origin.clone(),
    };
    elem.children.push(Elem {
        tag: "transform".into(),
        attrs: vec![("name".into(), "to_uv".into())],
        children: vec![
            op("translate", u_offset, v_offset, 0.0),
            op("scale", u_scale, v_scale, 1.0),
        ],
        origin,
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::Converted;
    use super::*;
    use std::path::Path;

    /// The scene of `body` at `version`, written in `dir` beside a quad mesh and a
    /// texture, as pathmix's TOML document.
    fn converted(dir: &Path, version: &str, body: &str) -> Result<toml::Table> {
        let scene = dir.join(format!("scene-{version}.xml"));
        let text = format!("<scene version=\"{version}\">\n{body}\n</scene>\n");
        std::fs::write(&scene, text).unwrap();
        std::fs::write(
            dir.join("quad.obj"),
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             f 1/1 2/2 3/3 4/4\n",
        )
        .unwrap();
        image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
            .save(dir.join("t.png"))
            .unwrap();
        Converted::read(&scene, &[]).map(|c| c.document)
    }

    /// A Mitsuba 0.5 file (camelCase names, `<lookAt>`, `<srgb>`, `uscale`/`voffset`,
    /// a diffuse `diffuseReflectance`) means what its Mitsuba 3 form means.
    #[test]
    fn an_old_scene_reads_as_its_mitsuba_3_form() {
        let old = r##"
            <integrator type="path"><integer name="maxDepth" value="5"/></integrator>
            <sensor type="perspective"><float name="fov" value="45"/>
              <string name="fovAxis" value="smaller"/>
              <transform name="toWorld"><lookAt origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
              <sampler type="independent"><integer name="sampleCount" value="8"/></sampler>
              <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/>
                <rfilter type="tent"/></film></sensor>
            <shape type="obj"><string name="filename" value="quad.obj"/>
              <boolean name="faceNormals" value="true"/>
              <bsdf type="roughplastic"><srgb name="diffuseReflectance" value="#808080"/>
                <float name="intIOR" value="1.6"/></bsdf></shape>
            <shape type="obj"><string name="filename" value="quad.obj"/>
              <bsdf type="diffuse"><texture name="diffuseReflectance" type="bitmap">
                <string name="filename" value="t.png"/><string name="filterType" value="nearest"/>
                <float name="uscale" value="2"/><float name="voffset" value="0.5"/></texture></bsdf>
              <emitter type="area"><srgb name="radiance" value="0.5"/></emitter></shape>"##;
        let grey = srgb_decode(128.0 / 255.0);
        let half = srgb_decode(0.5);
        let new = format!(
            r#"
            <integrator type="path"><integer name="max_depth" value="5"/></integrator>
            <sensor type="perspective"><float name="fov" value="45"/>
              <string name="fov_axis" value="smaller"/>
              <transform name="to_world"><lookat origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
              <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
              <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/>
                <rfilter type="tent"/></film></sensor>
            <shape type="obj"><string name="filename" value="quad.obj"/>
              <boolean name="face_normals" value="true"/>
              <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="{grey}, {grey}, {grey}"/>
                <float name="int_ior" value="1.6"/></bsdf></shape>
            <shape type="obj"><string name="filename" value="quad.obj"/>
              <bsdf type="diffuse"><texture name="reflectance" type="bitmap">
                <string name="filename" value="t.png"/><string name="filter_type" value="nearest"/>
                <transform name="to_uv"><translate y="0.5"/><scale x="2"/></transform></texture></bsdf>
              <emitter type="area"><rgb name="radiance" value="{half}"/></emitter></shape>"#
        );
        let dir = tempfile::Builder::new()
            .prefix("pathmix-upgrade-")
            .tempdir()
            .unwrap();
        assert_eq!(
            converted(dir.path(), "0.5.0", old).unwrap(),
            converted(dir.path(), "3.0.0", &new).unwrap()
        );
        // The upgrade is for old files only: a Mitsuba 3 file keeps its names.
        let error = converted(dir.path(), "3.0.0", old).unwrap_err().to_string();
        assert!(
            error.contains("<srgb name=\"diffuseReflectance\">: not supported"),
            "{error}"
        );
    }

    #[test]
    fn names_convert_as_mitsuba_3_converts_them() {
        for (old, new) in [
            ("intIOR", "int_ior"),
            ("extIOR", "ext_ior"),
            ("toWorld", "to_world"),
            ("diffuseReflectance", "diffuse_reflectance"),
            ("specularReflectance", "specular_reflectance"),
            ("sampleCount", "sample_count"),
            ("maxDepth", "max_depth"),
            ("filterType", "filter_type"),
            ("fovAxis", "fov_axis"),
            ("faceNormals", "face_normals"),
            ("highQualityEdges", "high_quality_edges"),
            ("rrDepth", "rr_depth"),
            ("alpha", "alpha"),
            ("already_snake", "already_snake"),
            ("UPPER", "UPPER"),
            ("uvscale", "uvscale"),
        ] {
            assert_eq!(camel_to_snake(old), new, "{old}");
        }
    }

    #[test]
    fn srgb_decodes_to_linear() {
        assert_eq!(srgb_decode(0.0), 0.0);
        assert!((srgb_decode(1.0) - 1.0).abs() < 1e-15);
        assert!((srgb_decode(0.5) - 0.214_041_140_5).abs() < 1e-9);
        assert!((srgb_decode(0.04) - 0.04 / 12.92).abs() < 1e-15);
    }
}

//! Bump and normal maps (`kinds::Bump`, Mitsuba's `bumpmap` and `normalmap`):
//! the shading normal they give, checked by the light a diffuse floor reflects
//! from a point light (a/pi I cos / d^2, the cosine against the perturbed
//! normal), their TOML and Mitsuba forms, and bad input.
//!
//! The floor is seen straight down through a 0.2 degree field: its pixels all
//! show the point below the camera, where the texture's slope is the same for
//! every sample. With `max_depth = 1` and a black background the point light's
//! shadow ray is each sample's only light, so the image is that value to
//! rounding.

mod common;

use pathmix::gpu::GpuContext;
use pathmix::kinds::Bump;
use pathmix::scene::Scene;
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

const ALBEDO: f64 = 0.5;
/// The point light's place (intensity 1) above the floor point (0, 0, 0), and
/// the camera's, unless a test says otherwise.
const LIGHT: [f64; 3] = [0.0, 1.0, -1.0];
const EYE: [f64; 3] = [0.0, 1.0, 0.0];

/// What the floor point reflects toward the camera with shading normal `n`
/// under a light at `light`: a/pi I cos / d^2, times the bump's shadowing
/// (Estevez et al., as Mitsuba's): 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_i)),
/// alpha^2 = min(tan^2 theta_n / 8, 1), both angles to the floor's normal.
fn reflected(n: [f64; 3], light: [f64; 3]) -> f64 {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let tan2 = |v: [f64; 3]| {
        let c2 = v[1] * v[1] / dot(v, v);
        (1.0 - c2) / c2
    };
    let d2 = dot(light, light);
    let cos = dot(n, light) / (dot(n, n) * d2).sqrt();
    let alpha2 = (tan2(n) / 8.0).min(1.0);
    let shadowing = 2.0 / (1.0 + (1.0 + alpha2 * tan2(light)).sqrt());
    ALBEDO / PI * cos / d2 * shadowing
}

/// The floor (`floor` the object's TOML, material `floor` with `bump` the
/// material's extra keys) under the light at `light`, seen from `eye`, in `dir`.
fn floor_scene(
    dir: &Path,
    (floor, bump): (&str, &str),
    strategy: &str,
    (eye, light): ([f64; 3], [f64; 3]),
) -> Scene {
    let text = format!(
        "[camera]\nlookfrom = {eye:?}\nlookat = [0, 0, 0]\nvup = [0, 0, -1]\nvfov = 0.2\n\
         width = 4\nheight = 4\n\
         [render]\nspp = 8\nmax_depth = 1\nstrategy = \"{strategy}\"\nsampler = \"independent\"\n\
         background = [0, 0, 0]\n\
         [materials.floor]\ntype = \"lambertian\"\nalbedo = [{ALBEDO}, {ALBEDO}, {ALBEDO}]\n{bump}\n\
         [[objects]]\n{floor}\nmaterial = \"floor\"\n\
         [[lights]]\ntype = \"point\"\nposition = {light:?}\nintensity = 1\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The floor as a quad: uv (a, b) at q + a u + b v, so dp_du = u = (0, 0, 20)
/// and dp_dv = v = (20, 0, 0); the point below the camera is at uv (0.5, 0.5).
const QUAD: &str = "type = \"quad\"\nq = [-10, 0, -10]\nu = [0, 0, 20]\nv = [20, 0, 0]";

/// An 8 x 8 grey height ramp along x: h = 0.1 + 0.01 x at texel x, so 0.08 per
/// unit of u' between texel centres (bilinear), clamped at the edges.
fn write_ramp(dir: &Path) {
    common::write_exr(&dir.join("ramp.exr"), 8, 8, |x, _| {
        [0.1 + 0.01 * x as f32; 3]
    });
}

fn mean(ctx: &GpuContext, scene: &Scene) -> f64 {
    let acc = common::render(ctx, scene, &common::with_variance());
    let values: Vec<f64> = acc.sum.iter().map(|s| s[1] / acc.samples as f64).collect();
    assert!(values.iter().all(|v| v.is_finite()));
    values.iter().sum::<f64>() / values.len() as f64
}

/// Within 1e-3: the EXR's texels are half floats.
fn assert_close(got: f64, expected: f64, what: &str) {
    println!("{what}: {got:.7}, expected {expected:.7}");
    assert!(
        (got - expected).abs() < 1e-3 * expected,
        "{what}: {got} against {expected}"
    );
}

/// With scale s the slope along u is g = 0.08 s: dp_du' = (0, g, 20), dp_dv' =
/// (20, 0, 0), and the normal is their cross product, along (0, 20, -g).
#[test]
fn a_height_ramp_tilts_the_normal_by_its_slope() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("bump", "ramp");
    write_ramp(&dir);
    let bitmap = "{ type = \"bitmap\", file = \"ramp.exr\", wrap_mode = \"clamp\" }";
    for strategy in ["bsdf", "nee-mis"] {
        let flat = floor_scene(&dir, (QUAD, ""), strategy, (EYE, LIGHT));
        assert_close(
            mean(ctx, &flat),
            reflected([0.0, 1.0, 0.0], LIGHT),
            "unbumped",
        );
        for scale in [1.0, 125.0, -40.0] {
            let bump = format!("bump = {{ texture = {bitmap}, scale = {scale} }}");
            let scene = floor_scene(&dir, (QUAD, &bump), strategy, (EYE, LIGHT));
            let g = 0.08 * scale;
            assert_close(
                mean(ctx, &scene),
                reflected([0.0, 20.0, -g], LIGHT),
                &format!("scale {scale}, {strategy}"),
            );
        }
    }
}

/// A normal map's texel c is the normal 2c - 1 in (s, t, n) = (dp_du / |dp_du|,
/// n x s, n) = (+z, +x, +y) on this floor.
#[test]
fn a_constant_normal_map_gives_its_normal() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("bump", "normal-map");
    for (tangent, world) in [
        ([-0.6f64, 0.0, 0.8], [0.0, 0.8, -0.6]),
        ([0.0, 0.6, 0.8], [0.6, 0.8, 0.0]),
        ([0.3, 0.0, 0.9], [0.0, 0.9, 0.3]),
    ] {
        let texel = tangent.map(|c| ((c + 1.0) / 2.0) as f32);
        common::write_exr(&dir.join("normals.exr"), 2, 2, |_, _| texel);
        let bump = "normal_map = { type = \"bitmap\", file = \"normals.exr\" }";
        let scene = floor_scene(&dir, (QUAD, bump), "nee-mis", (EYE, LIGHT));
        assert_close(
            mean(ctx, &scene),
            reflected(world, LIGHT),
            &format!("normal {tangent:?}"),
        );
    }
}

/// A normal that turns away from the viewer is mirrored about the unperturbed
/// one (Mitsuba's `flip_invalid_normals`: (x, y, z) -> (-x, -y, z) in the
/// tangent frame). Seen from (0, 1, 3), the normal (0, 0.5, -0.866) faces away
/// and shades as (0, 0.5, 0.866): lit by a light at (0, 1, 1), which the
/// unflipped normal would leave black.
#[test]
fn a_normal_facing_away_is_mirrored() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("bump", "flip");
    let sin60 = 3f64.sqrt() / 2.0;
    // World 0.5 n - 0.866 s, s = +z.
    let texel = [-sin60, 0.0, 0.5].map(|c| ((c + 1.0) / 2.0) as f32);
    common::write_exr(&dir.join("normals.exr"), 1, 1, |_, _| texel);
    let bump = "normal_map = { type = \"bitmap\", file = \"normals.exr\" }";
    let light = [0.0, 1.0, 1.0];
    let scene = floor_scene(&dir, (QUAD, bump), "nee-mis", ([0.0, 1.0, 3.0], light));
    assert_close(
        mean(ctx, &scene),
        reflected([0.0, 0.5, sin60], light),
        "mirrored",
    );
}

/// Spheres and disks orient bump and normal maps by Mitsuba's derivatives
/// along their uv (`sphere.cpp`, `disk.cpp`), not by a fixed frame about the
/// normal. The point below the camera:
/// - on the disk at (0, 0, -5) with u = (0, 0, 10), v = (10, 0, 0): local
///   (a, b) = (0.5, 0), uv (0.5, 0), dp_du = u, dp_dv = 2 pi 0.5 v = (10 pi, 0,
///   0): the normal map's frame (s, n x s, n) = (+z, +x, +y), as the quad's,
///   and a slope g along u gives the normal along (0, 10, -g);
/// - on the top of the sphere of radius R = 100 / pi about (0, -R, 0): local
///   (0, 1, 0), uv (1/4, 1/2), dp_du = 2 pi R (-1, 0, 0), dp_dv = pi R (0, 0,
///   -1): the frame (-x, +z, +y), and a slope g along u gives (g, 200, 0);
/// - on the top line of the cylinder of the same radius along x (`p0`, `p1`
///   at x = -50 and 50): uv (1/4, 1/2), (s, t) = ((0, 0, -1), (0, 1, 0)),
///   dp_du = 2 pi R (0, 0, 1), dp_dv = (100, 0, 0): the frame (+z, +x, +y),
///   and a slope g along u gives (0, 200, -g).
///
/// The fixed frame (+x, -z, +y) gives other normals in each case. A flat normal
/// (texel (0.5, 0.5, 1)) and a constant height leave the normal as it was.
#[test]
fn spheres_disks_and_cylinders_orient_their_maps_by_their_uv_derivatives() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("bump", "sphere-disk");
    write_ramp(&dir);
    common::write_exr(&dir.join("flat.exr"), 2, 2, |_, _| [0.3; 3]);
    let disk = "type = \"disk\"\ncenter = [0, 0, -5]\nu = [0, 0, 10]\nv = [10, 0, 0]";
    let r = 100.0 / PI;
    let sphere = format!("type = \"sphere\"\ncenter = [0, {}, 0]\nradius = {r}", -r);
    // Along x, its top line through the origin at u = 1/4: there (s, t) =
    // ((0, 0, -1), (0, 1, 0)), dp_du = 2 pi r (0, 0, 1) and dp_dv = (100, 0, 0).
    let cylinder = format!(
        "type = \"cylinder\"\np0 = [-50, {}, 0]\np1 = [50, {}, 0]\nradius = {r}",
        -r, -r
    );
    // Off the y-z plane, so that a normal's x matters too.
    let light = [0.5, 1.0, -1.0];
    let bitmap = "{ type = \"bitmap\", file = \"ramp.exr\", wrap_mode = \"clamp\" }";
    // (floor, what, tangent-frame texel to world normal, slope g to normal)
    type Frame = fn([f64; 3]) -> [f64; 3];
    type Slope = fn(f64) -> [f64; 3];
    let floors: [(&str, &str, Frame, Slope); 3] = [
        (disk, "disk", |t| [t[1], t[2], t[0]], |g| [0.0, 10.0, -g]),
        (
            &cylinder,
            "cylinder",
            |t| [t[1], t[2], t[0]],
            |g| [0.0, 200.0, -g],
        ),
        (
            &sphere,
            "sphere",
            |t| [-t[0], t[2], t[1]],
            |g| [g, 200.0, 0.0],
        ),
    ];
    for (floor, what, frame, slope) in floors {
        let render = |bump: &str| {
            mean(
                ctx,
                &floor_scene(&dir, (floor, bump), "nee-mis", (EYE, light)),
            )
        };
        let flat = reflected([0.0, 1.0, 0.0], light);
        assert_close(render(""), flat, &format!("{what}, unbumped"));
        let constant = "bump = { texture = { type = \"bitmap\", file = \"flat.exr\" }, scale = 7 }";
        assert_close(render(constant), flat, &format!("{what}, constant height"));
        for tangent in [
            [0.0f64, 0.0, 1.0],
            [-0.6, 0.0, 0.8],
            [0.0, 0.6, 0.8],
            [0.3, 0.0, 0.9],
        ] {
            let texel = tangent.map(|c| ((c + 1.0) / 2.0) as f32);
            common::write_exr(&dir.join("normals.exr"), 2, 2, |_, _| texel);
            let bump = "normal_map = { type = \"bitmap\", file = \"normals.exr\" }";
            assert_close(
                render(bump),
                reflected(frame(tangent), light),
                &format!("{what}, normal {tangent:?}"),
            );
        }
        for scale in [125.0, -40.0] {
            let bump = format!("bump = {{ texture = {bitmap}, scale = {scale} }}");
            assert_close(
                render(&bump),
                reflected(slope(0.08 * scale), light),
                &format!("{what}, bump scale {scale}"),
            );
        }
    }
}

/// A height that does not change leaves the shading normal exactly as it was:
/// the same image, bit for bit, as without the bump map, on a scene with
/// several bounces and both textured and untextured surfaces (the bump on the
/// quad floor and on the sphere).
#[test]
fn a_constant_height_changes_nothing() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("bump", "constant");
    common::write_exr(&dir.join("flat.exr"), 4, 4, |_, _| [0.3; 3]);
    let body = |bump: &str| {
        format!(
            "[camera]\nlookfrom = [0, 2, 3]\nlookat = [0, 0, 0]\nvfov = 50\nwidth = 24\nheight = 16\n\
             [render]\nspp = 16\nmax_depth = 4\nstrategy = \"nee-mis\"\nbackground = [0.2, 0.3, 0.4]\n\
             [materials.floor]\ntype = \"roughplastic\"\nalpha = 0.2\n\
             diffuse_reflectance = {{ type = \"checkerboard\", to_uv = {{ scale = 8 }} }}\n{bump}\n\
             [materials.ball]\ntype = \"lambertian\"\nalbedo = [0.7, 0.5, 0.3]\n{bump}\n\
             [materials.lamp]\ntype = \"light\"\nemit = [4, 4, 4]\n\
             [[objects]]\n{QUAD}\nmaterial = \"floor\"\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [0, 0.5, 0]\nradius = 0.5\nmaterial = \"ball\"\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [1, 2, 1]\nradius = 0.3\nmaterial = \"lamp\"\n"
        )
    };
    let load = |bump: &str| {
        let path = dir.join("scene.toml");
        std::fs::write(&path, body(bump)).unwrap();
        Scene::load(&path).unwrap()
    };
    let plain = common::render(ctx, &load(""), &common::with_variance());
    let bumped = common::render(
        ctx,
        &load("bump = { texture = { type = \"bitmap\", file = \"flat.exr\" }, scale = 7 }"),
        &common::with_variance(),
    );
    assert!(plain.sum.iter().any(|s| s[0] > 0.0));
    assert!(plain.sum == bumped.sum, "the images differ");
    assert!(plain.sum_sq == bumped.sum_sq, "the squares differ");
}

/// Mesh faces whose uvs are all equal have no dp_du: any frame about the
/// normal stands in ((1, 0, 0) and (0, 0, -1) about +y), and the bump's slope
/// tilts it without a NaN.
#[test]
fn degenerate_uvs_make_no_nan() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("bump", "degenerate");
    write_ramp(&dir);
    std::fs::write(
        dir.join("floor.obj"),
        "v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nvt 0.5 0.5\n\
         f 1/1 3/1 2/1\nf 1/1 4/1 3/1\n",
    )
    .unwrap();
    let mesh = "type = \"mesh\"\nfile = \"floor.obj\"";
    let scale = 5.0;
    let bump = format!(
        "bump = {{ texture = {{ type = \"bitmap\", file = \"ramp.exr\", wrap_mode = \"clamp\" }}, scale = {scale} }}"
    );
    let scene = floor_scene(&dir, (mesh, &bump), "nee-mis", (EYE, LIGHT));
    // dp_du' = (1, g, 0), dp_dv' = (0, 0, -1): the normal (-g, 1, 0).
    let g = 0.08 * scale;
    assert_close(
        mean(ctx, &scene),
        reflected([-g, 1.0, 0.0], LIGHT),
        "degenerate uvs",
    );
    let normal = "normal_map = { type = \"bitmap\", file = \"ramp.exr\" }";
    let scene = floor_scene(&dir, (mesh, normal), "nee-mis", (EYE, LIGHT));
    assert!(mean(ctx, &scene).is_finite());
}

fn mitsuba_scene(dir: &Path, bsdf: &str) -> std::path::PathBuf {
    let text = format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
  <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
{bsdf}
<shape type="rectangle"><ref id="floor"/></shape>
</scene>
"#
    );
    let path = dir.join("scene.xml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn mitsuba_bumpmap_and_normalmap_read_as_bump_keys() {
    let dir = common::TempDir::new("bump", "mitsuba");
    write_ramp(&dir);
    let load = |bsdf: &str| {
        let path = mitsuba_scene(&dir, bsdf);
        Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
    };
    let scene = load(
        r#"<bsdf type="twosided" id="floor"><bsdf type="bumpmap">
  <texture name="arbitrary" type="bitmap"><string name="filename" value="ramp.exr"/><boolean name="raw" value="true"/></texture>
  <float name="scale" value="0.25"/>
  <bsdf type="roughplastic"><float name="alpha" value="0.1"/></bsdf>
</bsdf></bsdf>"#,
    );
    let floor = &scene.materials[0];
    assert!(!floor.one_sided);
    match &floor.bump {
        Some(Bump::Height { texture, scale }) => {
            assert_eq!(*scale, 0.25);
            assert!((texture.mean().x - 0.135).abs() < 1e-6);
        }
        other => panic!("expected a height map, got {other:?}"),
    }
    let scene = load(
        r#"<bsdf type="normalmap" id="floor">
  <texture name="normalmap" type="bitmap"><string name="filename" value="ramp.exr"/><boolean name="raw" value="true"/></texture>
  <bsdf type="diffuse"/>
</bsdf>"#,
    );
    let floor = &scene.materials[0];
    assert!(floor.one_sided);
    assert!(
        matches!(floor.bump, Some(Bump::NormalMap { .. })),
        "{floor:?}"
    );
    // Mitsuba's default scale is 1; a bumpmap around a twosided BSDF is as
    // the twosided around it.
    let scene = load(
        r#"<bsdf type="bumpmap" id="floor">
  <texture name="bumpmap" type="bitmap"><string name="filename" value="ramp.exr"/></texture>
  <bsdf type="twosided"><bsdf type="conductor"/></bsdf>
</bsdf>"#,
    );
    let floor = &scene.materials[0];
    assert!(!floor.one_sided);
    assert!(
        matches!(floor.bump, Some(Bump::Height { scale: 1.0, .. })),
        "{floor:?}"
    );
}

/// Bad bump maps, in TOML and Mitsuba XML: exit 2, the place in the file, no
/// image.
#[test]
fn bad_bump_maps_are_refused_with_their_place() {
    let dir = common::TempDir::new("bump", "bad");
    std::fs::write(dir.join("empty.png"), b"").unwrap();
    std::fs::write(dir.join("text.png"), b"not an image at all").unwrap();
    write_ramp(&dir);
    let toml = |bump: &str| {
        format!(
            "[camera]\nlookfrom = [0, 1, 0]\nlookat = [0, 0, 0]\nvup = [0, 0, -1]\nwidth = 4\nheight = 4\n\
             [materials.floor]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n{bump}\n\
             [[objects]]\n{QUAD}\nmaterial = \"floor\"\n"
        )
    };
    let xml = |texture: &str| {
        format!(
            "<scene version=\"3.0.0\">\n<bsdf type=\"bumpmap\" id=\"floor\">\n{texture}\n<bsdf type=\"diffuse\"/>\n</bsdf>\n\
             <shape type=\"rectangle\"><ref id=\"floor\"/></shape>\n<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/></sensor>\n</scene>\n"
        )
    };
    let bitmap = |file: &str| {
        format!("<texture type=\"bitmap\"><string name=\"filename\" value=\"{file}\"/></texture>")
    };
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "empty.toml",
            toml("bump = { texture = { type = \"bitmap\", file = \"empty.png\" } }"),
            "materials.floor.bump.texture.file",
        ),
        (
            "text.toml",
            toml("bump = { texture = { type = \"bitmap\", file = \"text.png\" } }"),
            "materials.floor.bump.texture.file",
        ),
        (
            "checker.toml",
            toml("bump = { texture = { type = \"checkerboard\" } }"),
            "must be a `bitmap`",
        ),
        (
            "both.toml",
            toml(
                "bump = { texture = { type = \"bitmap\", file = \"ramp.exr\" } }\n\
                 normal_map = { type = \"bitmap\", file = \"ramp.exr\" }",
            ),
            "not both",
        ),
        (
            "scale.toml",
            toml(
                "bump = { texture = { type = \"bitmap\", file = \"ramp.exr\" }, scale = \"big\" }",
            ),
            "materials.floor.bump.scale",
        ),
        ("empty.xml", xml(&bitmap("empty.png")), "scene.xml:2:1"),
        ("text.xml", xml(&bitmap("text.png")), "scene.xml:2:1"),
        (
            "no-texture.xml",
            xml(""),
            "scene.xml:2:1: <bsdf type=\"bumpmap\" id=\"floor\">: a bumpmap takes exactly one nested <bsdf> and one <texture>",
        ),
        (
            "checker.xml",
            xml("<texture type=\"checkerboard\"/>"),
            "scene.xml:3:1: <texture type=\"checkerboard\">: a bumpmap's texture must be a bitmap",
        ),
    ];
    let mut failures = Vec::new();
    for (name, text, expected) in cases {
        let file = if name.ends_with(".xml") {
            "scene.xml"
        } else {
            name
        };
        let scene = dir.join(file);
        std::fs::write(&scene, text).unwrap();
        let png = dir.join("out.png");
        let output = Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args([
                "render",
                scene.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
            ])
            .args(["--spp", "1"])
            .env("NODEVICE_SELECT", "1")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        if output.status.code() != Some(2)
            || !stderr.contains(expected)
            || stderr.contains("panicked")
            || png.exists()
        {
            failures.push(format!(
                "{name}: expected exit 2 and `{expected}`, got {:?}:\n{stderr}",
                output.status.code()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

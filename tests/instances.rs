//! Instancing (`[[groups]]` and `instance` objects): an instanced scene renders
//! as the same scene with its copies written out flat, 10 000 copies of the
//! bunny store one bunny, and bad groups and instances are refused naming the
//! field, with nothing written.

mod common;

use pathmix::accel::WideBvh;
use pathmix::gpu::GpuContext;
use pathmix::kinds::PRIMITIVE_KINDS;
use pathmix::pack::SceneData;
use pathmix::scene::{Reconstruction, Sampler, Scene, Strategy};
use std::fmt::Write;
use std::path::Path;
use std::process::Command;

/// A floor under a quad light and a point light, and the objects `objects` (TOML).
fn scene_text(objects: &str) -> String {
    format!(
        r#"[camera]
lookfrom = [0, 4, -7]
lookat = [0, 0.6, 0]
vfov = 45
width = 48
height = 48

[render]
spp = 256
max_depth = 4
sampler = "independent"
reconstruction = "importance"

[materials.floor]
type = "lambertian"
albedo = [0.6, 0.6, 0.6]

[materials.gold]
type = "lambertian"
albedo = [0.8, 0.6, 0.2]

[materials.red]
type = "lambertian"
albedo = [0.8, 0.15, 0.1]

[materials.lamp]
type = "light"
emit = [6, 6, 6]

[[objects]]
type = "quad"
q = [-8, 0, -8]
u = [16, 0, 0]
v = [0, 0, 16]
material = "floor"

[[objects]]
type = "quad"
q = [-1, 4, -1]
u = [2, 0, 0]
v = [0, 0, 2]
material = "lamp"

[[lights]]
type = "point"
position = [2.5, 2, -1.5]
intensity = [3, 3, 3]

{objects}"#
    )
}

/// The groups: a smooth mesh (the knot), a box and a sphere, each in its own
/// space with no transform of its own, so that an instance's transform keys
/// placed on a group's object write that copy out flat.
fn groups() -> Vec<(&'static str, String)> {
    let knot = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/knot.obj");
    vec![
        (
            "knot",
            format!(
                "type = \"mesh\"\nfile = \"{}\"\nmaterial = \"gold\"\n",
                knot.display()
            ),
        ),
        (
            "block",
            "type = \"box\"\nmin = [-1, 0, -1]\nmax = [1, 1, 1]\nmaterial = \"red\"\n".into(),
        ),
        (
            "ball",
            "type = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1\nmaterial = \"red\"\n".into(),
        ),
    ]
}

/// Each copy: its group and its transform keys (the box's stretched unevenly;
/// the knot's and the sphere's scaled alike, as a flat mesh's vertex normals
/// and a sphere need).
const COPIES: &[(&str, &str)] = &[
    ("knot", "scale = 0.15\ntranslate = [-1.5, 0.5, 0.5]"),
    (
        "knot",
        "scale = 0.12\nrotate = { axis = [1, 1, 0], angle = 50 }\ntranslate = [1.2, 0.6, 1.5]",
    ),
    (
        "block",
        "scale = [0.8, 0.3, 0.4]\nrotate_y = 30\ntranslate = [0.5, 0, -1]",
    ),
    (
        "block",
        "scale = [0.2, 0.9, 0.3]\nrotate = { axis = [0, 0, 1], angle = 20 }\ntranslate = [-0.4, 0, 2]",
    ),
    ("ball", "scale = 0.35\ntranslate = [-1.2, 0, -1.2]"),
    ("ball", "scale = 0.5\ntranslate = [2, 0, 0.2]"),
];

fn instanced() -> String {
    let mut objects = String::new();
    for (name, object) in groups() {
        write!(
            objects,
            "[[groups]]\nname = \"{name}\"\n[[groups.objects]]\n{object}\n"
        )
        .unwrap();
    }
    for (group, transform) in COPIES {
        write!(
            objects,
            "[[objects]]\ntype = \"instance\"\ngroup = \"{group}\"\n{transform}\n\n"
        )
        .unwrap();
    }
    scene_text(&objects)
}

fn flat() -> String {
    let groups = groups();
    let mut objects = String::new();
    for (group, transform) in COPIES {
        let (_, object) = groups.iter().find(|(name, _)| name == group).unwrap();
        write!(objects, "[[objects]]\n{object}{transform}\n\n").unwrap();
    }
    scene_text(&objects)
}

/// The instanced scene and the same copies written out flat agree within
/// their noise: the image mean and every 12x12 block, per channel (within 4.5
/// standard errors of the difference); the scene with one copy left out does
/// not, so the check sees each copy. Under the mixture and under nee-mis, whose
/// shadow rays ask `occluded` through the instances (the point light's under both).
#[test]
fn instances_render_as_their_copies_written_out_flat() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    for strategy in [Strategy::Mixture, Strategy::NeeMis] {
        instances_agree_with_flat_copies(ctx, strategy);
    }
}

fn instances_agree_with_flat_copies(ctx: &GpuContext, strategy: Strategy) {
    let render = |text: &str| {
        let mut scene = Scene::parse(text, "test.toml").unwrap();
        scene.render.sampler = Sampler::Independent;
        scene.render.reconstruction = Some(Reconstruction::Importance);
        scene.render.strategy = strategy;
        let acc = common::render(ctx, &scene, &common::with_variance());
        (acc.mean(), acc.standard_error().unwrap())
    };
    let instanced_scene = Scene::parse(&instanced(), "test.toml").unwrap();
    assert_eq!(instanced_scene.instancing.instances.len(), COPIES.len());
    assert!(instanced_scene.shapes.triangles.is_empty());
    let instanced = render(&instanced());
    let agree = |(other, other_se): &(pathmix::output::Image, pathmix::output::Image)| {
        let (mean, se) = &instanced;
        let (w, h) = (mean.width as usize, mean.height as usize);
        let diff =
            |i: usize, c: usize| f64::from(mean.pixels[i][c]) - f64::from(other.pixels[i][c]);
        let variance = |i: usize, c: usize| {
            f64::from(se.pixels[i][c]).powi(2) + f64::from(other_se.pixels[i][c]).powi(2)
        };
        let blocks = (0..h / 12).flat_map(|by| (0..w / 12).map(move |bx| (bx, by)));
        let whole = std::iter::once((0..w * h).collect::<Vec<_>>());
        let regions = whole.chain(blocks.map(|(bx, by)| {
            (0..144)
                .map(|k| (by * 12 + k / 12) * w + bx * 12 + k % 12)
                .collect()
        }));
        for (r, pixels) in regions.enumerate() {
            for c in 0..3 {
                let (d, v) = (pixels.iter()).fold((0.0, 0.0), |(d, v), &i| {
                    (d + diff(i, c), v + variance(i, c))
                });
                if d.abs() > 4.5 * v.sqrt() {
                    return Err(format!(
                        "region {r} channel {c}: off by {:.1} standard errors",
                        d / v.sqrt()
                    ));
                }
            }
        }
        Ok(())
    };
    let flat_scene = flat();
    let flat = agree(&render(&flat_scene));
    assert!(flat.is_ok(), "{strategy}: {flat:?}");
    // Without the second ball the flat scene differs.
    let (last_group, last_transform) = COPIES[COPIES.len() - 1];
    let (_, ball) = groups()
        .into_iter()
        .find(|(n, _)| *n == last_group)
        .unwrap();
    let without = flat_scene.replacen(&format!("[[objects]]\n{ball}{last_transform}\n"), "", 1);
    assert_ne!(without, flat_scene);
    let missing = agree(&render(&without));
    assert!(missing.is_err(), "{strategy}: {missing:?}");
}

/// The device arrays of `copies` instances of the Stanford bunny (on a grid,
/// turned), as the two-level BVH lays them out: the faces stored, and the
/// bytes of the faces, their normals, the nodes and the instance records.
fn bunny_arrays(bunny: &Path, copies: usize) -> (usize, usize) {
    let mut objects = format!(
        "[[groups]]\nname = \"bunny\"\n[[groups.objects]]\ntype = \"mesh\"\nfile = \"{}\"\nmaterial = \"gold\"\nscale = 5\n\n",
        bunny.display()
    );
    for i in 0..copies {
        let (x, z) = ((i % 100) as f32 * 0.8 - 40.0, (i / 100) as f32 * 0.8 - 40.0);
        write!(
            objects,
            "[[objects]]\ntype = \"instance\"\ngroup = \"bunny\"\nrotate_y = {}\ntranslate = [{x}, 0, {z}]\n\n",
            i * 37 % 360
        )
        .unwrap();
    }
    let scene = Scene::parse(&scene_text(&objects), "test.toml").unwrap();
    let mut data = SceneData::pack(&scene);
    let set = std::mem::take(&mut data.instance_set);
    let (bvh, instancing) = WideBvh::build_instanced(&mut data.geometry, &set).unwrap();
    assert_eq!(instancing.records.len(), copies);
    let triangle = PRIMITIVE_KINDS
        .iter()
        .position(|k| k.name == "triangle")
        .unwrap();
    let faces = data.geometry.primitives[triangle].len();
    let bytes = data.geometry.primitives[triangle].bytes.len()
        + data.geometry.normals[triangle].len()
        + size_of_val(&bvh.nodes[..])
        + size_of_val(&instancing.records[..]);
    (faces, bytes)
}

/// 10 000 instances of the Stanford bunny store its 69 451 faces once: each
/// copy costs its 112-byte record and its share of the top level's nodes, under
/// 160 bytes, where a copy written out flat would cost the bunny's 4 MB.
#[test]
fn ten_thousand_bunnies_store_one_bunny() {
    let bunny = shared_or_skip!("mitsuba-scenes/meshes/bunny.ply");
    let (one_faces, one) = bunny_arrays(&bunny, 1);
    let (faces, many) = bunny_arrays(&bunny, 10_000);
    assert_eq!((one_faces, faces), (69_451, 69_451));
    let per_copy = (many - one) as f64 / 9_999.0;
    assert!(per_copy < 160.0, "{per_copy} bytes a copy");
    assert!(one > 4_000_000, "{one} bytes for one bunny");
}

/// Bad groups and instances: exit code 2, the field named, no image written.
#[test]
fn bad_groups_and_instances_are_refused_naming_the_field() {
    let dir = common::TempDir::new("instances", "bad");
    let group = "[[groups]]\nname = \"g\"\n[[groups.objects]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1\nmaterial = \"red\"\n";
    let cases: &[(&str, String, &str)] = &[
        (
            "missing-group",
            format!("{group}[[objects]]\ntype = \"instance\"\ngroup = \"trees\"\n"),
            "objects[2].group: unknown group `trees`",
        ),
        (
            "no-group",
            format!("{group}[[objects]]\ntype = \"instance\"\n"),
            "objects[2]: missing required key `group`",
        ),
        (
            "nested",
            format!("{group}[[groups.objects]]\ntype = \"instance\"\ngroup = \"g\"\n"),
            "groups[0].objects[1].type: an instance inside a group: nested instancing is not permitted",
        ),
        (
            "emitter",
            group.replace("\"red\"", "\"lamp\""),
            "groups[0].objects[0]: an emitting or `importance` shape inside a group",
        ),
    ];
    let mut failures = Vec::new();
    for (name, objects, expected) in cases {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, scene_text(objects)).unwrap();
        let png = dir.join(format!("{name}.png"));
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
        if output.status.code() != Some(2) || !stderr.contains(expected) || png.exists() {
            failures.push(format!(
                "{name}: expected exit 2, no image and `{expected}`, got {:?}:\n{stderr}",
                output.status.code()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

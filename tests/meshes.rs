//! Triangle meshes from files: watertight furnaces, emissive triangles as
//! lights, the BVH against the loop over every primitive, and a real mesh.

mod common;

use pathmix::kernel::{GroupedDensity, KernelConfig, SceneStorage};
use pathmix::render::{RenderOptions, Renderer};
use pathmix::scene::mesh::load_mesh;
use pathmix::scene::{Scene, Strategy};
use std::fmt::Write;

macro_rules! gpu_or_skip {
    () => {
        match common::gpu() {
            Some(ctx) => ctx,
            None => return,
        }
    };
}

/// The white furnace of `scenes/furnace.toml` (a closed cube, albedo 0.5,
/// emission 1, normals inward) with its walls as an OBJ mesh of 12 triangles,
/// two per wall, sharing the walls' edges and corners; `inside`: more objects
/// of the scene file, of the walls' material (`wall`).
fn furnace_mesh(name: &str, strategy: Strategy, spp: u32, max_depth: u32, inside: &str) -> Scene {
    let quads = common::scene_file("furnace.toml").shapes.quads;
    let mut obj = String::new();
    for (i, q) in quads.iter().enumerate() {
        for p in [q.q, q.q + q.u, q.q + q.u + q.v, q.q + q.v] {
            writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
        }
        // A quad face, fanned by the reader into (0 1 2) and (0 2 3): normals u x v.
        let base = 4 * i + 1;
        writeln!(obj, "f {} {} {} {}", base, base + 1, base + 2, base + 3).unwrap();
    }
    let dir = common::TempDir::new("meshes", name);
    let path = dir.join("furnace.obj");
    std::fs::write(&path, obj).unwrap();
    let text = format!(
        "[camera]\nlookfrom = [0, 0, 0]\nlookat = [0, 0, 1]\nvfov = 90\nwidth = 16\nheight = 16\n\
         [render]\nspp = {spp}\nmax_depth = {max_depth}\nstrategy = \"{strategy}\"\n\
         [materials.wall]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\nemit = [1, 1, 1]\n\
         [[objects]]\ntype = \"mesh\"\nfile = {path:?}\nmaterial = \"wall\"\n{inside}"
    );
    Scene::parse(&text, "furnace-mesh.toml").unwrap()
}

/// BSDF sampling weighs each bounce by exactly the albedo, so every path that
/// stays inside sees exactly the analytic value; a ray slipping through an edge
/// or a corner shared by two triangles would escape to the black background
/// (the test through the BVH and from buffers is watertight; baked, the walls
/// are tested at their planes, and none of this image's rays slips between).
#[test]
fn mesh_furnace_bsdf_is_exact() {
    let ctx = gpu_or_skip!();
    let scene = furnace_mesh("exact", Strategy::Bsdf, 64, 4, "");
    assert_eq!(scene.shapes.triangles.len(), 12);
    let expected = common::furnace_value(1.0, 0.5, 4) as f32;
    for storage in [
        SceneStorage::Baked,
        SceneStorage::Buffers,
        SceneStorage::Bvh,
    ] {
        let options = RenderOptions {
            scene_storage: Some(storage),
            ..RenderOptions::default()
        };
        let acc = common::render(ctx, &scene, &options);
        common::assert_every_pixel_is(&acc, expected, 1e-6, &format!("{storage:?}"));
    }
}

/// With a small mesh inside, the furnace's walls go beside the BVH, where their
/// test is the plane's (`triangle_constant_hit_t`), not the watertight one:
/// still every path stays inside and sees the analytic value. A ray passing
/// between two walls' triangles, or a hit off a wall, would find the black
/// background; a hit of the wrong triangle or at the wrong distance, a wrong
/// path.
#[test]
fn mesh_furnace_with_its_walls_beside_the_bvh_is_exact() {
    let ctx = gpu_or_skip!();
    let icosahedron =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/icosahedron.obj");
    let inside = format!(
        "[[objects]]\ntype = \"mesh\"\nfile = {:?}\nmaterial = \"wall\"\nscale = 0.25\n\
         translate = [0.3, -0.2, 0.5]\nsmooth = false\n",
        icosahedron.display().to_string()
    );
    let scene = furnace_mesh("beside", Strategy::Bsdf, 64, 4, &inside);
    assert_eq!(scene.shapes.triangles.len(), 32);
    let options = RenderOptions {
        scene_storage: Some(SceneStorage::Bvh),
        ..RenderOptions::default()
    };
    let renderer = Renderer::new(ctx, &scene, &options).unwrap();
    let beside: Vec<String> = (renderer.config().scene_arrays().into_iter())
        .filter(|array| array.name.starts_with("large_"))
        .map(|array| array.name)
        .collect();
    assert_eq!(beside, ["large_triangles"]);
    let acc = common::render(ctx, &scene, &options);
    let expected = common::furnace_value(1.0, 0.5, 4) as f32;
    common::assert_every_pixel_is(&acc, expected, 1e-6, "walls beside the BVH");
}

/// Emissive triangles are in the light density: the mixture, light sampling and
/// next-event estimation aim at them and stay unbiased.
#[test]
fn emissive_triangles_are_sampled_without_bias() {
    let ctx = gpu_or_skip!();
    let expected = common::furnace_value(1.0, 0.5, 4);
    for strategy in [Strategy::Mixture, Strategy::Light, Strategy::NeeMis] {
        let scene = furnace_mesh("lights", strategy, 256, 4, "");
        let renderer = Renderer::new(ctx, &scene, &common::with_variance()).unwrap();
        assert!(
            renderer.config().samples_lights(),
            "{strategy}: no light sampling"
        );
        let acc = common::render(ctx, &scene, &common::with_variance());
        let (mean, error) = common::image_mean_and_error(&acc);
        assert!(error > 0.0, "{strategy}: no noise at all");
        assert!(
            (mean - expected).abs() < 4.0 * error,
            "{strategy}: {mean} ± {error}, expected {expected}"
        );
    }
}

/// Mitsuba's Stanford bunny (69 451 triangles, binary PLY) from the shared data,
/// in the book's Cornell box: it loads, goes through the BVH, and renders a
/// finite image whose every invocation finishes.
#[test]
fn stanford_bunny_renders_through_the_bvh() {
    let bunny = shared_or_skip!("mitsuba-scenes/meshes/bunny.ply");
    let ctx = gpu_or_skip!();
    let mut text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-boxes.toml"),
    )
    .unwrap();
    write!(
        text,
        "\n[[objects]]\ntype = \"mesh\"\nfile = {:?}\nmaterial = \"white\"\nscale = 1800\n\
         rotate_y = 200\ntranslate = [290, -59.4, 300]\n",
        bunny.display().to_string()
    )
    .unwrap();
    let mut scene = Scene::parse(&text, "bunny.toml").unwrap();
    scene.camera.width = 32;
    scene.camera.height = 32;
    scene.render.spp = 4;
    scene.render.max_depth = 6;
    assert!(scene.shapes.triangles.len() + scene.degenerate_triangles == 69_451);
    let mut renderer = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
    assert_eq!(renderer.config().scene_storage(), SceneStorage::Bvh);
    while renderer.samples() < scene.render.spp {
        renderer.advance(scene.render.spp - renderer.samples());
    }
    let counters = renderer.check_counters().unwrap();
    assert_eq!(counters.discarded, 0);
    let mean = renderer.accumulation().mean();
    assert!(mean.pixels.iter().flatten().all(|c| c.is_finite()));
}

/// A scene file beside a mesh file `name` with `contents`, in a folder of its
/// own (named after `tag`).
fn scene_beside_mesh(tag: &str, name: &str, contents: &str, scene: &str) -> Scene {
    let dir = common::TempDir::new("meshes", tag);
    std::fs::write(dir.join(name), contents).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    Scene::load(&path).unwrap()
}

/// A thin closed cylinder (radius 0.05, length 2, 128 sides: faces 800 times as
/// long as they are wide, as long as the scene) under a red sky, at depth 1:
/// every ray that leaves its surface escapes, so every pixel the cylinder
/// fills holds its albedo's share of the sky, 0.5 in red, exactly. The
/// surface emits green alone, which marks the filled pixels (all samples hit
/// it). With rays leaving triangles by the offset of spheres and quads, such
/// slivers hit themselves: 626 of these pixels lost up to 8% of their red
/// (`PrimitiveKind::ray_offset_factor`).
#[test]
fn long_thin_faces_do_not_shadow_themselves() {
    let ctx = gpu_or_skip!();
    let sides = 128;
    let mut obj = String::new();
    for i in 0..sides {
        let angle = std::f64::consts::TAU * i as f64 / sides as f64;
        let (x, z) = (0.05 * angle.cos(), 0.05 * angle.sin());
        writeln!(obj, "v {x} -1 {z}\nv {x} 1 {z}").unwrap();
    }
    for i in 0..sides {
        let j = (i + 1) % sides;
        writeln!(
            obj,
            "f {} {} {} {}",
            2 * i + 1,
            2 * i + 2,
            2 * j + 2,
            2 * j + 1
        )
        .unwrap();
    }
    for end in [1, 2] {
        let cap: Vec<String> = (0..sides).map(|i| (2 * i + end).to_string()).collect();
        writeln!(obj, "f {}", cap.join(" ")).unwrap();
    }
    let scene = scene_beside_mesh(
        "thin-faces",
        "cylinder.obj",
        &obj,
        r#"
        [camera]
        lookfrom = [0.9, 1.3, 4]
        lookat = [0, 0, 0]
        vfov = 12
        width = 96
        height = 96
        [render]
        spp = 64
        max_depth = 1
        strategy = "bsdf"
        background = [1, 0, 0]
        [materials.marked]
        type = "lambertian"
        albedo = [0.5, 0.5, 0.5]
        emit = [0, 1, 0]
        [[objects]]
        type = "mesh"
        file = "cylinder.obj"
        smooth = false
        material = "marked"
        "#,
    );
    let mean = common::render(ctx, &scene, &RenderOptions::default()).mean();
    let filled: Vec<&[f32; 3]> = mean.pixels.iter().filter(|p| p[1] == 1.0).collect();
    assert!(filled.len() > 500, "{} filled pixels", filled.len());
    let dark = filled.iter().filter(|p| p[0] != 0.5).count();
    assert_eq!(dark, 0, "of {} filled pixels", filled.len());
}

/// A square of 2 000 strips, each two faces 1 000 times as long as wide, turned
/// off the axes: every face's box spans the square, so a ray's walk crosses
/// hundreds of them (about 1 460 steps on average by `WideBvh::expected_steps`).
/// The dispatches are sized for that, so no invocation is cut short by
/// lavapipe's loop limit (with 256 steps allowed a ray, as for any BVH before,
/// thousands were, and the run failed).
#[test]
fn overlapping_boxes_are_walked_within_the_loop_limit() {
    let ctx = gpu_or_skip!();
    let strips = 2000;
    let mut obj = String::new();
    for i in 0..strips {
        let [x0, x1] = [i, i + 1].map(|x| 2.0 * x as f64 / strips as f64 - 1.0);
        writeln!(obj, "v {x0} -1 0\nv {x1} -1 0\nv {x1} 1 0\nv {x0} 1 0").unwrap();
        let k = 4 * i + 1;
        writeln!(
            obj,
            "f {} {} {}\nf {} {} {}",
            k,
            k + 1,
            k + 2,
            k,
            k + 2,
            k + 3
        )
        .unwrap();
    }
    let scene = scene_beside_mesh(
        "overlapping-boxes",
        "strips.obj",
        &obj,
        r#"
        [camera]
        lookfrom = [0.3, 0.5, 3.2]
        lookat = [0, 0, 0]
        vfov = 40
        width = 24
        height = 24
        [render]
        spp = 64
        max_depth = 1
        strategy = "bsdf"
        background = [1, 1, 1]
        [materials.grey]
        type = "lambertian"
        albedo = [0.5, 0.5, 0.5]
        [[objects]]
        type = "mesh"
        file = "strips.obj"
        smooth = false
        material = "grey"
        rotate = { axis = [1, 2, 3], angle = 37 }
        "#,
    );
    // `common::render` asserts that no invocation was cut short.
    let mean = common::render(ctx, &scene, &RenderOptions::default()).mean();
    assert!(mean.pixels.iter().flatten().all(|c| c.is_finite()));
}

/// A square floor at y = 0 (two triangles, face normal +y) whose file normals
/// are all tilted by `tilt_degrees` toward +z, under a white sky, seen from
/// straight above; one Lambertian bounce (albedo 0.5) under BSDF sampling.
fn tilted_floor(tilt_degrees: f32, object_keys: &str) -> Scene {
    let (sin, cos) = tilt_degrees.to_radians().sin_cos();
    let obj = format!(
        "v -5 0 -5\nv -5 0 5\nv 5 0 5\nv 5 0 -5\nvn 0 {cos} {sin}\nf 1//1 2//1 3//1 4//1\n"
    );
    let scene = format!(
        "[camera]\nlookfrom = [0, 1, 0]\nlookat = [0, 0, 0]\nvup = [0, 0, -1]\nvfov = 30\n\
         width = 16\nheight = 16\n\
         [render]\nspp = 64\nmax_depth = 1\nstrategy = \"bsdf\"\nbackground = [1, 1, 1]\n\
         [materials.floor]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[objects]]\ntype = \"mesh\"\nfile = \"floor.obj\"\nmaterial = \"floor\"\n{object_keys}\n"
    );
    scene_beside_mesh(
        &format!("floor-{tilt_degrees}-{}", object_keys.len()),
        "floor.obj",
        &obj,
        &scene,
    )
}

/// The file's vertex normals shade the floor: cosine sampling about a normal
/// tilted by 60 degrees sends (1 - cos 60) / 2 of its directions below the
/// surface, which the geometric-normal check absorbs instead of letting them
/// through to the sky, so the floor reflects 0.5 (1 + cos 60) / 2 of the sky
/// (the view factor of a tilted plane); `smooth = false` shades with the face
/// normal and reflects exactly 0.5. Checked in every scene storage.
#[test]
fn shading_normals_from_the_file_light_a_floor_as_a_tilted_plane() {
    let ctx = gpu_or_skip!();
    let tilted = tilted_floor(60.0, "");
    assert!(tilted.shapes.triangles.iter().all(|t| t.normals.is_some()));
    let flat = tilted_floor(60.0, "smooth = false");
    assert!(flat.shapes.triangles.iter().all(|t| t.normals.is_none()));
    let expected = 0.5 * (1.0 + 60f64.to_radians().cos()) / 2.0;
    for storage in [
        SceneStorage::Baked,
        SceneStorage::Buffers,
        SceneStorage::Bvh,
    ] {
        let options = RenderOptions {
            scene_storage: Some(storage),
            variance: true,
            ..RenderOptions::default()
        };
        let (mean, error) = common::image_mean_and_error(&common::render(ctx, &tilted, &options));
        assert!(
            (mean - expected).abs() < 4.0 * error + 1e-4,
            "{storage:?}: {mean} ± {error}, expected {expected}"
        );
        let acc = common::render(ctx, &flat, &options);
        common::assert_every_pixel_is(&acc, 0.5, 1e-6, &format!("flat, {storage:?}"));
    }
}

/// A mesh without normals in its file is smooth by default: its vertices get
/// the angle-weighted average of their faces' normals (a cube's corners the
/// diagonals, however its faces are split), carried through the transform.
#[test]
fn meshes_without_normals_get_angle_weighted_vertex_normals() {
    let mut obj = String::new();
    for z in [0, 1] {
        for y in [0, 1] {
            for x in [0, 1] {
                writeln!(obj, "v {x} {y} {z}").unwrap();
            }
        }
    }
    // Outward, counter-clockwise: -z, +z, -y, +y, -x, +x; two faces fanned
    // from different corners, so corners see one or two triangles of a face.
    obj.push_str("f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n");
    let keys = "rotate = { axis = [0, 0, 1], angle = 90 }\nscale = 2";
    let scene_text = |keys: &str| {
        format!(
            "[camera]\nlookfrom = [0, 0, 9]\nlookat = [0, 0, 0]\nvfov = 40\nwidth = 8\nheight = 8\n\
             [materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[objects]]\ntype = \"mesh\"\nfile = \"cube.obj\"\nmaterial = \"white\"\n{keys}\n"
        )
    };
    let scene = scene_beside_mesh("cube", "cube.obj", &obj, &scene_text(keys));
    assert_eq!(scene.shapes.triangles.len(), 12);
    // The cube spans [-2, 0] x [0, 2] x [0, 2] once rotated and scaled.
    let centre = glam::Vec3::new(-1.0, 1.0, 1.0);
    for t in &scene.shapes.triangles {
        let normals = t.normals.expect("smooth by default");
        for (v, n) in t.vertices.iter().zip(normals) {
            let diagonal = (*v - centre).normalize();
            assert!(
                (n - diagonal).length() < 1e-5,
                "{v}: {n}, expected {diagonal}"
            );
        }
    }
    let flat = scene_beside_mesh("cube", "cube.obj", &obj, &scene_text("smooth = false"));
    assert!(flat.shapes.triangles.iter().all(|t| t.normals.is_none()));
}

/// The furnace's cube [-1, 1]^3 as one mesh of `2 * 6 * n * n` triangles of
/// unequal sizes (each wall an n x n grid, finer toward its edges), normals
/// inward. Every wall takes its vertices from one lattice of coordinates, so
/// walls meet at identical vertices and the mesh stays watertight.
fn subdivided_furnace(n: usize, strategy: Strategy, spp: u32) -> Scene {
    let lattice: Vec<f64> = (0..=n)
        .map(|i| -(std::f64::consts::PI * i as f64 / n as f64).cos())
        .collect();
    let mut obj = String::new();
    let mut vertices = 0;
    for axis in 0..3 {
        for side in [-1.0f64, 1.0] {
            let point = |i: usize, j: usize| {
                let mut p = [0.0; 3];
                p[axis] = side;
                p[(axis + 1) % 3] = lattice[i];
                p[(axis + 2) % 3] = lattice[j];
                p
            };
            for i in 0..n {
                for j in 0..n {
                    let corners = [
                        point(i, j),
                        point(i + 1, j),
                        point(i + 1, j + 1),
                        point(i, j + 1),
                    ];
                    for p in corners {
                        writeln!(obj, "v {} {} {}", p[0], p[1], p[2]).unwrap();
                    }
                    // (i, j, axis) is right-handed, so this order faces +axis:
                    // inward on the -1 side, reversed on the +1 side.
                    let face = if side < 0.0 {
                        [1, 2, 3, 4]
                    } else {
                        [4, 3, 2, 1]
                    };
                    let face = face.map(|k| vertices + k);
                    writeln!(obj, "f {} {} {} {}", face[0], face[1], face[2], face[3]).unwrap();
                    vertices += 4;
                }
            }
        }
    }
    let text = format!(
        "[camera]\nlookfrom = [0, 0, 0]\nlookat = [0, 0, 1]\nvfov = 90\nwidth = 16\nheight = 16\n\
         [render]\nspp = {spp}\nmax_depth = 4\nstrategy = \"{strategy}\"\n\
         [materials.wall]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\nemit = [1, 1, 1]\n\
         [[objects]]\ntype = \"mesh\"\nfile = \"furnace.obj\"\nmaterial = \"wall\"\nsmooth = false\n"
    );
    let scene = scene_beside_mesh(
        &format!("furnace-{n}-{strategy}"),
        "furnace.obj",
        &obj,
        &text,
    );
    assert_eq!(scene.shapes.triangles.len(), 12 * n * n);
    scene
}

/// Thousands of emitting triangles of unequal areas are one object of the light
/// density: a face is picked by power (here in proportion to its area) and the
/// density of a direction is found through the lights' BVH, not a loop over
/// every face. The mixture and `nee-mis` stay unbiased (a pick probability
/// that the density did not match would bias them here). `light` alone is
/// left out: near the cube's edges a face's area density weighs a sample by
/// 1 / distance^2 without bound, so its mean has no useful error bar.
#[test]
fn thousands_of_light_triangles_are_picked_by_power_without_bias() {
    let ctx = gpu_or_skip!();
    let expected = common::furnace_value(1.0, 0.5, 4);
    for strategy in [Strategy::Mixture, Strategy::NeeMis] {
        let scene = subdivided_furnace(14, strategy, 128);
        let renderer = Renderer::new(ctx, &scene, &common::with_variance()).unwrap();
        let source = renderer.config().source().unwrap();
        assert!(
            !source.contains("light_index < arrayLength(&light_triangles)"),
            "{strategy}: the light density loops over every light triangle"
        );
        let acc = common::render(ctx, &scene, &common::with_variance());
        let (mean, error) = common::image_mean_and_error(&acc);
        assert!(error > 0.0, "{strategy}: no noise at all");
        assert!(
            (mean - expected).abs() < 4.0 * error,
            "{strategy}: {mean} ± {error}, expected {expected}"
        );
    }
}

/// A glTF file with two triangles, each a primitive of its own material: a red
/// diffuse one and an emitting one (`KHR_materials_emissive_strength` 4), its
/// buffer in a file beside it.
fn gltf_two_materials(dir: &std::path::Path, second_material: &str) {
    let positions: [[f32; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    std::fs::write(dir.join("two.bin"), &bytes).unwrap();
    let accessor = |offset: usize, z: f32| {
        format!(
            r#"{{"bufferView": 0, "byteOffset": {offset}, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, {z}], "max": [1, 1, {z}]}}"#
        )
    };
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}, {{"attributes": {{"POSITION": 1}}{second_material}}}]}}],
        "materials": [
            {{"name": "paint", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.1, 0.1, 1], "metallicFactor": 0}}}},
            {{"name": "glow", "emissiveFactor": [1, 0.5, 0.25], "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 4}}}}}}
        ],
        "buffers": [{{"uri": "two.bin", "byteLength": {}}}],
        "bufferViews": [{{"buffer": 0, "byteLength": {}}}],
        "accessors": [{}, {}]}}"#,
        bytes.len(),
        bytes.len(),
        accessor(0, 0.0),
        accessor(36, 1.0)
    );
    std::fs::write(dir.join("two.gltf"), gltf).unwrap();
}

/// A glTF file's materials map to the nearest pathmix has (Lambertian with the
/// base colour, emitting the emission), said once as a warning; an emitting one
/// puts its faces in the light density; the object's `material` overrides them;
/// a face without a material needs `material`.
#[test]
fn gltf_materials_map_to_the_nearest_pathmix_material() {
    let dir = common::TempDir::new("meshes", "gltf");
    let scene = |second_material: &str, keys: &str| {
        gltf_two_materials(&dir, second_material);
        let text = format!(
            "[camera]\nlookfrom = [0, 0, 5]\nlookat = [0, 0, 0]\nwidth = 8\nheight = 8\n\
             [materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[objects]]\ntype = \"mesh\"\nfile = \"two.gltf\"\n{keys}\n"
        );
        let path = dir.join("scene.toml");
        std::fs::write(&path, text).unwrap();
        Scene::load(&path)
    };
    let mapped = scene(r#", "material": 1"#, "").unwrap();
    assert_eq!(mapped.materials.len(), 3);
    let [paint, glow] = [1, 2].map(|i| &mapped.materials[i]);
    assert_eq!(
        (paint.albedo, paint.emit),
        (glam::Vec3::new(0.8, 0.1, 0.1), glam::Vec3::ZERO)
    );
    assert_eq!(glow.emit, glam::Vec3::new(4.0, 2.0, 1.0));
    let faces: Vec<(u32, bool)> = mapped
        .shapes
        .triangles
        .iter()
        .map(|t| (t.material, t.importance))
        .collect();
    assert_eq!(faces, [(1, false), (2, true)]);
    assert_eq!(mapped.warnings.len(), 1, "{:?}", mapped.warnings);
    assert!(
        mapped.warnings[0].contains("nearest"),
        "{}",
        mapped.warnings[0]
    );

    let overridden = scene(r#", "material": 1"#, "material = \"white\"").unwrap();
    assert_eq!(overridden.materials.len(), 1);
    assert!(
        overridden
            .shapes
            .triangles
            .iter()
            .all(|t| t.material == 0 && !t.importance)
    );
    assert!(overridden.warnings.is_empty());

    let error = scene("", "").unwrap_err();
    assert!(error.to_string().contains("objects[0]"), "{error}");
    assert!(
        error
            .to_string()
            .contains("missing required key `material`"),
        "{error}"
    );
}

/// pathmix against Mitsuba 3 on Mitsuba's own Cornell box (its OBJ meshes,
/// materials and light) with the Stanford bunny, both from the shared data:
/// `tests/fixtures/mitsuba-cbox-bunny-64.exr` is Mitsuba's `path` integrator at
/// 64x64 and 65 536 spp (independent sampler, max_depth 8; made by
/// `scripts/compare-mitsuba.py --mitsuba-reference-only`). pathmix (`nee-mis`,
/// max depth 7) renders 32x32, each pixel the box of four reference pixels.
/// The image mean and every 8x8 block must agree within 4 standard errors of
/// pathmix's noise plus 1% (the reference's own noise and f32 rounding).
#[test]
fn cornell_box_meshes_and_bunny_match_mitsuba() {
    let dir = common::TempDir::new("meshes", "mitsuba-cbox-bunny");
    let Some(scene_file) =
        common::fixture_reading_shared("tests/fixtures/mitsuba-cbox-bunny.toml", &dir)
    else {
        return;
    };
    let ctx = gpu_or_skip!();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let reference =
        pathmix::output::read_exr(&root.join("tests/fixtures/mitsuba-cbox-bunny-64.exr")).unwrap();
    let mut scene = Scene::load(&scene_file).unwrap();
    let size = reference.width / 2;
    (scene.camera.width, scene.camera.height) = (size, size);
    scene.render.spp = 256;
    let acc = common::render(ctx, &scene, &common::with_variance());
    let n = acc.samples as f64;
    let sum_sq = acc.sum_sq.as_ref().unwrap();
    // Per block of `side` x `side` pixels: pathmix's mean, its standard
    // error (channels averaged, bounded as in `common::image_mean_and_error`),
    // and the reference's mean.
    let blocks = |side: u32| {
        let per_row = size / side;
        let mut out = vec![(0.0f64, 0.0f64, 0.0f64); (per_row * per_row) as usize];
        for y in 0..size {
            for x in 0..size {
                let i = (y * size + x) as usize;
                let block = &mut out[((y / side) * per_row + x / side) as usize];
                let weight = 1.0 / (3.0 * (side * side) as f64);
                for (c, (&sum, &sq)) in acc.sum[i].iter().zip(&sum_sq[i]).enumerate() {
                    let m = sum / n;
                    let variance = (sq - n * m * m).max(0.0) / (n - 1.0) / n;
                    block.0 += m * weight;
                    block.1 += variance * weight / (side * side) as f64;
                    let quad = [(0, 0), (1, 0), (0, 1), (1, 1)];
                    let r: f64 = quad
                        .iter()
                        .map(|&(dx, dy)| reference.get(2 * x + dx, 2 * y + dy)[c] as f64)
                        .sum();
                    block.2 += r / 4.0 * weight;
                }
            }
        }
        out.into_iter()
            .map(|(m, v, r)| (m, v.sqrt(), r))
            .collect::<Vec<_>>()
    };
    for (side, what) in [(size, "image mean"), (8, "8x8 block")] {
        for (i, (mean, error, expected)) in blocks(side).into_iter().enumerate() {
            let tolerance = 4.0 * error + 0.01 * expected;
            assert!(
                (mean - expected).abs() < tolerance,
                "{what} {i}: pathmix {mean} ± {error}, Mitsuba {expected} (off by {:.2}%)",
                100.0 * (mean / expected - 1.0)
            );
        }
    }
}

/// `importance = true` puts a mesh that does not emit in the light density too:
/// each mesh is one group, its faces weighed by area (by power, area times
/// luminance, when it emits).
#[test]
fn importance_meshes_are_light_groups_weighed_by_area() {
    // Two faces of areas 1 and 3 in the plane z = 0.
    let obj = "v 0 0 0\nv 2 0 0\nv 0 1 0\nv 8 0 0\nv 8 1 0\nf 1 2 3\nf 2 4 5\n";
    let text = "[camera]\nlookfrom = [0, 0, 5]\nlookat = [0, 0, 0]\nwidth = 8\nheight = 8\n\
         [materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [materials.lamp]\ntype = \"light\"\nemit = [2, 2, 2]\n\
         [[objects]]\ntype = \"mesh\"\nfile = \"two.obj\"\nmaterial = \"white\"\nimportance = true\n\
         [[objects]]\ntype = \"mesh\"\nfile = \"two.obj\"\nmaterial = \"lamp\"\ntranslate = [0, 0, -1]\n";
    let scene = scene_beside_mesh("importance", "two.obj", obj, text);
    let data = pathmix::pack::SceneData::pack(&scene);
    let triangle = pathmix::kinds::PRIMITIVE_KINDS
        .iter()
        .position(|k| k.name == "triangle")
        .unwrap();
    let tables = data.light_tables[triangle]
        .as_ref()
        .expect("triangles in the light density");
    assert_eq!(tables.groups.len(), 2);
    let pmf: Vec<f32> = tables.picks.iter().map(|p| p.pmf).collect();
    assert_eq!(pmf, [0.25, 0.75, 0.25, 0.75]);
}

/// Irradiance at the origin, normal +y, from a triangle of unit radiance with
/// vertices `v` (Lambert's polygon formula: half the sum over the edges of the
/// angle each subtends times the cosine of its plane's normal with +y).
fn triangle_irradiance(v: [[f64; 3]; 3]) -> f64 {
    let unit = |p: [f64; 3]| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / l, p[1] / l, p[2] / l]
    };
    let mut sum = 0.0;
    for i in 0..3 {
        let (a, b) = (unit(v[i]), unit(v[(i + 1) % 3]));
        let cross = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
        let cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        sum += sin.atan2(cos) * cross[1] / sin;
    }
    (sum / 2.0).abs()
}

/// A triangle light (facing down: emitters emit on their front side) over a
/// Lambertian floor gives the floor under it Lambert's
/// analytic irradiance under every strategy, near and large (where sampling by
/// area is noisy) and small and far, so the density each evaluates is the one
/// each draws from.
#[test]
fn triangle_light_gives_the_analytic_irradiance() {
    let ctx = gpu_or_skip!();
    let (emit, albedo) = (4.0f64, 0.6f64);
    for (name, v) in [
        (
            "near",
            [[-1.5, 0.4, -1.0], [1.0, 0.3, -0.6], [0.3, 0.5, 1.2]],
        ),
        (
            "far",
            [[-0.2, 20.0, -0.1], [0.15, 19.5, -0.1], [0.1, 21.0, 0.2]],
        ),
    ] {
        let obj: String = v
            .iter()
            .map(|p| format!("v {} {} {}\n", p[0], p[1], p[2]))
            .collect::<String>()
            + "f 1 2 3\n";
        let dir = common::TempDir::new("triangle-light", name);
        let path = dir.join("triangle.obj");
        std::fs::write(&path, obj).unwrap();
        let expected = albedo / std::f64::consts::PI * emit * triangle_irradiance(v);
        let mesh = format!("[[objects]]\ntype = \"mesh\"\nfile = {path:?}\nmaterial = \"lamp\"\n");
        common::assert_lit_floor(ctx, (albedo, emit, 0.1), &mesh, expected, name);
    }
}

/// An emitting cube over a Lambertian floor, each face split into `n` x `n`
/// squares of two triangles: the point under it sees the bottom face alone
/// (the others face away or lie behind it), so its irradiance is that square's,
/// under every strategy. Under `nee-mis`, with enough faces to be weighed by
/// their points' density (`GroupedDensity::Points`, 108 faces here; 12
/// keep the line's), a sample of a hidden face finds the bottom face first
/// and must count nothing: counting the face it found gave 1.6x the expected
/// radiance. The line's density tests the 12 faces each and walks the 108's
/// BVH, whose light tables are compiled in: read through a `switch`, lavapipe
/// gave `light` no light and the mixture 3.3x too much.
#[test]
fn an_emitting_cube_lights_the_floor_with_its_bottom_face_alone() {
    let ctx = gpu_or_skip!();
    let (emit, albedo) = (3.0f64, 0.6f64);
    let (low, high) = ([-0.5, 0.6, -0.3], [0.5, 1.4, 0.7]);
    for n in [1, 3] {
        let size = [high[0] - low[0], high[1] - low[1], high[2] - low[2]];
        let axis = |i: usize, length: f64| {
            let mut v = [0.0; 3];
            v[i] = length;
            v
        };
        let (x, y, z) = (axis(0, size[0]), axis(1, size[1]), axis(2, size[2]));
        let minus = |v: [f64; 3]| v.map(|c| -c);
        // Each face as (corner, edge u, edge v), u x v pointing out.
        let faces = [
            (low, x, z),
            (high, minus(z), minus(x)),
            (low, y, x),
            (high, minus(y), minus(z)),
            (low, z, y),
            (high, minus(x), minus(y)),
        ];
        let point = |(o, u, v): ([f64; 3], [f64; 3], [f64; 3]), a: f64, b: f64| {
            [0, 1, 2].map(|i| o[i] + a * u[i] + b * v[i])
        };
        let mut obj = String::new();
        let mut count = 0;
        for face in faces {
            for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
                let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                let step = 1.0 / n as f64;
                for p in [
                    point(face, a, b),
                    point(face, a + step, b),
                    point(face, a + step, b + step),
                    point(face, a, b + step),
                ] {
                    obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
                }
                obj += &format!(
                    "f {} {} {} {}\n",
                    count + 1,
                    count + 2,
                    count + 3,
                    count + 4
                );
                count += 4;
            }
        }
        let dir = common::TempDir::new("emitting-cube", &n.to_string());
        let path = dir.join("cube.obj");
        std::fs::write(&path, obj).unwrap();
        let mesh = format!("[[objects]]\ntype = \"mesh\"\nfile = {path:?}\nmaterial = \"lamp\"\n");
        // `nee-mis` weighs by points from `LIGHT_POINTS_MIN` faces on; the
        // mixture tests each face below `LIGHT_WALK_MIN` and walks their BVH from there.
        let density = |strategy: &str| {
            let scene = common::scene_text(&format!(
                "[camera]\nlookfrom = [0, 0.1, 0]\nlookat = [0, 0, 0]\nvup = [0, 0, -1]\nwidth = 4\nheight = 4\n[render]\nstrategy = \"{strategy}\"\n\
                 [materials.floor]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [materials.lamp]\ntype = \"light\"\nemit = [1, 1, 1]\n\
                 [[objects]]\ntype = \"sphere\"\ncenter = [0, -100, 0]\nradius = 100\nmaterial = \"floor\"\n{mesh}"
            ));
            let renderer = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
            renderer.config().grouped_density
        };
        let count = 12 * n * n;
        let line = match count >= KernelConfig::LIGHT_WALK_MIN {
            true => GroupedDensity::Walk,
            false => GroupedDensity::Every,
        };
        let points = count >= KernelConfig::LIGHT_POINTS_MIN;
        assert_eq!(
            density("nee-mis"),
            if points { GroupedDensity::Points } else { line }
        );
        assert_eq!(density("mixture"), line);
        let bottom = [
            point(faces[0], 0.0, 0.0),
            point(faces[0], 1.0, 0.0),
            point(faces[0], 1.0, 1.0),
            point(faces[0], 0.0, 1.0),
        ];
        let irradiance = triangle_irradiance([bottom[0], bottom[1], bottom[2]])
            + triangle_irradiance([bottom[0], bottom[2], bottom[3]]);
        let expected = albedo / std::f64::consts::PI * emit * irradiance;
        common::assert_lit_floor(
            ctx,
            (albedo, emit, 0.1),
            &mesh,
            expected,
            &format!("cube of {} faces", 12 * n * n),
        );
    }
}

/// Mitsuba's own meshes read as Mitsuba reads them: the bunny and the teapot
/// (PLY), the bunny without vertex normals.
#[test]
fn mitsuba_bunny_and_teapot_load() {
    let bunny = load_mesh(&shared_or_skip!("mitsuba-scenes/meshes/bunny.ply"), 0).unwrap();
    assert_eq!(bunny.positions.len(), 35_947);
    assert_eq!(bunny.triangles.len(), 69_451);
    assert_eq!(bunny.normals, None);
    let teapot = load_mesh(&shared_or_skip!("mitsuba-scenes/meshes/teapot.ply"), 0).unwrap();
    assert!(!teapot.triangles.is_empty());
}

/// Every OBJ of Mitsuba's Cornell box loads: the back wall one quad (two
/// faces), the large box 12 faces with its 24 vertex normals.
#[test]
fn mitsuba_cornell_box_objs_load() {
    let back = shared_or_skip!("mitsuba-scenes/cbox/meshes/cbox_back.obj");
    let mut seen = 0;
    for entry in std::fs::read_dir(back.parent().unwrap()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "obj") {
            let mesh = load_mesh(&path, 0).unwrap();
            assert!(!mesh.triangles.is_empty(), "{}", path.display());
            seen += 1;
        }
    }
    assert!(seen > 1);
    let back = load_mesh(&back, 0).unwrap();
    assert_eq!(back.positions.len(), 4);
    assert_eq!(back.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    let large = load_mesh(
        &shared_or_skip!("mitsuba-scenes/cbox/meshes/cbox_largebox.obj"),
        0,
    )
    .unwrap();
    assert_eq!(large.triangles.len(), 12);
    assert_eq!(large.normals.map(|n| n.len()), Some(24));
}

//! Mitsuba's `.serialized` meshes, written here as its format documents them
//! (versions 3 and 4, one zlib stream per mesh, the offsets at the end), read
//! back, picked by `shape_index`, refused when cut short or corrupt, and
//! rendered as the same mesh from an OBJ file renders.

mod common;

use flate2::Compression;
use flate2::write::ZlibEncoder;
use pathmix::render::RenderOptions;
use pathmix::scene::Scene;
use pathmix::scene::mesh::load_mesh;
use std::io::Write;
use std::process::Command;

/// One mesh as the writer stores it.
struct Part {
    name: &'static str,
    positions: Vec<[f64; 3]>,
    normals: Option<Vec<[f64; 3]>>,
    uvs: Option<Vec<[f64; 2]>>,
    colors: Option<Vec<[f64; 3]>>,
    triangles: Vec<[u32; 3]>,
    double: bool,
}

/// A `.serialized` file of `parts`, format `version` (3 or 4): each part's
/// header and zlib stream, then each part's offset (`u64`, `u32` in version 3)
/// and their count.
fn serialized(version: u16, parts: &[Part]) -> Vec<u8> {
    let mut file = Vec::new();
    let mut offsets = Vec::new();
    for part in parts {
        offsets.push(file.len() as u64);
        file.extend_from_slice(&0x041Cu16.to_le_bytes());
        file.extend_from_slice(&version.to_le_bytes());
        let mut stream = Vec::new();
        let flags = u32::from(part.normals.is_some())
            | u32::from(part.uvs.is_some()) << 1
            | u32::from(part.colors.is_some()) << 3
            | if part.double { 0x2000 } else { 0x1000 };
        stream.extend_from_slice(&flags.to_le_bytes());
        if version == 4 {
            stream.extend_from_slice(part.name.as_bytes());
            stream.push(0);
        }
        stream.extend_from_slice(&(part.positions.len() as u64).to_le_bytes());
        stream.extend_from_slice(&(part.triangles.len() as u64).to_le_bytes());
        let mut floats = |values: &[f64]| {
            for &v in values {
                match part.double {
                    true => stream.extend_from_slice(&v.to_le_bytes()),
                    false => stream.extend_from_slice(&(v as f32).to_le_bytes()),
                }
            }
        };
        floats(part.positions.as_flattened());
        if let Some(normals) = &part.normals {
            floats(normals.as_flattened());
        }
        if let Some(uvs) = &part.uvs {
            floats(uvs.as_flattened());
        }
        if let Some(colors) = &part.colors {
            floats(colors.as_flattened());
        }
        for index in part.triangles.as_flattened() {
            stream.extend_from_slice(&index.to_le_bytes());
        }
        let mut encoder = ZlibEncoder::new(Vec::new(), Compression::default());
        encoder.write_all(&stream).unwrap();
        file.extend_from_slice(&encoder.finish().unwrap());
    }
    for offset in offsets {
        match version {
            3 => file.extend_from_slice(&(offset as u32).to_le_bytes()),
            _ => file.extend_from_slice(&offset.to_le_bytes()),
        }
    }
    file.extend_from_slice(&(parts.len() as u32).to_le_bytes());
    file
}

/// The unit quad in z = 0, two triangles, as `quad.obj` writes it too.
const QUAD: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

fn quad(double: bool) -> Part {
    Part {
        name: "quad",
        positions: QUAD.to_vec(),
        normals: None,
        uvs: None,
        colors: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        double,
    }
}

/// A triangle with normals and texture coordinates, single precision.
fn triangle() -> Part {
    Part {
        name: "a triangle",
        positions: vec![[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [0.0, 3.0, 1.0]],
        normals: Some(vec![[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [0.6, 0.0, 0.8]]),
        uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 0.5]]),
        colors: None,
        triangles: vec![[0, 2, 1]],
        double: false,
    }
}

/// Both versions: the first mesh (with normals and uvs) and the second (in
/// double precision, with colours to skip), picked by index; an index past
/// the last is refused with the count.
#[test]
fn reads_each_mesh_of_versions_3_and_4() {
    let dir = common::TempDir::new("serialized", "parts");
    for version in [3, 4] {
        let mut second = quad(true);
        second.colors = Some(vec![[0.5, 0.25, 1.0]; 4]);
        let path = dir.join(format!("v{version}.serialized"));
        std::fs::write(&path, serialized(version, &[triangle(), second])).unwrap();
        let first = load_mesh(&path, 0).unwrap();
        assert_eq!(first.triangles, vec![[0, 2, 1]]);
        assert_eq!(first.positions[1], glam::Vec3::new(2.0, 0.0, 1.0));
        assert_eq!(first.normals.unwrap()[2], glam::Vec3::new(0.6, 0.0, 0.8));
        assert_eq!(first.uvs.unwrap()[2], glam::Vec2::new(0.0, 0.5));
        let second = load_mesh(&path, 1).unwrap();
        assert_eq!(second.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(second.positions[2], glam::Vec3::new(1.0, 1.0, 0.0));
        assert!(second.normals.is_none() && second.uvs.is_none());
        let e = load_mesh(&path, 2).unwrap_err().to_string();
        assert!(
            e.starts_with(&path.display().to_string()) && e.contains("the file holds 2"),
            "{e}"
        );
    }
}

/// A file cut short, one whose compressed data is damaged, one whose index
/// points past its vertices: `pathmix render` exits with code 2, naming the
/// scene's field and the mesh file, and writes nothing.
#[test]
fn a_truncated_or_corrupt_file_is_an_error_naming_it() {
    let dir = common::TempDir::new("serialized", "broken");
    let whole = serialized(4, &[quad(false)]);
    let mut corrupt = whole.clone();
    // Inside the zlib stream's deflate data.
    corrupt[12] ^= 0xff;
    corrupt[13] ^= 0x5a;
    let mut out_of_range = quad(false);
    out_of_range.triangles[1][2] = 4;
    for (name, bytes, problem) in [
        ("truncated", whole[..whole.len() / 2].to_vec(), "truncated"),
        ("corrupt", corrupt, "mesh 0"),
        (
            "index",
            serialized(4, &[out_of_range]),
            "index 4 out of range (4 vertices)",
        ),
    ] {
        let mesh = dir.join(format!("{name}.serialized"));
        std::fs::write(&mesh, bytes).unwrap();
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(
            &scene,
            format!(
                "[camera]\nlookfrom = [0, 0, 5]\nlookat = [0, 0, 0]\n\
                 [materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [[objects]]\ntype = \"mesh\"\nfile = \"{name}.serialized\"\nmaterial = \"white\"\n"
            ),
        )
        .unwrap();
        let out = dir.join(format!("{name}.png"));
        let output = Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args(["render", scene.to_str().unwrap(), "--spp", "1", "-o"])
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{name}: {stderr}");
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(
            stderr.contains("objects[0].file")
                && stderr.contains(&mesh.display().to_string())
                && stderr.contains(problem),
            "{name}: {stderr}"
        );
        assert!(!out.exists(), "{name}");
    }
}

/// `shape_index` picks a mesh of a `.serialized` file, and no other file's.
#[test]
fn shape_index_is_for_serialized_files_only() {
    let dir = common::TempDir::new("serialized", "index");
    std::fs::write(
        dir.join("two.serialized"),
        serialized(4, &[triangle(), quad(false)]),
    )
    .unwrap();
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    let scene = |file: &str, index: u32| {
        let path = dir.join("scene.toml");
        std::fs::write(
            &path,
            format!(
                "[camera]\nlookfrom = [0, 0, 5]\nlookat = [0, 0, 0]\n\
                 [materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nshape_index = {index}\nmaterial = \"white\"\n"
            ),
        )
        .unwrap();
        Scene::load(&path)
    };
    assert_eq!(
        scene("two.serialized", 1).unwrap().shapes.triangles.len(),
        2
    );
    assert_eq!(
        scene("two.serialized", 0).unwrap().shapes.triangles.len(),
        1
    );
    let e = scene("quad.obj", 0).unwrap_err().to_string();
    assert!(
        e.contains("objects[0].shape_index: only a `.serialized` file"),
        "{e}"
    );
}

/// The quad from a `.serialized` file (single and double precision, placed by
/// a transform) is the quad from an OBJ file: the same triangles, the same image.
#[test]
fn a_serialized_quad_renders_as_the_same_quad_from_obj() {
    let dir = common::TempDir::new("serialized", "render");
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(dir.join("single.serialized"), serialized(3, &[quad(false)])).unwrap();
    std::fs::write(dir.join("double.serialized"), serialized(4, &[quad(true)])).unwrap();
    let scene = |file: &str| {
        let path = dir.join(format!("{file}.toml"));
        std::fs::write(
            &path,
            format!(
                r#"
                [camera]
                lookfrom = [0.5, 0.5, 3]
                lookat = [0.5, 0.5, 0]
                vfov = 30
                width = 16
                height = 16
                [render]
                spp = 16
                max_depth = 2
                background = [1, 1, 1]
                [materials.white]
                type = "lambertian"
                albedo = [0.5, 0.5, 0.5]
                [materials.lamp]
                type = "light"
                emit = [4, 4, 4]
                [[objects]]
                type = "mesh"
                file = "{file}"
                rotate = {{ axis = [1, 1, 0], angle = 20 }}
                material = "white"
                [[objects]]
                type = "sphere"
                center = [0.5, 0.5, 2]
                radius = 0.2
                material = "lamp"
                "#
            ),
        )
        .unwrap();
        Scene::load(&path).unwrap()
    };
    let obj = scene("quad.obj");
    for file in ["single.serialized", "double.serialized"] {
        assert_eq!(scene(file).shapes, obj.shapes, "{file}");
    }
    let ctx = gpu_or_skip!();
    let image = common::render(ctx, &obj, &RenderOptions::default()).mean();
    assert!(image.pixels.iter().any(|p| p[0] > 0.0));
    let from_serialized =
        common::render(ctx, &scene("single.serialized"), &RenderOptions::default()).mean();
    assert_eq!(from_serialized.pixels, image.pixels);
}

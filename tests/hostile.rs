//! Hostile files (issue 47): no scene, mesh, image or include can crash pathmix,
//! hang it, make it read without end, or be silently dropped or misread. Every
//! bad input exits with code 2, names the file and the field or line, and writes
//! nothing. The files are made here, small, at run time.

mod common;

use pathmix::render::{self, RenderOptions, Renderer};
use pathmix::scene::{Scene, Strategy};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What one run of pathmix left: its exit code and what it printed.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// The longest a refusal may take: a reader that hangs fails the test.
const DEADLINE: Duration = Duration::from_secs(60);

/// Runs pathmix in `dir` within `DEADLINE`, its output kept outside `dir`.
fn pathmix(dir: &Path, args: &[&str]) -> Run {
    run_pathmix(dir, args, false)
}

/// Runs pathmix as [`pathmix`] does, and with `limited` under a 4 GiB
/// address-space limit: a reader that reads without end then fails, without
/// taking the machine's memory (a refusal needs no device, whose driver may
/// reserve more).
fn run_pathmix(dir: &Path, args: &[&str], limited: bool) -> Run {
    let logs = common::TempDir::new("hostile", "logs");
    let (out, err) = (logs.join("out"), logs.join("err"));
    let mut command = Command::new(env!("CARGO_BIN_EXE_pathmix"));
    command
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap());
    #[cfg(unix)]
    if limited {
        use std::os::unix::process::CommandExt;
        // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
        unsafe {
            command.pre_exec(|| {
                let limit = libc::rlimit {
                    rlim_cur: 4 << 30,
                    rlim_max: 4 << 30,
                };
                libc::setrlimit(libc::RLIMIT_AS, &limit);
                Ok(())
            });
        }
    }
    let mut child = command.spawn().unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > DEADLINE {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("pathmix {args:?} still ran after {DEADLINE:?}: it hangs");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let text = |path| String::from_utf8_lossy(&std::fs::read(path).unwrap()).into_owned();
    Run {
        code: status.code(),
        stdout: text(&out),
        stderr: text(&err),
    }
}

/// Every file under `dir`, by name, with its bytes (folders as empty).
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let regular = std::fs::metadata(&path).is_ok_and(|m| m.is_file());
            let bytes = match regular {
                true => std::fs::read(&path).unwrap(),
                false => Vec::new(),
            };
            (name, bytes)
        })
        .collect()
}

/// Runs `args` in `dir` and checks the refusal: exit code 2, every one of
/// `needles` in the message, and no file written or changed.
fn assert_refused(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = snapshot(dir);
    let run = run_pathmix(dir, args, true);
    let message = run.stderr;
    assert_eq!(run.code, Some(2), "pathmix {args:?}: {message}");
    for needle in needles {
        assert!(
            message.contains(needle),
            "pathmix {args:?}: `{needle}` not in: {message}"
        );
    }
    assert!(!message.contains("panicked"), "pathmix {args:?}: {message}");
    assert!(snapshot(dir) == before, "pathmix {args:?} wrote a file");
    message
}

/// The commands that read a scene, each with outputs it would write.
const SCENE_COMMANDS: [&[&str]; 2] = [
    &["render", "--spp", "1", "-o", "out.png", "--exr", "out.exr"],
    &["info"],
];

/// Each of `SCENE_COMMANDS` on `scene`, refused with `needles`.
fn assert_every_command_refuses(dir: &Path, scene: &str, needles: &[&str]) {
    for command in SCENE_COMMANDS {
        let args: Vec<&str> = [&command[..1], &[scene], &command[1..]].concat();
        assert_refused(dir, &args, needles);
    }
}

/// Writes a linear EXR whose texel (x, y) is `texel(x, y)`.
fn write_exr(path: &Path, width: u32, height: u32, texel: impl Fn(u32, u32) -> [f32; 3]) {
    let pixels = (0..width * height)
        .map(|i| texel(i % width, i / width))
        .collect();
    let image = pathmix::output::Image {
        width,
        height,
        pixels,
    };
    pathmix::output::write_exr(path, &image, &[]).unwrap();
}

/// A TOML scene: a camera, a white and a light material, a light quad, and
/// `objects` (more `[[objects]]`).
fn toml_scene(objects: &str) -> String {
    format!(
        r#"[camera]
lookfrom = [0.5, 0.5, 3]
lookat = [0.5, 0.5, 0]
width = 8
height = 8

[materials.white]
type = "lambertian"
albedo = [0.5, 0.5, 0.5]

[materials.light]
type = "light"
emit = [1, 1, 1]

[[objects]]
type = "quad"
q = [0, 2, 0]
u = [1, 0, 0]
v = [0, 0, 1]
material = "light"
{objects}
"#
    )
}

/// A TOML scene with a mesh object of `file`, with `keys` added to it.
fn mesh_scene(file: &str, keys: &str) -> String {
    toml_scene(&format!(
        "[[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nmaterial = \"white\"\n{keys}\n"
    ))
}

/// A Mitsuba scene: a sensor whose film is `$res` wide (default 8) and `body`.
fn xml_scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <default name="res" value="8"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0.5, 0.5, 3" target="0.5, 0.5, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="8"/>
        </film>
    </sensor>
    {body}
</scene>
"#
    )
}

/// A Mitsuba scene with a mesh of `file` (any format pathmix reads) and a
/// light above it.
fn xml_mesh_scene(file: &str, transform: &str) -> String {
    xml_scene(&format!(
        r#"<shape type="obj"><string name="filename" value="{file}"/>{transform}</shape>
    <shape type="rectangle"><transform name="to_world"><translate y="2"/></transform>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#
    ))
}

/// How a glTF test file differs from one valid triangle (positions in
/// `mesh.bin`, 36 bytes, then any index, normal and uv data).
struct Gltf<'a> {
    /// The index accessor's componentType, if indexed.
    index_type: Option<u32>,
    /// The positions' view's byteStride.
    stride: Option<u32>,
    /// The buffer's uri and byteLength, where not `mesh.bin`'s own.
    buffer: Option<(&'a str, usize)>,
    /// The node's properties besides its mesh (`"scale": [...]`, ...).
    node: &'a str,
    version: &'a str,
    normals: Option<[f32; 9]>,
    uvs: Option<[f32; 6]>,
}

impl Default for Gltf<'_> {
    fn default() -> Self {
        Gltf {
            index_type: None,
            stride: None,
            buffer: None,
            node: "",
            version: "2.0",
            normals: None,
            uvs: None,
        }
    }
}

/// Writes `NAME.gltf` and `mesh.bin` as `g` says, in `dir`.
fn write_gltf(dir: &Path, name: &str, g: &Gltf) {
    let floats =
        |values: &[f32]| -> Vec<u8> { values.iter().flat_map(|v| v.to_le_bytes()).collect() };
    let mut bytes = floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let stride = g
        .stride
        .map_or(String::new(), |s| format!(", \"byteStride\": {s}"));
    let mut views = vec![format!("{{\"buffer\": 0, \"byteLength\": 36{stride}}}")];
    let mut accessors = vec![
        r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}"#
            .to_string(),
    ];
    let mut attributes = vec![r#""POSITION": 0"#.to_string()];
    let mut indices = String::new();
    let mut add = |data: Vec<u8>, accessor: String, bytes: &mut Vec<u8>| {
        views.push(format!(
            "{{\"buffer\": 0, \"byteOffset\": {}, \"byteLength\": {}}}",
            bytes.len(),
            data.len()
        ));
        bytes.extend(&data);
        while bytes.len() % 4 != 0 {
            bytes.push(0);
        }
        accessors.push(format!(
            "{{\"bufferView\": {}, {accessor}}}",
            views.len() - 1
        ));
        accessors.len() - 1
    };
    if let Some(ty) = g.index_type {
        let data: Vec<u8> = match ty {
            5120 | 5121 => vec![0, 1, 2],
            5122 | 5123 => [0u16, 1, 2].iter().flat_map(|i| i.to_le_bytes()).collect(),
            5126 => floats(&[0.0, 1.0, 2.0]),
            _ => [0u32, 1, 2].iter().flat_map(|i| i.to_le_bytes()).collect(),
        };
        let accessor = format!("\"componentType\": {ty}, \"count\": 3, \"type\": \"SCALAR\"");
        indices = format!(", \"indices\": {}", add(data, accessor, &mut bytes));
    }
    if let Some(normals) = g.normals {
        let accessor = "\"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"".to_string();
        let index = add(floats(&normals), accessor, &mut bytes);
        attributes.push(format!("\"NORMAL\": {index}"));
    }
    if let Some(uvs) = g.uvs {
        let accessor = "\"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"".to_string();
        let index = add(floats(&uvs), accessor, &mut bytes);
        attributes.push(format!("\"TEXCOORD_0\": {index}"));
    }
    std::fs::write(dir.join("mesh.bin"), &bytes).unwrap();
    let (uri, length) = g.buffer.unwrap_or(("mesh.bin", bytes.len()));
    let node = match g.node {
        "" => String::new(),
        node => format!(", {node}"),
    };
    let text = format!(
        r#"{{"asset": {{"version": "{}"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0{node}}}],
  "meshes": [{{"primitives": [{{"attributes": {{{}}}{indices}}}]}}],
  "buffers": [{{"uri": "{uri}", "byteLength": {length}}}],
  "bufferViews": [{}],
  "accessors": [{}]}}"#,
        g.version,
        attributes.join(", "),
        views.join(", "),
        accessors.join(", ")
    );
    std::fs::write(dir.join(format!("{name}.gltf")), text).unwrap();
}

/// Writes `NAME.toml` and `NAME.xml`, scenes of the mesh `file`.
fn write_scenes(dir: &Path, name: &str, file: &str) {
    std::fs::write(dir.join(format!("{name}.toml")), mesh_scene(file, "")).unwrap();
    std::fs::write(dir.join(format!("{name}.xml")), xml_mesh_scene(file, "")).unwrap();
}

/// A glTF accessor the gltf crate's readers panicked on (index accessors of
/// float or signed type, strides shorter than an element) is refused by
/// `render`, `info` and `convert`, from TOML and through XML, naming the
/// primitive and the accessor.
#[test]
fn gltf_accessors_that_panicked_the_reader_are_refused() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let cases: [(&str, Gltf, &str); 5] = [
        (
            "float-indices",
            Gltf {
                index_type: Some(5126),
                ..Default::default()
            },
            "componentType FLOAT (5126)",
        ),
        (
            "byte-indices",
            Gltf {
                index_type: Some(5120),
                ..Default::default()
            },
            "componentType BYTE (5120)",
        ),
        (
            "short-indices",
            Gltf {
                index_type: Some(5122),
                ..Default::default()
            },
            "componentType SHORT (5122)",
        ),
        (
            "stride-4",
            Gltf {
                stride: Some(4),
                ..Default::default()
            },
            "byteStride 4 is shorter than the element (12 bytes)",
        ),
        (
            "stride-8",
            Gltf {
                stride: Some(8),
                ..Default::default()
            },
            "byteStride 8 is shorter than the element (12 bytes)",
        ),
    ];
    for (name, gltf, needle) in cases {
        write_gltf(dir, name, &gltf);
        let file = format!("{name}.gltf");
        write_scenes(dir, name, &file);
        let needles = [file.as_str(), "mesh 0, primitive 0", needle];
        assert_every_command_refuses(dir, &format!("{name}.toml"), &needles);
        assert_every_command_refuses(dir, &format!("{name}.xml"), &needles);
        assert_refused(
            dir,
            &["convert", &format!("{name}.xml"), "-o", "out.toml"],
            &needles,
        );
    }
    // Unsigned indices of every width still read.
    for ty in [5121, 5123, 5125] {
        write_gltf(
            dir,
            "indexed",
            &Gltf {
                index_type: Some(ty),
                ..Default::default()
            },
        );
        let mesh = pathmix::scene::mesh::load_mesh(&dir.join("indexed.gltf"), 0).unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]], "componentType {ty}");
    }
}

/// A glTF whose offsets, lengths, counts or stride do not fit its buffer, or
/// whose sparse indices are floats, is refused before a byte is read.
#[test]
fn gltf_views_and_accessors_are_checked_against_their_buffers() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    write_gltf(dir, "good", &Gltf::default());
    let good = std::fs::read_to_string(dir.join("good.gltf")).unwrap();
    let accessor = r#""bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]"#;
    let view = r#"{"buffer": 0, "byteLength": 36}"#;
    let cases = [
        (
            "offset",
            accessor.replace("\"count\"", "\"byteOffset\": 40, \"count\""),
            view.to_string(),
            "run past bufferView 0",
        ),
        (
            "count",
            accessor.replace("\"count\": 3", "\"count\": 4"),
            view.to_string(),
            "4 elements of 12 bytes",
        ),
        (
            "huge-count",
            accessor.replace("\"count\": 3", "\"count\": 4611686018427387904"),
            view.to_string(),
            "run past bufferView 0",
        ),
        (
            "view-past-buffer",
            accessor.to_string(),
            r#"{"buffer": 0, "byteOffset": 8, "byteLength": 36}"#.to_string(),
            "run past buffer 0",
        ),
        (
            "zero-count",
            accessor.replace("\"count\": 3", "\"count\": 0"),
            view.to_string(),
            "count is 0",
        ),
        (
            "sparse-float-indices",
            format!(
                "{accessor}, \"sparse\": {{\"count\": 1, \"indices\": {{\"bufferView\": 0, \"componentType\": 5126}}, \"values\": {{\"bufferView\": 0}}}}"
            ),
            view.to_string(),
            "",
        ),
    ];
    for (name, new_accessor, new_view, needle) in cases {
        let text = good
            .replace(accessor, &new_accessor)
            .replace(view, &new_view);
        assert_ne!(text, good, "{name}");
        let file = format!("{name}.gltf");
        std::fs::write(dir.join(&file), text).unwrap();
        std::fs::write(dir.join("scene.toml"), mesh_scene(&file, "")).unwrap();
        assert_refused(dir, &["info", "scene.toml"], &[&file, needle]);
    }
}

/// glTF files pathmix cannot read as they mean are refused, as OBJ and PLY
/// refuse theirs: another major version, a projective node matrix, a rotation
/// that is no unit quaternion, NaN normals and texture coordinates.
#[test]
fn gltf_versions_transforms_and_attributes_out_of_spec_are_refused() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let nan = f32::NAN;
    let cases: [(&str, Gltf, &str); 5] = [
        (
            "version",
            Gltf {
                version: "3.0",
                ..Default::default()
            },
            "asset.version `3.0`",
        ),
        (
            "projective",
            Gltf {
                node: r#""matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.5, 0, 0, 0, 1]"#,
                ..Default::default()
            },
            "node 0: matrix must be affine",
        ),
        (
            "zero-rotation",
            Gltf {
                node: r#""rotation": [0, 0, 0, 0]"#,
                ..Default::default()
            },
            "not a unit quaternion",
        ),
        (
            "nan-normal",
            Gltf {
                normals: Some([0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, nan]),
                ..Default::default()
            },
            "NaN in NORMAL",
        ),
        (
            "nan-uv",
            Gltf {
                uvs: Some([0.0, 0.0, 1.0, 0.0, nan, 1.0]),
                ..Default::default()
            },
            "NaN in TEXCOORD_0",
        ),
    ];
    for (name, gltf, needle) in cases {
        write_gltf(dir, name, &gltf);
        let file = format!("{name}.gltf");
        std::fs::write(dir.join("scene.toml"), mesh_scene(&file, "")).unwrap();
        assert_refused(dir, &["info", "scene.toml"], &[&file, needle]);
    }
    // Finite normals and uvs of the same file read.
    let valid = Gltf {
        normals: Some([0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]),
        uvs: Some([0.0, 0.0, 1.0, 0.0, 0.0, 1.0]),
        ..Default::default()
    };
    write_gltf(dir, "valid", &valid);
    let mesh = pathmix::scene::mesh::load_mesh(&dir.join("valid.gltf"), 0).unwrap();
    assert_eq!(mesh.normals.unwrap().len(), 3);
    assert_eq!(mesh.uvs.unwrap().len(), 3);
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let name = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).unwrap();
    // SAFETY: a valid C string; mkfifo only makes the file.
    assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
}

/// No device is read as an input: a glTF buffer of `/dev/zero` or
/// `/dev/urandom` (however named), an include of `/dev/zero` and a mesh that is
/// a symbolic link to it are refused at once, instead of read until memory runs
/// out.
#[cfg(unix)]
#[test]
fn devices_named_as_inputs_are_refused_before_they_are_read() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let not_regular = "not a regular file";
    // Two levels down, so that `../../dev/zero` is the device.
    let depth = dir.join("a/b");
    std::fs::create_dir_all(&depth).unwrap();
    let up = "../".repeat(depth.components().count());
    let relative_zero = format!("{up}dev/zero");
    for uri in [
        "/dev/zero",
        "file:///dev/zero",
        &relative_zero,
        "/dev/urandom",
    ] {
        let gltf = Gltf {
            buffer: Some((uri, 60)),
            ..Default::default()
        };
        write_gltf(&depth, "device", &gltf);
        std::fs::write(depth.join("scene.toml"), mesh_scene("device.gltf", "")).unwrap();
        assert_refused(
            &depth,
            &["info", "scene.toml"],
            &["device.gltf", "buffer 0", not_regular],
        );
    }
    for name in ["zero.ply", "zero.obj"] {
        std::os::unix::fs::symlink("/dev/zero", dir.join(name)).unwrap();
        std::fs::write(dir.join("scene.toml"), mesh_scene(name, "")).unwrap();
        assert_every_command_refuses(dir, "scene.toml", &[name, not_regular]);
    }
    std::fs::write(
        dir.join("include.xml"),
        xml_scene(r#"<include filename="/dev/zero"/>"#),
    )
    .unwrap();
    assert_every_command_refuses(
        dir,
        "include.xml",
        &["include.xml:", "/dev/zero", not_regular],
    );
}

/// A FIFO without a writer, as mesh, glTF buffer, include, image or scene, is
/// refused at once instead of waited on forever.
#[cfg(unix)]
#[test]
fn fifos_named_as_inputs_are_refused_without_waiting() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    mkfifo(&dir.join("pipe.obj"));
    mkfifo(&dir.join("pipe.bin"));
    mkfifo(&dir.join("pipe.xml"));
    mkfifo(&dir.join("pipe.exr"));
    mkfifo(&dir.join("pipe.toml"));
    std::fs::write(dir.join("scene.toml"), mesh_scene("pipe.obj", "")).unwrap();
    assert_every_command_refuses(dir, "scene.toml", &["pipe.obj", "a named pipe"]);
    write_gltf(
        dir,
        "piped",
        &Gltf {
            buffer: Some(("pipe.bin", 36)),
            ..Default::default()
        },
    );
    std::fs::write(dir.join("scene.toml"), mesh_scene("piped.gltf", "")).unwrap();
    assert_every_command_refuses(
        dir,
        "scene.toml",
        &["piped.gltf", "pipe.bin", "a named pipe"],
    );
    std::fs::write(
        dir.join("include.xml"),
        xml_scene(r#"<include filename="pipe.xml"/>"#),
    )
    .unwrap();
    assert_every_command_refuses(
        dir,
        "include.xml",
        &["include.xml:", "pipe.xml", "a named pipe"],
    );
    let environment = toml_scene("[environment]\nfile = \"pipe.exr\"\n");
    std::fs::write(dir.join("scene.toml"), environment).unwrap();
    assert_every_command_refuses(
        dir,
        "scene.toml",
        &["environment.file", "pipe.exr", "a named pipe"],
    );
    assert_every_command_refuses(dir, "pipe.toml", &["pipe.toml", "a named pipe"]);
    assert_refused(
        dir,
        &["compare", "pipe.exr", "pipe.exr"],
        &["pipe.exr", "a named pipe"],
    );
    assert_refused(
        dir,
        &["merge", "pipe.exr", "-o", "out.png"],
        &["pipe.exr", "a named pipe"],
    );
}

/// An OpenEXR header claiming `width` x `height` float RGB, with an offset
/// table cut short: a few hundred bytes.
fn exr_claiming(width: i32, height: i32) -> Vec<u8> {
    let attribute = |name: &str, ty: &str, value: &[u8]| -> Vec<u8> {
        let mut bytes = [name.as_bytes(), b"\0", ty.as_bytes(), b"\0"].concat();
        bytes.extend((value.len() as i32).to_le_bytes());
        bytes.extend(value);
        bytes
    };
    let mut channels = Vec::new();
    for name in [b"B", b"G", b"R"] {
        channels.extend(name);
        channels.push(0);
        channels.extend(2i32.to_le_bytes()); // FLOAT
        channels.extend([0, 0, 0, 0]); // pLinear, reserved
        channels.extend(1i32.to_le_bytes());
        channels.extend(1i32.to_le_bytes());
    }
    channels.push(0);
    let window: Vec<u8> = [0, 0, width - 1, height - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    let mut bytes = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    bytes.extend(attribute("channels", "chlist", &channels));
    bytes.extend(attribute("compression", "compression", &[0]));
    bytes.extend(attribute("dataWindow", "box2i", &window));
    bytes.extend(attribute("displayWindow", "box2i", &window));
    bytes.extend(attribute("lineOrder", "lineOrder", &[0]));
    bytes.extend(attribute("pixelAspectRatio", "float", &1f32.to_le_bytes()));
    bytes.extend(attribute("screenWindowCenter", "v2f", &[0; 8]));
    bytes.extend(attribute("screenWindowWidth", "float", &1f32.to_le_bytes()));
    bytes.push(0);
    let table_start = bytes.len() as u64;
    for _ in 0..8 {
        bytes.extend(table_start.to_le_bytes());
    }
    bytes
}

/// A PNG whose header claims `width` x `height` 8-bit RGB, with no image data.
fn png_claiming(width: u32, height: u32) -> Vec<u8> {
    let mut header = width.to_be_bytes().to_vec();
    header.extend(height.to_be_bytes());
    header.extend([8, 2, 0, 0, 0]);
    let mut bytes = b"\x89PNG\r\n\x1a\n".to_vec();
    for (kind, data) in [(b"IHDR", &header[..]), (b"IDAT", &[]), (b"IEND", &[])] {
        let chunk = [&kind[..], data].concat();
        bytes.extend((data.len() as u32).to_be_bytes());
        bytes.extend(&chunk);
        bytes.extend(crc32fast::hash(&chunk).to_be_bytes());
    }
    bytes
}

/// A small image whose header claims 100 000 x 100 000 texels is refused from
/// the header, before anything is allocated, wherever an image is read: as
/// environment map, as bitmap texture, by `compare` and by `merge`.
#[test]
fn image_headers_claiming_too_many_texels_are_refused_before_reading() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    std::fs::write(dir.join("huge.exr"), exr_claiming(100_000, 100_000)).unwrap();
    std::fs::write(
        dir.join("huge.hdr"),
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n",
    )
    .unwrap();
    std::fs::write(dir.join("huge.png"), png_claiming(100_000, 100_000)).unwrap();
    assert!(std::fs::metadata(dir.join("huge.exr")).unwrap().len() < 1000);
    let too_many = "100000x100000 (10000000000 texels), more than the 268435456";
    for image in ["huge.exr", "huge.hdr"] {
        let scene = toml_scene(&format!("[environment]\nfile = \"{image}\"\n"));
        std::fs::write(dir.join("environment.toml"), scene).unwrap();
        assert_every_command_refuses(
            dir,
            "environment.toml",
            &["environment.file", image, too_many],
        );
    }
    for image in ["huge.exr", "huge.hdr", "huge.png"] {
        let scene = toml_scene(&format!(
            "[materials.textured]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", file = \"{image}\" }}\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"textured\"\n"
        ));
        std::fs::write(dir.join("texture.toml"), scene).unwrap();
        let field = "materials.textured.albedo.file";
        assert_every_command_refuses(dir, "texture.toml", &[field, image, too_many]);
    }
    write_exr(&dir.join("small.exr"), 2, 2, |_, _| [0.5; 3]);
    assert_refused(
        dir,
        &["compare", "huge.exr", "small.exr"],
        &["huge.exr", too_many],
    );
    assert_refused(
        dir,
        &["compare", "small.exr", "huge.exr"],
        &["huge.exr", too_many],
    );
    assert_refused(
        dir,
        &["merge", "huge.exr", "-o", "out.png"],
        &["huge.exr", too_many],
    );
}

/// Texels that would overflow a path's throughput are refused as albedo: a 1e30
/// in an EXR and the largest Radiance HDR value, 1.7e38, naming the texel.
#[test]
fn texture_texels_beyond_the_documented_bound_are_refused() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    write_exr(&dir.join("bright.exr"), 3, 2, |x, y| match (x, y) {
        (2, 1) => [0.5, 1e30, 0.5],
        _ => [0.5; 3],
    });
    let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
    hdr.extend([128, 128, 128, 129, 255, 255, 255, 255]);
    std::fs::write(dir.join("bright.hdr"), hdr).unwrap();
    for (image, texel, value) in [
        ("bright.exr", "texel (2, 1)", "1e30"),
        ("bright.hdr", "texel (1, 0)", "1.6947657e38"),
    ] {
        let scene = toml_scene(&format!(
            "[materials.textured]\ntype = \"lambertian\"\nalbedo = {{ type = \"bitmap\", file = \"{image}\" }}\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"textured\"\n"
        ));
        std::fs::write(dir.join("texture.toml"), scene).unwrap();
        let needles = [
            "materials.textured.albedo.file",
            image,
            texel,
            value,
            "at most 1e6",
        ];
        assert_every_command_refuses(dir, "texture.toml", &needles);
    }
}

/// XML nested past `MAX_NESTING` is refused at the first element too deep,
/// with its line and column, before the reader recurses (20 000 levels
/// overflowed the stack); nesting within the limit is not what is refused.
#[test]
fn xml_nested_past_the_limit_is_refused_with_its_place() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    for (levels, refused) in [(20_000, true), (900, false)] {
        let nested = format!("{}{}", "<foo>".repeat(levels), "</foo>".repeat(levels));
        let body = format!("<shape type=\"sphere\">\n{nested}</shape>");
        std::fs::write(dir.join("deep.xml"), xml_scene(&body)).unwrap();
        let message = assert_refused(dir, &["info", "deep.xml"], &["deep.xml:"]);
        let limit = format!(
            "nested more than {} deep",
            pathmix::scene::mitsuba::MAX_NESTING
        );
        assert_eq!(message.contains(&limit), refused, "{levels}: {message}");
        if refused {
            // The 999th <foo>, under <scene> and <shape>, is the first too deep.
            let column = 1 + 5 * 998;
            assert!(
                message.contains(&format!("deep.xml:12:{column}: <foo>")),
                "{message}"
            );
        }
    }
}

/// Twenty-five files, each including the next twice (no cycle), expand 2^24
/// times: refused once the expansion passes `MAX_ELEMENTS`, naming where,
/// within the deadline.
#[test]
fn xml_includes_that_expand_exponentially_are_refused() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    for i in 0..25 {
        let body = match i {
            24 => String::new(),
            _ => format!("<include filename=\"part{}.xml\"/>", i + 1).repeat(2),
        };
        let text = format!("<scene version=\"3.0.0\">{body}</scene>");
        std::fs::write(dir.join(format!("part{i}.xml")), text).unwrap();
    }
    let scene = xml_scene(r#"<include filename="part0.xml"/><shape type="sphere"/>"#);
    std::fs::write(dir.join("bomb.xml"), scene).unwrap();
    let limit = format!(
        "more than {} elements",
        pathmix::scene::mitsuba::MAX_ELEMENTS
    );
    assert_every_command_refuses(dir, "bomb.xml", &["part", ".xml:", &limit]);
    assert_refused(dir, &["convert", "bomb.xml", "-o", "out.toml"], &[&limit]);
}

/// A binary PLY holding more than its header declares is refused, as its
/// ASCII twin is (it rendered half the mesh); so is a PLY version other than 1.0.
#[test]
fn ply_data_past_the_declared_elements_and_unknown_versions_are_refused() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let header = |format: &str, faces: usize| {
        format!(
            "ply\nformat {format}\nelement vertex 4\nproperty float x\nproperty float y\n\
             property float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    // Two faces, whatever the header says.
    let binary = |faces: usize| {
        let mut bytes = header("binary_little_endian 1.0", faces).into_bytes();
        for v in [
            0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0,
        ] {
            bytes.extend(v.to_le_bytes());
        }
        for face in [[0i32, 1, 2], [0, 2, 3]] {
            bytes.push(3);
            bytes.extend(face.iter().flat_map(|i| i.to_le_bytes()));
        }
        bytes
    };
    std::fs::write(dir.join("binary.ply"), binary(1)).unwrap();
    let ascii = header("ascii 1.0", 1) + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
    std::fs::write(dir.join("ascii.ply"), ascii).unwrap();
    let ascii_2 = header("ascii 2.0", 1) + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(dir.join("version.ply"), ascii_2).unwrap();
    for (file, needle) in [
        ("binary.ply", "after the last element the header declares"),
        ("ascii.ply", "after the last element the header declares"),
        ("version.ply", "format version 2.0: pathmix reads PLY 1.0"),
    ] {
        write_scenes(dir, "ply", file);
        assert_every_command_refuses(dir, "ply.toml", &["objects[1].file", file, needle]);
        assert_refused(dir, &["info", "ply.xml"], &["ply.xml:", file, needle]);
    }
    // The binary file with its count right reads both faces.
    std::fs::write(dir.join("fixed.ply"), binary(2)).unwrap();
    let mesh = pathmix::scene::mesh::load_mesh(&dir.join("fixed.ply"), 0).unwrap();
    assert_eq!(mesh.triangles.len(), 2);
}

/// A unit floor of two triangles, as OBJ.
const FLOOR_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 3 2\nf 1 4 3\n";

/// A mesh every face of which 32-bit floats cannot hold (a transform's scale
/// of 1e30 or 1e-30, faces 2e10 wide, a glTF node's scale, an XML to_world,
/// `[scene] scale = 1e12` or `1e-12`) rendered black with exit 0: it is
/// refused naming the object, as a quad of the same size is.
#[test]
fn meshes_no_face_of_which_survives_are_refused_as_quads_are() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    std::fs::write(dir.join("floor.obj"), FLOOR_OBJ).unwrap();
    std::fs::write(
        dir.join("wide.obj"),
        "v 0 0 0\nv 2e10 0 0\nv 0 0 2e10\nf 1 3 2\n",
    )
    .unwrap();
    write_gltf(
        dir,
        "node-scale",
        &Gltf {
            node: r#""scale": [1e30, 1e30, 1e30]"#,
            ..Default::default()
        },
    );
    let unusable = "none of the mesh's";
    for (name, scene) in [
        ("scale-up", mesh_scene("floor.obj", "scale = 1e30")),
        ("scale-down", mesh_scene("floor.obj", "scale = 1e-30")),
        ("wide", mesh_scene("wide.obj", "")),
        ("node-scale", mesh_scene("node-scale.gltf", "")),
    ] {
        std::fs::write(dir.join(format!("{name}.toml")), scene).unwrap();
        assert_every_command_refuses(dir, &format!("{name}.toml"), &["objects[1]", unusable]);
    }
    let scaled = xml_mesh_scene(
        "floor.obj",
        r#"<transform name="to_world"><scale value="1e30"/></transform>"#,
    );
    std::fs::write(dir.join("to-world.xml"), scaled).unwrap();
    assert_every_command_refuses(
        dir,
        "to-world.xml",
        &["to-world.xml:", "<shape type=\"obj\">", unusable],
    );
    for scale in ["1e12", "1e-12"] {
        // A mesh floor, and the same floor as a quad, which was refused already.
        let light = "[[objects]]\ntype = \"sphere\"\ncenter = [0.5, 2, 0.5]\nradius = 0.1\nmaterial = \"light\"\n";
        let camera =
            "[camera]\nlookfrom = [0.5, 1, 3]\nlookat = [0.5, 0, 0]\nwidth = 8\nheight = 8\n";
        let materials = "[materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
                         [materials.light]\ntype = \"light\"\nemit = [1, 1, 1]\n";
        let floors = [
            "[[objects]]\ntype = \"mesh\"\nfile = \"floor.obj\"\nmaterial = \"white\"\n",
            "[[objects]]\ntype = \"quad\"\nq = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 0, 1]\nmaterial = \"white\"\n",
        ];
        for floor in floors {
            let scene = format!("[scene]\nscale = {scale}\n{camera}{materials}{light}{floor}");
            std::fs::write(dir.join("scaled.toml"), scene).unwrap();
            assert_every_command_refuses(dir, "scaled.toml", &["scene.scale", "unusable"]);
        }
    }
}

/// A mesh some of whose faces are dropped is rendered with a warning naming
/// the object, and `info` always shows how many faces were dropped.
#[test]
fn dropped_mesh_faces_are_warned_and_counted() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    // The floor and a face with no area.
    let obj = format!("{FLOOR_OBJ}v 2 0 0\nf 1 2 5\n");
    std::fs::write(dir.join("floor.obj"), obj).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, mesh_scene("floor.obj", "")).unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.degenerate_triangles, 1);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("objects[1]: 1 of the mesh's 3 faces dropped")),
        "{:?}",
        scene.warnings
    );
    if common::gpu().is_none() {
        return;
    }
    let run = pathmix(dir, &["info", "scene.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stdout.contains("1 mesh faces with no area dropped"),
        "{}",
        run.stdout
    );
    assert!(
        run.stdout.contains("1 of the mesh's 3 faces dropped"),
        "{}",
        run.stdout
    );
}

/// Parameters within their documented ranges make no NaN sample: a roughness
/// of 1e-20 (GGX and Beckmann), conductor `eta` or `k` of 1e10. A
/// roughdielectric so nearly index-matched that no f32 can evaluate it is
/// refused with the reason; one just past that limit renders.
#[test]
fn extreme_material_parameters_make_no_nan_samples() {
    let dir = common::TempDir::new("hostile", "case");
    let path = dir.join("material.toml");
    let scene_of = |material: &str| {
        let text = format!(
            "[camera]\nlookfrom = [0, 1, 4]\nlookat = [0, 0, 0]\nwidth = 16\nheight = 16\n\
             [render]\nspp = 16\nmax_depth = 6\n\
             [materials.test]\n{material}\n\
             [materials.floor]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [materials.light]\ntype = \"light\"\nemit = [4, 4, 4]\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"test\"\n\
             [[objects]]\ntype = \"quad\"\nq = [-5, -1, -5]\nu = [10, 0, 0]\nv = [0, 0, 10]\nmaterial = \"floor\"\n\
             [[objects]]\ntype = \"quad\"\nq = [-1, 3, -1]\nu = [2, 0, 0]\nv = [0, 0, 2]\nmaterial = \"light\"\n"
        );
        std::fs::write(&path, text).unwrap();
        Scene::load(&path)
    };
    let materials = [
        "type = \"roughconductor\"\ndistribution = \"ggx\"\nalpha = 1e-20",
        "type = \"roughconductor\"\ndistribution = \"beckmann\"\nalpha = 1e-20",
        "type = \"roughconductor\"\nalpha_u = 1e-20\nalpha_v = 1",
        "type = \"roughplastic\"\nalpha = 1e-20",
        "type = \"roughdielectric\"\ndistribution = \"ggx\"\nalpha = 1e-20",
        "type = \"conductor\"\neta = [1e10, 1e10, 1e10]\nk = [1, 1, 1]",
        "type = \"conductor\"\neta = [1, 1, 1]\nk = [1e10, 1e10, 1e10]",
        "type = \"roughconductor\"\neta = [1e10, 1, 1]\nk = [1, 1e30, 1]",
        "type = \"roughdielectric\"\nint_ior = 1.001\next_ior = 1",
        "type = \"roughdielectric\"\ndistribution = \"ggx\"\nint_ior = 1\next_ior = 1.002",
    ];
    // With a device: every strategy, no sample discarded.
    if let Some(ctx) = common::gpu() {
        for material in materials {
            let scene = scene_of(material).unwrap();
            for strategy in [Strategy::Mixture, Strategy::NeeMis, Strategy::Bsdf] {
                let mut scene = scene.clone();
                scene.render.strategy = strategy;
                let mut renderer = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
                render::run(&mut renderer, render::StopRule::samples(16), |_| {}).unwrap();
                let discarded = renderer.counters().discarded;
                assert_eq!(discarded, 0, "{material:?} under {strategy}: NaN samples");
            }
        }
    }
    let refused =
        scene_of("type = \"roughdielectric\"\nint_ior = 1.0000001\next_ior = 1").unwrap_err();
    assert_eq!(refused.location, "materials.test", "{refused}");
    assert!(refused.message.contains("within 0.001 of 1"), "{refused}");
}

/// A glowing sphere, for XML scenes that need a light.
const XML_SPHERE: &str = r#"<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#;

/// A film side of 0 (from the file or `-D`) is refused naming the width at its
/// `<integer>`, not the field of view derived from it.
#[test]
fn a_film_side_of_zero_is_refused_naming_the_side() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let sphere = XML_SPHERE;
    std::fs::write(dir.join("film.xml"), xml_scene(sphere)).unwrap();
    std::fs::write(
        dir.join("zero.xml"),
        xml_scene(sphere).replace("value=\"8\"/>\n    <sensor", "value=\"0\"/>\n    <sensor"),
    )
    .unwrap();
    for args in [
        &["info", "zero.xml"][..],
        &["info", "film.xml", "-D", "res=0"],
    ] {
        let needles = [
            "xml:7:",
            "<integer name=\"width\">",
            "width must be between 1 and 65536, got 0",
        ];
        let message = assert_refused(dir, args, &needles);
        assert!(!message.contains("vfov"), "{message}");
    }
}

/// A constant emitter's radiance out of range is reported at its `<rgb>`, on
/// its line, not at the sensor.
#[test]
fn a_constant_emitters_radiance_is_located_at_its_element() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let sphere = XML_SPHERE;
    let constant =
        "<emitter type=\"constant\">\n    <rgb name=\"radiance\" value=\"1e39\"/>\n    </emitter>";
    let text = format!(
        "<scene version=\"3.0.0\">\n{constant}\n{}",
        &xml_scene(sphere)["<scene version=\"3.0.0\">\n".len()..]
    );
    std::fs::write(dir.join("constant.xml"), text).unwrap();
    assert_refused(
        dir,
        &["info", "constant.xml"],
        &[
            "constant.xml:3:5: <rgb name=\"radiance\">",
            "1e39 is too large",
            "render.background",
        ],
    );
}

/// A 10 MB value is quoted in a message by its first 64 characters, in XML and
/// in TOML.
#[test]
fn long_values_are_quoted_cut_short() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let long = format!("{}x", "1".repeat(10_000_000));
    let body = format!("<shape type=\"sphere\"><float name=\"radius\" value=\"{long}\"/></shape>");
    std::fs::write(dir.join("long.xml"), xml_scene(&body)).unwrap();
    let message = assert_refused(
        dir,
        &["info", "long.xml"],
        &["long.xml:", "…` is not a finite number"],
    );
    assert!(message.len() < 1000, "{} bytes", message.len());
    // And a TOML value, as an unknown name.
    let toml = toml_scene("").replace(
        "type = \"lambertian\"",
        &format!("type = \"{}\"", "x".repeat(10_000_000)),
    );
    std::fs::write(dir.join("long.toml"), toml).unwrap();
    let message = assert_refused(dir, &["info", "long.toml"], &["materials.white.type", "…`"]);
    assert!(message.len() < 1000, "{} bytes", message.len());
}

/// What was decided about files of other versions (docs/mitsuba.md): an XML
/// `version` that is no Mitsuba 0 to 3 version is refused; a `max_depth`
/// above pathmix's largest is rendered at it with a warning.
#[test]
fn xml_versions_are_checked_and_clamped_depths_warned() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let sphere = r#"<shape type="sphere"/>"#;
    for (version, needle) in [
        ("abc", "is not MAJOR.MINOR.PATCH"),
        ("4.0.0", "a Mitsuba 4 scene"),
    ] {
        let text =
            xml_scene(sphere).replace("version=\"3.0.0\"", &format!("version=\"{version}\""));
        std::fs::write(dir.join("version.xml"), text).unwrap();
        assert_every_command_refuses(dir, "version.xml", &["version.xml:1:1", needle]);
    }
    let deep =
        r#"<integrator type="path"><integer name="max_depth" value="1000000"/></integrator>"#;
    std::fs::write(dir.join("depth.xml"), xml_scene(&format!("{deep}{sphere}"))).unwrap();
    let run = pathmix(dir, &["convert", "depth.xml", "-o", "depth.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stderr
            .contains("max_depth 1000000 is more than pathmix's largest"),
        "{}",
        run.stderr
    );
    let converted = std::fs::read_to_string(dir.join("depth.toml")).unwrap();
    assert!(converted.contains("max_depth = 100000"), "{converted}");
}

/// The refusal of emission that could overflow the sums names its source: the
/// material and its `emit`, or the environment map's texel; in a Mitsuba file,
/// the element that gives it, with its line.
#[test]
fn emission_refusals_name_the_material_or_texel() {
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    let bright = toml_scene("").replace("emit = [1, 1, 1]", "emit = [1e38, 1e38, 1e38]");
    let scene = Scene::parse(&bright, "bright.toml").unwrap();
    let message = render::check_emission(&scene, 4, false)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("bright.toml: material `light` (its `emit`) up to 1e38"),
        "{message}"
    );
    write_exr(&dir.join("sky.exr"), 4, 2, |x, y| match (x, y) {
        (3, 1) => [1.0, 3e38, 1.0],
        _ => [1.0; 3],
    });
    let sky = toml_scene("[environment]\nfile = \"sky.exr\"\nscale = 1\n");
    std::fs::write(dir.join("sky.toml"), sky).unwrap();
    let scene = Scene::load(&dir.join("sky.toml")).unwrap();
    let message = render::check_emission(&scene, 4, false)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("environment map `sky.exr` (texel (3, 1)"),
        "{message}"
    );
    // From the command line too: exit 2, nothing written.
    assert_refused(
        dir,
        &["render", "sky.toml", "--spp", "4", "-o", "out.png"],
        &["texel (3, 1)", "overflow"],
    );
    // A Mitsuba file's emitter is placed at its element.
    let area = r#"<shape type="rectangle">
        <emitter type="area"><rgb name="radiance" value="1e38"/></emitter></shape>"#;
    std::fs::write(dir.join("bright.xml"), xml_scene(area)).unwrap();
    assert_refused(
        dir,
        &["render", "bright.xml", "--spp", "4", "-o", "out.png"],
        &[
            "given at ",
            "bright.xml:12:",
            "<emitter type=\"area\">",
            "overflow",
        ],
    );
}

/// A triangle soup refused for lavapipe's loop limit under the BVH is told
/// about the BVH's walk and its largest mesh, not to use the BVH.
#[test]
fn loop_limit_refusals_follow_the_storage_used_and_name_the_mesh() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = common::TempDir::new("hostile", "case");
    let dir: &Path = &dir;
    // Large triangles crossing the unit cube at random (a fixed LCG).
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f64 / (1u64 << 24) as f64
    };
    let mut obj = String::new();
    let triangles = 20_000;
    for _ in 0..3 * triangles {
        obj += &format!("v {:.5} {:.5} {:.5}\n", next(), next(), next());
    }
    for t in 0..triangles {
        obj += &format!("f {} {} {}\n", 3 * t + 1, 3 * t + 2, 3 * t + 3);
    }
    std::fs::write(dir.join("soup.obj"), obj).unwrap();
    // The soup alone fills the scene's box, so that lines through it cross it.
    let scene = "[camera]\nlookfrom = [0.5, 0.5, 3]\nlookat = [0.5, 0.5, 0]\nwidth = 8\nheight = 8\n\
                 [materials.glow]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\nemit = [1, 1, 1]\n\
                 [[objects]]\ntype = \"mesh\"\nfile = \"soup.obj\"\nmaterial = \"glow\"\n";
    let path = dir.join("soup.toml");
    std::fs::write(&path, scene).unwrap();
    let scene = Scene::load(&path).unwrap();
    let Err(error) = render::plan_kernel(ctx, &scene, &RenderOptions::default()) else {
        panic!("a soup of {triangles} crossing triangles fits the loop budget");
    };
    let message = error.to_string();
    assert!(message.contains("scene storage Bvh"), "{message}");
    assert!(
        message.contains("the largest meshes: objects[0] (20000 faces)"),
        "{message}"
    );
    assert!(!message.contains("needs far fewer"), "{message}");
}

//! Mesh files for `type = "mesh"` objects: Wavefront OBJ (read by `tobj`), PLY,
//! ASCII or binary (read by `ply-rs-bw`), glTF 2.0, `.gltf` or `.glb` (parsed by
//! `gltf`, its buffers and accessors read by `gltf_data`), and Mitsuba's
//! `.serialized` (its zlib streams inflated by `flate2`), each into one indexed
//! triangle mesh. Every file is opened by `paths::open_input` (regular files only).
//! Every problem is a [`MeshError`] that names the file and, where the reader
//! knows it, the line or the element; no input makes these readers panic.

use super::gltf_data::{self, Use};
use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::Semantic;
use gltf::json::accessor::Type;
use gltf::mesh::Mode;
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{DefaultElement, ElementDef, Encoding, Property, PropertyType};
use std::fmt;
use std::io::{self, BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

/// A triangle mesh as read from a file, in the file's own coordinates (for glTF,
/// the default scene's: the node transforms applied).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub positions: Vec<glam::Vec3>,
    /// Vertex indices, three per triangle (polygons fanned into triangles: (0,i,i+1)).
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex normals, where the file has them (same length as positions).
    pub normals: Option<Vec<glam::Vec3>>,
    /// Per-vertex texture coordinates, where the file has them, v down from the
    /// image's top row (OBJ's flipped, as Mitsuba reads them).
    pub uvs: Option<Vec<glam::Vec2>>,
    /// glTF: the file's materials that its triangles use, in order of first use.
    pub materials: Vec<MeshMaterial>,
    /// glTF: each triangle's index into `materials`, or `None` for a primitive
    /// without a material (empty for OBJ and PLY, whose materials are not read).
    pub triangle_materials: Vec<Option<usize>>,
}

/// A glTF metallic-roughness material, as far as pathmix can render it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshMaterial {
    /// Its name in the file, or `material N` (its index).
    pub name: String,
    /// `baseColorFactor` (RGB; the alpha and any texture are not read).
    pub base_color: Vec3,
    /// `emissiveFactor` times `KHR_materials_emissive_strength`.
    pub emission: Vec3,
}

/// The extensions [`load_mesh`] reads, for the message that names them.
const SUPPORTED: &str = ".obj, .ply, .gltf, .glb, .serialized";

/// Where in a mesh file a problem lies.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// The file as a whole, or a place the reader cannot name.
    File,
    /// A line of a text file, counted from 1.
    Line(usize),
    /// A PLY element ("vertex 12"), counted from 0 as PLY's own indices are, with
    /// its line in an ASCII file.
    Element {
        name: String,
        index: usize,
        line: Option<usize>,
    },
    /// A primitive of a glTF mesh, both counted from 0 as glTF's indices are.
    Primitive { mesh: usize, primitive: usize },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File => Ok(()),
            Location::Line(line) => write!(f, ": line {line}"),
            Location::Element {
                name,
                index,
                line: None,
            } => write!(f, ": {name} {index}"),
            Location::Element {
                name,
                index,
                line: Some(line),
            } => write!(f, ": line {line} ({name} {index})"),
            Location::Primitive { mesh, primitive } => {
                write!(f, ": mesh {mesh}, primitive {primitive}")
            }
        }
    }
}

/// Why a mesh file could not be read. Each message starts with the file's path and
/// the [`Location`] (`mesh.ply: face 3: ...`).
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{}: cannot read the mesh file: {source}", .path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{}: unknown mesh format {extension:?} (supported: {SUPPORTED})", .path.display())]
    UnknownFormat { path: PathBuf, extension: String },
    /// The reading crate's own complaint, in `message`.
    #[error("{}{at}: malformed mesh file: {message}", .path.display())]
    Malformed {
        path: PathBuf,
        at: Location,
        message: String,
    },
    /// `index` as the file writes it (OBJ counts from 1, or back from -1).
    #[error("{}{at}: index {index} out of range ({count} {of})", .path.display())]
    IndexOutOfRange {
        path: PathBuf,
        at: Location,
        index: i64,
        count: usize,
        of: &'static str,
    },
    #[error("{}{at}: non-finite number {value} in {what}", .path.display())]
    NonFinite {
        path: PathBuf,
        at: Location,
        what: String,
        value: f32,
    },
    #[error("{}{at}: face with {vertices} vertices (at least 3 needed)", .path.display())]
    DegenerateFace {
        path: PathBuf,
        at: Location,
        vertices: usize,
    },
    /// A PLY file that ends before the element at `at`.
    #[error(
        "{}{at}: truncated: the file ends before this element (the header declares {declared} such elements)",
        .path.display()
    )]
    Truncated {
        path: PathBuf,
        at: Location,
        declared: usize,
    },
    #[error("{}: no triangles", .path.display())]
    NoTriangles { path: PathBuf },
}

/// Whether `path` names a Mitsuba `.serialized` file (any case), whose meshes
/// are picked by index.
pub fn is_serialized(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("serialized"))
}

/// Reads a mesh file, choosing the format by the extension (any case); of a
/// `.serialized` file, its mesh `shape_index` (0 for the other formats).
pub fn load_mesh(path: &Path, shape_index: u32) -> Result<Mesh, MeshError> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let mesh = match extension.as_str() {
        "obj" => load_obj(path)?,
        "ply" => load_ply(path)?,
        "gltf" | "glb" => load_gltf(path)?,
        "serialized" => load_serialized(path, shape_index)?,
        _ => {
            return Err(MeshError::UnknownFormat {
                path: path.into(),
                extension,
            });
        }
    };
    if mesh.triangles.is_empty() {
        return Err(MeshError::NoTriangles { path: path.into() });
    }
    Ok(mesh)
}

/// The format identifier that starts each mesh of a `.serialized` file.
const SERIALIZED_MAGIC: u16 = 0x041C;
/// Its flags (versions 3 and 4): what each vertex has, and the precision.
const SERIALIZED_NORMALS: u32 = 0x0001;
const SERIALIZED_UVS: u32 = 0x0002;
const SERIALIZED_COLORS: u32 = 0x0008;
const SERIALIZED_DOUBLE: u32 = 0x2000;

/// Mesh `shape_index` of a Mitsuba `.serialized` file, versions 3 and 4, as
/// Mitsuba 3 reads it: each mesh a little-endian header (`0x041C`, the
/// version) and a zlib stream (flags, the name in version 4, the vertex and
/// triangle counts as `u64`, positions, then normals, texture coordinates and
/// colours as the flags say, in `f32`, or `f64` under `0x2000`, and `u32`
/// vertex indices); the file ends with each mesh's byte offset (`u64`, `u32` in
/// version 3) and their count (`u32`). Colours are skipped, as Mitsuba skips them.
fn load_serialized(path: &Path, shape_index: u32) -> Result<Mesh, MeshError> {
    let bytes = crate::paths::read_input(path).map_err(read_error(path))?;
    let malformed = |message: String| MeshError::Malformed {
        path: path.into(),
        at: Location::File,
        message: format!("mesh {shape_index}: {message}"),
    };
    let header = |offset: usize| -> Result<u16, MeshError> {
        let field = |at: usize| {
            bytes
                .get(at..at + 2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
        };
        match (field(offset), field(offset + 2)) {
            (Some(SERIALIZED_MAGIC), Some(version @ (3 | 4))) => Ok(version),
            (Some(SERIALIZED_MAGIC), Some(version)) => Err(malformed(format!(
                "format version {version} (pathmix reads versions 3 and 4)"
            ))),
            _ => Err(malformed(format!(
                "no serialized mesh header (0x041C) at byte {offset}"
            ))),
        }
    };
    let version = header(0)?;
    let offset = match shape_index {
        0 => 0,
        index => {
            // The dictionary at the end: the meshes' offsets, then their count.
            let word = if version == 3 { 4 } else { 8 };
            let count_at = bytes
                .len()
                .checked_sub(4)
                .ok_or_else(|| malformed("truncated".into()))?;
            let count = u32::from_le_bytes(bytes[count_at..].try_into().expect("4 bytes"));
            if index >= count {
                return Err(malformed(format!(
                    "no such mesh: the file holds {count} (shape_index counts from 0)"
                )));
            }
            let entry = (count - index) as usize * word;
            let at = count_at.checked_sub(entry).ok_or_else(|| {
                malformed("the offsets at the end of the file are cut off".into())
            })?;
            let mut offset = [0u8; 8];
            offset[..word].copy_from_slice(&bytes[at..at + word]);
            let offset = u64::from_le_bytes(offset);
            match usize::try_from(offset) {
                Ok(offset) if offset < bytes.len() => offset,
                _ => {
                    return Err(malformed(format!(
                        "its offset {offset} lies past the end of the file"
                    )));
                }
            }
        }
    };
    if header(offset)? != version {
        return Err(malformed(
            "its version differs from the file's first mesh's".into(),
        ));
    }
    let mut stream = SerializedStream {
        reader: flate2::read::ZlibDecoder::new(&bytes[offset + 4..]),
        double: false,
    };
    let flags = stream
        .u32()
        .map_err(|e| stream_error(&malformed, e, "flags"))?;
    stream.double = flags & SERIALIZED_DOUBLE != 0;
    if version == 4 {
        // The shape's name, null-terminated.
        while stream
            .u8()
            .map_err(|e| stream_error(&malformed, e, "name"))?
            != 0
        {}
    }
    let vertices = stream
        .u64()
        .map_err(|e| stream_error(&malformed, e, "vertex count"))?;
    let triangles = stream
        .u64()
        .map_err(|e| stream_error(&malformed, e, "triangle count"))?;
    let vertices = u32::try_from(vertices).map_err(|_| {
        malformed(format!(
            "{vertices} vertices, more than pathmix's 32-bit indices can reach"
        ))
    })? as usize;
    let triangles =
        usize::try_from(triangles).map_err(|_| malformed(format!("{triangles} triangles")))?;
    let vectors = |stream: &mut SerializedStream, what: &str| -> Result<Vec<Vec3>, MeshError> {
        let values = stream
            .floats(vertices * 3)
            .map_err(|e| stream_error(&malformed, e, what))?;
        check_serialized_finite(path, shape_index, &values, what)?;
        Ok(values.chunks_exact(3).map(Vec3::from_slice).collect())
    };
    let positions = vectors(&mut stream, "positions")?;
    let normals = match flags & SERIALIZED_NORMALS {
        0 => None,
        _ => Some(vectors(&mut stream, "normals")?),
    };
    let uvs = match flags & SERIALIZED_UVS {
        0 => None,
        _ => {
            let values = stream
                .floats(vertices * 2)
                .map_err(|e| stream_error(&malformed, e, "texture coordinates"))?;
            check_serialized_finite(path, shape_index, &values, "texture coordinates")?;
            Some(values.chunks_exact(2).map(Vec2::from_slice).collect())
        }
    };
    if flags & SERIALIZED_COLORS != 0 {
        stream
            .floats(vertices * 3)
            .map_err(|e| stream_error(&malformed, e, "colors"))?;
    }
    let mut faces = Vec::with_capacity(triangles.min(1 << 20));
    for face in 0..triangles {
        let mut triangle = [0u32; 3];
        for index in &mut triangle {
            *index = stream
                .u32()
                .map_err(|e| stream_error(&malformed, e, "indices"))?;
            if *index as usize >= vertices {
                return Err(MeshError::IndexOutOfRange {
                    path: path.into(),
                    at: Location::Element {
                        name: format!("mesh {shape_index}, triangle"),
                        index: face,
                        line: None,
                    },
                    index: (*index).into(),
                    count: vertices,
                    of: "vertices",
                });
            }
        }
        faces.push(triangle);
    }
    // To the stream's end, where its checksum is checked: damaged data that
    // still inflated is found there.
    io::copy(&mut stream.reader, &mut io::sink())
        .map_err(|e| stream_error(&malformed, e, "end (its checksum)"))?;
    Ok(Mesh {
        positions,
        triangles: faces,
        normals,
        uvs,
        materials: Vec::new(),
        triangle_materials: Vec::new(),
    })
}

/// A mesh's inflated stream, little-endian, its floats `f64` or `f32`.
struct SerializedStream<'a> {
    reader: flate2::read::ZlibDecoder<&'a [u8]>,
    double: bool,
}

impl SerializedStream<'_> {
    fn bytes<const N: usize>(&mut self) -> io::Result<[u8; N]> {
        let mut bytes = [0u8; N];
        self.reader.read_exact(&mut bytes)?;
        Ok(bytes)
    }

    fn u8(&mut self) -> io::Result<u8> {
        Ok(self.bytes::<1>()?[0])
    }

    fn u32(&mut self) -> io::Result<u32> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }

    fn u64(&mut self) -> io::Result<u64> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }

    /// `count` floats, grown as they arrive (a count the data does not hold
    /// ends in an error, not in a huge allocation).
    fn floats(&mut self, count: usize) -> io::Result<Vec<f32>> {
        let mut values = Vec::with_capacity(count.min(1 << 20));
        for _ in 0..count {
            values.push(match self.double {
                true => f64::from_le_bytes(self.bytes()?) as f32,
                false => f32::from_le_bytes(self.bytes()?),
            });
        }
        Ok(values)
    }
}

/// A read of `what` that failed: the stream ends early, or does not inflate.
fn stream_error(malformed: &impl Fn(String) -> MeshError, e: io::Error, what: &str) -> MeshError {
    match e.kind() {
        io::ErrorKind::UnexpectedEof => malformed(format!("truncated in its {what}")),
        _ => malformed(format!("corrupt compressed data in its {what}: {e}")),
    }
}

fn check_serialized_finite(
    path: &Path,
    shape_index: u32,
    values: &[f32],
    what: &str,
) -> Result<(), MeshError> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(MeshError::NonFinite {
            path: path.into(),
            at: Location::File,
            what: format!("mesh {shape_index}'s {what}"),
            value,
        }),
        None => Ok(()),
    }
}

/// Smooth vertex normals for a mesh without its own: each face's unit normal
/// added to its vertices weighted by the face's angle there (Thürrner and
/// Wüthrich 1998, as Mitsuba does), so the result does not depend on how a
/// surface is split into triangles. Unit length, or zero at a vertex of only
/// degenerate faces.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sums = vec![glam::DVec3::ZERO; positions.len()];
    for triangle in triangles {
        let p = triangle.map(|i| positions[i as usize].as_dvec3());
        let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for corner in 0..3 {
            let to_next = p[(corner + 1) % 3] - p[corner];
            let to_previous = p[(corner + 2) % 3] - p[corner];
            let angle = to_next.angle_between(to_previous);
            if angle.is_finite() {
                sums[triangle[corner] as usize] += angle * face;
            }
        }
    }
    sums.iter()
        .map(|n| n.normalize_or_zero().as_vec3())
        .collect()
}

/// The triangles (0,i,i+1) of a polygon.
fn fan(face: &[u32]) -> impl Iterator<Item = [u32; 3]> + '_ {
    (1..face.len().saturating_sub(1)).map(move |i| [face[0], face[i], face[i + 1]])
}

/// The line (from 1) that holds byte `offset` of `bytes`.
fn line_of(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count()
}

fn read_error(path: &Path) -> impl FnOnce(io::Error) -> MeshError + '_ {
    |source| MeshError::Read {
        path: path.into(),
        source,
    }
}

fn load_obj(path: &Path) -> Result<Mesh, MeshError> {
    let bytes = crate::paths::read_input(path).map_err(read_error(path))?;
    let text = surface_lines(&String::from_utf8_lossy(&bytes));
    check_obj(path, &text)?;

    // Polygons are fanned below, with one index per vertex (normals and texture
    // coordinates follow the positions).
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ..tobj::LoadOptions::default()
    };
    let bytes = text.as_bytes();
    let mut rest = bytes;
    // Materials are the scene file's business: no library is opened.
    let (models, _) = tobj::load_obj_buf(&mut rest, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| MeshError::Malformed {
        path: path.into(),
        // tobj stops on the line it fails on, so what it consumed ends with that line.
        at: Location::Line(line_of(bytes, (bytes.len() - rest.len()).saturating_sub(1))),
        message: e.to_string(),
    })?;

    let mut mesh = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        materials: Vec::new(),
        triangle_materials: Vec::new(),
    };
    for tobj::Model { mesh: m, .. } in models {
        // Indices fit u32: tobj numbers its vertices with u32.
        let base = mesh.positions.len() as u32;
        let vertices = m.positions.len() / 3;
        mesh.positions
            .extend(m.positions.chunks_exact(3).map(Vec3::from_slice));
        // Normals and uvs only where every vertex of every object has one.
        mesh.normals = mesh.normals.filter(|_| m.normals.len() == 3 * vertices);
        if let Some(normals) = &mut mesh.normals {
            normals.extend(m.normals.chunks_exact(3).map(Vec3::from_slice));
        }
        mesh.uvs = mesh.uvs.filter(|_| m.texcoords.len() == 2 * vertices);
        if let Some(uvs) = &mut mesh.uvs {
            // OBJ's v runs up the image; Mitsuba's (and pathmix's) down from its top row.
            uvs.extend(
                m.texcoords
                    .chunks_exact(2)
                    .map(|t| Vec2::new(t[0], 1.0 - t[1])),
            );
        }
        // tobj leaves the arities out when every face is a triangle.
        let arities = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities
        };
        let mut start = 0;
        for arity in arities {
            let face = &m.indices[start..start + arity as usize];
            start += arity as usize;
            mesh.triangles
                .extend(fan(face).map(|t| t.map(|i| base + i)));
        }
    }
    Ok(mesh)
}

/// An OBJ file's text as tobj is given it, line for line: comments (from `#`,
/// also after data) cut off, and points and lines (`p`, `l`), which are no
/// surface, emptied (tobj would make faces of polylines). Mitsuba reads OBJ
/// so, as bytes: text that is not UTF-8 reaches here replaced by U+FFFD,
/// harmless in a comment or a name and a parse error in a number.
fn surface_lines(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    // A byte order mark is no part of the first line's keyword.
    for line in text.strip_prefix('\u{feff}').unwrap_or(text).lines() {
        let data = line.split_once('#').map_or(line, |(data, _)| data);
        if !matches!(data.split_whitespace().next(), Some("p" | "l")) {
            out.push_str(data);
        }
        out.push('\n');
    }
    out
}

/// Checks, with the line, what tobj does not check (non-finite numbers, faces of
/// fewer than three vertices) and what it reports only without a line, or, in a
/// debug build, overflows on (indices out of range; indices count from 1,
/// negative ones back from the last element so far).
fn check_obj(path: &Path, text: &str) -> Result<(), MeshError> {
    // By kind: v, vt, vn.
    const OF: [&str; 3] = [
        "positions before this line",
        "texture coordinates before this line",
        "normals before this line",
    ];
    let mut counts = [0usize; 3];
    for (n, line) in text.lines().enumerate() {
        let at = Location::Line(n + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some(kind @ ("v" | "vt" | "vn")) => {
                counts[match kind {
                    "v" => 0,
                    "vt" => 1,
                    _ => 2,
                }] += 1;
                // Words that are no number are tobj's to report.
                if let Some(value) = words
                    .filter_map(|w| w.parse::<f32>().ok())
                    .find(|v| !v.is_finite())
                {
                    return Err(MeshError::NonFinite {
                        path: path.into(),
                        at,
                        what: format!("a `{kind}` line"),
                        value,
                    });
                }
            }
            Some("f") => {
                let vertices: Vec<&str> = words.collect();
                if vertices.len() < 3 {
                    return Err(MeshError::DegenerateFace {
                        path: path.into(),
                        at,
                        vertices: vertices.len(),
                    });
                }
                // v, v/vt, v//vn or v/vt/vn.
                for vertex in vertices {
                    for ((word, &count), of) in vertex.split('/').zip(&counts).zip(OF) {
                        let Ok(index) = word.parse::<i64>() else {
                            continue;
                        };
                        let in_range = index != 0
                            && usize::try_from(index.unsigned_abs()).is_ok_and(|i| i <= count);
                        if !in_range {
                            return Err(MeshError::IndexOutOfRange {
                                path: path.into(),
                                at,
                                index,
                                count,
                                of,
                            });
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// ply-rs-bw's message on one line, without its own "Line N: " (the location
/// says it) and without the Rust debug output it appends to the text it
/// quotes (`Error: ParseIntError { kind: InvalidDigit }`).
fn ply_message(e: &ParseError) -> String {
    let text = e.to_string();
    let text = match e.line() {
        Some(n) => text.strip_prefix(&format!("Line {n}: ")).unwrap_or(&text),
        None => &text,
    };
    // A quoted header line ends with its newline.
    let text = text.replace("\n'", "'");
    let text = text.split("\n\tError:").next().unwrap_or_default();
    let text = text.split(": Parse").next().unwrap_or_default();
    super::excerpt_words(text)
}

/// The names of the texture coordinates PLY writers use, by pairs (pbrt-v4's).
const UV_NAMES: [[&str; 2]; 4] = [
    ["u", "v"],
    ["s", "t"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

fn load_ply(path: &Path) -> Result<Mesh, MeshError> {
    let (file, _) = crate::paths::open_input(path).map_err(read_error(path))?;
    let mut reader = Reader::new(BufReader::new(file));
    let parser = Parser::<DefaultElement>::new();
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| MeshError::Malformed {
            path: path.into(),
            at: e.line().map_or(Location::File, Location::Line),
            message: ply_message(&e),
        })?;
    // PLY has one version; a later one could mean something else.
    if (header.version.major, header.version.minor) != (1, 0) {
        return Err(MeshError::Malformed {
            path: path.into(),
            at: Location::File,
            message: format!(
                "format version {}.{}: pathmix reads PLY 1.0",
                header.version.major, header.version.minor
            ),
        });
    }

    let vertex_def = header.elements.get("vertex");
    let has = |name: &str| vertex_def.is_some_and(|d| d.properties.contains_key(name));
    let vertex_count = vertex_def.map_or(0, |d| d.count);
    let normal_names = ["nx", "ny", "nz"].iter().all(|&n| has(n));
    let uv_names = UV_NAMES.into_iter().find(|uv| uv.iter().all(|&n| has(n)));
    let mut mesh = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: normal_names.then(Vec::new),
        uvs: uv_names.map(|_| Vec::new()),
        materials: Vec::new(),
        triangle_materials: Vec::new(),
    };

    // ASCII data is words separated by white space, on lines or across them
    // (as Mitsuba and pbrt-v4 read it), from the line after `end_header`.
    let first_line = reader.line();
    let mut body = Vec::new();
    if header.encoding == Encoding::Ascii {
        reader
            .get_mut()
            .read_to_end(&mut body)
            .map_err(read_error(path))?;
    }
    let body = std::str::from_utf8(&body).map_err(|e| MeshError::Malformed {
        path: path.into(),
        at: Location::Line(first_line + line_of(&body, e.valid_up_to()) - 1),
        message: "ASCII data that is not UTF-8 text".into(),
    })?;
    let mut words = (body.lines().enumerate())
        .flat_map(|(i, text)| {
            text.split_whitespace()
                .map(move |word| (first_line + i, word))
        })
        .peekable();
    for def in header.elements.values() {
        // Element by element, not the crate's whole payload at once, so that an
        // error names the element (the crate's binary errors carry none).
        for index in 0..def.count {
            let at = Location::Element {
                name: def.name.clone(),
                index,
                line: (header.encoding == Encoding::Ascii).then(|| match words.peek() {
                    Some(&(line, _)) => line,
                    // The file ends before this element: the line after its last.
                    None => first_line + body.lines().count(),
                }),
            };
            let element = match header.encoding {
                Encoding::Ascii => ascii_element(&parser, &mut words, def),
                encoding => binary_element(&parser, &mut reader, encoding, def),
            };
            let element = match element {
                Ok(Some(element)) => element,
                Ok(None) => {
                    return Err(MeshError::Truncated {
                        path: path.into(),
                        at,
                        declared: def.count,
                    });
                }
                Err(e) => {
                    return Err(MeshError::Malformed {
                        path: path.into(),
                        at,
                        message: ply_message(&e),
                    });
                }
            };
            match def.name.as_str() {
                "vertex" => {
                    let number = |name: &str| -> Result<f32, MeshError> {
                        match scalar(&element, name) {
                            Some(value) if value.is_finite() => Ok(value),
                            Some(value) => Err(MeshError::NonFinite {
                                path: path.into(),
                                at: at.clone(),
                                what: format!("property {name}"),
                                value,
                            }),
                            None => Err(MeshError::Malformed {
                                path: path.into(),
                                at: at.clone(),
                                message: format!("no number {name}"),
                            }),
                        }
                    };
                    mesh.positions
                        .push(Vec3::new(number("x")?, number("y")?, number("z")?));
                    if let Some(normals) = &mut mesh.normals {
                        normals.push(Vec3::new(number("nx")?, number("ny")?, number("nz")?));
                    }
                    if let (Some(uvs), Some([u, v])) = (&mut mesh.uvs, uv_names) {
                        uvs.push(Vec2::new(number(u)?, number(v)?));
                    }
                }
                "face" => {
                    let indices = index_list(&element, "vertex_indices")
                        .or_else(|| index_list(&element, "vertex_index"))
                        .ok_or_else(|| MeshError::Malformed {
                            path: path.into(),
                            at: at.clone(),
                            message: "no integer list vertex_indices or vertex_index".into(),
                        })?;
                    if indices.len() < 3 {
                        return Err(MeshError::DegenerateFace {
                            path: path.into(),
                            at,
                            vertices: indices.len(),
                        });
                    }
                    let face = indices
                        .iter()
                        .map(|&index| {
                            u32::try_from(index)
                                .ok()
                                .filter(|&i| (i as usize) < vertex_count)
                                .ok_or_else(|| MeshError::IndexOutOfRange {
                                    path: path.into(),
                                    at: at.clone(),
                                    index,
                                    count: vertex_count,
                                    of: "vertices in the file",
                                })
                        })
                        .collect::<Result<Vec<u32>, _>>()?;
                    mesh.triangles.extend(fan(&face));
                }
                // Edges, materials and the like are no part of the surface.
                _ => {}
            }
        }
    }
    // Data the header does not declare is a count that is wrong (Mitsuba refuses it too).
    if let Some((line, word)) = words.next() {
        return Err(MeshError::Malformed {
            path: path.into(),
            at: Location::Line(line),
            message: format!(
                "`{}` after the last element the header declares",
                super::excerpt(word)
            ),
        });
    }
    let trailing = reader.get_mut().fill_buf().map_err(read_error(path))?;
    if header.encoding != Encoding::Ascii && !trailing.is_empty() {
        return Err(MeshError::Malformed {
            path: path.into(),
            at: Location::File,
            message: "data after the last element the header declares (a count that is wrong)"
                .into(),
        });
    }
    Ok(mesh)
}

/// The next ASCII element, its words taken from `words` (with their lines), or
/// `None` where the file ends before or within it.
fn ascii_element<'a>(
    parser: &Parser<DefaultElement>,
    words: &mut impl Iterator<Item = (usize, &'a str)>,
    def: &ElementDef,
) -> Result<Option<DefaultElement>, ParseError> {
    let mut taken = Vec::new();
    for property in def.properties.values() {
        // A list is its length, then as many words; a length that is no
        // number is the parser's to report.
        let Some((_, word)) = words.next() else {
            return Ok(None);
        };
        taken.push(word);
        if let PropertyType::List(..) = property.data_type {
            for _ in 0..word.parse::<usize>().unwrap_or(0) {
                let Some((_, word)) = words.next() else {
                    return Ok(None);
                };
                taken.push(word);
            }
        }
    }
    parser.read_ascii_element(&taken.join(" "), def).map(Some)
}

/// The next binary element, or `None` where the file ends before or within it.
fn binary_element<R: BufRead>(
    parser: &Parser<DefaultElement>,
    reader: &mut Reader<R>,
    encoding: Encoding,
    def: &ElementDef,
) -> Result<Option<DefaultElement>, ParseError> {
    let element = match encoding {
        Encoding::BinaryLittleEndian => parser.read_little_endian_element(reader.get_mut(), def),
        Encoding::BinaryBigEndian => parser.read_big_endian_element(reader.get_mut(), def),
        Encoding::Ascii => unreachable!("ASCII elements are read by ascii_element"),
    };
    match element {
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Ok(None),
        element => element.map(Some),
    }
}

/// A scalar property as f32, whatever its type in the file.
fn scalar(element: &DefaultElement, name: &str) -> Option<f32> {
    Some(match *element.get(name)? {
        Property::Char(v) => v.into(),
        Property::UChar(v) => v.into(),
        Property::Short(v) => v.into(),
        Property::UShort(v) => v.into(),
        Property::Int(v) => v as f32,
        Property::UInt(v) => v as f32,
        Property::Float(v) => v,
        Property::Double(v) => v as f32,
        _ => return None,
    })
}

/// An integer list property (a face's vertex indices), whatever its integer type.
fn index_list(element: &DefaultElement, name: &str) -> Option<Vec<i64>> {
    fn widen<T: Copy + Into<i64>>(list: &[T]) -> Vec<i64> {
        list.iter().map(|&i| i.into()).collect()
    }
    Some(match element.get(name)? {
        Property::ListChar(list) => widen(list),
        Property::ListUChar(list) => widen(list),
        Property::ListShort(list) => widen(list),
        Property::ListUShort(list) => widen(list),
        Property::ListInt(list) => widen(list),
        Property::ListUInt(list) => widen(list),
        _ => return None,
    })
}

fn load_gltf(path: &Path) -> Result<Mesh, MeshError> {
    let malformed = |message: String| MeshError::Malformed {
        path: path.into(),
        at: Location::File,
        message,
    };
    let bytes = crate::paths::read_input(path).map_err(read_error(path))?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| malformed(super::excerpt_words(&e.to_string())))?;
    // gltf-json's validation looks up each POSITION accessor before it checks the
    // index, and panics on one out of range: check that first.
    let mut json = document.into_json();
    check_gltf_version(&json.asset).map_err(malformed)?;
    // Read here: integer positions, normals and texture coordinates (`attribute`).
    json.extensions_required
        .retain(|extension| extension != "KHR_mesh_quantization");
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) =
                (primitive.attributes.values()).find(|i| i.value() >= json.accessors.len())
            {
                return Err(MeshError::IndexOutOfRange {
                    path: path.into(),
                    at: Location::Primitive {
                        mesh: m,
                        primitive: p,
                    },
                    index: index.value() as i64,
                    count: json.accessors.len(),
                    of: "accessors in the file",
                });
            }
        }
    }
    let gltf = gltf::Document::from_json(json).map_err(|e| malformed(e.to_string()))?;
    check_gltf_nodes(&gltf.as_json().nodes).map_err(malformed)?;
    let buffers = gltf_data::buffers(path, gltf.as_json(), blob).map_err(malformed)?;
    let mut mesh = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        materials: Vec::new(),
        triangle_materials: Vec::new(),
    };
    // The file's material index of each of `mesh.materials`.
    let mut material_indices: Vec<usize> = Vec::new();
    // A file without a default scene shows its first, as viewers do.
    let Some(scene) = gltf.default_scene().or_else(|| gltf.scenes().next()) else {
        return Err(malformed(
            "no scene: `scenes` is empty, so no node places a mesh".into(),
        ));
    };
    // Depth first, with each node's transform composed onto its parent's.
    let mut stack: Vec<_> = scene.nodes().map(|node| (node, Mat4::IDENTITY)).collect();
    // glTF's nodes form disjoint trees; validation lets cycles and shared nodes
    // through, which would never end or multiply the work.
    let mut reached = vec![false; gltf.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut reached[node.index()], true) {
            return Err(malformed(format!(
                "node {} is reached twice (nodes must form disjoint trees)",
                node.index()
            )));
        }
        let transform = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(m) = node.mesh() {
            for primitive in m.primitives() {
                let at = Location::Primitive {
                    mesh: m.index(),
                    primitive: primitive.index(),
                };
                let triangles_before = mesh.triangles.len();
                let data = (gltf.as_json(), &buffers[..]);
                add_primitive(path, &mut mesh, &primitive, data, transform, at)?;
                let added = mesh.triangles.len() - triangles_before;
                if added == 0 {
                    continue;
                }
                let material = primitive.material();
                let used = material.index().map(|index| {
                    material_indices
                        .iter()
                        .position(|&i| i == index)
                        .unwrap_or_else(|| {
                            material_indices.push(index);
                            mesh.materials.push(mesh_material(&material, index));
                            mesh.materials.len() - 1
                        })
                });
                mesh.triangle_materials
                    .extend(std::iter::repeat_n(used, added));
            }
        }
        stack.extend(node.children().map(|child| (child, transform)));
    }
    if mesh.materials.is_empty() {
        mesh.triangle_materials.clear();
    }
    Ok(mesh)
}

/// Refuses a glTF file of another major version than 2 (or one that needs a
/// later minor version): its meaning could differ from what is read.
fn check_gltf_version(asset: &gltf::json::Asset) -> Result<(), String> {
    let major = asset.version.split('.').next().unwrap_or_default();
    if major != "2" {
        return Err(format!(
            "asset.version `{}`: pathmix reads glTF 2.x",
            super::excerpt(&asset.version)
        ));
    }
    match asset.min_version.as_deref() {
        Some(min) if min != "2.0" => Err(format!(
            "asset.minVersion `{}`: pathmix reads glTF 2.0",
            super::excerpt(min)
        )),
        _ => Ok(()),
    }
}

/// Refuses node transforms that are no affine transform: a `matrix` whose last
/// row is not (0, 0, 0, 1) (projective, as Mitsuba's reader refuses too) and a
/// `rotation` that is no unit quaternion (a zero one would silently be the
/// identity; glTF requires unit length).
fn check_gltf_nodes(nodes: &[gltf::json::Node]) -> Result<(), String> {
    for (i, node) in nodes.iter().enumerate() {
        // Column-major: the last row is elements 3, 7, 11 and 15.
        if let Some(m) = node.matrix
            && [m[3], m[7], m[11], m[15]] != [0.0, 0.0, 0.0, 1.0]
        {
            return Err(format!(
                "node {i}: matrix must be affine: its last row must be [0, 0, 0, 1], got [{}, {}, {}, {}]",
                m[3], m[7], m[11], m[15]
            ));
        }
        if let Some(gltf::json::scene::UnitQuaternion(q)) = node.rotation {
            let length = q.iter().map(|c| c * c).sum::<f32>().sqrt();
            // Exporters round; a quaternion further from unit length (or NaN) is no rotation.
            let unit = (length - 1.0).abs() <= 1e-3;
            if !unit {
                return Err(format!(
                    "node {i}: rotation [{}, {}, {}, {}] is not a unit quaternion (length {length})",
                    q[0], q[1], q[2], q[3]
                ));
            }
        }
    }
    Ok(())
}

fn mesh_material(material: &gltf::Material, index: usize) -> MeshMaterial {
    let [r, g, b, _] = material.pbr_metallic_roughness().base_color_factor();
    let strength = material.emissive_strength().unwrap_or(1.0);
    MeshMaterial {
        name: material
            .name()
            .map_or_else(|| format!("material {index}"), str::to_string),
        base_color: Vec3::new(r, g, b),
        emission: Vec3::from(material.emissive_factor()) * strength,
    }
}

/// Appends one glTF primitive to `mesh`, transformed into the scene's
/// coordinates: its triangles, whether a list, a strip or a fan; points and
/// lines are no surface, and add nothing (as `p` and `l` in OBJ). `data` is the
/// document and its buffers, which `gltf_data` reads the accessors from.
fn add_primitive(
    path: &Path,
    mesh: &mut Mesh,
    primitive: &gltf::Primitive,
    (root, buffers): (&gltf::json::Root, &[Vec<u8>]),
    transform: Mat4,
    at: Location,
) -> Result<(), MeshError> {
    let malformed = |message: String| MeshError::Malformed {
        path: path.into(),
        at: at.clone(),
        message,
    };
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(());
    }
    // An attribute's values (its type's components per vertex), every one finite, or `None` without it.
    let attribute = |semantic: Semantic, name: &str| -> Result<Option<Vec<Vec<f32>>>, MeshError> {
        let Some(accessor) = primitive.get(&semantic) else {
            return Ok(None);
        };
        let ty = match semantic {
            Semantic::TexCoords(_) => Type::Vec2,
            _ => Type::Vec3,
        };
        let values = gltf_data::read(root, buffers, accessor.index(), Use::Attribute, ty)
            .map_err(|e| malformed(format!("{name}: {e}")))?;
        if let Some(&value) = values.iter().find(|v| !v.is_finite()) {
            return Err(MeshError::NonFinite {
                path: path.into(),
                at: at.clone(),
                what: name.into(),
                value: value as f32,
            });
        }
        let n = ty.multiplicity();
        Ok(Some(
            values
                .chunks_exact(n)
                .map(|v| v.iter().map(|&c| c as f32).collect())
                .collect(),
        ))
    };
    let positions: Vec<Vec3> = attribute(Semantic::Positions, "POSITION")?
        .ok_or_else(|| malformed("no POSITION accessor".into()))?
        .into_iter()
        .map(|p| transform.transform_point3(Vec3::from_slice(&p)))
        .collect();
    if let Some(p) = positions.iter().find(|p| !p.is_finite()) {
        let value = p
            .to_array()
            .into_iter()
            .find(|v| !v.is_finite())
            .unwrap_or(f32::NAN);
        return Err(MeshError::NonFinite {
            path: path.into(),
            at,
            what: "POSITION (node transforms applied)".into(),
            value,
        });
    }
    let count = positions.len();
    let indices: Vec<u32> = match primitive.indices() {
        // Unsigned integers of at most 32 bits, as `gltf_data::read` checked.
        Some(accessor) => {
            gltf_data::read(root, buffers, accessor.index(), Use::Indices, Type::Scalar)
                .map_err(|e| malformed(format!("indices: {e}")))?
                .into_iter()
                .map(|i| i as u32)
                .collect()
        }
        // Unindexed triangles take the vertices in order; count fits u32 as glTF's indices do.
        None => (0..count as u32).collect(),
    };
    if mode == Mode::Triangles && indices.len() % 3 != 0 {
        return Err(malformed(format!(
            "{} triangle indices, not a multiple of 3",
            indices.len()
        )));
    }
    if let Some(&index) = indices.iter().find(|&&i| i as usize >= count) {
        return Err(MeshError::IndexOutOfRange {
            path: path.into(),
            at,
            index: index.into(),
            count,
            of: "vertices in the primitive",
        });
    }
    // Every attribute describes every vertex (glTF 2.0, 3.7.2.1).
    let per_vertex = |values: Option<Vec<Vec<f32>>>, name: &str| match values {
        Some(values) if values.len() != count => Err(malformed(format!(
            "{name} has {} elements, POSITION {count}",
            values.len()
        ))),
        values => Ok(values),
    };
    let normals = per_vertex(attribute(Semantic::Normals, "NORMAL")?, "NORMAL")?;
    let uvs = per_vertex(
        attribute(Semantic::TexCoords(0), "TEXCOORD_0")?,
        "TEXCOORD_0",
    )?;

    // glTF 2.0, 3.7.2.1: a strip's triangle i is (i, i + 1 + i % 2, i + 2 - i % 2),
    // so that each keeps the first's winding, and a fan's is (i + 1, i + 2, 0).
    let after_first_two = 0..indices.len().saturating_sub(2);
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::TriangleStrip => after_first_two
            .map(|i| [i, i + 1 + i % 2, i + 2 - i % 2].map(|v| indices[v]))
            .collect(),
        Mode::TriangleFan => after_first_two
            .map(|i| [i + 1, i + 2, 0].map(|v| indices[v]))
            .collect(),
        _ => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
    };
    // A transform that mirrors (negative determinant) turns counter-clockwise
    // faces clockwise: glTF says their winding then reverses, so the face
    // normal stays on the side the vertex normals are on.
    let mirrors = Mat3::from_mat4(transform).determinant() < 0.0;
    let base = mesh.positions.len() as u32;
    mesh.positions.extend(positions);
    mesh.triangles
        .extend(triangles.into_iter().map(|[a, b, c]| match mirrors {
            true => [base + a, base + c, base + b],
            false => [base + a, base + b, base + c],
        }));
    // Normals turn by the inverse transpose, so that they stay perpendicular
    // under non-uniform scale.
    let normal_matrix = Mat3::from_mat4(transform).inverse().transpose();
    mesh.normals = mesh.normals.take().zip(normals).map(|(mut all, normals)| {
        all.extend(
            normals
                .iter()
                .map(|n| (normal_matrix * Vec3::from_slice(n)).normalize_or_zero()),
        );
        all
    });
    mesh.uvs = mesh.uvs.take().zip(uvs).map(|(mut all, uvs)| {
        all.extend(uvs.iter().map(|t| Vec2::from_slice(t)));
        all
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder of its own under the system's temp dir, removed when dropped.
    struct Scratch(tempfile::TempDir);

    impl Scratch {
        fn new() -> Scratch {
            Scratch(
                tempfile::Builder::new()
                    .prefix("pathmix-mesh-")
                    .tempdir()
                    .unwrap(),
            )
        }

        fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
            let path = self.0.path().join(name);
            std::fs::write(&path, bytes).unwrap();
            path
        }
    }

    fn load(name: &str, bytes: &[u8]) -> Result<Mesh, MeshError> {
        load_mesh(&Scratch::new().file(name, bytes), 0)
    }

    const CUBE_OBJ: &str = "\
# a unit cube, quads
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
";

    #[test]
    fn obj_cube_of_quads_is_fanned() {
        let mesh = load("cube.obj", CUBE_OBJ.as_bytes()).unwrap();
        // tobj numbers the vertices by first use: 1 4 3 2 5 6 7 8 become 0..8.
        assert_eq!(mesh.positions.len(), 8);
        assert_eq!(mesh.positions[1], Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(
            mesh.triangles,
            vec![
                [0, 1, 2],
                [0, 2, 3],
                [4, 5, 6],
                [4, 6, 7],
                [0, 3, 5],
                [0, 5, 4],
                [3, 2, 6],
                [3, 6, 5],
                [2, 1, 7],
                [2, 7, 6],
                [1, 0, 4],
                [1, 4, 7],
            ]
        );
        assert_eq!(mesh.normals, None);
        assert_eq!(mesh.uvs, None);
    }

    #[test]
    fn obj_polygon_is_fanned_from_its_first_vertex() {
        let obj = "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5\nf 5 1 3\n";
        let mesh = load("pentagon.OBJ", obj.as_bytes()).unwrap();
        assert_eq!(
            mesh.triangles,
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [4, 0, 2]]
        );
    }

    /// A byte order mark, text that is not UTF-8 in a comment, comments after
    /// data, points and polylines: read past, each line where it was.
    #[test]
    fn obj_comments_points_and_lines_are_skipped() {
        let obj = b"\xef\xbb\xbf# caf\xe9\nv 0 0 0 # origin\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    p 1\nl 1 2\nl 1 2 3 4\nf 1 2 3 # first\nf 1 3 4\nf 1 2 5\n";
        let mesh = load("comments.obj", obj);
        let text = mesh.unwrap_err().to_string();
        assert!(
            text.contains("line 11") && text.contains("index 5 out of range"),
            "{text}"
        );
        let obj = &obj[..obj.len() - b"f 1 2 5\n".len()];
        let mesh = load("comments.obj", obj).unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn obj_objects_are_merged_and_relative_indices_resolved() {
        let obj = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\
                   o b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n";
        let mesh = load("two.obj", obj.as_bytes()).unwrap();
        assert_eq!(mesh.positions.len(), 6);
        assert_eq!(mesh.positions[3], Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [3, 4, 5]]);
    }

    #[test]
    fn obj_normals_and_uvs_follow_the_vertices() {
        let obj = "\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
vn 0 0 -1
f 1/1/1 2/2/1 3/3/1 4/4/1
f 3/3/2 2/2/2 1/1/2
";
        let mesh = load("quad.obj", obj.as_bytes()).unwrap();
        // The same position with another normal is another vertex.
        assert_eq!(mesh.positions.len(), 7);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]]);
        let normals = mesh.normals.unwrap();
        assert_eq!(normals[..4], [Vec3::Z; 4]);
        assert_eq!(normals[4..], [Vec3::NEG_Z; 3]);
        // v flipped: `vt 1 1` is the image's top right.
        let uvs = mesh.uvs.unwrap();
        assert_eq!(uvs[1], Vec2::new(1.0, 1.0));
        assert_eq!(uvs[2], Vec2::new(1.0, 0.0));
        assert_eq!(uvs[4], Vec2::new(1.0, 0.0));
        assert_eq!(mesh.positions[4], Vec3::new(1.0, 1.0, 0.0));
    }

    const ASCII_PLY: &str = "\
ply
format ascii 1.0
comment a square with normals and uvs, one quad and one triangle
element vertex 4
property float x
property float y
property float z
property float nx
property float ny
property float nz
property float s
property float t
element face 2
property list uchar int vertex_indices
end_header
0 0 0 0 0 1 0 0
1 0 0 0 0 1 1 0
1 1 0 0 0 1 1 1
0 1 0 0 0 1 0 1
4 0 1 2 3
3 0 2 3
";

    #[test]
    fn ascii_ply_with_normals_uvs_and_polygons() {
        let mesh = load("square.ply", ASCII_PLY.as_bytes()).unwrap();
        assert_eq!(
            mesh.positions,
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
        );
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
        assert_eq!(mesh.normals, Some(vec![Vec3::Z; 4]));
        assert_eq!(mesh.uvs.unwrap()[2], Vec2::new(1.0, 1.0));
    }

    /// ASCII values are words: blank lines, an element over two lines and pbrt's
    /// `texture_s`/`texture_t` read as the plain file is.
    #[test]
    fn ascii_ply_words_across_lines() {
        let plain = load("square.ply", ASCII_PLY.as_bytes()).unwrap();
        let spread = ASCII_PLY
            .replace(
                "property float s\nproperty float t",
                "property float texture_s\nproperty float texture_t",
            )
            .replace("end_header\n", "end_header\n\n")
            .replace("4 0 1 2 3\n", "4 0 1\n\t2 3\n\n");
        assert_eq!(load("spread.ply", spread.as_bytes()).unwrap(), plain);
    }

    /// A binary PLY of a unit square as two triangles: little endian with float
    /// coordinates and int indices, or big endian with double coordinates and
    /// unsigned short indices (`vertex_index`), declaring `faces` faces.
    fn binary_ply(big_endian: bool, faces: usize) -> Vec<u8> {
        let (format, coordinate, list) = if big_endian {
            ("binary_big_endian", "double", "uchar ushort vertex_index")
        } else {
            ("binary_little_endian", "float", "uchar int vertex_indices")
        };
        let mut bytes = format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty {coordinate} x\n\
             property {coordinate} y\nproperty {coordinate} z\nelement face {faces}\n\
             property list {list}\nend_header\n"
        )
        .into_bytes();
        for [x, y] in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
            for c in [x, y, 0.5] {
                if big_endian {
                    bytes.extend_from_slice(&f64::to_be_bytes(c));
                } else {
                    bytes.extend_from_slice(&f32::to_le_bytes(c as f32));
                }
            }
        }
        for face in [[0, 1, 2], [0, 2, 3]] {
            bytes.push(3);
            for i in face {
                if big_endian {
                    bytes.extend_from_slice(&u16::to_be_bytes(i));
                } else {
                    bytes.extend_from_slice(&i32::to_le_bytes(i.into()));
                }
            }
        }
        bytes
    }

    /// `ply` with coordinate `axis` of vertex `vertex` replaced by `value` (the
    /// bytes of one coordinate in the file's type and byte order).
    fn with_vertex_value(mut ply: Vec<u8>, vertex: usize, axis: usize, value: &[u8]) -> Vec<u8> {
        let end = b"end_header\n";
        let payload = ply.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let at = payload + (3 * vertex + axis) * value.len();
        ply[at..at + value.len()].copy_from_slice(value);
        ply
    }

    #[test]
    fn binary_ply_both_byte_orders() {
        for big_endian in [false, true] {
            let mesh = load("square.ply", &binary_ply(big_endian, 2)).unwrap();
            assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.5));
            assert_eq!(mesh.positions.len(), 4);
            assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
            assert_eq!(mesh.normals, None);
            assert_eq!(mesh.uvs, None);
        }
    }

    #[test]
    fn bad_files_name_the_file_the_place_and_the_problem() {
        let square = "v 0 0 0\nv 1 0 0\nv 1 1 0\n";
        let ply_header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
                          property float y\nproperty float z\nelement face 1\n\
                          property list uchar int vertex_indices\nend_header\n";
        let garbage: Vec<u8> = (0u32..512)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        let cases: Vec<(&str, Vec<u8>, &[&str])> = vec![
            (
                "short-face.obj",
                format!("{square}f 1 2\n").into_bytes(),
                &["line 4", "face with 2 vertices"],
            ),
            (
                "index.obj",
                format!("{square}f 1 2 4\n").into_bytes(),
                &["line 4", "index 4 out of range", "3 positions"],
            ),
            (
                "zero-index.obj",
                format!("{square}f 0 1 2\n").into_bytes(),
                &["line 4", "index 0 out of range"],
            ),
            (
                "relative.obj",
                format!("{square}f -1 -2 -4\n").into_bytes(),
                &["line 4", "index -4 out of range"],
            ),
            (
                "normal-index.obj",
                format!("{square}vn 0 0 1\nf 1//1 2//2 3//1\n").into_bytes(),
                &["line 5", "index 2 out of range", "1 normals"],
            ),
            (
                "nan.obj",
                "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n".into(),
                &["line 2", "non-finite number NaN", "`v`"],
            ),
            (
                "inf.obj",
                "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n".into(),
                &["line 3", "non-finite number -inf"],
            ),
            (
                "polyline.obj",
                format!("{square}l 1 2 3\n").into_bytes(),
                &["no triangles"],
            ),
            (
                "latin1-number.obj",
                b"v 0 0 0\nv 1 0 0\nv 0 1\xb7 0\nf 1 2 3\n".to_vec(),
                &["line 3", "malformed"],
            ),
            (
                "words.obj",
                format!("{square}v 1 2\nf 1 2 3\n").into_bytes(),
                &["line 4", "malformed", "position parse error"],
            ),
            (
                "points.obj",
                format!("{square}l 1 2\n").into_bytes(),
                &["no triangles"],
            ),
            ("empty.obj", Vec::new(), &["no triangles"]),
            // Read as Mitsuba does, as bytes: nothing in it is a face.
            ("garbage.obj", garbage.clone(), &["no triangles"]),
            (
                "index.ply",
                format!("{ply_header}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").into_bytes(),
                &["line 13 (face 0)", "index 3 out of range", "3 vertices"],
            ),
            (
                "negative.ply",
                format!("{ply_header}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n").into_bytes(),
                &["face 0", "index -1 out of range"],
            ),
            (
                "short-face.ply",
                format!("{ply_header}0 0 0\n1 0 0\n0 1 0\n2 0 1\n").into_bytes(),
                &["line 13 (face 0)", "face with 2 vertices"],
            ),
            (
                "nan.ply",
                with_vertex_value(binary_ply(false, 2), 1, 1, &f32::NAN.to_le_bytes()),
                &["vertex 1", "non-finite number NaN", "property y"],
            ),
            (
                "inf.ply",
                with_vertex_value(binary_ply(true, 2), 2, 2, &f64::INFINITY.to_be_bytes()),
                &["vertex 2", "non-finite number inf", "property z"],
            ),
            (
                "words.ply",
                format!("{ply_header}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n").into_bytes(),
                &["line 11 (vertex 1)", "malformed"],
            ),
            (
                "ascii-truncated.ply",
                format!("{ply_header}0 0 0\n1 0 0\n").into_bytes(),
                &["line 12 (vertex 2)", "truncated", "declares 3"],
            ),
            (
                "ascii-truncated-list.ply",
                format!("{ply_header}0 0 0\n1 0 0\n0 1 0\n3 0 1\n").into_bytes(),
                &["line 13 (face 0)", "truncated", "declares 1"],
            ),
            (
                // Words, not lines: the 7 shifts every value after it.
                "extra-value.ply",
                format!("{ply_header}0 0 0 7\n1 0 0\n0 1 0\n3 0 1 2\n").into_bytes(),
                &["line 12 (face 0)", "face with 0 vertices"],
            ),
            (
                "extra-line.ply",
                format!("{ply_header}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n").into_bytes(),
                &["line 14", "`3` after the last element"],
            ),
            (
                "list-length.ply",
                format!("{ply_header}0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n").into_bytes(),
                &["line 13 (face 0)", "malformed", "'-3'"],
            ),
            (
                "truncated.ply",
                binary_ply(false, 5),
                &["face 2", "truncated", "declares 5"],
            ),
            (
                "truncated-mid-element.ply",
                {
                    let mut bytes = binary_ply(true, 2);
                    bytes.truncate(bytes.len() - 3);
                    bytes
                },
                &["face 1", "truncated", "declares 2"],
            ),
            (
                "no-faces.ply",
                format!(
                    "{}0 0 0\n1 0 0\n0 1 0\n",
                    ply_header.replace("face 1", "face 0")
                )
                .into_bytes(),
                &["no triangles"],
            ),
            (
                "bad-header.ply",
                "ply\nformat ascii 1.0\nelement vertex three\nend_header\n".into(),
                &["line 3", "malformed"],
            ),
            (
                "bad-format.ply",
                "ply\nformat binary_middle_endian 1.0\nend_header\n".into(),
                &["line 2", "malformed", "'format binary_middle_endian 1.0'"],
            ),
            ("garbage.ply", garbage, &["malformed", "UTF-8"]),
            (
                "text.ply",
                "solid cube\n".into(),
                &["line 1", "malformed", "magic number"],
            ),
            (
                "mesh.stl",
                "solid\n".into(),
                &["unknown mesh format", ".obj, .ply"],
            ),
            ("no-extension", "v 0 0 0\n".into(), &["unknown mesh format"]),
        ];
        for (name, bytes, expected) in cases {
            let text = load(name, &bytes)
                .expect_err(&format!("{name} should not load"))
                .to_string();
            assert!(text.contains(name), "{name}: {text}");
            for part in expected {
                assert!(text.contains(part), "{name}: {part:?} not in {text:?}");
            }
        }
    }

    #[test]
    fn missing_file_is_named() {
        let path = Scratch::new().0.path().join("absent.ply");
        let e = load_mesh(&path, 0).unwrap_err();
        assert!(matches!(e, MeshError::Read { .. }));
        let text = e.to_string();
        assert!(
            text.contains("absent.ply") && text.contains("cannot read"),
            "{text}"
        );
    }

    /// Every prefix and many corruptions of good files give a mesh or an error,
    /// never a panic.
    #[test]
    fn no_input_panics() {
        let scratch = Scratch::new();
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let goods: [(&str, Vec<u8>); 7] = [
            ("fuzz.serialized", serialized_quads()),
            ("fuzz.obj", CUBE_OBJ.into()),
            ("fuzz.ply", ASCII_PLY.into()),
            ("fuzz.ply", binary_ply(false, 2)),
            ("fuzz.ply", binary_ply(true, 2)),
            ("fuzz.gltf", gltf(SQUARE, 4, NODES)),
            ("fuzz.glb", glb()),
        ];
        for (name, good) in goods {
            // A `.serialized` file's second mesh is found through its end.
            let index = u32::from(name.ends_with(".serialized"));
            for len in 0..good.len() {
                let _ = load_mesh(&scratch.file(name, &good[..len]), index);
            }
            for _ in 0..300 {
                let mut bytes = good.clone();
                for _ in 0..1 + random() % 4 {
                    let at = random() as usize % bytes.len();
                    bytes[at] = match random() % 4 {
                        0 => b"0123456789"[random() as usize % 10],
                        1 => b" -\n/"[random() as usize % 4],
                        _ => random() as u8,
                    };
                }
                let _ = load_mesh(&scratch.file(name, &bytes), index);
            }
        }
        let quads = serialized_quads();
        let first = load("two.serialized", &quads).unwrap();
        assert_eq!(
            (first.triangles.len(), first.normals.map(|n| n[3])),
            (2, Some(Vec3::Z))
        );
    }

    /// A version 4 `.serialized` file of two unit quads (positions, normals,
    /// uvs in single precision, then positions alone in double).
    fn serialized_quads() -> Vec<u8> {
        use std::io::Write;
        let mut file = Vec::new();
        let mut offsets = Vec::new();
        for (flags, double) in [(0x1003u32, false), (0x2000, true)] {
            offsets.push(file.len() as u64);
            file.extend_from_slice(&[0x1c, 0x04, 4, 0]);
            let mut stream = flags.to_le_bytes().to_vec();
            stream.extend_from_slice(b"quad\0");
            stream.extend_from_slice(&4u64.to_le_bytes());
            stream.extend_from_slice(&2u64.to_le_bytes());
            let arrays: &[&[f64]] = match double {
                false => &[
                    &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.],
                    &[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.],
                    &[0., 0., 1., 0., 1., 1., 0., 1.],
                ],
                true => &[&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]],
            };
            for &value in arrays.iter().copied().flatten() {
                match double {
                    true => stream.extend_from_slice(&value.to_le_bytes()),
                    false => stream.extend_from_slice(&(value as f32).to_le_bytes()),
                }
            }
            for index in [0u32, 1, 2, 0, 2, 3] {
                stream.extend_from_slice(&index.to_le_bytes());
            }
            let mut encoder =
                flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            encoder.write_all(&stream).unwrap();
            file.extend_from_slice(&encoder.finish().unwrap());
        }
        for offset in offsets {
            file.extend_from_slice(&offset.to_le_bytes());
        }
        file.extend_from_slice(&2u32.to_le_bytes());
        file
    }

    /// Standard base64, for the glTF test files' data URIs.
    fn base64(bytes: &[u8]) -> String {
        const DIGITS: &[u8; 64] =
            b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut out = String::new();
        for chunk in bytes.chunks(3) {
            let n = (chunk.iter().enumerate())
                .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
            for i in 0..4 {
                out.push(if i <= chunk.len() {
                    DIGITS[(n >> (18 - 6 * i) & 63) as usize] as char
                } else {
                    '='
                });
            }
        }
        out
    }

    /// A glTF document and its buffer: a unit square with normals (mesh 0: positions,
    /// normals, `indices` as u16) and its first triangle unindexed (mesh 1), drawn in
    /// `mode`, with the given nodes and scenes. The buffer is a data URI where `embed`,
    /// else left for a GLB's binary chunk.
    fn gltf_parts(indices: [u16; 6], mode: u32, nodes: &str, embed: bool) -> (String, Vec<u8>) {
        let mut buffer = Vec::new();
        for p in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ] {
            p.iter().for_each(|c: &f32| buffer.extend(c.to_le_bytes()));
        }
        for _ in 0..4 {
            [0.0f32, 0.0, 1.0]
                .iter()
                .for_each(|c| buffer.extend(c.to_le_bytes()));
        }
        indices.iter().for_each(|i| buffer.extend(i.to_le_bytes()));
        let uri = if embed {
            format!(
                r#""uri": "data:application/octet-stream;base64,{}", "#,
                base64(&buffer)
            )
        } else {
            String::new()
        };
        let json = format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}, {{"nodes": [2]}}],
  "nodes": {nodes},
  "meshes": [
    {{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 2, "mode": {mode}}}]}},
    {{"primitives": [{{"attributes": {{"POSITION": 3}}}}]}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 12}}
  ],
  "buffers": [{{{uri}"byteLength": 108}}]
}}"#
        );
        (json, buffer)
    }

    /// Node 0 (mesh 0, moved by 10 in x) with child node 1 (mesh 1, scaled by 2) in
    /// the default scene; node 2 only in the other scene.
    const NODES: &str = r#"[{"mesh": 0, "translation": [10, 0, 0], "children": [1]},
        {"mesh": 1, "scale": [2, 2, 2]}, {"mesh": 0}]"#;
    const SQUARE: [u16; 6] = [0, 1, 2, 0, 2, 3];

    fn gltf(indices: [u16; 6], mode: u32, nodes: &str) -> Vec<u8> {
        gltf_parts(indices, mode, nodes, true).0.into_bytes()
    }

    fn glb() -> Vec<u8> {
        let (json, mut bin) = gltf_parts(SQUARE, 4, NODES, false);
        let mut json = json.into_bytes();
        // Chunks are padded to 4 bytes: JSON with spaces, binary with zeros.
        json.resize(json.len().next_multiple_of(4), b' ');
        bin.resize(bin.len().next_multiple_of(4), 0);
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
        for (chunk, kind) in [(json, b"JSON"), (bin, b"BIN\0")] {
            glb.extend((chunk.len() as u32).to_le_bytes());
            glb.extend(kind);
            glb.extend(chunk);
        }
        glb
    }

    #[test]
    fn gltf_default_scene_with_node_transforms() {
        for (name, bytes) in [("scene.gltf", gltf(SQUARE, 4, NODES)), ("scene.GLB", glb())] {
            let mesh = load(name, &bytes).unwrap();
            assert_eq!(
                mesh.positions,
                vec![
                    Vec3::new(10.0, 0.0, 0.0),
                    Vec3::new(11.0, 0.0, 0.0),
                    Vec3::new(11.0, 1.0, 0.0),
                    Vec3::new(10.0, 1.0, 0.0),
                    Vec3::new(10.0, 0.0, 0.0),
                    Vec3::new(12.0, 0.0, 0.0),
                    Vec3::new(12.0, 2.0, 0.0),
                ],
                "{name}"
            );
            assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]]);
            // Mesh 1 has none.
            assert_eq!(mesh.normals, None);
            assert_eq!(mesh.uvs, None);
        }
    }

    /// Under a mirroring node the normals follow the inverse transpose and the
    /// winding reverses, so that the face's normal is on their side too.
    #[test]
    fn gltf_mirrored_nodes_keep_faces_and_normals_together() {
        let nodes = r#"[{"mesh": 0, "scale": [1, 1, -2]}, {}, {}]"#;
        let mesh = load("mirrored.gltf", &gltf(SQUARE, 4, nodes)).unwrap();
        assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(mesh.normals, Some(vec![Vec3::NEG_Z; 4]));
        assert_eq!(mesh.triangles, vec![[0, 2, 1], [0, 3, 2]]);
        for [a, b, c] in mesh.triangles {
            let p = [a, b, c].map(|i| mesh.positions[i as usize]);
            assert!((p[1] - p[0]).cross(p[2] - p[0]).dot(Vec3::NEG_Z) > 0.0);
        }
    }

    /// `KHR_mesh_quantization`'s integer attributes (gltfpack writes them):
    /// positions as shorts scaled back by the node, normals as normalized bytes,
    /// texture coordinates as normalized unsigned or signed shorts.
    #[test]
    fn gltf_quantized_attributes_are_read() {
        for (uv_type, uv_max) in [(5123u32, 65535u16), (5122, 32767)] {
            let mut buffer = Vec::new();
            // Positions: three shorts and two bytes of padding (a stride of 8).
            for [x, y] in [[0i16, 0], [2, 0], [2, 2], [0, 2]] {
                [x, y, 0, 0]
                    .iter()
                    .for_each(|c| buffer.extend(c.to_le_bytes()));
            }
            // Normals: three normalized bytes and one of padding.
            for _ in 0..4 {
                buffer.extend([0u8, 0, 127, 0]);
            }
            for [u, v] in [[0, 0], [uv_max, 0], [uv_max, uv_max], [0, uv_max]] {
                [u, v].iter().for_each(|c| buffer.extend(c.to_le_bytes()));
            }
            SQUARE.iter().for_each(|i| buffer.extend(i.to_le_bytes()));
            let json = format!(
                r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_mesh_quantization"],
  "extensionsRequired": ["KHR_mesh_quantization"],
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0, "scale": [0.5, 0.5, 0.5]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3}}]}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5122, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [2, 2, 0]}},
    {{"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": {uv_type}, "normalized": true, "count": 4, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 32, "byteStride": 8}},
    {{"buffer": 0, "byteOffset": 32, "byteLength": 16, "byteStride": 4}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 16}},
    {{"buffer": 0, "byteOffset": 64, "byteLength": 12}}
  ],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 76}}]
}}"#,
                base64(&buffer)
            );
            let mesh = load("quantized.gltf", json.as_bytes()).unwrap();
            assert_eq!(
                mesh.positions,
                vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
            );
            assert_eq!(mesh.normals, Some(vec![Vec3::Z; 4]));
            let uvs = mesh.uvs.unwrap();
            assert_eq!((uvs[0], uvs[2]), (Vec2::ZERO, Vec2::ONE), "{uv_type}");
        }
    }

    /// Strips and fans become triangles of the same winding (glTF 2.0,
    /// 3.7.2.1); points and lines add nothing.
    #[test]
    fn gltf_strips_and_fans_are_triangles() {
        let nodes = r#"[{"mesh": 0}, {}, {}]"#;
        let strip = load("strip.gltf", &gltf([0, 1, 3, 2, 0, 1], 5, nodes)).unwrap();
        assert_eq!(
            strip.triangles,
            vec![[0, 1, 3], [1, 2, 3], [3, 2, 0], [2, 1, 0]]
        );
        let fan = load("fan.gltf", &gltf([0, 1, 2, 3, 0, 0], 6, nodes)).unwrap();
        assert_eq!(
            fan.triangles,
            vec![[1, 2, 0], [2, 3, 0], [3, 0, 0], [0, 0, 0]]
        );
        for mode in [0, 1, 2, 3] {
            let text = load("lines.gltf", &gltf(SQUARE, mode, nodes))
                .unwrap_err()
                .to_string();
            assert!(text.contains("no triangles"), "mode {mode}: {text}");
        }
    }

    #[test]
    fn bad_gltf_files_name_the_file_the_primitive_and_the_problem() {
        let cycle = r#"[{"mesh": 0, "children": [1]}, {"children": [0]}, {}]"#;
        let external = gltf_parts(SQUARE, 4, NODES, false).0.replace(
            r#""byteLength": 108"#,
            r#""uri": "absent.bin", "byteLength": 108"#,
        );
        let cases: Vec<(&str, Vec<u8>, &[&str])> = vec![
            (
                "no-scene.gltf",
                String::from_utf8(gltf(SQUARE, 4, NODES))
                    .unwrap()
                    .replace(r#""scene": 0,"#, "")
                    .replace(r#""scenes": [{"nodes": [0]}, {"nodes": [2]}],"#, "")
                    .into_bytes(),
                &["malformed", "no scene"],
            ),
            (
                "bad-base64.gltf",
                String::from_utf8(gltf(SQUARE, 4, NODES))
                    .unwrap()
                    .replace("base64,", "base64,@")
                    .into_bytes(),
                &["malformed", "buffer 0 (a data URI)"],
            ),
            (
                "index.gltf",
                gltf([0, 1, 2, 0, 2, 4], 4, NODES),
                &["mesh 0, primitive 0", "index 4 out of range", "4 vertices"],
            ),
            (
                "cycle.gltf",
                gltf(SQUARE, 4, cycle),
                &["malformed", "node 0 is reached twice"],
            ),
            (
                "external.gltf",
                external.into_bytes(),
                &["malformed", "buffer 0 (`absent.bin`)"],
            ),
            ("broken.gltf", b"{\"asset\": ".to_vec(), &["malformed"]),
            ("empty.glb", Vec::new(), &["malformed"]),
            (
                "accessor.gltf",
                gltf_parts(SQUARE, 4, NODES, true)
                    .0
                    .replace(r#""NORMAL": 1"#, r#""NORMAL": 9"#)
                    .into_bytes(),
                &["mesh 0, primitive 0", "index 9 out of range", "4 accessors"],
            ),
        ];
        for (name, bytes, expected) in cases {
            let text = load(name, &bytes)
                .expect_err(&format!("{name} should not load"))
                .to_string();
            assert!(text.contains(name), "{name}: {text}");
            for part in expected {
                assert!(text.contains(part), "{name}: {part:?} not in {text:?}");
            }
        }
    }
}

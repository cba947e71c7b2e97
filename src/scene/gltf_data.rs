//! glTF's binary data, read without trusting the file: each buffer at most as
//! long as its `byteLength` says (and only from a regular file), and each
//! accessor only after its type, count, offsets and stride are checked against
//! its buffer view and buffer. The gltf crate's own readers panic on index
//! accessors of float or signed type and on strides shorter than an element,
//! and read unbounded files, so pathmix reads the bytes itself.

use gltf::json::accessor::{ComponentType, GenericComponentType, Type};
use gltf::json::validation::Checked;
use gltf::json::{self, Root};
use std::path::{Path, PathBuf};

/// The most elements of an accessor without a buffer view, all zeros but
/// for its sparse values: no data in the file bounds its count.
const MAX_ZERO_FILLED_ELEMENTS: u64 = 1 << 24;

/// The data of each of the document's buffers: the GLB's binary chunk (`blob`),
/// a data URI, or a file, as glTF resolves them, read up to the buffer's
/// `byteLength`. An error names the buffer.
pub fn buffers(
    path: &Path,
    root: &Root,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut buffers = Vec::new();
    for (index, buffer) in root.buffers.iter().enumerate() {
        let length = buffer.byte_length.0;
        let (which, data) = match buffer.uri.as_deref() {
            None => (
                "the GLB's binary chunk".to_string(),
                blob.take()
                    .ok_or_else(|| "no GLB binary chunk holds it".to_string()),
            ),
            Some(uri) if uri.starts_with("data:") => (
                "a data URI".into(),
                gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
                    .map(|data| data.0)
                    .map_err(|e| e.to_string()),
            ),
            Some(uri) => (
                format!("`{}`", super::excerpt(uri)),
                buffer_file(path, uri).and_then(|file| {
                    crate::paths::read_input_prefix(&file, length)
                        .map_err(|e| format!("cannot read `{}`: {e}", file.display()))
                }),
            ),
        };
        let data = data
            .and_then(|data| match (data.len() as u64) < length {
                true => Err(format!(
                    "{} bytes, fewer than its byteLength {length}",
                    data.len()
                )),
                false => Ok(data),
            })
            .map_err(|message| format!("buffer {index} ({which}): {message}"))?;
        buffers.push(data);
    }
    Ok(buffers)
}

/// The file a buffer's URI names: `file:` and `file://` URIs and relative
/// references (against the glTF file's folder), percent-decoded.
fn buffer_file(gltf_path: &Path, uri: &str) -> Result<PathBuf, String> {
    let (reference, relative) = match uri.split_once(':') {
        Some(("file", rest)) => (rest.strip_prefix("//").unwrap_or(rest), false),
        // A scheme is letters and digits (RFC 3986) before any `/`.
        Some((scheme, _)) if !scheme.contains('/') => {
            return Err(format!(
                "URI scheme `{}:` is not read (data:, file: and relative references are)",
                super::excerpt(scheme)
            ));
        }
        _ => (uri, true),
    };
    let decoded = percent_decode(reference)?;
    Ok(match relative {
        true => gltf_path.parent().unwrap_or(Path::new("")).join(decoded),
        false => PathBuf::from(decoded),
    })
}

/// `%XX` escapes decoded (RFC 3986); the result must be UTF-8.
fn percent_decode(text: &str) -> Result<String, String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok());
            let byte = hex.and_then(|h| u8::from_str_radix(h, 16).ok());
            out.push(byte.ok_or_else(|| {
                format!(
                    "`{}`: a `%` not followed by two hex digits",
                    super::excerpt(text)
                )
            })?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| {
        format!(
            "`{}`: percent-escapes that are not UTF-8",
            super::excerpt(text)
        )
    })
}

/// What an accessor is read as: the type and component types glTF allows for
/// that use.
#[derive(Clone, Copy)]
pub enum Use {
    /// `indices`: unsigned integer scalars.
    Indices,
    /// A vertex attribute (positions, normals, texture coordinates): floats,
    /// or 8- and 16-bit integers as `KHR_mesh_quantization` allows.
    Attribute,
}

/// A component type's size in bytes and whether a use may take it.
fn component(ty: ComponentType, usage: Use) -> (usize, bool) {
    let size = ty.size();
    let allowed = match usage {
        Use::Indices => matches!(
            ty,
            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
        ),
        Use::Attribute => ty != ComponentType::U32,
    };
    (size, allowed)
}

fn type_name(ty: ComponentType) -> &'static str {
    match ty {
        ComponentType::I8 => "BYTE (5120)",
        ComponentType::U8 => "UNSIGNED_BYTE (5121)",
        ComponentType::I16 => "SHORT (5122)",
        ComponentType::U16 => "UNSIGNED_SHORT (5123)",
        ComponentType::U32 => "UNSIGNED_INT (5125)",
        ComponentType::F32 => "FLOAT (5126)",
    }
}

/// One component at `bytes[at..]` as f64 (little-endian, as glTF stores it),
/// an integer mapped to [0, 1] or [-1, 1] where `normalized`, as glTF says.
fn component_value(bytes: &[u8], at: usize, ty: ComponentType, normalized: bool) -> f64 {
    let mut w = [0u8; 4];
    w[..ty.size()].copy_from_slice(&bytes[at..at + ty.size()]);
    let (value, max) = match ty {
        ComponentType::I8 => (f64::from(w[0] as i8), 127.0),
        ComponentType::U8 => (f64::from(w[0]), 255.0),
        ComponentType::I16 => (f64::from(i16::from_le_bytes([w[0], w[1]])), 32767.0),
        ComponentType::U16 => (f64::from(u16::from_le_bytes([w[0], w[1]])), 65535.0),
        ComponentType::U32 => (f64::from(u32::from_le_bytes(w)), 1.0),
        ComponentType::F32 => return f64::from(f32::from_le_bytes(w)),
    };
    match normalized {
        true => (value / max).max(-1.0),
        false => value,
    }
}

/// The bytes of `count` elements of `element_size` from `offset` within buffer
/// view `view`, with the view's stride: checked against the view's length and
/// the view against its buffer. Returns the buffer, the first element's start
/// and the stride.
fn view_elements<'b>(
    root: &Root,
    buffers: &'b [Vec<u8>],
    view: json::Index<json::buffer::View>,
    offset: u64,
    count: u64,
    element_size: usize,
) -> Result<(&'b [u8], usize, usize), String> {
    let index = view.value();
    let view = root
        .buffer_views
        .get(index)
        .ok_or_else(|| format!("bufferView {index} does not exist"))?;
    let which = format!("bufferView {index}");
    let stride = match view.byte_stride {
        Some(stride) if stride.0 < element_size => {
            return Err(format!(
                "{which}: byteStride {} is shorter than the element ({element_size} bytes)",
                stride.0
            ));
        }
        Some(stride) => stride.0,
        None => element_size,
    };
    let buffer_index = view.buffer.value();
    let buffer = buffers
        .get(buffer_index)
        .ok_or_else(|| format!("{which}: buffer {buffer_index} does not exist"))?;
    let view_start = view.byte_offset.map_or(0, |o| o.0);
    let view_end = view_start.checked_add(view.byte_length.0);
    if view_end.is_none_or(|end| end > buffer.len() as u64) {
        return Err(format!(
            "{which}: bytes {view_start} + {} run past buffer {buffer_index} ({} bytes)",
            view.byte_length.0,
            buffer.len()
        ));
    }
    // The last element's end, within the view.
    let end = (count - 1)
        .checked_mul(stride as u64)
        .and_then(|last| last.checked_add(offset))
        .and_then(|last| last.checked_add(element_size as u64));
    if end.is_none_or(|end| end > view.byte_length.0) {
        return Err(format!(
            "{count} elements of {element_size} bytes, {stride} apart from byte {offset}, \
             run past {which} ({} bytes)",
            view.byte_length.0
        ));
    }
    // Both fit the buffer, whose length is a usize.
    Ok((buffer, (view_start + offset) as usize, stride))
}

/// Accessor `index` read for `usage`: `dimensions` values per element (as
/// f64), after its type, component type, count, buffer views and sparse
/// substitutions are checked. The error names the accessor.
pub fn read(
    root: &Root,
    buffers: &[Vec<u8>],
    index: usize,
    usage: Use,
    dimensions: Type,
) -> Result<Vec<f64>, String> {
    let which = format!("accessor {index}");
    let accessor = root
        .accessors
        .get(index)
        .ok_or_else(|| format!("{which} does not exist"))?;
    let (Checked::Valid(GenericComponentType(ty)), Checked::Valid(kind)) =
        (&accessor.component_type, &accessor.type_)
    else {
        return Err(format!("{which}: unknown componentType or type"));
    };
    let (ty, kind) = (*ty, *kind);
    let (size, allowed) = component(ty, usage);
    if !allowed {
        let expected = match usage {
            Use::Indices => "indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
            Use::Attribute => "a vertex attribute must be FLOAT or an 8- or 16-bit integer",
        };
        return Err(format!(
            "{which}: componentType {}: {expected}",
            type_name(ty)
        ));
    }
    if kind != dimensions {
        return Err(format!(
            "{which}: type {kind:?}, where {dimensions:?} is expected"
        ));
    }
    let n = dimensions.multiplicity();
    let element_size = n * size;
    let count = accessor.count.0;
    if count == 0 {
        return Err(format!("{which}: count is 0 (glTF needs at least 1)"));
    }
    let normalized = accessor.normalized;
    let mut values = match accessor.buffer_view {
        Some(view) => {
            let offset = accessor.byte_offset.map_or(0, |o| o.0);
            let (buffer, start, stride) =
                view_elements(root, buffers, view, offset, count, element_size)
                    .map_err(|e| format!("{which}: {e}"))?;
            let mut values = Vec::with_capacity(count as usize * n);
            for element in 0..count as usize {
                let at = start + element * stride;
                values
                    .extend((0..n).map(|c| component_value(buffer, at + c * size, ty, normalized)));
            }
            values
        }
        None if count > MAX_ZERO_FILLED_ELEMENTS => {
            return Err(format!(
                "{which}: {count} elements without a bufferView (zeros): more than the \
                 {MAX_ZERO_FILLED_ELEMENTS} pathmix reads"
            ));
        }
        None => vec![0.0; count as usize * n],
    };
    if let Some(sparse) = &accessor.sparse {
        let substitutions = sparse.count.0;
        if substitutions == 0 || substitutions > count {
            return Err(format!(
                "{which}: sparse count {substitutions}, where 1 to {count} are allowed"
            ));
        }
        let Checked::Valid(json::accessor::IndexComponentType(index_type)) =
            &sparse.indices.component_type
        else {
            return Err(format!("{which}: unknown sparse indices componentType"));
        };
        let index_type = *index_type;
        let (index_size, unsigned) = component(index_type, Use::Indices);
        if !unsigned {
            return Err(format!(
                "{which}: sparse indices of componentType {}: they must be unsigned",
                type_name(index_type)
            ));
        }
        let (index_bytes, index_start, index_stride) = view_elements(
            root,
            buffers,
            sparse.indices.buffer_view,
            sparse.indices.byte_offset.0,
            substitutions,
            index_size,
        )
        .map_err(|e| format!("{which}: sparse indices: {e}"))?;
        let (value_bytes, value_start, value_stride) = view_elements(
            root,
            buffers,
            sparse.values.buffer_view,
            sparse.values.byte_offset.0,
            substitutions,
            element_size,
        )
        .map_err(|e| format!("{which}: sparse values: {e}"))?;
        let mut previous = None;
        for s in 0..substitutions as usize {
            let target = component_value(
                index_bytes,
                index_start + s * index_stride,
                index_type,
                false,
            ) as u64;
            // glTF: strictly increasing, so each element is substituted once.
            if target >= count || previous.is_some_and(|p| target <= p) {
                return Err(format!(
                    "{which}: sparse index {target} out of order or range (count {count})"
                ));
            }
            previous = Some(target);
            for c in 0..n {
                values[target as usize * n + c] = component_value(
                    value_bytes,
                    value_start + s * value_stride + c * size,
                    ty,
                    normalized,
                );
            }
        }
    }
    Ok(values)
}

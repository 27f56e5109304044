//! Raw glTF data: GLB chunks, buffers (data URIs, files, the BIN chunk) and bounds-checked
//! accessor reads (strided, sparse, every component type).
//!
//! Nothing here trusts a number from the file: every offset, stride and count is checked
//! against the bytes actually present before anything is allocated or read.

use anyhow::{anyhow, bail, ensure, Context, Result};
use gltf::accessor::{DataType, Dimensions};
use std::borrow::Cow;
use std::path::Path;

/// Most vertices one accessor (or a whole scene) may hold.
pub const MAX_VERTICES: usize = 1 << 26;
/// Most indices one index accessor may hold.
pub const MAX_INDICES: usize = 3 << 26;
/// Largest external file (buffer or image) we read.
pub const MAX_FILE_BYTES: u64 = 1 << 31;

/// The two chunks of a `.glb` file.
pub struct Glb<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

fn le_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB container into its JSON and optional BIN chunk.
pub fn split_glb(bytes: &[u8]) -> Result<Glb<'_>> {
    ensure!(
        bytes.len() >= 12,
        "truncated GLB: {} bytes, shorter than the 12-byte header",
        bytes.len()
    );
    ensure!(&bytes[0..4] == b"glTF", "not a GLB file (bad magic)");
    let version = le_u32(bytes, 4).unwrap_or(0);
    ensure!(version == 2, "unsupported GLB version {version} (only 2)");
    let length = le_u32(bytes, 8).unwrap_or(0) as usize;
    ensure!(
        length <= bytes.len(),
        "truncated GLB: header says {length} bytes, file has {}",
        bytes.len()
    );
    ensure!(
        length >= 20,
        "corrupt GLB: total length {length} leaves no JSON chunk"
    );
    let bytes = &bytes[..length];
    let mut pos = 12;
    let mut json = None;
    let mut bin = None;
    while pos < bytes.len() {
        let (Some(chunk_len), Some(chunk_type)) = (le_u32(bytes, pos), le_u32(bytes, pos + 4))
        else {
            bail!("truncated GLB: incomplete chunk header at byte {pos}");
        };
        let start = pos + 8;
        let end = start
            .checked_add(chunk_len as usize)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                anyhow!("truncated GLB: chunk at byte {pos} claims {chunk_len} bytes past the end")
            })?;
        let data = &bytes[start..end];
        match &chunk_type.to_le_bytes() {
            b"JSON" if json.is_none() && pos == 12 => json = Some(data),
            b"BIN\0" if bin.is_none() && json.is_some() => bin = Some(data),
            b"JSON" | b"BIN\0" => bail!("corrupt GLB: unexpected chunk order at byte {pos}"),
            _ => {}
        }
        pos = end;
    }
    let json = json.ok_or_else(|| anyhow!("corrupt GLB: the first chunk is not JSON"))?;
    Ok(Glb { json, bin })
}

/// Decodes standard base64 (with or without padding; whitespace is an error).
pub fn decode_base64(text: &str) -> Result<Vec<u8>> {
    fn value(c: u8) -> Option<u32> {
        match c {
            b'A'..=b'Z' => Some((c - b'A') as u32),
            b'a'..=b'z' => Some((c - b'a') as u32 + 26),
            b'0'..=b'9' => Some((c - b'0') as u32 + 52),
            b'+' | b'-' => Some(62),
            b'/' | b'_' => Some(63),
            _ => None,
        }
    }
    let body = text.trim_end_matches('=').as_bytes();
    let mut out = Vec::with_capacity(body.len() / 4 * 3 + 3);
    for chunk in body.chunks(4) {
        ensure!(chunk.len() >= 2, "invalid base64 data (bad length)");
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            let v = value(c).ok_or_else(|| anyhow!("invalid base64 data (byte {c:#04x})"))?;
            acc |= v << (18 - 6 * i);
        }
        let bytes = acc.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    Ok(out)
}

/// Undoes URI percent-encoding (`%20` → space).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Reads the bytes a URI names: a `data:` URI, or a file relative to `base_dir`.
pub fn read_uri(uri: &str, base_dir: Option<&Path>, what: &str) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or_else(|| anyhow!("{what}: data URI is not base64-encoded"))?;
        return decode_base64(payload).with_context(|| format!("{what}: bad data URI"));
    }
    let base = base_dir.ok_or_else(|| {
        anyhow!("{what}: refers to external file {uri:?} but the scene has no directory")
    })?;
    let path = base.join(percent_decode(uri));
    let meta = std::fs::metadata(&path)
        .map_err(|e| anyhow!("{what}: missing file {}: {e}", path.display()))?;
    ensure!(meta.is_file(), "{what}: {} is not a file", path.display());
    ensure!(
        meta.len() <= MAX_FILE_BYTES,
        "{what}: {} is absurdly large ({} bytes)",
        path.display(),
        meta.len()
    );
    std::fs::read(&path).map_err(|e| anyhow!("{what}: cannot read {}: {e}", path.display()))
}

/// Every buffer of a document, resolved to bytes (bounded by its declared `byteLength`).
pub struct Buffers<'a> {
    data: Vec<Cow<'a, [u8]>>,
}

impl<'a> Buffers<'a> {
    pub fn resolve(
        doc: &gltf::Document,
        bin: Option<&'a [u8]>,
        base_dir: Option<&Path>,
    ) -> Result<Self> {
        let mut data = Vec::new();
        for buffer in doc.buffers() {
            let what = format!("buffer {}", buffer.index());
            let bytes: Cow<'a, [u8]> = match buffer.source() {
                gltf::buffer::Source::Bin => Cow::Borrowed(bin.ok_or_else(|| {
                    anyhow!("{what} refers to the GLB BIN chunk but the file has none")
                })?),
                gltf::buffer::Source::Uri(uri) => Cow::Owned(read_uri(uri, base_dir, &what)?),
            };
            let declared = buffer.length();
            ensure!(
                bytes.len() >= declared,
                "{what} is truncated: byteLength {declared} but only {} bytes present",
                bytes.len()
            );
            data.push(match bytes {
                Cow::Borrowed(b) => Cow::Borrowed(&b[..declared]),
                Cow::Owned(mut v) => {
                    v.truncate(declared);
                    Cow::Owned(v)
                }
            });
        }
        Ok(Self { data })
    }

    /// The bytes of a buffer view, bounds-checked.
    pub fn view(&self, view: &gltf::buffer::View) -> Result<&[u8]> {
        let buffer = self
            .data
            .get(view.buffer().index())
            .ok_or_else(|| anyhow!("bufferView {} names a missing buffer", view.index()))?;
        let start = view.offset();
        let end = start.checked_add(view.length());
        match end {
            Some(end) if end <= buffer.len() => Ok(&buffer[start..end]),
            _ => bail!(
                "bufferView {} (offset {start}, length {}) is out of bounds of its buffer ({} bytes)",
                view.index(),
                view.length(),
                buffer.len()
            ),
        }
    }
}

fn component_size(ty: DataType) -> usize {
    match ty {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn dimension_count(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

fn component_f32(ty: DataType, b: &[u8], normalized: bool) -> f32 {
    match (ty, normalized) {
        (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (DataType::U8, false) => b[0] as f32,
        (DataType::U8, true) => b[0] as f32 / 255.0,
        (DataType::I8, false) => b[0] as i8 as f32,
        (DataType::I8, true) => (b[0] as i8 as f32 / 127.0).max(-1.0),
        (DataType::U16, false) => u16::from_le_bytes([b[0], b[1]]) as f32,
        (DataType::U16, true) => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        (DataType::I16, false) => i16::from_le_bytes([b[0], b[1]]) as f32,
        (DataType::I16, true) => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
        (DataType::U32, _) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
    }
}

fn index_u32(ty: DataType, b: &[u8]) -> Result<u32> {
    Ok(match ty {
        DataType::U8 => b[0] as u32,
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        other => bail!("bad component type {other:?} for indices (need u8, u16 or u32)"),
    })
}

/// A strided run of `count` elements of `elem` bytes inside `bytes`, bounds-checked.
fn strided(
    bytes: &[u8],
    offset: usize,
    stride: usize,
    elem: usize,
    count: usize,
) -> Result<impl Iterator<Item = &[u8]>> {
    if count > 0 {
        let last_end = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(offset))
            .and_then(|x| x.checked_add(elem));
        match last_end {
            Some(end) if end <= bytes.len() => {}
            _ => bail!(
                "{count} elements of {elem} bytes (stride {stride}, offset {offset}) run past the end of the buffer view ({} bytes)",
                bytes.len()
            ),
        }
    }
    Ok((0..count).map(move |i| &bytes[offset + i * stride..offset + i * stride + elem]))
}

/// Reads an accessor as `dims` floats per element (sparse substitution applied).
pub fn read_f32(
    buffers: &Buffers,
    accessor: &gltf::Accessor,
    dims: Dimensions,
    max_count: usize,
) -> Result<Vec<f32>> {
    let what = format!("accessor {}", accessor.index());
    read_f32_inner(buffers, accessor, dims, max_count).with_context(|| what)
}

fn check_count(accessor: &gltf::Accessor, max_count: usize) -> Result<usize> {
    let count = accessor.count();
    ensure!(
        count <= max_count,
        "absurd count {count} (limit {max_count})"
    );
    Ok(count)
}

fn read_f32_inner(
    buffers: &Buffers,
    accessor: &gltf::Accessor,
    dims: Dimensions,
    max_count: usize,
) -> Result<Vec<f32>> {
    ensure!(
        accessor.dimensions() == dims,
        "has type {:?}, expected {dims:?}",
        accessor.dimensions()
    );
    let count = check_count(accessor, max_count)?;
    let ty = accessor.data_type();
    let n = dimension_count(dims);
    let csize = component_size(ty);
    let elem = n * csize;
    let normalized = accessor.normalized();
    let mut out = Vec::new();
    match accessor.view() {
        Some(view) => {
            let bytes = buffers.view(&view)?;
            let stride = view.stride().unwrap_or(elem);
            ensure!(
                stride >= elem,
                "byteStride {stride} is smaller than an element ({elem} bytes)"
            );
            let iter = strided(bytes, accessor.offset(), stride, elem, count)?;
            out.reserve_exact(count * n);
            for e in iter {
                out.extend(
                    e.chunks_exact(csize)
                        .map(|c| component_f32(ty, c, normalized)),
                );
            }
        }
        None => out.resize(count * n, 0.0),
    }
    if let Some(sparse) = accessor.sparse() {
        let k = sparse.count();
        ensure!(
            k <= count,
            "sparse count {k} exceeds accessor count {count}"
        );
        let idx = sparse.indices();
        let ity = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => DataType::U8,
            gltf::accessor::sparse::IndexType::U16 => DataType::U16,
            gltf::accessor::sparse::IndexType::U32 => DataType::U32,
        };
        let ibytes = buffers.view(&idx.view())?;
        let isize = component_size(ity);
        let indices = strided(ibytes, idx.offset(), isize, isize, k).context("sparse indices")?;
        let vals = sparse.values();
        let vbytes = buffers.view(&vals.view())?;
        let values = strided(vbytes, vals.offset(), elem, elem, k).context("sparse values")?;
        for (ib, vb) in indices.zip(values) {
            let i = index_u32(ity, ib)? as usize;
            ensure!(i < count, "sparse index {i} out of range (count {count})");
            for (c, cb) in vb.chunks_exact(csize).enumerate() {
                out[i * n + c] = component_f32(ty, cb, normalized);
            }
        }
    }
    Ok(out)
}

/// Reads an index accessor (SCALAR of u8/u16/u32) as `u32`s.
pub fn read_indices(buffers: &Buffers, accessor: &gltf::Accessor) -> Result<Vec<u32>> {
    let what = format!("index accessor {}", accessor.index());
    read_indices_inner(buffers, accessor).with_context(|| what)
}

fn read_indices_inner(buffers: &Buffers, accessor: &gltf::Accessor) -> Result<Vec<u32>> {
    ensure!(
        accessor.dimensions() == Dimensions::Scalar,
        "has type {:?}, expected Scalar",
        accessor.dimensions()
    );
    let ty = accessor.data_type();
    ensure!(
        matches!(ty, DataType::U8 | DataType::U16 | DataType::U32),
        "bad component type {ty:?} for indices (need u8, u16 or u32)"
    );
    ensure!(
        accessor.sparse().is_none(),
        "sparse index accessors are not supported"
    );
    let count = check_count(accessor, MAX_INDICES)?;
    let view = accessor
        .view()
        .ok_or_else(|| anyhow!("index accessor has no bufferView"))?;
    let bytes = buffers.view(&view)?;
    let elem = component_size(ty);
    let stride = view.stride().unwrap_or(elem);
    ensure!(
        stride >= elem,
        "byteStride {stride} is smaller than an index"
    );
    let mut out = Vec::with_capacity(count);
    for e in strided(bytes, accessor.offset(), stride, elem, count)? {
        out.push(index_u32(ty, e)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_with_and_without_padding() {
        assert_eq!(decode_base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(decode_base64("aGVsbG8").unwrap(), b"hello");
        assert_eq!(decode_base64("").unwrap(), b"");
        assert!(decode_base64("a").is_err());
        assert!(decode_base64("aGV$").is_err());
    }

    #[test]
    fn percent_encoded_uris_are_decoded() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("%4"), "%4");
    }

    #[test]
    fn glb_with_huge_chunk_length_is_truncated_error() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(28u32.to_le_bytes());
        glb.extend(u32::MAX.to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(b"{}  ");
        let err = split_glb(&glb).err().unwrap().to_string();
        assert!(err.contains("truncated"), "{err}");
    }
}

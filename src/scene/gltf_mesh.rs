//! One glTF primitive → one [`Mesh`], with the repairs that make [`Mesh`]'s invariants hold.
//!
//! Repairs (each logged once per mesh): zero-area triangles dropped; zero-length or
//! non-finite normals, and normals facing away from every triangle they belong to (flipped),
//! recomputed from the adjacent faces; non-finite UVs zeroed; missing
//! normals computed as flat face normals (the glTF specification requires flat normals).
//! Rejected: non-finite positions, indices out of range, bad accessor types.

use super::gltf_data::{read_f32, read_indices, Buffers, MAX_VERTICES};
use super::Mesh;
use anyhow::{bail, ensure, Context, Result};
use glam::{Vec2, Vec3};
use gltf::accessor::Dimensions;
use gltf::mesh::Mode;
use gltf::Semantic;

/// Converts a primitive. `Ok(None)` when the primitive is skipped (points, lines, or nothing
/// left after dropping degenerate triangles); the caller has been warned through the log.
pub fn convert_primitive(
    file: &str,
    name: &str,
    primitive: &gltf::Primitive,
    buffers: &Buffers,
    material: usize,
) -> Result<Option<Mesh>> {
    let mode = primitive.mode();
    if matches!(
        mode,
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
    ) {
        log::warn!("{file}: mesh {name}: skipping {mode:?} primitive (only triangles render)");
        return Ok(None);
    }
    let pos_acc = primitive
        .get(&Semantic::Positions)
        .context("primitive has no POSITION attribute")?;
    let positions: Vec<Vec3> = read_f32(buffers, &pos_acc, Dimensions::Vec3, MAX_VERTICES)
        .context("POSITION")?
        .chunks_exact(3)
        .map(Vec3::from_slice)
        .collect();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        bail!("non-finite vertex position at vertex {i}");
    }
    let n = positions.len();
    let normals = match primitive.get(&Semantic::Normals) {
        Some(acc) => {
            ensure!(
                acc.count() == n,
                "NORMAL count {} differs from POSITION count {n}",
                acc.count()
            );
            let v = read_f32(buffers, &acc, Dimensions::Vec3, MAX_VERTICES).context("NORMAL")?;
            Some(v.chunks_exact(3).map(Vec3::from_slice).collect::<Vec<_>>())
        }
        None => None,
    };
    let mut uvs = match primitive.get(&Semantic::TexCoords(0)) {
        Some(acc) => {
            ensure!(
                acc.count() == n,
                "TEXCOORD_0 count {} differs from POSITION count {n}",
                acc.count()
            );
            let v =
                read_f32(buffers, &acc, Dimensions::Vec2, MAX_VERTICES).context("TEXCOORD_0")?;
            v.chunks_exact(2).map(Vec2::from_slice).collect::<Vec<_>>()
        }
        None => vec![Vec2::ZERO; n],
    };
    if uvs.iter().any(|uv| !uv.is_finite()) {
        log::warn!("{file}: mesh {name}: non-finite texture coordinates replaced by 0");
        uvs.iter_mut()
            .filter(|uv| !uv.is_finite())
            .for_each(|uv| *uv = Vec2::ZERO);
    }

    let indices = match primitive.indices() {
        Some(acc) => read_indices(buffers, &acc)?,
        None => (0..n as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
        bail!("index {bad} out of range (the primitive has {n} vertices)");
    }
    let triangles = assemble(file, name, mode, &indices);

    let mut mesh = Mesh {
        name: name.to_owned(),
        positions,
        normals: Vec::new(),
        uvs,
        triangles,
        material,
    };
    drop_degenerate(file, &mut mesh);
    if mesh.triangles.is_empty() {
        log::warn!("{file}: mesh {name}: no triangles left, primitive skipped");
        return Ok(None);
    }
    match normals {
        Some(normals) => {
            mesh.normals = normals;
            repair_normals(file, &mut mesh);
        }
        None => {
            ensure!(
                mesh.triangles.len() * 3 <= MAX_VERTICES,
                "absurd size: flat normals for {} triangles need more than {MAX_VERTICES} vertices",
                mesh.triangles.len()
            );
            flat_normals(&mut mesh)
        }
    }
    Ok(Some(mesh))
}

/// Index list → triangles, for TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN (glTF §3.7.2.1).
fn assemble(file: &str, name: &str, mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i], idx[i + 2], idx[i + 1]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[i], idx[i + 1], idx[0]])
            .collect(),
        _ => {
            if idx.len() % 3 != 0 {
                log::warn!(
                    "{file}: mesh {name}: {} indices is not a multiple of 3; the last {} ignored",
                    idx.len(),
                    idx.len() % 3
                );
            }
            idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        }
    }
}

/// Twice the triangle's area vector (unnormalised face normal).
fn face_cross(mesh: &Mesh, t: &[u32; 3]) -> Vec3 {
    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
    (b - a).cross(c - a)
}

fn is_degenerate(mesh: &Mesh, t: &[u32; 3]) -> bool {
    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
    let longest = (b - a)
        .length_squared()
        .max((c - a).length_squared())
        .max((c - b).length_squared());
    let cross = (b - a).cross(c - a).length();
    !(cross.is_finite() && cross > longest * 1e-7 && cross > 0.0)
}

fn drop_degenerate(file: &str, mesh: &mut Mesh) {
    let before = mesh.triangles.len();
    let keep: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|t| !is_degenerate(mesh, t))
        .copied()
        .collect();
    if keep.len() < before {
        log::warn!(
            "{file}: mesh {}: dropped {} zero-area triangle(s)",
            mesh.name,
            before - keep.len()
        );
    }
    mesh.triangles = keep;
}

/// glTF: "When normals are not specified, client implementations MUST calculate flat normals."
/// Every triangle gets its own three vertices.
fn flat_normals(mesh: &mut Mesh) {
    let mut positions = Vec::with_capacity(mesh.triangles.len() * 3);
    let mut normals = Vec::with_capacity(mesh.triangles.len() * 3);
    let mut uvs = Vec::with_capacity(mesh.triangles.len() * 3);
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        let n = face_cross(mesh, t).normalize();
        let base = positions.len() as u32;
        for &i in t {
            positions.push(mesh.positions[i as usize]);
            normals.push(n);
            uvs.push(mesh.uvs[i as usize]);
        }
        triangles.push([base, base + 1, base + 2]);
    }
    mesh.positions = positions;
    mesh.normals = normals;
    mesh.uvs = uvs;
    mesh.triangles = triangles;
}

/// Normalises the given normals; those that cannot be (zero, non-finite) are recomputed as the
/// area-weighted average of the adjacent face normals.
fn repair_normals(file: &str, mesh: &mut Mesh) {
    let bad: Vec<bool> = mesh
        .normals
        .iter()
        .map(|n| {
            let l = n.length();
            !(l.is_finite() && l > 1e-12)
        })
        .collect();
    let bad_count = bad.iter().filter(|&&b| b).count();
    if bad_count > 0 {
        log::warn!(
            "{file}: mesh {}: {bad_count} zero-length or non-finite normal(s) recomputed from geometry",
            mesh.name
        );
        let mut acc = vec![Vec3::ZERO; mesh.positions.len()];
        for t in &mesh.triangles {
            let f = face_cross(mesh, t);
            for &i in t {
                if bad[i as usize] {
                    acc[i as usize] += f;
                }
            }
        }
        for (i, n) in mesh.normals.iter_mut().enumerate() {
            if bad[i] {
                *n = acc[i];
            }
        }
    }
    for n in &mut mesh.normals {
        *n = n.try_normalize().unwrap_or(Vec3::Y);
    }
    flip_backward_normals(file, mesh);
}

/// Hard case "flipped normals": a normal that points behind every triangle it belongs to
/// (against the winding, glTF's front side) would make the surface black to direct light and
/// reject every photon by the front-side test; it is recomputed from the adjacent faces.
fn flip_backward_normals(file: &str, mesh: &mut Mesh) {
    let mut faces = vec![Vec3::ZERO; mesh.positions.len()];
    let mut agrees = vec![false; mesh.positions.len()];
    for t in &mesh.triangles {
        let f = face_cross(mesh, t);
        for &i in t {
            faces[i as usize] += f;
            agrees[i as usize] |= mesh.normals[i as usize].dot(f) > 0.0;
        }
    }
    let mut flipped = 0usize;
    for ((n, face), agrees) in mesh.normals.iter_mut().zip(&faces).zip(&agrees) {
        if let (false, Some(face)) = (*agrees, face.try_normalize()) {
            *n = face;
            flipped += 1;
        }
    }
    if flipped > 0 {
        log::warn!(
            "{file}: mesh {}: {flipped} normal(s) facing away from every adjacent triangle recomputed from geometry",
            mesh.name
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_and_fan_keep_gltf_winding() {
        let idx = [0, 1, 2, 3, 4];
        assert_eq!(
            assemble("f", "m", Mode::TriangleStrip, &idx),
            vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]
        );
        assert_eq!(
            assemble("f", "m", Mode::TriangleFan, &idx),
            vec![[1, 2, 0], [2, 3, 0], [3, 4, 0]]
        );
    }

    #[test]
    fn repaired_normals_are_unit_and_face_outward() {
        let mut mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::ZERO, Vec3::splat(f32::NAN), Vec3::Z * 3.0],
            uvs: vec![Vec2::ZERO; 3],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        };
        repair_normals("f", &mut mesh);
        for n in &mesh.normals {
            assert!((*n - Vec3::Z).length() < 1e-6);
        }
    }

    #[test]
    fn flipped_normals_are_recomputed_and_tilted_ones_kept() {
        let tilted = Vec3::new(0.3, 0.0, 1.0).normalize();
        let mut mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::NEG_Z, tilted, Vec3::new(0.0, 0.2, -1.0)],
            uvs: vec![Vec2::ZERO; 3],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        };
        repair_normals("f", &mut mesh);
        assert!((mesh.normals[0] - Vec3::Z).length() < 1e-6);
        assert!((mesh.normals[1] - tilted).length() < 1e-6);
        assert!((mesh.normals[2] - Vec3::Z).length() < 1e-6);
    }
}

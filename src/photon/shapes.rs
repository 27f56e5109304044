//! Procedural meshes for tests and benchmarks: a closed icosphere with shared vertices, a
//! grid, and a one-instance-per-mesh [`Scene`] around them.

use glam::{Mat4, Vec2, Vec3};

use crate::scene::{Instance, Material, Mesh, Scene};

/// A closed unit icosphere: an icosahedron whose faces are split into four `subdivisions`
/// times, with vertices shared between faces (so every edge belongs to exactly two triangles)
/// and projected onto the sphere. Counter-clockwise seen from outside; normals point out.
pub fn icosphere(subdivisions: u32) -> Mesh {
    let (positions, triangles) = crate::scene::authoring::unit_icosphere(subdivisions);
    Mesh {
        name: format!("icosphere{subdivisions}"),
        normals: positions.clone(),
        uvs: crate::scene::authoring::sphere_uvs(&positions),
        positions,
        triangles,
        material: 0,
    }
}

/// A `cells × cells` grid of unit-square cells in the XZ plane at y = 0, starting at the
/// origin, facing +Y, with `height(x, z)` added to y.
pub fn grid(cells: u32, height: impl Fn(f32, f32) -> f32) -> Mesh {
    let n = cells + 1;
    let mut positions = Vec::with_capacity((n * n) as usize);
    let mut uvs = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let (x, z) = (i as f32, j as f32);
            positions.push(Vec3::new(x, height(x, z), z));
            uvs.push(Vec2::new(x, z) / cells as f32);
        }
    }
    let mut triangles = Vec::with_capacity((cells * cells * 2) as usize);
    for j in 0..cells {
        for i in 0..cells {
            let v = j * n + i;
            triangles.push([v, v + n, v + 1]);
            triangles.push([v + 1, v + n, v + n + 1]);
        }
    }
    Mesh {
        name: format!("grid{cells}"),
        normals: vec![Vec3::Y; positions.len()],
        positions,
        uvs,
        triangles,
        material: 0,
    }
}

/// A scene with one default material and one instance per `(mesh, transform)`.
pub fn scene_of(meshes: Vec<(Mesh, Mat4)>) -> Scene {
    let mut scene = Scene {
        materials: vec![Material::default()],
        ..Scene::default()
    };
    for (i, (mesh, transform)) in meshes.into_iter().enumerate() {
        scene.instances.push(Instance {
            name: format!("{}#{i}", mesh.name),
            mesh: i,
            transform,
        });
        scene.meshes.push(mesh);
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    #[test]
    fn icosphere_is_closed_with_every_edge_shared_by_two_triangles() {
        let mesh = icosphere(2);
        assert_eq!(mesh.triangles.len(), 320);
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &mesh.triangles {
            for k in 0..3 {
                // Directed edges: a closed, consistently wound mesh has each one exactly once,
                // and its reverse exactly once.
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &count) in &edges {
            assert_eq!(count, 1);
            assert_eq!(edges.get(&(b, a)), Some(&1));
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            assert!((b - a).cross(c - a).dot(a) > 0.0, "faces outwards");
        }
    }
}

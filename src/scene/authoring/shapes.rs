//! Meshes for the bundled scenes: every shape has outward unit normals and CCW winding seen
//! from the side its normals point to.

use glam::{Mat3, Quat, Vec2, Vec3};
use std::collections::HashMap;

/// Indexed triangles with per-vertex normals and UVs (CCW seen from the normal's side).
#[derive(Default, Clone)]
pub struct Geometry {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
}

impl Geometry {
    fn append(&mut self, other: Geometry) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        self.normals.extend(other.normals);
        self.uvs.extend(other.uvs);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }
}

/// A rectangle centred at `center` facing `normal`, with half-sizes `hu`, `hv` along tangents.
pub fn quad(center: Vec3, normal: Vec3, hu: f32, hv: f32) -> Geometry {
    let n = normal.normalize();
    let a = if n.y.abs() > 0.5 { Vec3::X } else { Vec3::Y };
    let u = a.cross(n).normalize();
    let v = n.cross(u);
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    Geometry {
        positions: corners
            .iter()
            .map(|&(s, t)| center + u * (s * hu) + v * (t * hv))
            .collect(),
        normals: vec![n; 4],
        uvs: corners
            .iter()
            .map(|&(s, t)| Vec2::new(s * 0.5 + 0.5, 0.5 - t * 0.5))
            .collect(),
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// An axis-aligned box centred at the origin with outward normals.
pub fn cuboid(half: Vec3) -> Geometry {
    let mut g = Geometry::default();
    for n in [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ] {
        let a = if n.y.abs() > 0.5 { Vec3::X } else { Vec3::Y };
        let u = a.cross(n);
        let v = n.cross(u);
        g.append(quad(n * half, n, (u * half).length(), (v * half).length()));
    }
    g
}

/// The unit icosphere: the icosahedron's 20 faces split into four `levels` times, vertices
/// shared between faces and projected onto the unit sphere, counter-clockwise seen from
/// outside. The one icosphere of the project: the bundled scenes, the tests' closed meshes
/// (`photon::shapes`) and the photon volumes (`levels = 0`) are all built from it.
pub fn unit_icosphere(levels: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut pos: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push((pos[a as usize] + pos[b as usize]).normalize());
                pos.len() as u32 - 1
            })
        };
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    (pos, tris)
}

/// Spherical UVs of unit-sphere points (longitude, latitude).
pub fn sphere_uvs(points: &[Vec3]) -> Vec<Vec2> {
    points
        .iter()
        .map(|p| {
            Vec2::new(
                0.5 + p.z.atan2(p.x) / std::f32::consts::TAU,
                0.5 - p.y.asin() / std::f32::consts::PI,
            )
        })
        .collect()
}

/// An icosphere of `radius` centred at the origin, subdivided `levels` times.
pub fn icosphere(radius: f32, levels: u32) -> Geometry {
    let (pos, tris) = unit_icosphere(levels);
    let mut indices = Vec::with_capacity(tris.len() * 3);
    for [a, b, c] in tris {
        let (pa, pb, pc) = (pos[a as usize], pos[b as usize], pos[c as usize]);
        let outward = (pb - pa).cross(pc - pa).dot(pa + pb + pc) > 0.0;
        indices.extend(if outward { [a, b, c] } else { [a, c, b] });
    }
    Geometry {
        uvs: sphere_uvs(&pos),
        normals: pos.clone(),
        positions: pos.iter().map(|p| *p * radius).collect(),
        indices,
    }
}

/// A thin-walled open ring standing on y = 0: outer wall, inner wall, top and bottom rims.
pub fn ring(radius: f32, height: f32, thickness: f32, segments: u32) -> Geometry {
    let mut g = Geometry::default();
    let (r_out, r_in) = (radius + thickness * 0.5, radius - thickness * 0.5);
    let dir = |i: u32| {
        let a = i as f32 / segments as f32 * std::f32::consts::TAU;
        Vec3::new(a.cos(), 0.0, -a.sin())
    };
    // Walls: (radius, normal sign). Rims: (y, normal).
    for (r, sign) in [(r_out, 1.0f32), (r_in, -1.0)] {
        let mut w = Geometry::default();
        for i in 0..=segments {
            let d = dir(i);
            for y in [0.0, height] {
                w.positions.push(d * r + Vec3::Y * y);
                w.normals.push(d * sign);
                w.uvs
                    .push(Vec2::new(i as f32 / segments as f32, 1.0 - y / height));
            }
        }
        for i in 0..segments {
            let (b0, t0, b1, t1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            if sign > 0.0 {
                w.indices.extend([b0, b1, t1, b0, t1, t0]);
            } else {
                w.indices.extend([b0, t1, b1, b0, t0, t1]);
            }
        }
        g.append(w);
    }
    for (y, n) in [(height, Vec3::Y), (0.0, Vec3::NEG_Y)] {
        let mut rim = Geometry::default();
        for i in 0..=segments {
            let d = dir(i);
            for r in [r_in, r_out] {
                rim.positions.push(d * r + Vec3::Y * y);
                rim.normals.push(n);
                rim.uvs
                    .push(Vec2::new(i as f32 / segments as f32, r / r_out));
            }
        }
        for i in 0..segments {
            let (i0, o0, i1, o1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            if n.y > 0.0 {
                rim.indices.extend([i0, o0, o1, i0, o1, i1]);
            } else {
                rim.indices.extend([i0, o1, o0, i0, i1, o1]);
            }
        }
        g.append(rim);
    }
    g
}

/// Rotation that turns a node's −Z (where lights shine and cameras look) towards `dir`, with
/// +Y kept as close to world up as possible.
pub fn look_rotation(dir: Vec3) -> Quat {
    let f = dir.normalize();
    let up = if f.y.abs() > 0.999 { Vec3::Z } else { Vec3::Y };
    let x = f.cross(up).normalize();
    let y = x.cross(f);
    Quat::from_mat3(&Mat3::from_cols(x, y, -f)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_winding(g: &Geometry) {
        for t in g.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| g.positions[i as usize]);
            let face = (b - a).cross(c - a);
            assert!(face.length() > 0.0);
            for &i in t {
                assert!(
                    face.dot(g.normals[i as usize]) > 0.0,
                    "winding disagrees with normal"
                );
            }
        }
    }

    #[test]
    fn generated_shapes_wind_ccw_around_their_normals() {
        check_winding(&quad(Vec3::ZERO, Vec3::NEG_X, 1.0, 2.0));
        check_winding(&cuboid(Vec3::new(1.0, 2.0, 3.0)));
        check_winding(&icosphere(1.0, 2));
        check_winding(&ring(0.5, 0.2, 0.02, 32));
    }

    #[test]
    fn look_rotation_points_minus_z_along_the_direction() {
        for d in [Vec3::NEG_Y, Vec3::new(1.0, -0.3, 0.2), Vec3::Z] {
            let r = look_rotation(d);
            assert!((r * Vec3::NEG_Z - d.normalize()).length() < 1e-5);
        }
    }
}

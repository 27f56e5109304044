//! Emissive triangles as light sources (issue #18): their power, and the points every method
//! samples on them. No Vulkan.
//!
//! A triangle whose material has `emission` L_e > 0 (W/(m²·sr), the same radiometric unit the
//! punctual lights are converted to, `scene::units`) is a Lambertian emitter: it sends
//! `Φ = π·L_e·A` watts out of its **front side** (counter-clockwise winding, as
//! `Hit::front_face`), and out of both sides when its material is double-sided (glTF
//! `doubleSided`). Each emitting side is one [`EmitterFace`].
//!
//! The GPU renderer turns the emitters into **area-sample lights** ([`LightKind::AreaSample`]):
//! each frame, `count` points on the emitters, chosen by power and spread over the frames of an
//! accumulation by a low-discrepancy sequence ([`Emitters::lights`]), each a one-sided light
//! with the face's normal and radiant intensity `I(θ) = I₀·max(0, cos θ)`, `I₀ = Φ_k/π` for the
//! share Φ_k of the emitted power its point stands for. They are shadow-mapped and emit photons
//! like any punctual light, so averaged over frames the direct light converges to the area
//! light's soft shadows and the photons to its emission. The CPU references sample the same
//! faces directly ([`Emitters::sample`]): next-event estimation and photon emission by area.

use super::{Light, LightKind, MaterialId, Scene};
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;

/// How far (relative to the scene's bounding-box diagonal) an area-sample light sits in front
/// of its face: off the surface, so the face is behind the light and neither shadows nor
/// receives its light (the shadow views' near plane is at the same distance).
pub const AREA_SAMPLE_OFFSET: f32 = 1e-4;

/// The generators of the 3D Kronecker (R3) sequence: 1/g, 1/g², 1/g³ for g the real root of
/// x⁴ = x + 1 (Roberts 2018), in f64 so that point `i` stays accurate for large `i`.
const R3: [f64; 3] = [
    0.819_172_513_396_164_4,
    0.671_043_606_703_789_2,
    0.549_700_477_901_970_4,
];

/// One emitting side of an emissive triangle, in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct EmitterFace {
    pub vertices: [Vec3; 3],
    /// Unit normal of the side that emits.
    pub normal: Vec3,
    pub area: f32,
    /// Emitted radiance L_e, W/(m²·sr), linear RGB.
    pub radiance: Vec3,
    pub material: MaterialId,
}

impl EmitterFace {
    /// The face's flux `π·L_e·A` (W, RGB).
    pub fn flux(&self) -> Vec3 {
        self.radiance * (PI * self.area)
    }

    /// The point with barycentric coordinates drawn from `u` in [0, 1)² (uniform by area).
    pub fn point(&self, u: Vec2) -> Vec3 {
        let s = u.x.sqrt();
        let (b1, b2) = (s * (1.0 - u.y), s * u.y);
        let [a, b, c] = self.vertices;
        a + (b - a) * b1 + (c - a) * b2
    }
}

/// A point drawn on the emitters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterSample {
    pub position: Vec3,
    /// The emitting side's unit normal.
    pub normal: Vec3,
    /// Emitted radiance at the point, W/(m²·sr).
    pub radiance: Vec3,
    /// Probability density of the point per unit area (over all faces).
    pub pdf_area: f32,
    /// The flux this point stands for: the face's flux over the probability of its face (W).
    pub flux: Vec3,
    /// Index into [`Emitters::faces`].
    pub face: usize,
}

/// The emissive faces of a scene, with a distribution ∝ each face's mean flux.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Emitters {
    pub faces: Vec<EmitterFace>,
    /// Cumulative mean flux, `cdf[i]` = Σ_{j ≤ i} Φ̄_j / Φ̄ (the last is 1).
    cdf: Vec<f64>,
    /// Σ mean flux (W).
    total: f64,
    /// The scene's bounding-box diagonal (sizes [`AREA_SAMPLE_OFFSET`]).
    diagonal: f32,
}

fn mean(v: Vec3) -> f64 {
    (f64::from(v.x) + f64::from(v.y) + f64::from(v.z)) / 3.0
}

impl Emitters {
    /// Every emitting side of every instance's emissive triangles.
    pub fn of(scene: &Scene) -> Self {
        let mut faces = Vec::new();
        for (vertices, material) in scene.world_triangles() {
            let Some(m) = scene.materials.get(material) else {
                continue;
            };
            // An unlit material shows its colour but lights nothing (`Material::is_emitter`).
            let radiance = m.emission;
            if !(m.is_emitter() && radiance.is_finite()) {
                continue;
            }
            let [a, b, c] = vertices.map(Vec3::as_dvec3);
            let cross: DVec3 = (b - a).cross(c - a);
            let area = 0.5 * cross.length();
            if !(area.is_finite() && area > 0.0) {
                continue;
            }
            let normal = (cross / (2.0 * area)).as_vec3();
            let face = EmitterFace {
                vertices,
                normal,
                area: area as f32,
                radiance: radiance.max(Vec3::ZERO),
                material,
            };
            if m.double_sided {
                faces.push(EmitterFace {
                    normal: -normal,
                    ..face.clone()
                });
            }
            faces.push(face);
        }
        let mut cdf = Vec::with_capacity(faces.len());
        let mut total = 0.0;
        for f in &faces {
            total += mean(f.flux());
            cdf.push(total);
        }
        if total > 0.0 {
            cdf.iter_mut().for_each(|c| *c /= total);
        }
        let bounds = scene.bounds();
        let diagonal = if bounds.is_empty() {
            1.0
        } else {
            bounds.extent().length().max(1e-6)
        };
        Self {
            faces,
            cdf,
            total,
            diagonal,
        }
    }

    /// No emitter carries power.
    pub fn is_empty(&self) -> bool {
        !(self.total > 0.0 && self.total.is_finite())
    }

    /// The emitters' total flux (W, RGB).
    pub fn flux(&self) -> Vec3 {
        self.faces.iter().fold(Vec3::ZERO, |s, f| s + f.flux())
    }

    /// The probability of face `i` (∝ its mean flux).
    pub fn face_probability(&self, i: usize) -> f64 {
        let below = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - below
    }

    /// A point on the emitters for `u` in [0, 1)³: `u[0]` picks the face ∝ power, `u[1..3]`
    /// the point on it, uniformly by area. `None` when there are no emitters.
    pub fn sample(&self, u: [f32; 3]) -> Option<EmitterSample> {
        if self.is_empty() {
            return None;
        }
        let x = f64::from(u[0]);
        let face = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.faces.len() - 1);
        let p = self.face_probability(face);
        let f = &self.faces[face];
        Some(EmitterSample {
            position: f.point(Vec2::new(u[1], u[2])),
            normal: f.normal,
            radiance: f.radiance,
            pdf_area: (p / f64::from(f.area)) as f32,
            flux: f.flux() / p as f32,
            face,
        })
    }

    /// `p` on a face with unit normal `normal`, moved [`AREA_SAMPLE_OFFSET`] of the scene's
    /// diagonal in front of it (where lights and shadow rays start or end).
    pub fn in_front(&self, p: Vec3, normal: Vec3) -> Vec3 {
        p + normal * (AREA_SAMPLE_OFFSET * self.diagonal)
    }

    /// Point `index` of the R3 low-discrepancy sequence in [0, 1)³.
    pub fn sequence(index: u64) -> [f32; 3] {
        R3.map(|a| (0.5 + a * index as f64).fract() as f32)
    }

    /// The `count` area-sample lights of frame `sample` (empty without emitters): points
    /// `sample·count … sample·count + count − 1` of the R3 sequence on the emitters
    /// ([`Emitters::sample`]), each carrying 1/count of the flux its point stands for, placed
    /// [`AREA_SAMPLE_OFFSET`] of the scene's diagonal in front of its face. Over the frames of
    /// an accumulation the points fill the emitters evenly, by power.
    pub fn lights(&self, scene: &Scene, sample: u32, count: u32) -> Vec<Light> {
        if self.is_empty() || count == 0 {
            return Vec::new();
        }
        (0..count)
            .filter_map(|k| {
                let index = u64::from(sample) * u64::from(count) + u64::from(k);
                let s = self.sample(Self::sequence(index))?;
                let material = scene
                    .materials
                    .get(self.faces[s.face].material)
                    .map_or("default", |m| m.name.as_str());
                Some(Light {
                    name: format!("emitter sample {k} ('{material}')"),
                    kind: LightKind::AreaSample,
                    position: self.in_front(s.position, s.normal),
                    direction: s.normal,
                    intensity: s.flux / (PI * count as f32),
                })
            })
            .collect()
    }

    /// `scene` with its emitters' area-sample lights of frame 0 after its own lights (what a
    /// renderer of it plans and draws first, `frame/emission.rs`); a scene that already has
    /// area samples, or no emitters, is returned as it is.
    pub fn with_area_samples(scene: &Scene, count: u32) -> Scene {
        let mut out = scene.clone();
        if !scene.lights.iter().any(|l| l.kind == LightKind::AreaSample) {
            out.lights
                .extend(Emitters::of(scene).lights(scene, 0, count));
        }
        out
    }

    /// A one-line description for the effects plan: how many faces, of which material, and
    /// their power.
    pub fn describe(&self, scene: &Scene) -> String {
        let Some(first) = self.faces.first() else {
            return "no emissive surfaces".to_string();
        };
        let name = scene
            .materials
            .get(first.material)
            .map_or("default", |m| m.name.as_str());
        let flux = self.flux();
        format!(
            "{} emissive face(s), material '{name}' first, flux ({:.3}, {:.3}, {:.3}) W",
            self.faces.len(),
            flux.x,
            flux.y,
            flux.z
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Instance, Material, Mesh};
    use glam::Mat4;

    /// A unit square at height 1 facing down (−Y), emitting `radiance`, and a dim triangle.
    fn panel_scene(double_sided: bool) -> Scene {
        let square = Mesh {
            name: "panel".into(),
            positions: vec![
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
            normals: vec![Vec3::NEG_Y; 4],
            uvs: vec![Vec2::ZERO; 4],
            // Counter-clockwise seen from below.
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            material: 0,
        };
        let dim = Mesh {
            name: "dim".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z],
            normals: vec![Vec3::Y; 3],
            uvs: vec![Vec2::ZERO; 3],
            triangles: vec![[0, 2, 1]],
            material: 1,
        };
        Scene {
            meshes: vec![square, dim],
            instances: vec![
                Instance {
                    name: "panel".into(),
                    mesh: 0,
                    transform: Mat4::IDENTITY,
                },
                Instance {
                    name: "dim".into(),
                    mesh: 1,
                    transform: Mat4::IDENTITY,
                },
            ],
            materials: vec![
                Material {
                    name: "lamp".into(),
                    emission: Vec3::new(2.0, 1.0, 3.0),
                    double_sided,
                    ..Material::default()
                },
                Material {
                    name: "ember".into(),
                    emission: Vec3::splat(0.1),
                    ..Material::default()
                },
            ],
            ..Scene::default()
        }
    }

    #[test]
    fn faces_emit_pi_radiance_area_from_the_front_side() {
        let e = Emitters::of(&panel_scene(false));
        assert_eq!(e.faces.len(), 3);
        assert!(e.faces[..2]
            .iter()
            .all(|f| f.normal.abs_diff_eq(Vec3::NEG_Y, 1e-6)));
        assert!(e.faces[2].normal.abs_diff_eq(Vec3::Y, 1e-6));
        let expected = Vec3::new(2.0, 1.0, 3.0) * PI + Vec3::splat(0.1 * PI * 0.5);
        assert!(e.flux().abs_diff_eq(expected, 1e-5), "{}", e.flux());
        // Double-sided: both sides of the panel emit.
        let both = Emitters::of(&panel_scene(true));
        assert_eq!(both.faces.len(), 5);
        let twice = Vec3::new(2.0, 1.0, 3.0) * (2.0 * PI) + Vec3::splat(0.1 * PI * 0.5);
        assert!(both.flux().abs_diff_eq(twice, 1e-5));
    }

    #[test]
    fn area_sample_lights_carry_the_emitted_flux_on_average() {
        let scene = panel_scene(false);
        let e = Emitters::of(&scene);
        let (frames, count) = (2000u32, 4u32);
        let mut sum = DVec3::ZERO;
        let mut on_dim = 0usize;
        for sample in 0..frames {
            for l in e.lights(&scene, sample, count) {
                assert_eq!(l.kind, LightKind::AreaSample);
                sum += (l.intensity * PI).as_dvec3();
                on_dim += usize::from(l.direction.y > 0.0);
                if l.direction.y < 0.0 {
                    let p = l.position;
                    assert!(p.x >= 0.0 && p.x <= 1.0 && p.z >= 0.0 && p.z <= 1.0, "{p}");
                    assert!(p.y < 1.0 && p.y > 1.0 - 1e-3, "in front of the panel: {p}");
                }
            }
        }
        let mean_flux = sum / f64::from(frames);
        let flux = e.flux().as_dvec3();
        assert!(
            ((mean_flux - flux).abs() / flux).max_element() < 2e-3,
            "{mean_flux} vs {flux}"
        );
        // The dim face gets its share of the points by power (0.05/6.33 of them).
        let share = on_dim as f64 / f64::from(frames * count);
        let expected = mean(e.faces[2].flux()) / e.total;
        assert!((share - expected).abs() < 1e-3, "{share} vs {expected}");
    }

    #[test]
    fn points_cover_the_panel_evenly() {
        let scene = panel_scene(false);
        let e = Emitters::of(&scene);
        let mut bins = [0usize; 16];
        let mut n = 0;
        for sample in 0..4000 {
            for l in e.lights(&scene, sample, 4) {
                if l.direction.y < 0.0 {
                    let (i, j) = ((l.position.x * 4.0) as usize, (l.position.z * 4.0) as usize);
                    bins[i.min(3) * 4 + j.min(3)] += 1;
                    n += 1;
                }
            }
        }
        for b in bins {
            let share = b as f64 / n as f64;
            assert!((share - 1.0 / 16.0).abs() < 2e-3, "{bins:?}");
        }
    }

    #[test]
    fn a_scene_without_emission_has_no_emitters() {
        let mut scene = panel_scene(false);
        scene
            .materials
            .iter_mut()
            .for_each(|m| m.emission = Vec3::ZERO);
        let e = Emitters::of(&scene);
        assert!(e.is_empty());
        assert!(e.lights(&scene, 0, 4).is_empty());
        assert!(e.sample([0.5; 3]).is_none());
    }
}

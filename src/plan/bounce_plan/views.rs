//! [`BouncePlan`]'s views from the photon budget: each light's share, its main views'
//! resolution (the probe of its cone), its caustic windows and their subdivision k, the slots
//! grown to hold the budget, the per-light power factor that makes its photons sum to its exact
//! flux, and the room the plan's lights need when they move (module docs: "Exact power", "Spot
//! cones", "Caustic views", "Budget").

use super::caster::{caster_rect, casters};
use super::texels::{light_seed, texel_ndc, unproject, FAR, NEAR};
use super::{
    coverage, BouncePlan, Capacity, LightsToPlan, MAX_CAUSTIC_SUBDIVISION, MAX_RESOLUTION,
};
use crate::layout::shared_constants::{BOUNCE_VIEW_CAUSTIC, BOUNCE_VIEW_PARENT, BOUNCE_VIEW_WHOLE};
use crate::layout::{
    BounceView, FrameUniforms, LIGHT_AREA_SAMPLE, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT,
};
use crate::photon::emit::{light_falloff, spot_falloff_integral};
use crate::plan::lighting::LightSetup;
use crate::scene::LightKind;
use glam::{DMat4, DVec2, DVec4, UVec4, Vec4};

/// Texels per side of the probe grid that measures the fraction of a light's texels inside its
/// cone.
const PROBE: u32 = 64;

/// `BounceView.kind.w` of a caustic view: this plus its parent's (the parent's own is its index
/// among the light's main views).
const CAUSTIC_ORDINAL: u32 = 16;

/// A caustic view's window: texels `[i0, i1) × [j0, j1)` of its parent view.
#[derive(Clone, Copy, Debug)]
struct Window {
    parent: usize,
    i0: u32,
    j0: u32,
    i1: u32,
    j1: u32,
}

impl Window {
    fn texels(&self) -> usize {
        ((self.i1 - self.i0) * (self.j1 - self.j0)) as usize
    }
}

impl BouncePlan {
    pub(super) fn plan(lights: &LightsToPlan, share: f32, max_k: u32) -> BouncePlan {
        let LightsToPlan {
            scene,
            budget,
            origin,
            bounds,
        } = *lights;
        // Shadow views are the light G-buffer's views; with resolution 1 their texel parameter
        // is the full window: 2·tan(fov/2) (perspective) or 2·radius (orthographic).
        let setup = LightSetup::photon_views(&scene.lights, origin, bounds);
        let share = if share.is_finite() {
            f64::from(share.clamp(0.0, 0.95))
        } else {
            0.0
        };
        let casters = if share > 0.0 {
            casters(scene)
        } else {
            Vec::new()
        };
        let mut plan = BouncePlan {
            origin,
            ..Default::default()
        };
        let lights = scene.lights.iter().zip(&setup.lights).zip(budget);
        for (index, ((light, gpu_light), &n)) in lights.enumerate() {
            let Some(n) = n else {
                continue;
            };
            let first = gpu_light.shadow.y as usize;
            let count = gpu_light.shadow.z as usize;
            let kind = gpu_light.shadow.x;
            let (cos_outer, cos_inner) = (gpu_light.direction.w, gpu_light.intensity.w);
            let axis = gpu_light.direction.truncate().as_dvec3();
            let ortho = kind == LIGHT_DIRECTIONAL;
            // Spots and emitters' area samples light a cone (a hemisphere) of their views.
            let coned = kind == LIGHT_SPOT || kind == LIGHT_AREA_SAMPLE;
            debug_assert!(kind == LIGHT_POINT || coned || ortho);
            let matrices: Vec<DMat4> = (first..first + count)
                .map(|v| setup.view_matrices[v])
                .collect();
            let inverses: Vec<DMat4> = matrices.iter().map(DMat4::inverse).collect();
            // Half the window: tan(fov/2) on the plane at unit distance, or metres (ortho).
            let halves: Vec<f64> = (first..first + count)
                .map(|v| f64::from(setup.views[v].params.x) * 0.5)
                .collect();
            let direction = |v: usize, ndc: DVec2| {
                (unproject(&inverses[v], ndc, FAR) - unproject(&inverses[v], ndc, NEAR)).normalize()
            };
            let in_cone =
                |v: usize, ndc: DVec2| !coned || axis.dot(direction(v, ndc)) > f64::from(cos_outer);
            let rects: Vec<Option<(DVec2, DVec2)>> = matrices
                .iter()
                .map(|m| {
                    if n > 0 && !casters.is_empty() {
                        caster_rect(m, &casters, origin)
                    } else {
                        None
                    }
                })
                .collect();
            // The probe: the fraction of the main texels inside the cone.
            let mut inside = 0usize;
            if coned {
                for v in 0..count {
                    for y in 0..PROBE {
                        for x in 0..PROBE {
                            inside += usize::from(in_cone(v, texel_ndc(x, y, PROBE, PROBE)));
                        }
                    }
                }
            } else {
                inside = count * (PROBE * PROBE) as usize;
            }
            let probes = (count as u32 * PROBE * PROBE).max(1) as f64;
            let useful = (inside.max(1) as f64 / probes).min(1.0);
            // The main views' side for the share `s` of the budget spent elsewhere, before the
            // cap at MAX_RESOLUTION.
            let main_side = |s: f64| {
                let texels = (1.0 - s) * n as f64 / (useful * count.max(1) as f64);
                texels.sqrt().ceil()
            };
            let main_res = |s: f64| {
                if n == 0 || count == 0 {
                    0
                } else {
                    (main_side(s) as u32).clamp(1, MAX_RESOLUTION)
                }
            };
            let wanted = if rects.iter().any(Option::is_some) {
                share
            } else {
                0.0
            };
            // Each rectangle as whole texels of its view at `res`; windows holding no texel
            // inside the cone are dropped (the casters are outside the light's reach).
            let windows_at = |res: u32| -> Vec<Window> {
                let mut windows = Vec::new();
                for (v, rect) in rects.iter().enumerate() {
                    let Some((lo, hi)) = rect else { continue };
                    let r = f64::from(res);
                    let to_texel = |ndc: f64| (ndc + 1.0) * 0.5 * r;
                    let w = Window {
                        parent: v,
                        i0: (to_texel(lo.x).floor().max(0.0) as u32).min(res),
                        j0: (to_texel(lo.y).floor().max(0.0) as u32).min(res),
                        i1: (to_texel(hi.x).ceil().max(0.0) as u32).min(res),
                        j1: (to_texel(hi.y).ceil().max(0.0) as u32).min(res),
                    };
                    let reaches = (w.j0..w.j1)
                        .any(|y| (w.i0..w.i1).any(|x| in_cone(v, texel_ndc(x, y, res, res))));
                    if w.i1 > w.i0 && w.j1 > w.j0 && reaches {
                        windows.push(w);
                    }
                }
                windows
            };
            let longest = |windows: &[Window]| {
                windows
                    .iter()
                    .map(|w| (w.i1 - w.i0).max(w.j1 - w.j0))
                    .max()
                    .unwrap_or(1)
            };
            let mut res = main_res(wanted);
            let mut main_share = wanted;
            let mut windows = windows_at(res);
            let window_texels: usize = windows.iter().map(Window::texels).sum();
            let mut k = if window_texels > 0 {
                let k = (wanted * n as f64 / window_texels as f64).sqrt().round() as u32;
                k.clamp(1, max_k.clamp(1, MAX_CAUSTIC_SUBDIVISION))
                    .min(MAX_RESOLUTION / longest(&windows))
            } else {
                0
            };
            if k < 2 && wanted > 0.0 {
                // Casters that fill the light's view: its main views sample them densely
                // enough, and get the whole budget (unless `max_k` = 0 took the caustic views
                // away to fit a renderer's buffers).
                windows.clear();
                if max_k > 0 {
                    res = main_res(0.0);
                    main_share = 0.0;
                }
            }
            // The photons the views send ("Budget" above): a main texel inside the cone sends
            // one; under a window, a parent texel on a caster sends its k × k caustic texels'
            // photons, one elsewhere sends its own and those of its caustic texels on a caster
            // (coverage.rs predicts which they are).
            let window_sends = |res: u32, w: &Window, k: u32| -> Vec<usize> {
                let r = f64::from(res);
                let ndc = |t: u32| f64::from(t) / r * 2.0 - 1.0;
                let rect = (
                    DVec2::new(ndc(w.i0), ndc(w.j0)),
                    DVec2::new(ndc(w.i1), ndc(w.j1)),
                );
                let (pw, ph) = (w.i1 - w.i0, w.j1 - w.j0);
                let m = &matrices[w.parent];
                let parents = coverage::covered_texels(m, origin, &casters, rect, (pw, ph));
                let children =
                    coverage::covered_texels(m, origin, &casters, rect, (pw * k, ph * k));
                let kk = (k * k) as usize;
                (0..ph)
                    .flat_map(|y| (0..pw).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        if parents[(y * pw + x) as usize] {
                            return kk;
                        }
                        let hits = (0..k)
                            .flat_map(|j| (0..k).map(move |i| (i, j)))
                            .filter(|&(i, j)| children[((y * k + j) * pw * k + x * k + i) as usize])
                            .count();
                        usize::from(hits < kk) + hits
                    })
                    .collect()
            };
            let slots_at = |res: u32, windows: &[Window], k: u32| -> usize {
                let sends: Vec<Vec<usize>> =
                    windows.iter().map(|w| window_sends(res, w, k)).collect();
                let mut slots = 0usize;
                for v in 0..count {
                    let under = |x: u32, y: u32| {
                        windows.iter().zip(&sends).find_map(|(w, s)| {
                            let inside = w.parent == v
                                && (w.i0..w.i1).contains(&x)
                                && (w.j0..w.j1).contains(&y);
                            inside.then(|| s[((y - w.j0) * (w.i1 - w.i0) + x - w.i0) as usize])
                        })
                    };
                    for y in 0..res {
                        for x in 0..res {
                            if in_cone(v, texel_ndc(x, y, res, res)) {
                                slots += under(x, y).unwrap_or(1);
                            }
                        }
                    }
                }
                slots
            };
            // The probe's estimate rounded up to whole texels may still fall short of the
            // budget (a cone's edge, the windows' whole texels): grow the main views until the
            // views hold it, then keep each texel with probability `keep` so that the light
            // emits its budget, not whole grids (bounce_map.comp, `texel_kept`).
            // A plan fitted to a renderer's buffers (`max_k` lowered by `within`) keeps its
            // main views: they hold what the buffers were sized for, and the light emits fewer
            // photons.
            let mut slots = slots_at(res, &windows, k);
            let mut grown = 0;
            let may_grow = max_k >= MAX_CAUSTIC_SUBDIVISION;
            while may_grow && n > 0 && slots < n && res < MAX_RESOLUTION && grown < 8 {
                let ratio = (n as f64 / slots.max(1) as f64).sqrt();
                res = ((f64::from(res) * ratio).ceil() as u32)
                    .max(res + 1)
                    .min(MAX_RESOLUTION);
                if !windows.is_empty() {
                    windows = windows_at(res);
                    k = k.min(MAX_RESOLUTION / longest(&windows)).max(1);
                }
                slots = slots_at(res, &windows, k);
                grown += 1;
            }
            let keep = if slots > n {
                n as f64 / slots as f64
            } else {
                1.0
            };
            plan.slots += slots;
            plan.photons += slots.min(n);
            let short = slots < n && res >= MAX_RESOLUTION;
            if n > 0 && count > 0 && (short || main_side(main_share) > f64::from(MAX_RESOLUTION)) {
                plan.lights_at_max_resolution.push(index);
            }

            // The main views' per-texel weights, summed for the exact-flux normalisation.
            let side = |v: usize| 2.0 * halves[v] / f64::from(res.max(1));
            let mut sum = 0.0f64;
            if res > 0 {
                for (v, &half) in halves.iter().enumerate() {
                    let side = side(v);
                    if ortho {
                        sum += side * side * f64::from(res * res);
                        continue;
                    }
                    for y in 0..res {
                        for x in 0..res {
                            let ndc = texel_ndc(x, y, res, res);
                            let q = ndc * half;
                            let mut w = side * side / (1.0 + q.length_squared()).powf(1.5);
                            if coned {
                                let cd = axis.dot(direction(v, ndc)) as f32;
                                w *= f64::from(light_falloff(kind, cos_inner, cos_outer, cd));
                            }
                            sum += w;
                        }
                    }
                }
            }
            let exact = match light.kind {
                LightKind::Point => 4.0 * std::f64::consts::PI,
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    std::f64::consts::TAU
                        * f64::from(spot_falloff_integral(inner_cone_angle, outer_cone_angle))
                }
                LightKind::Directional => sum,
                LightKind::AreaSample => std::f64::consts::PI,
            };
            let scale = if sum > 0.0 { exact / sum } else { 0.0 };
            let light_rel = (light.position.as_dvec3() - origin).as_vec3();
            let template = BounceView {
                inv_view_proj: glam::Mat4::IDENTITY,
                light: light_rel.extend(0.0),
                axis: gpu_light.direction,
                intensity: (light.intensity * scale as f32).extend(cos_inner),
                params: Vec4::ZERO,
                // Temporal case: keyed by the light's name, not its position, so a moving
                // light keeps every texel's random numbers (no flicker as it moves).
                texels: UVec4::new(0, 0, 0, light_seed(&scene.lights, index)),
                kind: UVec4::new(kind, BOUNCE_VIEW_WHOLE, 0, 0),
            };
            let viewer = if ortho {
                (-axis).as_vec3().extend(0.0)
            } else {
                light_rel.extend(1.0)
            };
            // Moved, the main views may grow up to the side that holds the whole budget (their
            // windows' photons falling short: "Budget"), a texel more for the probe.
            let full = (main_res(0.0) + 1).min(MAX_RESOLUTION);
            let first_view = plan.views.len();
            for v in 0..count {
                let child = windows.iter().position(|w| w.parent == v);
                let (role, child) = match child {
                    Some(c) => (BOUNCE_VIEW_PARENT, (first_view + count + c) as u32),
                    None => (BOUNCE_VIEW_WHOLE, 0),
                };
                let corner = -halves[v] as f32;
                let view = BounceView {
                    params: Vec4::new(side(v) as f32, keep as f32, corner, corner),
                    kind: UVec4::new(kind, role, child, v as u32),
                    ..template
                };
                plan.push(matrices[v], view, (res, res), viewer, index);
            }
            for w in &windows {
                let v = w.parent;
                let r = f64::from(res);
                let ndc = |t: u32| f64::from(t) / r * 2.0 - 1.0;
                let (lo, hi) = (
                    DVec2::new(ndc(w.i0), ndc(w.j0)),
                    DVec2::new(ndc(w.i1), ndc(w.j1)),
                );
                // Clip space of the parent → clip space of the window: x' = s·(x − c·w).
                let s = 2.0 / (hi - lo);
                let c = 0.5 * (lo + hi);
                let to_window = DMat4::from_cols(
                    DVec4::new(s.x, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, s.y, 0.0, 0.0),
                    DVec4::Z,
                    DVec4::new(-s.x * c.x, -s.y * c.y, 0.0, 1.0),
                );
                let parent_side = side(v);
                let view = BounceView {
                    params: Vec4::new(
                        (parent_side / f64::from(k)) as f32,
                        keep as f32,
                        (-halves[v] + f64::from(w.i0) * parent_side) as f32,
                        (-halves[v] + f64::from(w.j0) * parent_side) as f32,
                    ),
                    kind: UVec4::new(
                        kind,
                        BOUNCE_VIEW_CAUSTIC,
                        (first_view + v) as u32,
                        CAUSTIC_ORDINAL + v as u32,
                    ),
                    ..template
                };
                let extent = ((w.i1 - w.i0) * k, (w.j1 - w.j0) * k);
                plan.push(to_window * matrices[v], view, extent, viewer, index);
                plan.caustic_texels += (extent.0 * extent.1) as usize;
                // 25 % for the casters' projection, and the main views' growth (below).
                let main_growth = f64::from(full) / f64::from(res.max(1));
                let grown = |t: u32| {
                    ((f64::from(t) * 1.25 * main_growth.max(1.0)).ceil() as u32).min(MAX_RESOLUTION)
                };
                let reserve = &mut plan.reserve.extent;
                *reserve = (
                    reserve.0.max(grown(extent.0)),
                    reserve.1.max(grown(extent.1)),
                );
            }
            if !casters.is_empty() && n > 0 {
                plan.reserve.views += count;
                plan.reserve.texels += (16.0 / 9.0 * share * n as f64).ceil() as usize;
                if full > res {
                    plan.reserve.texels += count * (full * full - res * res) as usize;
                }
                let extent = &mut plan.reserve.extent;
                *extent = (extent.0.max(full), extent.1.max(full));
            }
        }
        plan.reserve.views += plan.views.len() - plan.caustic_views();
        plan.reserve.texels += plan.texels - plan.caustic_texels;
        plan.reserve = plan.reserve.max(Capacity {
            views: plan.views.len(),
            texels: plan.texels,
            extent: plan.max_extent,
        });
        plan
    }

    /// Appends a view: its bounce-map range, uniforms and bookkeeping.
    fn push(
        &mut self,
        m: DMat4,
        mut view: BounceView,
        (width, height): (u32, u32),
        viewer: Vec4,
        light: usize,
    ) {
        view.inv_view_proj = m.inverse().as_mat4();
        view.texels.x = width;
        view.texels.y = height;
        view.texels.z = self.texels as u32;
        self.views.push(view);
        self.uniforms.push(FrameUniforms {
            view_proj: m.as_mat4(),
            inv_view_proj: m.inverse().as_mat4(),
            camera_pos: self.origin.as_vec3().extend(1.0),
            counts: UVec4::new(0, 0, width, height),
            params: Vec4::ZERO,
            viewer,
        });
        self.view_matrices.push(m);
        self.extents.push((width, height));
        self.view_lights.push(light);
        self.texels += (width * height) as usize;
        self.max_extent = (self.max_extent.0.max(width), self.max_extent.1.max(height));
    }
}

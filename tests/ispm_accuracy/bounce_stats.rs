//! The bounce-map statistics of `tests/ispm_accuracy.rs`: the GPU bounce map and the CPU first
//! bounce as samples of the same photon distribution, and power-weighted histograms of them
//! compared bin by bin (docs/accuracy.md §1).

use glam::Vec3;
use ispm::scene::Scene;

/// One emitted photon after its first bounce: zero power when it missed or was absorbed.
#[derive(Clone, Copy, Debug)]
pub struct Bounced {
    pub light: usize,
    pub power: Vec3,
    /// Where it left the surface (meaningful when `power` > 0).
    pub position: Vec3,
    pub direction: Vec3,
    pub rho_p: f32,
}

/// The GPU bounce map of `scene` (rendered with `photons` and `seed`), one record per texel,
/// each assigned to its light, with its hit point rebuilt from the light G-buffer depth.
pub fn gpu_bounces(scene: &Scene, photons: usize, seed: u32) -> Vec<Bounced> {
    let (renderer, _) = crate::render(scene, crate::settings(16, 16, photons, seed));
    let photons = renderer.photons().expect("ispm");
    let (map, plan) = (photons.bounce_map().to_vec(), photons.plan());
    assert_eq!(
        plan.texels,
        map.len(),
        "the plan does not describe this bounce map"
    );
    let mut out = Vec::with_capacity(map.len());
    for (v, view) in plan.views.iter().enumerate() {
        let light = plan.view_lights[v];
        let (size, offset) = (
            (view.texels.x * view.texels.y) as usize,
            view.texels.z as usize,
        );
        let records = &map[offset..offset + size];
        // `photon_starts` places every surviving record of this view (and only this view).
        let mut only_this_view = vec![ispm::photon::types::BounceMapPhoton::default(); map.len()];
        only_this_view[offset..offset + size].copy_from_slice(records);
        let mut starts = plan.photon_starts(&only_this_view, 0).into_iter();
        for r in records {
            let (direction, rho_p) = ispm::photon::types::unpack_direction(r.direction);
            let alive = r.power.max_element() > 0.0 && direction != Vec3::ZERO;
            let position = if alive {
                starts.next().expect("a start per surviving texel").origin
            } else {
                Vec3::ZERO
            };
            out.push(Bounced {
                light,
                power: if alive { r.power } else { Vec3::ZERO },
                position,
                direction,
                rho_p,
            });
        }
        assert!(starts.next().is_none());
    }
    out
}

/// The CPU emitter's photons after `photon::trace::first_bounce`.
pub fn cpu_bounces(scene: &Scene, photons: usize, seed: u32) -> Vec<Bounced> {
    let bvh = ispm::photon::bvh::SceneBvh::new(scene);
    ispm::photon::emit::emit_photons(scene, photons, seed)
        .iter()
        .map(|p| {
            let light = p.light as usize;
            match ispm::photon::trace::first_bounce(scene, &bvh, p) {
                Some(s) => Bounced {
                    light,
                    power: s.power,
                    position: s.origin,
                    direction: s.direction,
                    rho_p: s.rho_p,
                },
                None => Bounced {
                    light,
                    power: Vec3::ZERO,
                    position: Vec3::ZERO,
                    direction: Vec3::ZERO,
                    rho_p: 0.0,
                },
            }
        })
        .collect()
}

/// A Monte-Carlo sum Σ wⱼ·1[j in bin] over n samples, with its variance estimate
/// Σ wⱼ²·1 − (Σ wⱼ·1)²/n (independent samples; the GPU's stratified texels vary less, so this
/// overestimates its variance and the test is conservative).
#[derive(Clone, Copy, Debug, Default)]
pub struct Tally {
    pub sum: f64,
    pub sum_sq: f64,
    pub count: usize,
}

impl Tally {
    pub fn add(&mut self, w: f64) {
        self.sum += w;
        self.sum_sq += w * w;
        self.count += 1;
    }

    pub fn variance(&self, n: usize) -> f64 {
        (self.sum_sq - self.sum * self.sum / n.max(1) as f64).max(0.0)
    }
}

/// Two independent estimates of the same histogram compared bin by bin: z = Δ/σ per bin
/// (bins with fewer than 20 samples on both sides together are skipped), χ² = Σ z².
pub struct Comparison {
    pub max_z: f64,
    pub chi2: f64,
    pub bins: usize,
}

pub fn compare(gpu: &[Tally], gpu_n: usize, cpu: &[Tally], cpu_n: usize) -> Comparison {
    let mut c = Comparison {
        max_z: 0.0,
        chi2: 0.0,
        bins: 0,
    };
    for (g, k) in gpu.iter().zip(cpu) {
        if g.count + k.count < 20 {
            continue;
        }
        let sigma = (g.variance(gpu_n) + k.variance(cpu_n)).sqrt();
        let z = (g.sum - k.sum) / sigma.max(1e-30);
        c.max_z = c.max_z.max(z.abs());
        c.chi2 += z * z;
        c.bins += 1;
    }
    c
}

/// Power-weighted histograms of one light's bounced photons: [position cell (4³ over the scene
/// bounds), outgoing direction (4 bands of ω.y × 4 azimuth quadrants), lobe (ρp > 0.1: a delta
/// lobe)] and the per-channel total power.
pub fn histograms(
    samples: &[Bounced],
    light: usize,
    scene: &Scene,
) -> ([Vec<Tally>; 3], [Tally; 3], usize) {
    let bounds = scene.bounds();
    let (min, extent) = (bounds.min, bounds.extent().max(Vec3::splat(1e-6)));
    let mut position = vec![Tally::default(); 64];
    let mut direction = vec![Tally::default(); 16];
    let mut lobe = vec![Tally::default(); 2];
    let mut total = [Tally::default(); 3];
    let mut n = 0;
    for s in samples.iter().filter(|s| s.light == light) {
        n += 1;
        for (c, t) in total.iter_mut().enumerate() {
            t.add(f64::from(s.power[c]));
        }
        let w = f64::from(s.power.element_sum() / 3.0);
        if w <= 0.0 {
            continue;
        }
        let cell = ((s.position - min) / extent * 4.0)
            .floor()
            .clamp(Vec3::ZERO, Vec3::splat(3.0))
            .as_uvec3();
        position[(cell.x + 4 * cell.y + 16 * cell.z) as usize].add(w);
        let band = (((s.direction.y + 1.0) * 2.0).floor() as usize).min(3);
        let quadrant = match (s.direction.x >= 0.0, s.direction.z >= 0.0) {
            (true, true) => 0,
            (false, true) => 1,
            (false, false) => 2,
            (true, false) => 3,
        };
        direction[band * 4 + quadrant].add(w);
        lobe[usize::from(s.rho_p > 0.1)].add(w);
    }
    ([position, direction, lobe], total, n)
}

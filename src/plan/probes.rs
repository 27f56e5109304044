//! Environment probes: the points glass and mirrors see the rest of the scene from.
//!
//! The translucent pass looks reflected and refracted rays up in cube maps of the opaque scene
//! (`passes/environment.rs`), rendered from a probe's centre and box-projected onto the scene's
//! bounds. One viewpoint is exact only for a ray that starts at it, so each delta instance gets
//! a probe of its own:
//!
//! ```text
//!   one probe for both mirrors            a probe each
//!   |        ●        |                   ●|       ( )       |●
//!   |       ( )       |                    |                 |
//!   ─────────────────────                 ─────────────────────
//!   the ball hides the floor both         each mirror sees the floor from
//!   mirrors reflect                       where it stands
//! ```

use crate::scene::Aabb;

/// Most probes a scene gets. Each is a cached cube of `passes::environment::FACE_SIZE`² a face
/// (rendered again when lights or instances move) and a small indirect cube the CPU gathers from
/// every photon map (`render/photon_frame/environment.rs`), so their cost grows with the count.
pub const MAX_PROBES: usize = 4;

/// Where glass and mirrors look up their environment: each delta instance is a probe centred on
/// its own bounds (a single viewpoint for all of them put `facing-mirrors`' ball at the point
/// both mirrors saw the floor from, and each mirror showed it). Past [`MAX_PROBES`], instances
/// in scene order from the last probe's on share it, centred on their common bounds. Scene
/// order, not size or screen coverage, because it never changes: instances that move are
/// assigned again (`TranslucentFrame::moved`) and must land in the probes they were made with.
///
/// Returns the bounds each probe is centred on, and per instance of `delta` (index, non-empty
/// bounds, in instance order: `Scene::delta_instance_bounds`) its probe.
pub fn assign_probes(delta: &[(usize, Aabb)]) -> (Vec<Aabb>, Vec<(usize, usize)>) {
    let mut probes: Vec<Aabb> = Vec::new();
    let mut of = Vec::with_capacity(delta.len());
    for (k, &(instance, b)) in delta.iter().enumerate() {
        debug_assert!(!b.is_empty(), "instance {instance}: a probe needs bounds");
        let probe = k.min(MAX_PROBES - 1);
        if probe == probes.len() {
            probes.push(b);
        } else {
            let shared = &mut probes[probe];
            shared.grow(b.min);
            shared.grow(b.max);
        }
        of.push((instance, probe));
    }
    (probes, of)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn unit_box(x: f32) -> Aabb {
        Aabb {
            min: Vec3::new(x, 0.0, 0.0),
            max: Vec3::new(x + 1.0, 1.0, 1.0),
        }
    }

    #[test]
    fn each_delta_instance_is_its_own_probe_up_to_the_limit() {
        let two = [(3, unit_box(-2.0)), (7, unit_box(5.0))];
        let (probes, of) = assign_probes(&two);
        assert_eq!(probes, vec![unit_box(-2.0), unit_box(5.0)]);
        assert_eq!(of, vec![(3, 0), (7, 1)]);

        let many: Vec<(usize, Aabb)> = (0..MAX_PROBES + 2)
            .map(|i| (10 + i, unit_box(3.0 * i as f32)))
            .collect();
        let (probes, of) = assign_probes(&many);
        assert_eq!(probes.len(), MAX_PROBES);
        assert_eq!(probes[0], unit_box(0.0));
        // The last probe holds the rest, centred on their common bounds.
        let last = MAX_PROBES - 1;
        let x0 = 3.0 * last as f32;
        let x1 = 3.0 * (MAX_PROBES + 1) as f32 + 1.0;
        assert_eq!(probes[last].min.x, x0);
        assert_eq!(probes[last].max.x, x1);
        let shared: Vec<usize> = of.iter().filter(|o| o.1 == last).map(|o| o.0).collect();
        assert_eq!(shared, (10 + last..10 + MAX_PROBES + 2).collect::<Vec<_>>());
    }
}

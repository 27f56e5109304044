//! Moving instances, and posing the renderer's scene at a time of its animation.
//!
//! ```text
//!  set_pose(scene.pose_at(t))
//!    ├─ set_instance_transforms: moved instances only
//!    │    ├─ GpuScene: their transform (host; draws push their matrices)
//!    │    ├─ effects plan made again (geometry changed; the static instances' closed
//!    │    │  surfaces welded once, the moving ones each time: StaticEnclosures)
//!    │    ├─ PhotonFrame: light views planned again (caustic windows follow moving glass),
//!    │    │  SceneBvh::set_instance_transform + update: moving level only, static BVH kept
//!    │    ├─ TranslucentFrame: cube map centre follows the delta instances, cube redrawn
//!    │    └─ photon map invalid: the next frame traces every light again
//!    └─ set_lights (when a light moved): as before
//! ```
//!
//! A frame after which nothing moved and no light changed reuses the photon map (`render/frame.rs`).

use super::Renderer;
use crate::plan::{EffectsPlan, SceneAnalysis, StaticEnclosures};
use crate::scene::Pose;
use glam::Mat4;

impl Renderer {
    /// Moves the instances to `transforms` (world-from-object, one per `Scene::instances`
    /// entry, in order) for the next frame. Only instances whose transform changed are touched:
    /// the GPU draws them there (their model matrices are push constants computed every frame),
    /// the CPU tracer's BVH moves them by transform (the instances the scene animates were
    /// declared moving when the renderer was made, and static geometry is never rebuilt), the
    /// effects plan is made again, the environment cube maps are drawn again (each probe from its instances' new centre) and, as when a light
    /// moves, the next frame traces a new photon map. An instance the scene does not animate
    /// may move too: the tracer's static BVH is then rebuilt once, without it.
    ///
    /// Fails, changing nothing, for the wrong number of transforms, a non-finite or singular
    /// transform, or a plan this renderer was not made for (see [`Renderer::set_lights`]).
    pub fn set_instance_transforms(&mut self, transforms: &[Mat4]) -> anyhow::Result<()> {
        let instances = &self.source.instances;
        anyhow::ensure!(
            transforms.len() == instances.len(),
            "{} instance transforms given, the scene has {} instances",
            transforms.len(),
            instances.len()
        );
        let moved: Vec<(usize, Mat4)> = transforms
            .iter()
            .enumerate()
            .filter(|&(i, m)| *m != instances[i].transform)
            .map(|(i, m)| (i, *m))
            .collect();
        for &(i, m) in &moved {
            let det = m.determinant();
            anyhow::ensure!(
                m.is_finite() && det.is_finite() && det.abs() > 1e-30,
                "instance {i} ('{}'): the new transform is not finite and invertible",
                instances[i].name
            );
        }
        if moved.is_empty() {
            return Ok(()); // nothing moved: the photon map stays valid
        }
        // Moved in place (the scene's meshes are not copied), and back if anything fails.
        let before: Vec<Mat4> = moved
            .iter()
            .map(|&(i, _)| self.source.instances[i].transform)
            .collect();
        for &(i, m) in &moved {
            self.source.instances[i].transform = m;
        }
        let indices: Vec<usize> = moved.iter().map(|&(i, _)| i).collect();
        let emitters_before = self.move_emitters(&indices);
        let (analysis, plan) = match self.plan_moved_instances(&moved) {
            Ok(planned) => planned,
            Err(e) => {
                self.restore_emitters(emitters_before);
                for (&(i, _), m) in moved.iter().zip(before) {
                    self.source.instances[i].transform = m;
                }
                return Err(e);
            }
        };
        for &(i, _) in &moved {
            self.scene.set_instance_transform(&self.source, i);
        }
        if let Some(translucent) = &mut self.translucent {
            translucent.moved(&self.source.delta_instance_bounds());
        }
        if plan != self.plan {
            log::info!("{plan}");
        }
        self.analysis = analysis;
        self.plan = plan;
        self.photon_map = None;
        self.restart_accumulation(true);
        Ok(())
    }

    /// The scene's analysis (its geometry changed: flat or closed surfaces may not be any more)
    /// and the effects plan for the scene with `moved` already applied to `source`, and the photon
    /// part moved (nothing else is changed).
    fn plan_moved_instances(
        &mut self,
        moved: &[(usize, Mat4)],
    ) -> anyhow::Result<(SceneAnalysis, EffectsPlan)> {
        let analysis = self.analyse_moved(moved);
        let plan = analysis.plan(&self.source, &self.camera);
        anyhow::ensure!(
            !plan.indirect.needed || self.photons.is_some(),
            "the moved instances need indirect light ({}), which this renderer was planned \
             without ({}): create a new renderer",
            plan.indirect.reason,
            self.plan.indirect.reason
        );
        if let Some(photons) = &mut self.photons {
            photons.move_instances(moved, &self.lights, &plan.photon_budget())?;
        }
        Ok((analysis, plan))
    }

    /// The scene's analysis with `moved` applied to `source`. While only the instances the
    /// scene animates move, the static geometry's closed surfaces are welded once (the first
    /// time) and reused (`plan/enclosure.rs`); another instance moving makes it welded again.
    fn analyse_moved(&mut self, moved: &[(usize, Mat4)]) -> SceneAnalysis {
        let moving = &self.plan.motion.instances;
        let valid = self
            .static_enclosures
            .as_ref()
            .is_some_and(|s| s.covers(moved.iter().map(|&(i, _)| i)));
        let declared = moved.iter().all(|(i, _)| moving.contains(i));
        if !valid {
            self.static_enclosures = None;
            if declared && crate::plan::welds_enclosures(&self.source, &self.settings) {
                // Welded from the scene as it is now; valid until an instance outside
                // `moving` moves (then `covers` fails and it is dropped).
                self.static_enclosures = Some(StaticEnclosures::new(&self.source, moving));
            }
        }
        match &self.static_enclosures {
            Some(statics) => SceneAnalysis::with_static(&self.source, &self.settings, statics),
            None => SceneAnalysis::new(&self.source, &self.settings),
        }
    }

    /// Moves the scene to `pose` (from `Scene::pose_at` of the scene this renderer was made
    /// from) for the next frame: its instances, then its lights. The camera stays where it is:
    /// who owns the view (the viewer, a script) decides whether to follow an animated camera.
    pub fn set_pose(&mut self, pose: &Pose) -> anyhow::Result<()> {
        self.set_instance_transforms(&pose.instances)?;
        self.set_lights(&pose.lights)
    }

    /// World-from-object transform of every instance, as the next frame draws them.
    pub fn instance_transforms(&self) -> Vec<Mat4> {
        self.source.instances.iter().map(|i| i.transform).collect()
    }
}

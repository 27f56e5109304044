//! [`MotionPlan`]: what the scene's animations move (instances, lights), and so what a frame
//! redoes: the moving instances' BVHs updated by transform, the photon map re-traced.

use crate::scene::Scene;

/// What moves in the scene (glTF animations, `--orbit-lights`), and so what a frame redoes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MotionPlan {
    /// The instances that move (indices into `Scene::instances`): each gets an object-space
    /// BVH of its mesh, moved by transform every frame (`photon::bvh::SceneBvh::update`); every
    /// other instance is in the static BVH, built once and never rebuilt.
    pub instances: Vec<usize>,
    /// The lights that move (indices into `Scene::lights`).
    pub lights: Vec<usize>,
    pub reason: String,
}

impl MotionPlan {
    /// What `scene`'s animations move.
    pub fn of(scene: &Scene) -> Self {
        let instances = scene.moving_instances();
        let lights = scene.moving_lights();
        let names = |names: Vec<&str>| {
            let shown: Vec<String> = names.iter().take(3).map(|n| format!("'{n}'")).collect();
            let more = names.len().saturating_sub(3);
            let more = if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            };
            format!("{}{more}", shown.join(", "))
        };
        let static_triangles: usize = scene
            .instances
            .iter()
            .enumerate()
            .filter(|(i, _)| instances.binary_search(i).is_err())
            .map(|(_, inst)| scene.meshes[inst.mesh].triangles.len())
            .sum();
        let mut what = Vec::new();
        if !instances.is_empty() {
            let moving = instances.iter().map(|&i| scene.instances[i].name.as_str());
            what.push(format!(
                "{} instance(s) move ({})",
                instances.len(),
                names(moving.collect())
            ));
        }
        if !lights.is_empty() {
            let moving = lights.iter().map(|&i| scene.lights[i].name.as_str());
            what.push(format!(
                "{} light(s) move ({})",
                lights.len(),
                names(moving.collect())
            ));
        }
        let reason = if what.is_empty() {
            "nothing is animated: one BVH, built once; frames reuse the photon map until a light \
             or an instance is changed"
                .to_string()
        } else if instances.is_empty() {
            format!(
                "{}: the BVH is static, built once; every frame re-traces the photon map",
                what.join(", ")
            )
        } else {
            format!(
                "{}: static geometry's BVH ({static_triangles} triangles) is built once and never \
                 rebuilt, the moving instances' BVHs are moved by transform each frame; every \
                 frame re-traces the photon map",
                what.join(", ")
            )
        };
        Self {
            instances,
            lights,
            reason,
        }
    }

    /// Something moves.
    pub fn moves(&self) -> bool {
        !self.instances.is_empty() || !self.lights.is_empty()
    }
}

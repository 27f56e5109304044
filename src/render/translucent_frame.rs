//! The translucent part of a frame: per probe (each delta instance, `plan::probes`) the
//! environment cube map (cached) and the photons' indirect light seen from its centre (a small
//! cube, new with every photon map), and the forward pass that draws glass and mirrors over the
//! opaque radiance. Exists only for scenes with at least
//! one delta-material instance; `frame.rs` calls [`TranslucentFrame::update`] with the frame's
//! uniforms, [`TranslucentFrame::set_indirect`] after a photon trace and
//! [`TranslucentFrame::record`] after the composite.

use crate::config::settings::SkippedPass;
use crate::gpu::scene::{Draw, GpuScene};
use crate::gpu::{vk, Buffer, Gpu, Image, ImageDesc, MemoryLocation, ViewKind};
use crate::layout::{EnvironmentUniforms, FrameUniforms};
use crate::passes::environment::{EnvironmentInputs, EnvironmentPass};
use crate::passes::translucent::{ProbeInputs, TranslucentInputs, TranslucentPass};
use crate::photon::bsdf::BsdfVariant;
use crate::plan::probes::assign_probes;
use crate::render::photon_frame::environment::FACE_SIZE as INDIRECT_FACE_SIZE;
use crate::scene::{Aabb, Scene};
use glam::DVec3;
use std::sync::Arc;

/// The buffers and images of the frame the translucent passes read.
pub struct TranslucentResources<'a> {
    pub frame: &'a Buffer,
    pub lights: &'a Buffer,
    pub shadow_views: &'a Buffer,
    pub shadow_atlas: &'a Image,
}

/// One probe's GPU side.
struct Probe {
    /// `EnvironmentUniforms`, camera-relative, rewritten every frame.
    uniforms: Buffer,
    /// The photons' indirect light seen from the centre (an RGBA16F cube like the direct one:
    /// linear filtering of 16-bit floats is required by Vulkan, of 32-bit ones not;
    /// `photon_frame/environment.rs`), its host-visible staging copy.
    indirect: Image,
    indirect_staging: Buffer,
    /// World-space centre of the probe's cubes.
    centre: DVec3,
}

pub struct TranslucentFrame {
    environment: EnvironmentPass,
    pass: TranslucentPass,
    probes: Vec<Probe>,
    /// Per scene instance, its probe (0 for instances not drawn here).
    probe_of: Vec<usize>,
    /// Whether the staging copies hold texels the cubes do not have yet.
    indirect_pending: bool,
    /// World-space scene bounds, the box environment lookups are projected onto.
    bounds: Aabb,
    /// Near plane of the cube faces (metres).
    near: f32,
}

impl TranslucentFrame {
    /// `None` when no instance has a delta material: the pass does not run and no cube map is
    /// allocated. Both passes compile in the über-BSDF lobes of `variant`.
    pub fn new(
        gpu: &Arc<Gpu>,
        scene: &Scene,
        gpu_scene: &GpuScene,
        resources: &TranslucentResources,
        (depth, radiance): (&Image, &Image),
        variant: BsdfVariant,
    ) -> anyhow::Result<Option<Self>> {
        let delta = scene.delta_instance_bounds();
        if delta.is_empty() {
            return Ok(None);
        }
        let (probe_bounds, assigned) = assign_probes(&delta);
        let mut probe_of = vec![0; gpu_scene.instances.len()];
        for (instance, probe) in assigned {
            probe_of[instance] = probe;
        }
        let environment = EnvironmentPass::new(
            gpu,
            gpu_scene,
            &EnvironmentInputs {
                materials: &gpu_scene.materials,
                lights: resources.lights,
                shadow_views: resources.shadow_views,
                shadow_atlas: resources.shadow_atlas,
            },
            variant,
            probe_bounds.len(),
        )?;
        let texels = 6 * INDIRECT_FACE_SIZE * INDIRECT_FACE_SIZE;
        let probes = (probe_bounds.iter().enumerate())
            .map(|(k, bounds)| {
                let uniforms = Buffer::constants(
                    gpu,
                    &format!("environment.probe[{k}].uniforms"),
                    size_of::<EnvironmentUniforms>() as u64,
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                )?;
                let indirect = Image::planned(
                    gpu,
                    &ImageDesc {
                        name: &format!("environment.probe[{k}].indirect"),
                        format: crate::passes::environment::FORMAT,
                        width: INDIRECT_FACE_SIZE,
                        height: INDIRECT_FACE_SIZE,
                        layers: 6,
                        // Copied into from the staging buffer; the translucent pass samples it.
                        usage: vk::ImageUsageFlags::TRANSFER_DST,
                        view: ViewKind::Cube,
                    },
                );
                let indirect_staging = Buffer::new(
                    gpu,
                    &format!("environment.probe[{k}].indirect.staging"),
                    u64::from(texels) * 8,
                    vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::CpuToGpu,
                )?;
                // Black until a photon map says otherwise (`--method direct`, or no photons).
                indirect_staging.write(0, &vec![0u8; texels as usize * 8])?;
                Ok(Probe {
                    uniforms,
                    indirect,
                    indirect_staging,
                    centre: bounds.center().as_dvec3(),
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let pass = TranslucentPass::new(
            gpu,
            (gpu_scene, scene),
            &TranslucentInputs {
                frame: resources.frame,
                materials: &gpu_scene.materials,
                lights: resources.lights,
                shadow_views: resources.shadow_views,
                shadow_atlas: resources.shadow_atlas,
                probes: probe_inputs(&probes, &environment),
            },
            (radiance, depth),
            variant,
        )?;
        let bounds = gpu_scene.bounds;
        Ok(Some(Self {
            environment,
            pass,
            probes,
            probe_of,
            indirect_pending: true,
            bounds,
            // Scale case: relative only (a 10⁻⁴ m floor clipped the middle of a 2 mm scene).
            near: (1e-3 * bounds.extent().length()).max(f32::MIN_POSITIVE),
        }))
    }

    /// Records this frame's camera-relative uniforms (and the cube faces' while they are
    /// dirty); without `indirect` (the direct-only debug view) lookups leave the indirect cubes
    /// out.
    pub fn update(
        &self,
        cmd: &crate::gpu::Cmd,
        frame: &FrameUniforms,
        camera: DVec3,
        indirect: bool,
    ) {
        let relative = |p: glam::Vec3| (p.as_dvec3() - camera).as_vec3().extend(1.0);
        let centres: Vec<glam::Vec3> = (self.probes.iter())
            .map(|p| (p.centre - camera).as_vec3())
            .collect();
        for (probe, centre) in self.probes.iter().zip(&centres) {
            let uniforms = EnvironmentUniforms {
                centre: centre.extend(if indirect { 1.0 } else { 0.0 }),
                bounds_min: relative(self.bounds.min),
                bounds_max: relative(self.bounds.max),
            };
            cmd.update_buffer(&probe.uniforms, 0, bytemuck::bytes_of(&uniforms));
        }
        self.environment.update(cmd, frame, &centres, self.near);
    }

    /// The environment cube maps (if dirty) from the `opaque` draws, then the `delta` draws
    /// over `radiance`, depth-tested against the eye G-buffer's `depth`. `resources` are the
    /// ones the frame was made with.
    pub fn record(
        &mut self,
        cmd: &crate::gpu::Cmd,
        (scene, opaque, delta): (&GpuScene, &[Draw], &[Draw]),
        resources: &TranslucentResources,
        depth: &mut Image,
        radiance: &mut Image,
    ) {
        let environment = EnvironmentInputs {
            materials: &scene.materials,
            lights: resources.lights,
            shadow_views: resources.shadow_views,
            shadow_atlas: resources.shadow_atlas,
        };
        self.environment.record(cmd, scene, opaque, &environment);
        if std::mem::take(&mut self.indirect_pending) {
            for probe in &self.probes {
                cmd.copy_buffer_to_image(&probe.indirect_staging, &probe.indirect);
            }
        }
        let inputs = TranslucentInputs {
            frame: resources.frame,
            materials: &scene.materials,
            lights: resources.lights,
            shadow_views: resources.shadow_views,
            shadow_atlas: resources.shadow_atlas,
            probes: probe_inputs(&self.probes, &self.environment),
        };
        self.pass.record(
            cmd,
            (scene, delta, &self.probe_of),
            &inputs,
            depth,
            radiance,
        );
    }

    /// The translucent pass's shader variants compiled out, in the stats' form
    /// ([`TranslucentPass::variants_skipped`]).
    pub fn variants_skipped(&self) -> Option<SkippedPass> {
        self.pass.variants_skipped()
    }

    /// World-space centre of each probe's cube maps.
    pub fn centres(&self) -> Vec<DVec3> {
        self.probes.iter().map(|p| p.centre).collect()
    }

    /// Gives the next [`Self::record`] new indirect texels, one cube a probe
    /// (`PhotonFrame::environment_indirect`). The GPU must be done with the previous frame
    /// (whose record may have copied the staging buffers this writes).
    pub fn set_indirect(&mut self, cubes: &[Vec<[f32; 4]>]) -> anyhow::Result<()> {
        anyhow::ensure!(
            cubes.len() == self.probes.len(),
            "{} indirect cubes for {} probes",
            cubes.len(),
            self.probes.len()
        );
        for (probe, texels) in self.probes.iter().zip(cubes) {
            anyhow::ensure!(
                texels.len() == (6 * INDIRECT_FACE_SIZE * INDIRECT_FACE_SIZE) as usize,
                "{} indirect environment texels for a cube of {INDIRECT_FACE_SIZE}² a face",
                texels.len()
            );
            let halves: Vec<u16> = texels
                .iter()
                .flatten()
                .map(|&v| half::f16::from_f32(v).to_bits())
                .collect();
            probe
                .indirect_staging
                .write(0, bytemuck::cast_slice(&halves))?;
        }
        self.indirect_pending = true;
        Ok(())
    }

    /// Makes the next frame render the environment cube maps again.
    pub fn invalidate(&mut self) {
        self.environment.invalidate();
    }

    /// Instances moved: the cube maps are rendered again, each probe from the centre of its
    /// instances where they are now (`delta`: `Scene::delta_instance_bounds`, the same
    /// instances as when the frame was made, so the same probes).
    pub fn moved(&mut self, delta: &[(usize, Aabb)]) {
        let (probe_bounds, _) = assign_probes(delta);
        debug_assert_eq!(probe_bounds.len(), self.probes.len());
        for (probe, bounds) in self.probes.iter_mut().zip(probe_bounds) {
            probe.centre = bounds.center().as_dvec3();
        }
        self.environment.invalidate();
    }
}

/// The translucent pass's view of each probe.
fn probe_inputs<'a>(probes: &'a [Probe], environment: &'a EnvironmentPass) -> Vec<ProbeInputs<'a>> {
    (probes.iter().zip(&environment.cubes))
        .map(|(probe, cube)| ProbeInputs {
            environment: &probe.uniforms,
            map: cube,
            indirect: &probe.indirect,
        })
        .collect()
}

//! The estimate half of the photon part of a frame: the photon volumes drawn for the current
//! eye (`set_view`: the eye-relative offset and the kernel's footprint floor), upsampled at
//! `--subsample N > 1`, composited, and what the debug views read of it.
//!
//! **Fine photons at full resolution.** At `--subsample N > 1` the photons are split
//! (`photon::kernel::Share`): the **fine** ones, caustic photons whose kernel is narrower than
//! [`FINE_KERNEL_PIXELS`](crate::photon::kernel::FINE_KERNEL_PIXELS) low-resolution pixels, are
//! estimated at full resolution with the full image's footprint floor; the others (global
//! photons, and wide caustic ones: smooth light, where the fill rate goes) at 1/N as before:
//!
//! ```text
//!   coarse photons ──(estimator, 1/N)──► low ──► support ──► denoise ──► upsample ──► indirect
//!   fine photons ────(estimator, full resolution, added)───────────────────────────► indirect +=
//! ```
//!
//! A focused caustic is a few pixels across: drawn at 1/N its kernels grew to the low image's
//! footprint floor and its light spread over N×N blocks (`glass-sphere` at 640×480, N 4:
//! relMSE 0.234 against the reference, 0.104 at N 1, 0.104 with the split;
//! docs/accuracy.md, "Fine photons at full resolution"). Fine kernels are small, so the
//! full-resolution estimate costs little; the tiled gather dispatches it over the tiles with a
//! list only. A scene without delta or glossy lobes makes no caustic photons and pays nothing
//! (under `--effects auto`, the default, no second estimator is made:
//! `EffectsPlan::fine_photons`), a frame without
//! caustic photons skips it, and `--subsample-caustics` turns the split off for comparison.

use super::{estimate_targets, fine_split, Estimator, PhotonFrame};
use crate::gpu::{Access, Buffer, Cmd, Image, Resource};
use crate::passes::debug_view::PhotonSources;
use crate::passes::eye_gbuffer::GBuffer;
use crate::passes::photon_tiles::lists as tiles;
use crate::passes::photon_tiles::TileStats;
use crate::passes::photon_volumes::PhotonVolumeInputs;
use crate::passes::upsample::UpsampleInputs;
use crate::passes::value_check::{Checked, Records, ValueCheckPass};
use crate::photon::density::Neighbours;
use crate::photon::kernel::{KernelSettings, Share};
use crate::photon::types::{unpack_direction, unpack_normal, BounceMapPhoton, Photon};
use crate::timing;

/// The photon map as the estimators draw it: the host's copy the tiled estimator bins (as
/// uploaded, [`PhotonFrame::packed`]), the photons in each photon buffer, and the threads
/// binning may use.
struct Drawn<'a> {
    photons: &'a [Photon],
    counts: &'a [u32],
    threads: usize,
}

impl Estimator {
    /// Points the estimator at new photon buffers ([`PhotonFrame::record_estimate`]).
    fn rebind(&mut self, inputs: &PhotonVolumeInputs) -> anyhow::Result<()> {
        match self {
            Estimator::Volumes(pass) => pass.rebind(inputs),
            Estimator::Tiled(pass) => {
                pass.rebind();
                Ok(())
            }
        }
    }

    /// Records the estimate of `map`'s photons of `share` into `targets`, with `kernel`'s
    /// radii, `offset` added to each position; the tiled estimator bins them for `screen`
    /// first (its lists are per frame `slot`) and returns what its lists held.
    fn record(
        &mut self,
        cmd: &Cmd,
        inputs: &PhotonVolumeInputs,
        map: &Drawn,
        (kernel, offset, share): (&KernelSettings, glam::Vec3, Share),
        (screen, slot): (&tiles::Screen, usize),
        (targets, add): (&[&Image], bool),
    ) -> anyhow::Result<Option<TileStats>> {
        let volumes = (map.counts, kernel, offset);
        match self {
            Estimator::Volumes(pass) => {
                pass.record(cmd, inputs, volumes, (targets, share, add));
                Ok(None)
            }
            Estimator::Tiled(pass) => {
                // A photon another estimate draws is binned as one without power: in no list.
                let of_share = move |p: Photon| {
                    let (_, r_knn) = unpack_normal(p.normal);
                    let (_, rho_p) = unpack_direction(p.direction);
                    let d = (p.position + offset).length();
                    match share.draws(r_knn, rho_p, kernel, d) {
                        true => p,
                        false => Photon {
                            power: glam::Vec3::ZERO,
                            ..p
                        },
                    }
                };
                let lists = timing::timed(tiles::SPAN, || {
                    tiles::bin(
                        |range| {
                            let end = range.end.min(map.photons.len());
                            let photons = &map.photons[range.start.min(end)..end];
                            photons.iter().copied().map(of_share)
                        },
                        map.counts,
                        (kernel, offset),
                        screen,
                        map.threads,
                    )
                });
                let stats = pass.record(cmd, inputs, volumes, (&lists, slot), (targets, add))?;
                Ok(Some(stats))
            }
        }
    }
}

impl PhotonFrame {
    /// Draws the photon volumes for `camera` from the next recorded estimate on: its position
    /// (the offset added to the photons) and its field of view (the kernel's footprint floor).
    /// The photon map itself does not depend on the camera and stays valid.
    pub fn set_view(&mut self, camera: &crate::scene::Camera) {
        self.eye = camera.position().as_dvec3();
        self.yfov = camera.yfov;
    }

    /// The kernel of an estimate `height` pixels high: the clamp (and the radius scale) with
    /// the view's footprint floor at that resolution.
    fn kernel_at(&self, height: u32) -> KernelSettings {
        self.kernel_clamp.for_view(self.yfov, height)
    }

    /// What the photon volumes add to each stored position to make it eye-relative:
    /// `origin − eye`, subtracted in f64 and rounded once.
    pub(super) fn eye_offset(&self) -> glam::Vec3 {
        (self.plan.origin - self.eye).as_vec3()
    }

    /// Photon volumes into the indirect buffer (at 1/N resolution and upsampled, at
    /// `--subsample N > 1`), then radiance += indirect. Takes the photon buffer over from the
    /// transfer queue after an upload (a no-op in a frame that reuses the photon map) and keeps
    /// it until the next [`Self::record_emission`]. Without `composite` (the direct-only debug
    /// view) the estimate is made but not added. With `check` (`--check-values`), the bounce
    /// map and photon map are checked before the photon volumes draw, the low-resolution
    /// targets before the upsample reads them, the indirect image before the composite
    /// (`passes/value_check.rs`). `slot` is the frame slot (the tiled estimator's lists are
    /// per slot) and `view_proj` the frame's camera-relative world → clip (what they are
    /// binned for). `accumulated`: the frames already in the mean this frame joins (0 when it
    /// starts one or is not accumulated), which sets the denoiser's levels
    /// ([`crate::passes::denoise::levels_for`]). `lambert`: the direct pass's Lambertian
    /// BRDF image `c_L/π`, which the upsample reads (at `--subsample N > 1`).
    pub fn record_estimate(
        &mut self,
        cmd: &Cmd,
        (frame, materials, gbuffer): (&Buffer, &Buffer, &GBuffer),
        lambert: Option<&Image>,
        (radiance, slot, view_proj): (&mut Image, usize, glam::Mat4),
        (composite, accumulated, mut check): (bool, u32, Option<&mut ValueCheckPass>),
    ) -> anyhow::Result<()> {
        // The photon map from the upload and the bounce map back from the readback (for the
        // next frame's bounce map), acquired here (`gpu/tracker.rs`: a use on the receiving
        // queue acquires what was handed to it). Required here, not at a later first use: box D
        // is the submission that waits for the readback's and the upload's releases, and an
        // acquire must follow its release.
        let mut uses: Vec<_> = Vec::new();
        if self.count() > 0 {
            uses.extend(
                (self.buffers.used())
                    .map(|(_, p)| (Resource::Buffer(p), Access::GraphicsStorageRead)),
            );
        }
        if !self.batches.is_empty() {
            uses.extend(
                (self.bounce_map.device.iter())
                    .map(|b| (Resource::Buffer(b), Access::ComputeStorageWrite)),
            );
        }
        cmd.barriers(&uses);
        if let Some(check) = check.as_deref_mut() {
            self.check_photon_records(cmd, check)?;
        }
        let inputs = PhotonVolumeInputs {
            frame,
            photons: &self.buffers.device,
            materials,
            gbuffer,
        };
        if self.rebind {
            self.estimator.rebind(&inputs)?;
            if let Some(fine) = self.subsampled.as_mut().and_then(|s| s.fine.as_mut()) {
                fine.estimator.rebind(&inputs)?;
            }
            self.rebind = false;
        }
        let offset = self.eye_offset();
        let (size, subsample) = self.screen_size;
        let map = Drawn {
            photons: &self.packed,
            counts: &self.buffers.counts,
            // The tiled estimator bins on every core where the device has its own (module
            // docs of `tiles`).
            threads: match self.gpu.properties.is_cpu() {
                true => 1,
                false => rayon::current_num_threads(),
            },
        };
        // At --subsample N > 1, the fine photons apart (module docs), where the scene makes
        // caustic photons this frame.
        let kernel = self.kernel();
        // The fine photons' kernel: the full image's footprint floor.
        let fine_kernel = self.kernel_at(self.screen_size.0 .1);
        let fine = (self.subsampled.as_ref())
            .and_then(|s| s.fine.as_ref())
            .filter(|_| self.caustic_photons > 0)
            .map(|_| fine_split(&fine_kernel, subsample));
        let targets = estimate_targets(
            &self.indirect,
            self.support.as_ref(),
            self.subsampled.as_ref(),
        );
        let screen = tiles::Screen {
            view_proj,
            size,
            subsample,
        };
        let share = fine.map_or(Share::All, |split| Share::Coarse { split });
        self.tile_stats = self.estimator.record(
            cmd,
            &inputs,
            &map,
            (&kernel, offset, share),
            (&screen, slot),
            (&targets, false),
        )?;
        let denoise_levels = self.denoise.as_ref().map_or(0, |(_, levels)| {
            crate::passes::denoise::levels_for(*levels, accumulated)
        });
        let denoise = (
            denoise_levels,
            kernel.pixel_angle(),
            crate::passes::denoise::reach_for(accumulated),
        );
        match &mut self.subsampled {
            None => {
                let (images, support) = self
                    .support
                    .as_ref()
                    .expect("the support targets exist at subsample 1");
                support.record(cmd, (frame, gbuffer), (&self.indirect, None), images, 1);
                if let Some((pass, _)) = &self.denoise {
                    pass.record(cmd, gbuffer, (&self.indirect, &images[0]), denoise);
                }
            }
            Some(sub) => {
                let (images, support) = &sub.support;
                let low = (&sub.low[0], Some(&sub.low[1]));
                support.record(cmd, (frame, gbuffer), low, images, sub.subsample);
                if let Some((pass, _)) = &self.denoise {
                    pass.record(cmd, gbuffer, (&sub.low[0], &images[0]), denoise);
                }
                if let Some(check) = check.as_deref_mut() {
                    check.image(cmd, Checked::IndirectLowIrradiance, &sub.low[0])?;
                    check.image(cmd, Checked::IndirectLowGlossy, &sub.low[1])?;
                }
                let lambert = lambert.ok_or_else(|| {
                    anyhow::anyhow!(
                        "internal: a subsampled estimate without the direct pass's c_L/π image"
                    )
                })?;
                let low = UpsampleInputs {
                    gbuffer,
                    lambert,
                    low: &sub.low,
                };
                sub.upsample.record(cmd, &low, &mut self.indirect);
                // Then the fine photons at full resolution, added to the upsampled estimate.
                if let (Some(split), Some(pass)) = (fine, sub.fine.as_mut()) {
                    let screen = tiles::Screen {
                        subsample: 1,
                        ..screen
                    };
                    let targets: Vec<&Image> = std::iter::once(&self.indirect)
                        .chain(pass.support.iter().flatten())
                        .collect();
                    let stats = pass.estimator.record(
                        cmd,
                        &inputs,
                        &map,
                        (&fine_kernel, offset, Share::Fine { split }),
                        (&screen, slot),
                        (&targets, true),
                    )?;
                    self.tile_stats = match (self.tile_stats, stats) {
                        (Some(a), Some(b)) => Some(a.and(b)),
                        (a, b) => a.or(b),
                    };
                }
            }
        }
        if let Some(stats) = self.tile_stats {
            log::debug!("photon tiles: {stats:?}");
        }
        if let Some(check) = check {
            check.image(cmd, Checked::Indirect, &self.indirect)?;
        }
        if composite {
            self.composite.record(cmd, &self.indirect, radiance);
        }
        Ok(())
    }

    /// The value check of the bounce map (the records the plan's texels filled, once it is
    /// back on this queue) and of the photon map (the photons drawn), every buffer of each
    /// into the one count of its map.
    fn check_photon_records(&self, cmd: &Cmd, check: &mut ValueCheckPass) -> anyhow::Result<()> {
        const FLOAT: usize = size_of::<f32>();
        let split = self.bounce_map.split;
        for (b, records) in split.pieces(0..self.plan.texels) {
            let records = Records {
                first: records.start as u64,
                count: records.len() as u32,
                stride: (size_of::<BounceMapPhoton>() / FLOAT) as u32,
                power_offset: (std::mem::offset_of!(BounceMapPhoton, power) / FLOAT) as u32,
            };
            check.records(cmd, Checked::BounceMap, &self.bounce_map.device[b], records)?;
        }
        // Buffers hold the map in photon order, each full but the last used one
        // (`PhotonBuffers::write`); the first is checked even when empty, so the photon map is
        // listed with 0 values in a frame without photons.
        let mut first = 0u64;
        for (i, (buffer, &count)) in self
            .buffers
            .device
            .iter()
            .zip(&self.buffers.counts)
            .enumerate()
        {
            if i > 0 && count == 0 {
                continue;
            }
            let records = Records {
                first,
                count,
                stride: (size_of::<Photon>() / FLOAT) as u32,
                power_offset: (std::mem::offset_of!(Photon, power) / FLOAT) as u32,
            };
            check.records(cmd, Checked::PhotonMap, buffer, records)?;
            first += u64::from(count);
        }
        Ok(())
    }

    /// What the debug views read of the photon part of the frame (`passes/debug_view.rs`).
    pub fn debug_sources(&self) -> PhotonSources<'_> {
        let lum = |c: glam::Vec3| c.dot(glam::Vec3::new(0.2126, 0.7152, 0.0722));
        let first = self.plan.views.first().map(|v| (v.texels.x, v.texels.y));
        let first_view_records = self.plan.texel_range(0..self.plan.views.len().min(1));
        let bounce_peak = self
            .traced
            .bounce_map()
            .get(first_view_records.clone())
            .unwrap_or_default()
            .iter()
            .map(|p| lum(p.power))
            .fold(0.0, f32::max);
        let photon_peak = self
            .traced
            .photons()
            .map(|p| lum(p.power))
            .fold(0.0, f32::max);
        PhotonSources {
            light_gbuffer: &self.light_gbuffer,
            first_view_extent: first.unwrap_or((0, 0)),
            views: &self.views,
            bounce_map: &self.bounce_map.device,
            bounce_split: self.bounce_map.split,
            first_view_records,
            bounce_peak,
            photons: &self.buffers.device,
            counts: &self.buffers.counts,
            photon_peak,
            offset: self.eye_offset(),
            indirect: &self.indirect,
        }
    }

    /// The tiled estimator's lists of the last recorded estimate (`None` with the photon
    /// volumes).
    pub fn tile_stats(&self) -> Option<crate::passes::photon_tiles::TileStats> {
        self.tile_stats
    }

    /// The kernel settings the photon volumes use: the kNN radii's scale, the clamp and the
    /// footprint floor of the estimate's resolution (the low one when subsampling).
    pub fn kernel(&self) -> KernelSettings {
        self.kernel_at(self.estimate_height)
    }

    /// k per photon class of the kNN radii packed into the drawn normals (`photon::density`).
    pub fn neighbours(&self) -> Neighbours {
        self.neighbours
    }

    /// Reads back the indirect radiance (RGBA f32; alpha = volumes per pixel).
    pub fn read_indirect(&self) -> anyhow::Result<Vec<f32>> {
        Ok(bytemuck::pod_collect_to_vec(
            &self.gpu.read_image(&self.indirect)?,
        ))
    }

    /// Reads back the low-resolution irradiance and glossy images the upsample reads (RGBA
    /// f32 each, at their size), or `None` at `--subsample 1`. For the tests.
    pub fn read_low(&self) -> anyhow::Result<Option<[Vec<f32>; 2]>> {
        let Some(sub) = &self.subsampled else {
            return Ok(None);
        };
        let read = |i: usize| -> anyhow::Result<Vec<f32>> {
            Ok(bytemuck::pod_collect_to_vec(
                &self.gpu.read_image(&sub.low[i])?,
            ))
        };
        Ok(Some([read(0)?, read(1)?]))
    }

    /// Reads back, per pixel, the share `f` of the global photons' kernel on the surface that
    /// the support normalisation divided by (`passes/support.rs`; unclamped, 0 where no global
    /// photon reached the pixel), or `None` when subsampling (the low-resolution pass keeps the
    /// glossy share where f would go). For the tests.
    pub fn read_support_fraction(&self) -> anyhow::Result<Option<Vec<f32>>> {
        let Some((images, _)) = &self.support else {
            return Ok(None);
        };
        let texels: Vec<f32> = bytemuck::pod_collect_to_vec(&self.gpu.read_image(&images[1])?);
        Ok(Some(texels.chunks_exact(4).map(|t| t[1]).collect()))
    }
}

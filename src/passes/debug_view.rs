//! Debug views (compute): one of the frame's intermediate buffers, false-coloured, written over
//! the display image after tonemapping: what the viewer's overlay toggles and `ispm render
//! --debug-view` writes.
//!
//! | view | source | shown as |
//! |---|---|---|
//! | `eye-normals` | eye G-buffer normal | normal xyz → rgb, background black |
//! | `light-gbuffer` | light G-buffer, first light view (layer 0) | its normals, stretched over the image |
//! | `bounce-map` | bounce map records of the first light view (every buffer they lie in) | power, log scale (Turbo) |
//! | `photon-positions` | photon map (every buffer of it) | one pixel per visible photon, power on a log scale, over the dimmed frame |
//! | `photon-overdraw` | indirect image's alpha (volumes that shaded a pixel) | count, log scale (Turbo) |
//! | `indirect-only` | indirect image (before composite) | tonemapped like the frame |
//! | `direct-only` | — | the frame without the composite step (`frame.rs`), no pass here |
//!
//! Each view is its own shader (`glsl/debug/`) with only the bindings it reads, so a
//! [`DebugViewPass`] is made for one view and one set of inputs; `frame.rs` makes a new one when
//! the view or the photon buffers change (the old one retires through the graveyard). The
//! views of a map split over several buffers (`photon_frame/buffers.rs`) have one descriptor
//! set per buffer and a dispatch for each.

use super::bounce_map::Split;
use super::eye_gbuffer::GBuffer;
use super::tonemap::Tonemap;
use super::ComputeKernel;
use crate::gpu::{
    shader_table, vk, Access, BindingKind, Buffer, Cmd, Filter, Gpu, Image, Sampler, Write,
};
use crate::pass_id::PassId;
use std::sync::Arc;

/// The count at the top of the photon-overdraw view's scale.
pub const OVERDRAW_SCALE_MAX: f32 = 64.0;

/// An intermediate buffer shown instead of the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DebugView {
    /// The eye G-buffer's normals.
    EyeNormals,
    /// The first light view's G-buffer (its normals).
    LightGbuffer,
    /// The first light view's bounce map (photon power after the first bounce).
    BounceMap,
    /// The photon map's photons where the eye sees them.
    PhotonPositions,
    /// How many photon volumes shaded each pixel.
    PhotonOverdraw,
    /// Direct light (and glass) only: the frame without the indirect light.
    DirectOnly,
    /// Indirect light only: the photon volumes' estimate.
    IndirectOnly,
}

impl DebugView {
    pub const ALL: [DebugView; 7] = [
        DebugView::EyeNormals,
        DebugView::LightGbuffer,
        DebugView::BounceMap,
        DebugView::PhotonPositions,
        DebugView::PhotonOverdraw,
        DebugView::DirectOnly,
        DebugView::IndirectOnly,
    ];

    /// Words for the overlay.
    pub fn label(self) -> &'static str {
        match self {
            DebugView::EyeNormals => "eye G-buffer normals",
            DebugView::LightGbuffer => "light G-buffer (first view)",
            DebugView::BounceMap => "bounce map (first view)",
            DebugView::PhotonPositions => "photon positions",
            DebugView::PhotonOverdraw => "photon-volume overdraw",
            DebugView::DirectOnly => "direct light only",
            DebugView::IndirectOnly => "indirect light only",
        }
    }

    /// Whether the view shows a buffer of the photon part of the frame (which a frame without
    /// indirect light does not have).
    pub fn needs_photons(self) -> bool {
        !matches!(self, DebugView::EyeNormals | DebugView::DirectOnly)
    }
}

/// The photon part of the frame's buffers the views read (`PhotonFrame::debug_sources`).
pub struct PhotonSources<'a> {
    pub light_gbuffer: &'a GBuffer,
    /// Texels of the first light view ((0, 0): no light view this frame).
    pub first_view_extent: (u32, u32),
    pub views: &'a Buffer,
    /// The bounce map's buffers, and how the map is split over them.
    pub bounce_map: &'a [Buffer],
    pub bounce_split: Split,
    /// The first light view's records (map indices).
    pub first_view_records: std::ops::Range<usize>,
    /// The brightest record of the first view's bounce map (luminance; 0: none).
    pub bounce_peak: f32,
    /// The photon map's buffers, and the photons in each this frame.
    pub photons: &'a [Buffer],
    pub counts: &'a [u32],
    /// The brightest stored photon (luminance; 0: none).
    pub photon_peak: f32,
    /// Photon map origin − eye.
    pub offset: glam::Vec3,
    /// The photon volumes' estimate (alpha: volumes per pixel).
    pub indirect: &'a Image,
}

/// What a debug view reads.
pub struct DebugInputs<'a> {
    pub frame: &'a Buffer,
    pub gbuffer: &'a GBuffer,
    pub photons: Option<PhotonSources<'a>>,
    pub tonemap: Tonemap,
    pub exposure_ev: f32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ExtentPush {
    extent: [u32; 2],
    layer: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PeakPush {
    inv_peak: f32,
    view: u32,
    /// The records this dispatch shows (map indices `first_record..first_record + records`),
    /// and the map index of the bound buffer's first record.
    first_record: u32,
    records: u32,
    base: u32,
    pad: [u32; 3],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PhotonPush {
    offset: [f32; 4],
    count: u32,
    inv_peak: f32,
    pad: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ScalePush {
    value: f32,
    op: u32,
    pad: [u32; 2],
}

/// One debug view's kernels, bound to one set of inputs.
pub struct DebugViewPass {
    view: DebugView,
    /// The photon buffers the kernels were bound to (they are replaced when the map outgrows
    /// them).
    photons: Option<Vec<vk::Buffer>>,
    kernels: Vec<ComputeKernel>,
    _sampler: Sampler,
}

fn missing(view: DebugView) -> anyhow::Error {
    anyhow::anyhow!(
        "the debug view {} needs the photon part of the frame, which this frame does not have \
         (no indirect light: --method direct, --bounces 0, or nothing to light)",
        view.label()
    )
}

impl DebugViewPass {
    /// The kernels of `view` over `inputs` and the display image `display`.
    pub fn new(
        gpu: &Arc<Gpu>,
        view: DebugView,
        inputs: &DebugInputs,
        display: &Image,
    ) -> anyhow::Result<Self> {
        use BindingKind::{SampledImage, StorageBuffer, StorageImage, UniformBuffer};
        let sampler = Sampler::new(gpu, "debug_view.nearest", Filter::Nearest, false)?;
        let s = &sampler;
        let name = PassId::DebugView.name();
        let photons = inputs.photons.as_ref();
        let need = || photons.ok_or_else(|| missing(view));
        let image = |image| Write::Image { image, sampler: s };
        let push = |size: usize| size as u32;
        let kernels = match view {
            DebugView::DirectOnly => Vec::new(),
            DebugView::EyeNormals => vec![ComputeKernel::new(
                gpu,
                name,
                &shader_table::DEBUG_EYE_NORMALS_COMP,
                &[StorageImage, SampledImage, SampledImage],
                0,
                &[
                    Write::StorageImage(display),
                    image(&inputs.gbuffer.position),
                    image(&inputs.gbuffer.normal),
                ],
                &[],
            )?],
            DebugView::LightGbuffer => {
                let p = need()?;
                vec![ComputeKernel::new(
                    gpu,
                    name,
                    &shader_table::DEBUG_LIGHT_GBUFFER_COMP,
                    &[StorageImage, SampledImage, SampledImage],
                    push(size_of::<ExtentPush>()),
                    &[
                        Write::StorageImage(display),
                        image(&p.light_gbuffer.position),
                        image(&p.light_gbuffer.normal),
                    ],
                    &[],
                )?]
            }
            DebugView::BounceMap => {
                let p = need()?;
                let sets: Vec<[Write; 3]> = p
                    .bounce_map
                    .iter()
                    .map(|buffer| {
                        [
                            Write::StorageImage(display),
                            Write::Buffer(p.views),
                            Write::Buffer(buffer),
                        ]
                    })
                    .collect();
                let sets: Vec<&[Write]> = sets.iter().map(|s| s.as_slice()).collect();
                vec![ComputeKernel::with_sets(
                    gpu,
                    name,
                    &shader_table::DEBUG_BOUNCE_MAP_COMP,
                    (
                        &[StorageImage, StorageBuffer, StorageBuffer],
                        push(size_of::<PeakPush>()),
                    ),
                    &sets,
                    &[],
                )?]
            }
            DebugView::PhotonPositions => {
                let p = need()?;
                // One set per photon buffer, the same but for the photons.
                let photon_sets: Vec<[Write; 4]> = p
                    .photons
                    .iter()
                    .map(|buffer| {
                        [
                            Write::StorageImage(display),
                            Write::Buffer(inputs.frame),
                            Write::Buffer(buffer),
                            image(&inputs.gbuffer.position),
                        ]
                    })
                    .collect();
                vec![
                    ComputeKernel::new(
                        gpu,
                        "debug_view.dim",
                        &shader_table::DEBUG_DIM_COMP,
                        &[StorageImage],
                        0,
                        &[Write::StorageImage(display)],
                        &[],
                    )?,
                    ComputeKernel::with_sets(
                        gpu,
                        name,
                        &shader_table::DEBUG_PHOTON_POSITIONS_COMP,
                        (
                            &[StorageImage, UniformBuffer, StorageBuffer, SampledImage],
                            push(size_of::<PhotonPush>()),
                        ),
                        &photon_sets.iter().map(|s| s.as_slice()).collect::<Vec<_>>(),
                        &[],
                    )?,
                ]
            }
            DebugView::PhotonOverdraw | DebugView::IndirectOnly => {
                let p = need()?;
                let shader = if view == DebugView::PhotonOverdraw {
                    &shader_table::DEBUG_OVERDRAW_COMP
                } else {
                    &shader_table::DEBUG_INDIRECT_COMP
                };
                vec![ComputeKernel::new(
                    gpu,
                    name,
                    shader,
                    &[StorageImage, SampledImage],
                    push(size_of::<ScalePush>()),
                    &[Write::StorageImage(display), image(p.indirect)],
                    &[],
                )?]
            }
        };
        Ok(Self {
            view,
            photons: photons.map(|p| raw_buffers(p.photons)),
            kernels,
            _sampler: sampler,
        })
    }

    /// Whether this pass shows `view` of `inputs` (else make a new one).
    pub fn fits(&self, view: DebugView, inputs: &DebugInputs) -> bool {
        self.view == view && self.photons == inputs.photons.as_ref().map(|p| raw_buffers(p.photons))
    }

    /// Writes the view into `display` (after the tonemapping, in the same command buffer).
    pub fn record(&self, cmd: &Cmd, inputs: &DebugInputs, display: &mut Image) {
        if self.kernels.is_empty() {
            return; // direct only: the frame itself skipped the composite
        }
        let _scope = cmd.scope(PassId::DebugView.name());
        let groups = super::image_groups(display.width, display.height);
        let sampled = |image: &Image| cmd.transition(image, Access::ComputeSampledRead);
        let photons = inputs.photons.as_ref();
        match (self.view, photons) {
            (DebugView::EyeNormals, _) => {
                sampled(&inputs.gbuffer.position);
                sampled(&inputs.gbuffer.normal);
                cmd.transition(display, Access::ComputeStorageWrite);
                self.kernels[0].dispatch(cmd, groups);
            }
            (DebugView::LightGbuffer, Some(p)) => {
                sampled(&p.light_gbuffer.position);
                sampled(&p.light_gbuffer.normal);
                cmd.transition(display, Access::ComputeStorageWrite);
                let (w, h) = p.first_view_extent;
                let push = ExtentPush {
                    extent: [w.max(1), h.max(1)],
                    layer: 0,
                    pad: 0,
                };
                self.kernels[0].dispatch_with(cmd, &push, groups);
            }
            (DebugView::BounceMap, Some(p)) => {
                cmd.transition_buffer(p.views, Access::ComputeStorageRead);
                let split = p.bounce_split;
                // Each buffer holding the first view's records shows its pixels of it.
                for (b, records) in split.pieces(p.first_view_records.clone()) {
                    cmd.transition_buffer(&p.bounce_map[b], Access::ComputeStorageRead);
                    // After the previous buffer's pixels: a write-after-write barrier.
                    cmd.transition(display, Access::ComputeStorageWrite);
                    let push = PeakPush {
                        inv_peak: inverse(p.bounce_peak),
                        view: 0,
                        first_record: records.start as u32,
                        records: records.len() as u32,
                        base: split.records_of(b).start as u32,
                        pad: [0; 3],
                    };
                    self.kernels[0].dispatch_set_with(cmd, b, &push, groups);
                }
            }
            (DebugView::PhotonPositions, Some(p)) => {
                cmd.transition(display, Access::ComputeStorageWrite);
                self.kernels[0].dispatch(cmd, groups);
                sampled(&inputs.gbuffer.position);
                cmd.transition_buffer(inputs.frame, Access::AnyShaderUniformRead);
                // Every buffer of the photon map with photons this frame, in turn.
                for (i, (photons, &count)) in p.photons.iter().zip(p.counts).enumerate() {
                    if count == 0 {
                        continue;
                    }
                    cmd.transition_buffer(photons, Access::ComputeStorageRead);
                    // After the backdrop or the previous buffer's photons: a write-after-write
                    // barrier on the display.
                    cmd.transition(display, Access::ComputeStorageWrite);
                    let push = PhotonPush {
                        offset: p.offset.extend(0.0).to_array(),
                        count,
                        inv_peak: inverse(p.photon_peak),
                        pad: [0; 2],
                    };
                    let groups = [count.div_ceil(64), 1, 1];
                    self.kernels[1].dispatch_set_with(cmd, i, &push, groups);
                }
            }
            (DebugView::PhotonOverdraw | DebugView::IndirectOnly, Some(p)) => {
                sampled(p.indirect);
                cmd.transition(display, Access::ComputeStorageWrite);
                let push = if self.view == DebugView::PhotonOverdraw {
                    ScalePush {
                        value: OVERDRAW_SCALE_MAX,
                        op: 0,
                        pad: [0; 2],
                    }
                } else {
                    ScalePush {
                        value: inputs.exposure_ev.exp2(),
                        op: inputs.tonemap.id(),
                        pad: [0; 2],
                    }
                };
                self.kernels[0].dispatch_with(cmd, &push, groups);
            }
            // Direct only has no kernel (returned above); the other views were made with
            // photon sources (`new` fails without), and a renderer's photon part, once made,
            // stays.
            (DebugView::DirectOnly, _) | (_, None) => {}
        }
    }
}

/// The raw handles of `buffers` (what a pass was bound to).
fn raw_buffers(buffers: &[Buffer]) -> Vec<vk::Buffer> {
    buffers.iter().map(Buffer::raw).collect()
}

/// 1 / `peak`, or 1 for no peak.
fn inverse(peak: f32) -> f32 {
    if peak > 0.0 && peak.is_finite() {
        1.0 / peak
    } else {
        1.0
    }
}

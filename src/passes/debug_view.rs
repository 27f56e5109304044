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
//! | `direct-only` | — | the frame without the composite step (`render/frame.rs`), no pass here |
//!
//! Each view is its own shader (`glsl/debug/`) with only the bindings it reads, so a
//! [`DebugViewPass`] is made for one view and one set of inputs; `render/frame.rs` makes a new one when
//! the view or the photon buffers change (the old one retires through the graveyard). The
//! views of a map split over several buffers (`photon_frame/buffers.rs`) have one descriptor
//! set per buffer and a dispatch for each.

use super::bounce_map::Split;
use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::config::settings::Tonemap;
use crate::gpu::{shader_table, vk, Buffer, Cmd, Filter, Gpu, Image, Sampler, Shaders, Use};
use crate::timing::pass_id::PassId;
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
    sampler: Sampler,
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
        let sampler = Sampler::new(gpu, "debug_view.nearest", Filter::Nearest, false)?;
        let name = PassId::DebugView.name();
        let photons = inputs.photons.as_ref();
        if view != DebugView::DirectOnly && view != DebugView::EyeNormals && photons.is_none() {
            return Err(missing(view));
        }
        // Kernel `k` with one descriptor set per buffer it is dispatched over.
        let kernel = |k: usize, shader, push: usize, sets: usize| {
            let sets: Vec<Vec<Use>> = (0..sets)
                .map(|set| uses(view, (k, set), inputs, display, &sampler))
                .collect();
            let sets: Vec<&[Use]> = sets.iter().map(Vec::as_slice).collect();
            ComputeKernel::with_sets(gpu, name, shader, push as u32, &sets, &[])
        };
        let buffers = |of: fn(&PhotonSources) -> usize| photons.map_or(0, of);
        let kernels = match view {
            DebugView::DirectOnly => Vec::new(),
            DebugView::EyeNormals => vec![kernel(0, &shader_table::DEBUG_EYE_NORMALS_COMP, 0, 1)?],
            DebugView::LightGbuffer => vec![kernel(
                0,
                &shader_table::DEBUG_LIGHT_GBUFFER_COMP,
                size_of::<ExtentPush>(),
                1,
            )?],
            DebugView::BounceMap => vec![kernel(
                0,
                &shader_table::DEBUG_BOUNCE_MAP_COMP,
                size_of::<PeakPush>(),
                buffers(|p| p.bounce_map.len()),
            )?],
            DebugView::PhotonPositions => vec![
                kernel(0, &shader_table::DEBUG_DIM_COMP, 0, 1)?,
                kernel(
                    1,
                    &shader_table::DEBUG_PHOTON_POSITIONS_COMP,
                    size_of::<PhotonPush>(),
                    buffers(|p| p.photons.len()),
                )?,
            ],
            DebugView::PhotonOverdraw | DebugView::IndirectOnly => {
                let shader = if view == DebugView::PhotonOverdraw {
                    &shader_table::DEBUG_OVERDRAW_COMP
                } else {
                    &shader_table::DEBUG_INDIRECT_COMP
                };
                vec![kernel(0, shader, size_of::<ScalePush>(), 1)?]
            }
        };
        Ok(Self {
            view,
            photons: photons.map(|p| raw_buffers(p.photons)),
            kernels,
            sampler,
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
        let photons = inputs.photons.as_ref();
        // The barriers before kernel `k`'s dispatch with set `set` (a write-after-write one on
        // the display after the kernel before).
        let uses = |k: usize, set: usize| {
            let uses = uses(self.view, (k, set), inputs, display, &self.sampler);
            cmd.uses(Shaders::Compute, &uses);
        };
        match (self.view, photons) {
            (DebugView::EyeNormals, _) => {
                uses(0, 0);
                self.kernels[0].dispatch(cmd, groups);
            }
            (DebugView::LightGbuffer, Some(p)) => {
                uses(0, 0);
                let (w, h) = p.first_view_extent;
                let push = ExtentPush {
                    extent: [w.max(1), h.max(1)],
                    layer: 0,
                    pad: 0,
                };
                self.kernels[0].dispatch_with(cmd, &push, groups);
            }
            (DebugView::BounceMap, Some(p)) => {
                let split = p.bounce_split;
                // Each buffer holding the first view's records shows its pixels of it.
                for (b, records) in split.pieces(p.first_view_records.clone()) {
                    uses(0, b);
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
                uses(0, 0);
                self.kernels[0].dispatch(cmd, groups);
                // Every buffer of the photon map with photons this frame, in turn.
                for (i, &count) in p.counts.iter().enumerate().take(p.photons.len()) {
                    if count == 0 {
                        continue;
                    }
                    uses(1, i);
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
            (DebugView::PhotonOverdraw | DebugView::IndirectOnly, Some(_)) => {
                uses(0, 0);
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

/// What kernel `k` of `view` uses with its descriptor set `set` (one per buffer of a map
/// split over several), in its shader's binding order. Empty for the views that need photon
/// sources when `inputs` has none.
fn uses<'a>(
    view: DebugView,
    (k, set): (usize, usize),
    inputs: &DebugInputs<'a>,
    display: &'a Image,
    s: &'a Sampler,
) -> Vec<Use<'a>> {
    let g = inputs.gbuffer;
    let out = Use::Storage(display);
    let p = inputs.photons.as_ref();
    match (view, p, k) {
        (DebugView::EyeNormals, _, _) => {
            vec![
                out,
                Use::Sampled(&g.position, s),
                Use::Sampled(&g.normal, s),
            ]
        }
        (DebugView::LightGbuffer, Some(p), _) => vec![
            out,
            Use::Sampled(&p.light_gbuffer.position, s),
            Use::Sampled(&p.light_gbuffer.normal, s),
        ],
        (DebugView::BounceMap, Some(p), _) => {
            vec![out, Use::Read(p.views), Use::Read(&p.bounce_map[set])]
        }
        (DebugView::PhotonPositions, Some(_), 0) => vec![out],
        (DebugView::PhotonPositions, Some(p), _) => vec![
            out,
            Use::Uniform(inputs.frame),
            Use::Read(&p.photons[set]),
            Use::Sampled(&g.position, s),
        ],
        (DebugView::PhotonOverdraw | DebugView::IndirectOnly, Some(p), _) => {
            vec![out, Use::Sampled(p.indirect, s)]
        }
        (DebugView::DirectOnly, _, _) | (_, None, _) => Vec::new(),
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

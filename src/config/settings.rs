//! The settings of a frame, one floor below everything that reads them: [`RenderSettings`]
//! and the choices it is made of ([`Method`], [`Schedule`], [`Density`], [`Effects`],
//! [`Tonemap`], [`Upsample`]), and [`SkippedPass`], the plan's and the stats' record of a pass
//! not run. The renderer (`frame`), the effects plan (`plan`), the passes and the command line
//! all read them here; none of them is imported back (docs/architecture.md).
//!
//! The settings' one home: the user's knobs ([`Knobs`]: flags, a `--quality` preset) become
//! settings in one function, [`RenderSettings::from_knobs`], and every default is one named
//! constant in [`knobs`], as pbrt-v4 reads each parameter once. `--photons` thus walks
//! CLI → [`Knobs::photons`] → [`RenderSettings::photons`] → the effects plan's split over the
//! lights (`plan::LightPlan::photons`), which the bounce plan (`bounce_plan::BouncePlan`) takes as it is.

use crate::layout::shared_constants::{TONEMAP_ACES, TONEMAP_LINEAR, TONEMAP_PBR_NEUTRAL};
use crate::photon::bsdf::BsdfVariant;
use crate::timing::pass_id::PassId;

pub mod knobs;

pub use knobs::{
    Knobs, Preset, CAUSTIC_SHARE, DEFAULT_BOUNCES, DEFAULT_DENOISE, DEFAULT_EMITTER_LIGHTS,
    DEFAULT_EXPOSURE_EV, DEFAULT_PHOTONS, DEFAULT_SEED, DEFAULT_SHADOW_RESOLUTION, DEFAULT_SIZE,
    DEFAULT_SUBSAMPLE, MAX_EMITTER_LIGHTS, SHADOW_RESOLUTIONS,
};

/// Frames the host may issue before it waits for the oldest one to finish.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// How the frame's steps are ordered in time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Schedule {
    /// [`Schedule::Overlapped`], except on a device that runs on the host's own cores (a CPU
    /// implementation such as lavapipe), where box C's trace waits for box B
    /// ([`Schedule::trace_beside_box_b`]); frames still overlap.
    #[default]
    Auto,
    /// The paper's Figure 3: the CPU trace runs while the GPU draws the eye G-buffer and
    /// direct light (box B), on every device; frames overlap.
    Overlapped,
    /// Every step waits for the one before: the baseline the overlap is measured against.
    Serial,
}

impl Schedule {
    /// Whether box C's trace runs while the device draws box B. `Auto` does not on a CPU
    /// device: there the "GPU" passes run on the cores the trace would use, so running both
    /// at once only makes each slower (lavapipe, cornell-box at 640×480: the trace took
    /// 358 ms beside box B against 185 ms in the serial frame, the GPU passes 2285 against
    /// 2113 ms;
    /// docs/performance.md, "Overlap on a CPU device"). The host then waits for box B (the
    /// trace's span `box B wait: CPU device` says why) and traces on idle cores. `cpu_device`:
    /// the device runs on the host's cores (`gpu::DeviceProperties::is_cpu`).
    pub fn trace_beside_box_b(self, cpu_device: bool) -> bool {
        match self {
            Schedule::Auto => !cpu_device,
            Schedule::Overlapped => true,
            Schedule::Serial => false,
        }
    }
}

/// The order in which the tiled gather's workgroups take the screen's tiles
/// (`RenderSettings::tile_order`; `passes/photon_tiles/order.rs` has the picture).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TileOrder {
    /// [`TileOrder::Balanced`] on a device that runs on the host's cores (lavapipe splits a
    /// dispatch into one block of workgroups per thread), else [`TileOrder::Rows`].
    #[default]
    Auto,
    /// Row-major: neighbouring tiles, which read much the same photons, run in turn.
    Rows,
    /// Every run of consecutive workgroups holds its share of the estimated cost
    /// (`passes/photon_tiles/order.rs`).
    Balanced,
}

impl TileOrder {
    /// `Auto` made concrete for a device that runs on the host's cores (`cpu_device`) or not.
    pub fn resolve(self, cpu_device: bool) -> TileOrder {
        match self {
            TileOrder::Auto if cpu_device => TileOrder::Balanced,
            TileOrder::Auto => TileOrder::Rows,
            other => other,
        }
    }
}

/// How the radiance estimate is made from the photon map (`--density`). Both give the same
/// sums (tests/tiled_density.rs); they differ in speed, by device.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Density {
    /// Photon volumes: each photon's kernel rasterised as a billboard and shaded per fragment
    /// (the paper's §4, `passes/photon_volumes.rs`).
    Volumes,
    /// A tiled gather in compute: per screen tile, the photons that may reach it, tested by
    /// each pixel (`passes/photon_tiles.rs`).
    Tiled,
    /// The faster, as measured (docs/performance.md, "Density estimators"): `tiled` wherever
    /// the device has the compute subgroup operations it needs (its estimate took 3.5–5× less
    /// time than the volumes' on lavapipe and 13–280× less on an NVIDIA H100), else `volumes`.
    #[default]
    Auto,
}

impl Density {
    /// `Auto` made concrete for a device that has (`gather`) or lacks the compute subgroup
    /// operations the tiled gather needs
    /// ([`crate::gpu::DeviceProperties::compute_subgroup_gather`]).
    pub fn resolve(self, gather: bool) -> Density {
        match self {
            Density::Auto if gather => Density::Tiled,
            Density::Auto => Density::Volumes,
            other => other,
        }
    }

    /// [`Density::resolve`] for a device.
    pub fn resolve_for_device(self, device: &crate::gpu::DeviceProperties) -> Density {
        self.resolve(device.compute_subgroup_gather)
    }

    /// `Auto` made concrete for Vulkan device `device` (`--device`), or for the device the
    /// renderer picks when none is named, without creating it; `Auto` when Vulkan lists no
    /// such usable device.
    pub fn resolve_for(self, device: Option<usize>) -> Density {
        if self != Density::Auto {
            return self;
        }
        let Ok(devices) = crate::gpu::list_devices() else {
            return self;
        };
        let usable = devices.iter().filter(|(_, ok)| ok.is_ok());
        let chosen = match device {
            Some(i) => devices.get(i).filter(|(_, ok)| ok.is_ok()),
            None => usable.min_by_key(|(p, _)| crate::gpu::device_type_rank(p.device_type)),
        };
        chosen.map_or(self, |(p, _)| self.resolve_for_device(p))
    }

    /// The estimator's pass (`Auto` unresolved: the photon volumes).
    pub fn pass(self) -> PassId {
        match self {
            Density::Tiled => PassId::PhotonTiles,
            Density::Volumes | Density::Auto => PassId::PhotonVolumes,
        }
    }
}

/// How a picture is made (`--method`): the GPU renderer's two frames, or one of the CPU
/// references (`reference::render`). The one list of methods: `render --method` takes them all,
/// `plan --method` the GPU ones ([`Method::GPU`]), `sweep`'s grid `ispm` and `photon-gather`,
/// and [`RenderSettings::method`] a GPU one (`Renderer::new` refuses a CPU reference).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Image Space Photon Mapping on the GPU (direct + photon-mapped indirect light).
    #[default]
    Ispm,
    /// Shadow-mapped deferred direct light only (GPU).
    Direct,
    /// CPU reference: traditional photon mapping with a k-d tree gather, same kernel as ISPM.
    PhotonGather,
    /// CPU reference: unidirectional path tracing with next-event estimation.
    PathTrace,
    /// CPU reference: progressive photon mapping (consistent, for caustics).
    Progressive,
}

impl Method {
    /// The methods the GPU renderer draws (`frame::Renderer`); the others are CPU references.
    pub const GPU: [Method; 2] = [Method::Ispm, Method::Direct];

    /// Whether the GPU renderer draws this method ([`Method::GPU`]).
    pub fn is_gpu(self) -> bool {
        Self::GPU.contains(&self)
    }

    /// The method's name on the command line and in the sweep's records (`photon-gather`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Ispm => "ispm",
            Method::Direct => "direct",
            Method::PhotonGather => "photon-gather",
            Method::PathTrace => "path-trace",
            Method::Progressive => "progressive",
        }
    }
}

/// What to render and how.
/// Made from the user's [`Knobs`] by [`RenderSettings::from_knobs`] (every command does), or
/// written out by a library caller (the tests) from [`RenderSettings::default`]; each default
/// is a named constant of [`knobs`], written once.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub method: Method,
    /// Photons emitted from all lights together (split by power), per frame: exactly, to within
    /// the binomial spread of the texels' keep test (src/plan/bounce_plan.rs, "Budget").
    pub photons: usize,
    /// Every light-view texel inside its light's cone sends its photon: the budget rounded up
    /// to whole grids, instead of each texel kept with probability budget/texels. The bounce
    /// map then carries exactly each light's flux in every frame, not only on average (the
    /// tests of that sum use it). Default false.
    pub whole_light_grids: bool,
    /// Most scattering events a photon may take. Default [`DEFAULT_BOUNCES`], a safety net:
    /// Russian roulette ends the paths (`photon::trace`, "Bounces").
    pub bounces: u32,
    /// Largest kernel radius in metres (`None`: relative to the scene and photon count).
    pub radius: Option<f32>,
    /// Seed of every random choice (frame-coherent: same seed, same photons).
    pub seed: u32,
    pub width: u32,
    pub height: u32,
    /// Shadow-map resolution per light view (texels per side).
    pub shadow_resolution: u32,
    pub tonemap: Tonemap,
    /// Exposure in stops: the radiance is multiplied by 2^EV before tonemapping.
    pub exposure_ev: f32,
    /// Photon volumes at 1/N resolution, upsampled (1: full resolution, no upsampling).
    pub subsample: u32,
    /// How a subsampled estimate is upsampled (joint bilateral, or plain bilinear).
    pub upsample: Upsample,
    /// At `subsample > 1`, estimate the caustic photons at 1/N too (`--subsample-caustics`:
    /// cheaper, and spreads a focused caustic over N×N blocks) instead of at full resolution
    /// (`render/photon_frame/estimate.rs`).
    pub subsampled_caustics: bool,
    /// Levels of the indirect light's edge-avoiding à-trous filter for a frame that starts an
    /// accumulation or is not accumulated, fewer as frames accumulate (`--denoise`;
    /// `passes/denoise.rs`). 0 ([`DEFAULT_DENOISE`], the library's default; the command
    /// line's is [`crate::passes::denoise::DEFAULT_LEVELS`]): the raw estimate.
    pub denoise: u32,
    pub schedule: Schedule,
    /// `Auto`: the effects plan (`plan::EffectsPlan`) may skip what the scene does not need;
    /// `All`: every pass and shader variant runs (`--effects all`, for comparison).
    pub effects: Effects,
    /// The über-BSDF lobes compiled into every shader that evaluates it (default: all).
    /// `EffectsPlan::bsdf_variant` is the smallest one a scene renders exactly with.
    pub bsdf_variant: BsdfVariant,
    /// Smallest share of each light's photons spent on its caustic views, the windows around
    /// the mirrors and glass it lights (`config::settings::CAUSTIC_SHARE`; 0: no caustic views).
    pub caustic_share: f32,
    /// Most bytes one buffer of the bounce map or photon map is bound with (`None`: what one
    /// storage-buffer descriptor reaches, the device's `maxStorageBufferRange`; a larger value
    /// is lowered to it); a larger map is split over several buffers, written, read back and
    /// drawn buffer by buffer. Tests lower it to exercise the splits at small sizes.
    pub storage_buffer_range: Option<u64>,
    /// Count the NaN, ±Inf and negative values of the frame's HDR buffers on the GPU
    /// (`--check-values`, `FrameStats::value_check`; `passes/value_check.rs`). Off: the pass
    /// is neither made nor recorded.
    pub check_values: bool,
    /// Progressive accumulation: while nothing moves, each frame traces an independent photon
    /// map with smaller kernels and the displayed image is the mean of the frames since the
    /// last change (`passes/accumulate.rs`; `ispm render --frames N` returns the mean of N).
    /// Off: every frame stands alone and a still frame reuses the photon map (real-time
    /// frames, `ispm bench`).
    pub accumulate: bool,
    /// Points sampled on the emissive surfaces per frame, each a light (`scene::emitters`):
    /// new points every frame of an accumulation, the same ones in a frame that stands alone.
    /// 0: emissive surfaces are seen but light nothing.
    pub emitter_lights: u32,
    /// The density estimator (`--density`; `Auto` is resolved for the device when the
    /// renderer is made).
    pub density: Density,
    /// The order in which the tiled gather's workgroups take the screen's tiles (`Auto`:
    /// balanced on a CPU device, row-major on a GPU; `passes/photon_tiles/order.rs`). The
    /// image is the same in any order; tests pick one to compare them.
    pub tile_order: TileOrder,
}

impl Default for RenderSettings {
    /// The defaults, one named constant each ([`knobs`]): what [`RenderSettings::from_knobs`]
    /// makes of no knobs (its tests check the two agree).
    fn default() -> Self {
        Self {
            method: Method::default(),
            photons: DEFAULT_PHOTONS,
            whole_light_grids: false,
            bounces: DEFAULT_BOUNCES,
            radius: None,
            seed: DEFAULT_SEED,
            width: DEFAULT_SIZE.0,
            height: DEFAULT_SIZE.1,
            shadow_resolution: DEFAULT_SHADOW_RESOLUTION,
            tonemap: Tonemap::default(),
            exposure_ev: DEFAULT_EXPOSURE_EV,
            subsample: DEFAULT_SUBSAMPLE,
            upsample: Upsample::default(),
            subsampled_caustics: false,
            denoise: DEFAULT_DENOISE,
            schedule: Schedule::default(),
            effects: Effects::default(),
            bsdf_variant: BsdfVariant::ALL,
            caustic_share: CAUSTIC_SHARE,
            storage_buffer_range: None,
            check_values: false,
            accumulate: false,
            emitter_lights: DEFAULT_EMITTER_LIGHTS,
            density: Density::default(),
            tile_order: TileOrder::Auto,
        }
    }
}

/// A pass a frame did not run, and why.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SkippedPass {
    pub name: String,
    pub reason: String,
}

/// `--effects`: plan the frame, or force everything on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Effects {
    /// Skip the passes, shader variants, lights and bounces the scene does not need.
    #[default]
    Auto,
    /// Every pass, variant, light and bounce, as without a plan (for comparison).
    All,
}

/// A display transform (`--tonemap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tonemap {
    /// Clamp to [0, 1].
    Linear,
    /// Stephen Hill's fit of ACES (RRT + sRGB ODT).
    Aces,
    /// Khronos PBR Neutral: keeps base colours faithful up to the highlights.
    #[default]
    PbrNeutral,
}

impl Tonemap {
    pub fn id(self) -> u32 {
        match self {
            Tonemap::Linear => TONEMAP_LINEAR,
            Tonemap::Aces => TONEMAP_ACES,
            Tonemap::PbrNeutral => TONEMAP_PBR_NEUTRAL,
        }
    }
}

/// How the low-resolution estimate is brought to full resolution (`--upsample`).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Upsample {
    /// Joint bilateral: bilinear × normal similarity × tangent-plane distance.
    #[default]
    Joint,
    /// Plain bilinear of the (non-background) low-resolution samples.
    Bilinear,
}

impl RenderSettings {
    /// The `--subsample` factor the frame estimates indirect light at: clamped to 1 ..= the
    /// image's larger side.
    pub fn subsample_factor(&self) -> u32 {
        self.subsample.clamp(1, self.width.max(self.height).max(1))
    }
}

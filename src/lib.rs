//! ispm: real-time global illumination by Image Space Photon Mapping on raw Vulkan.
//!
//! Module map (see `docs/overview.md`; which may import which: `docs/architecture.md`, checked
//! by `tests/floors.rs`):
//! - [`scene`]: glTF → [`scene::Scene`]; no Vulkan.
//! - [`photon`]: über-BSDF, photon types, RNG, BVH and watertight tracing, CPU photon tracer;
//!   no Vulkan.
//! - [`reference`]: CPU reference renderers; no Vulkan.
//! - [`gpu`]: the only place raw `ash` lives.
//! - [`passes`]: one explicit GPU pass per file.
//! - [`plan`]: scene analysis → which effects, passes, lights and shader variants a frame
//!   needs; no Vulkan.
//! - [`metrics`]: relMSE, FLIP and the error–time Pareto front; no Vulkan.
//! - [`sweep`]: `ispm sweep`, accuracy against time over a grid of settings.
//! - [`settings`]: [`settings::RenderSettings`] and its choices, below the frame and the plan.
//! - [`stats`]: what a frame reports ([`stats::FrameImage`], [`stats::FrameStats`], the stats
//!   JSON), below the renderer ([`frame`]) and its parts.
//! - [`pass_id`]: [`pass_id::PassId`], every stage of the frame by one name.
//! - [`timing`]: CPU and GPU spans on one host clock, Chrome trace JSON.
//! - [`camera_control`]: the viewer's fly camera and scripted camera path; no window.
//! - [`viewer`], [`overlay`]: `ispm view`'s window, keys and egui overlay (drawn by
//!   `gpu::OverlayPass`).

pub mod bench;
pub mod camera_control;
pub mod frame;
pub mod gpu;
pub mod gpu_scene;
pub mod ispm;
pub mod layout;
pub mod lighting;
pub mod metrics;
pub mod output;
pub mod overlay;
pub mod pass_id;
pub mod passes;
pub mod photon;
pub mod photon_frame;
pub mod plan;
pub mod quality;
pub mod reference;
pub mod scene;
pub mod settings;
pub mod stats;
pub mod sweep;
pub mod timing;
pub mod translucent_frame;
pub mod viewer;

/// Constants shared with GLSL (generated into `shared_constants.glsl` by `build.rs`).
pub mod shared_constants {
    include!("shared_constants.rs");
}

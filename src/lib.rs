//! ispm: real-time global illumination by Image Space Photon Mapping on raw Vulkan.
//!
//! The crate's root holds only rooms (folders), each on one floor of the import graph
//! (`docs/architecture.md`, checked by `tests/floors.rs`): a room imports from rooms below it,
//! never above, never in a circle.
//!
//! - [`app`]: `ispm view`'s window, keys, fly camera and egui overlay.
//! - [`tools`]: `ispm bench`, `ispm sweep` and the error metrics (relMSE, FLIP, Pareto front).
//! - [`render`]: the renderer ([`render::frame`]) and its two parts (photons, translucency),
//!   and what a frame reports ([`render::stats`]).
//! - [`passes`]: one explicit GPU pass per file.
//! - [`plan`]: scene analysis → which effects, passes, lights and shader variants a frame
//!   needs; the lights' shadow views; the bounce plan (photon budget → bounce-map views, bounce
//!   map → photon map). No Vulkan.
//! - [`reference`](mod@reference): CPU reference renderers; no Vulkan.
//! - [`config`]: [`config::settings::RenderSettings`], built once from the user's knobs, and the
//!   `--quality` presets.
//! - [`photon`]: über-BSDF, photon types, RNG, BVH and watertight tracing, CPU photon tracer;
//!   no Vulkan.
//! - [`gpu`]: the only place raw `ash` lives; the scene's GPU buffers ([`gpu::scene`]).
//! - [`layout`]: the structs and constants shared with GLSL, checked at compile time.
//! - [`timing`]: CPU and GPU spans on one host clock, Chrome trace JSON, and every stage of the
//!   frame by one name ([`timing::pass_id::PassId`]).
//! - [`scene`]: glTF → [`scene::Scene`]; no Vulkan.
//! - [`output`]: PNG and EXR files, written atomically.
//!
//! The commands (`src/main.rs`, `src/cli/`) sit above every room.

pub mod app;
pub mod config;
pub mod gpu;
pub mod layout;
pub mod output;
pub mod passes;
pub mod photon;
pub mod plan;
pub mod reference;
pub mod render;
pub mod scene;
pub mod timing;
pub mod tools;

//! The renderer: one frame of Image Space Photon Mapping, recorded in the order of the paper's
//! Figure 3 (`docs/overview.md`).
//!
//! - [`frame`]: the [`frame::Renderer`], which makes the passes and records and submits a frame.
//! - [`photon_frame`]: the photon part (bounce map, readback, CPU trace, density estimate).
//! - [`translucent_frame`]: the translucency part (the translucent pass and its environment).
//! - [`stats`]: what a frame reports (`FrameImage`, `FrameStats`, the stats JSON), filled in by
//!   the frame and its photon part. The parts never call the frame back (translucency reads
//!   only the photon part's cube size).

pub mod frame;
pub mod photon_frame;
pub mod stats;
pub mod translucent_frame;

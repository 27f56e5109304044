//! `ispm view`: the window and what the user touches in it.
//!
//! - [`viewer`]: the window, swapchain loop, keys and the still-camera accumulation.
//! - [`overlay`]: the egui overlay's contents (drawn by `gpu::OverlayPass`).
//! - [`camera_control`]: the fly camera and the scripted camera path; no window.

pub mod camera_control;
pub mod overlay;
pub mod viewer;

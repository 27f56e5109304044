//! The measuring commands and what they measure with.
//!
//! - [`bench`](mod@bench): `ispm bench`, frame times per pass and queue, side by side.
//! - [`sweep`]: `ispm sweep`, accuracy against time over a grid of settings.
//! - [`metrics`]: relMSE, FLIP and the error–time Pareto front; no Vulkan.

pub mod bench;
pub mod metrics;
pub mod sweep;

//! What the user asked for. One floor above `gpu` and `photon`: `--density auto` resolves
//! against the device's properties, and the settings name the photon kernel's and BSDF's types.
//!
//! - [`settings`]: [`settings::RenderSettings`] and its choices, built in one place
//!   ([`settings::RenderSettings::from_knobs`]) from the knobs, the preset and the defaults,
//!   each default written once beside its name.
//! - [`quality`]: the `--quality` presets (draft, interactive, high, reference) as points of the
//!   measured error–time fronts.

pub mod quality;
pub mod settings;

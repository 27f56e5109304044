//! The knobs a user turns ([`Knobs`]) and the one function that makes [`RenderSettings`] of
//! them ([`RenderSettings::from_knobs`]): each setting is the knob if given, else the
//! `--quality` preset's value ([`Preset`]) for the knobs a preset sets, else its default, a
//! named constant below written once beside its name (pbrt-v4 reads each parameter once, in one
//! place). `ispm render`, `view`, `bench`, `plan` and `sweep` all make their settings here, and
//! the library's [`RenderSettings::default`] is made of the same constants.
//!
//! Knob checks that need no scene live here too, so a bad value fails once, with one line
//! naming the flag (`--radius 0 must be a positive length`); clamps to what the renderer
//! supports ([`SHADOW_RESOLUTIONS`], [`MAX_EMITTER_LIGHTS`]) are applied here, silently, as the
//! command line always has.

use super::{Density, Effects, Method, RenderSettings, Schedule, TileOrder, Tonemap, Upsample};
use crate::photon::bsdf::BsdfVariant;
use crate::photon::kernel::KernelSettings;
use crate::scene::Aabb;
use std::ops::RangeInclusive;

/// Photons emitted per frame from all lights together without `--photons` or a preset.
pub const DEFAULT_PHOTONS: usize = 100_000;

/// Most scattering events per photon (`--bounces`): not a bounce count, only the safety cap,
/// since Russian roulette ends the paths (issue #19: the old fixed 8 bounces cost an albedo-0.8
/// room 13 % of its light, `tests/physics_energy.rs`).
pub const DEFAULT_BOUNCES: u32 = crate::photon::trace::MAX_BOUNCES;

/// Seed of every random choice (`--seed`).
pub const DEFAULT_SEED: u32 = 0;

/// Image size of a library caller's frame (each command has its own `--size` default, for what
/// it is for: a window, a benchmark, a sweep's many renders).
pub const DEFAULT_SIZE: (u32, u32) = (640, 480);

/// Shadow-map resolution per light view (`--shadow-resolution`), texels per side.
pub const DEFAULT_SHADOW_RESOLUTION: u32 = 1024;

/// The shadow-map resolutions the renderer makes: a `--shadow-resolution` outside is clamped.
pub const SHADOW_RESOLUTIONS: RangeInclusive<u32> = 16..=8192;

/// Exposure in stops (`--exposure`).
pub const DEFAULT_EXPOSURE_EV: f32 = 0.0;

/// Indirect light at full resolution (`--subsample 1`) without `--subsample` or a preset.
pub const DEFAULT_SUBSAMPLE: u32 = 1;

/// Levels of the à-trous filter for a library caller: none, the raw estimate (the command
/// line asks for [`crate::passes::denoise::DEFAULT_LEVELS`]).
pub const DEFAULT_DENOISE: u32 = 0;

/// The share of a light's photons that its caustic views get when its views see delta
/// instances (the default of `--caustic-share`; `plan::bounce_plan` module docs, "Budget").
pub const CAUSTIC_SHARE: f32 = 0.5;

/// Points sampled on the emissive surfaces per frame, each a light (`--emitter-lights`;
/// `scene::emitters`).
pub const DEFAULT_EMITTER_LIGHTS: u32 = 4;

/// The most `--emitter-lights` a frame takes (more is clamped): each is a shadow-mapped light.
pub const MAX_EMITTER_LIGHTS: u32 = 64;

/// The knobs a `--quality` preset sets (`quality::Quality::preset`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    pub photons: usize,
    pub bounces: u32,
    /// Multiple of the scene-relative kernel `r_max` (`KernelSettings::scene_relative`), so a
    /// preset means the same on a scene of any size.
    pub radius_scale: f32,
    pub subsample: u32,
    pub upsample: Upsample,
}

/// The knobs of a frame as the user gives them: `None` where not given, so that the preset
/// (for the knobs it sets) or the default fills it in [`RenderSettings::from_knobs`]. The
/// command line's flags map onto these one to one; a flag with a default of its own on the
/// command line (`--denoise`, `--density`) gives its knob always.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Knobs {
    /// `--method` (a GPU one for the renderer; [`Method::default`]).
    pub method: Option<Method>,
    /// `--quality`'s preset, or the command's default one (`quality::RENDER_DEFAULT`, …); `None`:
    /// no preset, the defaults.
    pub preset: Option<Preset>,
    /// `--photons` (the preset's, else [`DEFAULT_PHOTONS`]).
    pub photons: Option<usize>,
    /// `--bounces` (the preset's, else [`DEFAULT_BOUNCES`]).
    pub bounces: Option<u32>,
    /// `--radius`, the kernel `r_max` in metres: positive and finite (the preset's scale of the
    /// scene-relative radius, else that radius itself).
    pub radius: Option<f32>,
    /// `--subsample` (the preset's, else [`DEFAULT_SUBSAMPLE`]).
    pub subsample: Option<u32>,
    /// `--upsample` (the preset's, else [`Upsample::default`]).
    pub upsample: Option<Upsample>,
    /// `--subsample-caustics` (else the caustic photons at full resolution).
    pub subsampled_caustics: Option<bool>,
    /// `--size` (else [`DEFAULT_SIZE`]).
    pub size: Option<(u32, u32)>,
    /// `--seed` (else [`DEFAULT_SEED`]).
    pub seed: Option<u32>,
    /// `--shadow-resolution`, clamped to [`SHADOW_RESOLUTIONS`] (else
    /// [`DEFAULT_SHADOW_RESOLUTION`]).
    pub shadow_resolution: Option<u32>,
    /// `--tonemap` (else [`Tonemap::default`]).
    pub tonemap: Option<Tonemap>,
    /// `--exposure` in stops (else [`DEFAULT_EXPOSURE_EV`]).
    pub exposure_ev: Option<f32>,
    /// `--denoise` levels (else [`DEFAULT_DENOISE`]).
    pub denoise: Option<u32>,
    /// `--schedule` (else [`Schedule::default`]).
    pub schedule: Option<Schedule>,
    /// `--effects` (else [`Effects::default`]).
    pub effects: Option<Effects>,
    /// `--caustic-share` (else [`CAUSTIC_SHARE`]).
    pub caustic_share: Option<f32>,
    /// `--emitter-lights`, at most [`MAX_EMITTER_LIGHTS`] (else [`DEFAULT_EMITTER_LIGHTS`]).
    pub emitter_lights: Option<u32>,
    /// `--check-values` (else off).
    pub check_values: Option<bool>,
    /// Progressive accumulation (`--no-accumulate` turns it off; else off, as a library
    /// caller's frame stands alone).
    pub accumulate: Option<bool>,
    /// `--density` (else [`Density::default`]).
    pub density: Option<Density>,
}

impl RenderSettings {
    /// The settings of `knobs` for a scene with `bounds` (module docs): each knob given, else
    /// the preset's value, else the default. `bounds` only scales a preset's radius. Fails,
    /// with one line naming the flag, for a `--radius` that is not a positive length.
    pub fn from_knobs(knobs: &Knobs, bounds: &Aabb) -> anyhow::Result<RenderSettings> {
        if let Some(r) = knobs.radius {
            anyhow::ensure!(
                r.is_finite() && r > 0.0,
                "--radius {r} must be a positive length"
            );
        }
        let preset = knobs.preset;
        let photons = knobs
            .photons
            .or(preset.map(|p| p.photons))
            .unwrap_or(DEFAULT_PHOTONS);
        let radius = knobs.radius.or_else(|| {
            preset.map(|p| {
                p.radius_scale * KernelSettings::scene_relative(bounds, photons, None).r_max
            })
        });
        let (width, height) = knobs.size.unwrap_or(DEFAULT_SIZE);
        let (low, high) = SHADOW_RESOLUTIONS.into_inner();
        Ok(RenderSettings {
            method: knobs.method.unwrap_or_default(),
            photons,
            whole_light_grids: false,
            bounces: knobs
                .bounces
                .or(preset.map(|p| p.bounces))
                .unwrap_or(DEFAULT_BOUNCES),
            radius,
            seed: knobs.seed.unwrap_or(DEFAULT_SEED),
            width,
            height,
            shadow_resolution: knobs
                .shadow_resolution
                .unwrap_or(DEFAULT_SHADOW_RESOLUTION)
                .clamp(low, high),
            tonemap: knobs.tonemap.unwrap_or_default(),
            exposure_ev: knobs.exposure_ev.unwrap_or(DEFAULT_EXPOSURE_EV),
            subsample: knobs
                .subsample
                .or(preset.map(|p| p.subsample))
                .unwrap_or(DEFAULT_SUBSAMPLE),
            upsample: knobs
                .upsample
                .or(preset.map(|p| p.upsample))
                .unwrap_or_default(),
            subsampled_caustics: knobs.subsampled_caustics.unwrap_or(false),
            denoise: knobs.denoise.unwrap_or(DEFAULT_DENOISE),
            schedule: knobs.schedule.unwrap_or_default(),
            effects: knobs.effects.unwrap_or_default(),
            bsdf_variant: BsdfVariant::ALL,
            caustic_share: knobs.caustic_share.unwrap_or(CAUSTIC_SHARE),
            storage_buffer_range: None,
            check_values: knobs.check_values.unwrap_or(false),
            accumulate: knobs.accumulate.unwrap_or(false),
            emitter_lights: knobs
                .emitter_lights
                .unwrap_or(DEFAULT_EMITTER_LIGHTS)
                .min(MAX_EMITTER_LIGHTS),
            density: knobs.density.unwrap_or_default(),
            tile_order: TileOrder::default(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn unit_box() -> Aabb {
        Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        }
    }

    fn draft() -> Preset {
        Preset {
            photons: 10_000,
            bounces: 7,
            radius_scale: 2.0,
            subsample: 4,
            upsample: Upsample::Bilinear,
        }
    }

    #[test]
    fn no_knobs_give_the_defaults() {
        let settings = RenderSettings::from_knobs(&Knobs::default(), &unit_box()).unwrap();
        assert_eq!(settings, RenderSettings::default());
        assert_eq!(settings.photons, DEFAULT_PHOTONS);
        assert_eq!(settings.bounces, DEFAULT_BOUNCES);
        assert_eq!(settings.radius, None);
        assert_eq!((settings.width, settings.height), DEFAULT_SIZE);
        assert_eq!(settings.emitter_lights, DEFAULT_EMITTER_LIGHTS);
    }

    #[test]
    fn a_preset_fills_only_the_knobs_not_given() {
        let bounds = unit_box();
        let preset = draft();
        let from_preset = RenderSettings::from_knobs(
            &Knobs {
                preset: Some(preset),
                photons: Some(1234),
                ..Default::default()
            },
            &bounds,
        )
        .unwrap();
        assert_eq!(from_preset.photons, 1234, "the flag beats the preset");
        assert_eq!(from_preset.bounces, preset.bounces);
        assert_eq!(from_preset.subsample, preset.subsample);
        assert_eq!(from_preset.upsample, preset.upsample);
        // The preset's radius scales the scene-relative one for the photons asked.
        let r = KernelSettings::scene_relative(&bounds, 1234, None).r_max;
        assert_eq!(from_preset.radius, Some(preset.radius_scale * r));
        // What no preset sets keeps its default.
        assert_eq!(from_preset.shadow_resolution, DEFAULT_SHADOW_RESOLUTION);
        let flags = RenderSettings::from_knobs(
            &Knobs {
                preset: Some(preset),
                radius: Some(0.05),
                subsample: Some(1),
                upsample: Some(Upsample::Joint),
                bounces: Some(3),
                ..Default::default()
            },
            &bounds,
        )
        .unwrap();
        assert_eq!(flags.photons, preset.photons);
        assert_eq!(
            (flags.radius, flags.subsample, flags.upsample, flags.bounces),
            (Some(0.05), 1, Upsample::Joint, 3)
        );
    }

    #[test]
    fn a_bad_radius_fails_with_one_line_naming_the_flag() {
        for r in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let knobs = Knobs {
                radius: Some(r),
                ..Default::default()
            };
            let err = RenderSettings::from_knobs(&knobs, &unit_box()).unwrap_err();
            assert_eq!(
                err.to_string(),
                format!("--radius {r} must be a positive length")
            );
        }
    }

    #[test]
    fn out_of_range_knobs_are_clamped_to_what_the_renderer_makes() {
        let settings = RenderSettings::from_knobs(
            &Knobs {
                shadow_resolution: Some(1),
                emitter_lights: Some(1000),
                ..Default::default()
            },
            &unit_box(),
        )
        .unwrap();
        assert_eq!(settings.shadow_resolution, *SHADOW_RESOLUTIONS.start());
        assert_eq!(settings.emitter_lights, MAX_EMITTER_LIGHTS);
    }
}

//! The command line's parts (`src/main.rs` parses, these run): one module per command with its
//! arguments and what it does, and here what they share: the scene and quality flags, value
//! parsers, loading the scene and starting Vulkan. Settings are made in one place, the library's
//! `settings::RenderSettings::from_knobs`: a command only maps its flags onto `settings::Knobs`.

use anyhow::Context;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::ValueEnum;
use ispm::config::quality::Quality;
use ispm::config::settings::{Density, Knobs};
use ispm::gpu::{Gpu, GpuOptions};

pub mod bench;
pub mod info;
pub mod plan;
pub mod render;
pub mod sweep;
pub mod view;

/// `--quality` and the knobs it sets, shared by `render`, `view` and `bench` (src/config/quality.rs).
#[derive(clap::Args)]
pub struct QualityArgs {
    /// Set photons, bounces, kernel radius and subsampling to a point measured on the
    /// error–time Pareto fronts of the bundled scenes (docs/accuracy.md §5); explicit flags
    /// override its values. `none`: no preset, the flags' own defaults. Default: `high` for
    /// `render --method ispm`, `interactive` for `view`, `none` otherwise.
    #[arg(long, value_parser = preset_or_none())]
    quality: Option<PresetOrNone>,
    /// Photons emitted per frame, split over the lights by power (default: the --quality
    /// preset's; 100000 without one). A light view holds at most 2048x2048 texels: a light whose share
    /// asks for more emits fewer photons, and `render` says so.
    #[arg(long)]
    photons: Option<usize>,
    /// Estimate indirect light at 1/N resolution and upsample it (--upsample; N is clamped to
    /// the image size; 1: full resolution). Default: the --quality preset's; 1 without one.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    subsample: Option<u32>,
    /// Most scattering events per photon, and per path for the references (default: until
    /// Russian roulette ends the path, at most 256; a lower N cuts the light after N bounces).
    #[arg(long)]
    bounces: Option<u32>,
    /// Largest photon kernel radius in metres (default: from the scene size and photon count,
    /// scaled by the --quality preset's factor).
    #[arg(long)]
    radius: Option<f32>,
    /// At --subsample N > 1: `joint` bilateral upsampling against the full-resolution G-buffer,
    /// or plain `bilinear` (default joint).
    #[arg(long, value_enum)]
    upsample: Option<ispm::config::settings::Upsample>,
    /// At --subsample N > 1, estimate the caustic photons at 1/N too, as the global ones:
    /// cheaper, but a focused caustic spreads over N×N blocks (default: the caustic photons at
    /// full resolution).
    #[arg(long)]
    subsample_caustics: bool,
}

/// What `--quality` names: a preset, or `none` (no preset, whatever the command's default one).
#[derive(Clone, Copy)]
pub struct PresetOrNone(Option<Quality>);

/// `--quality`'s values: `none` and the presets, each with its description.
fn preset_or_none() -> impl TypedValueParser<Value = PresetOrNone> {
    let none = PossibleValue::new("none").help("No preset: the flags' own defaults");
    let presets = Quality::value_variants()
        .iter()
        .filter_map(ValueEnum::to_possible_value);
    PossibleValuesParser::new(std::iter::once(none).chain(presets)).map(|name| {
        // The parser admits only the names above: `none`, or a preset's.
        PresetOrNone((name != "none").then(|| Quality::from_str(&name, false).expect("a preset")))
    })
}

impl QualityArgs {
    /// The knobs these flags give, with `--quality`'s preset, else the command's `default` one
    /// (`settings::RenderSettings::from_knobs` fills the rest and checks them).
    pub fn knobs(&self, default: Option<Quality>) -> Knobs {
        Knobs {
            preset: self.quality.map_or(default, |q| q.0).map(Quality::preset),
            photons: self.photons,
            bounces: self.bounces,
            radius: self.radius,
            subsample: self.subsample,
            upsample: self.upsample,
            subsampled_caustics: self.subsample_caustics.then_some(true),
            ..Knobs::default()
        }
    }
}

/// Which scene, how its file is read and from which of its cameras: shared by every command
/// that loads one.
#[derive(clap::Args)]
pub struct SceneArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    /// Render a scene with no light and no emissive surface as it is (unlit: only unlit
    /// materials show) instead of adding the default key light over the camera's shoulder.
    #[arg(long)]
    no_default_light: bool,
    /// KHR_materials_variants: show the material variant NAME instead of the default materials.
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// View the scene from the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
}

impl SceneArgs {
    /// The scene's name as the user gave it (the bundled cornell-box when none was).
    pub fn name(&self) -> &str {
        self.scene.as_deref().unwrap_or("cornell-box")
    }

    /// The scene read as these flags say, seen from its file's camera `--camera N` if given,
    /// with its lights orbiting when `orbit` asks. Says on stderr when the default light was
    /// added, or when `--no-default-light` leaves the scene without light.
    pub fn load(&self, orbit: &OrbitArgs) -> anyhow::Result<ispm::scene::Scene> {
        let options = ispm::scene::load::LoadOptions {
            default_light: !self.no_default_light,
            variant: self.variant.clone(),
        };
        let mut scene = ispm::scene::bundled::resolve_with(self.scene.as_deref(), &options)?;
        let name = self.name();
        if let Some(n) = self.camera {
            let count = scene.cameras.len();
            scene.camera = *scene.cameras.get(n).ok_or_else(|| match count {
                0 => anyhow::anyhow!("--camera {n}: {name} has no cameras"),
                1 => anyhow::anyhow!("--camera {n}: {name} has 1 camera (--camera 0)"),
                _ => anyhow::anyhow!(
                    "--camera {n}: {name} has {count} cameras (--camera 0 to {})",
                    count - 1
                ),
            })?;
            scene.aim_default_light();
        }
        if let Some(seconds) = orbit.orbit_lights {
            scene.orbit_lights(seconds).context("--orbit-lights")?;
        }
        if scene.default_light {
            eprintln!(
                "ispm: {name} has no lights; adding a default key light (--no-default-light \
                 turns it off)"
            );
        } else if scene.needs_default_light() {
            eprintln!(
                "ispm: warning: {name} has no lights and --no-default-light keeps it so: nothing \
                 in it is lit (only unlit materials show)"
            );
        }
        Ok(scene)
    }
}

/// `--orbit-lights`, shared by `render`, `view`, `bench` and `plan` (not `sweep`: its error
/// against a still reference needs still lights).
#[derive(clap::Args, Default)]
pub struct OrbitArgs {
    /// Orbit every light about the vertical axis through the scene's centre, one turn per
    /// SECONDS_PER_TURN (default 10), so any scene shows moving light and caustics.
    #[arg(long, value_name = "SECONDS_PER_TURN", num_args = 0..=1, default_missing_value = "10",
          value_parser = parse_seconds_per_turn)]
    orbit_lights: Option<f32>,
}

/// How the GPU methods estimate the indirect light, shared by `render`, `view`, `bench` and
/// `plan`.
#[derive(clap::Args)]
pub struct EstimateArgs {
    /// GPU methods: the density estimator: `volumes` (each photon's kernel rasterised as a
    /// billboard, the paper's), `tiled` (a per-tile gather in compute; the same sums) or `auto`
    /// (the faster on the device: tiled on a CPU implementation such as lavapipe, volumes on
    /// a GPU; `ispm info` says which).
    #[arg(long, value_enum, default_value_t)]
    pub density: Density,
    /// GPU methods: levels of the edge-avoiding à-trous filter over the indirect light (taps up
    /// to ±2·(2^N − 1) pixels apart, on one surface), fewer as still frames accumulate and none
    /// from the 2^N-th on, so the mean converges as without it (0: the raw estimate;
    /// docs/accuracy.md, "The denoiser").
    #[arg(long, value_name = "N", default_value_t = ispm::passes::denoise::DEFAULT_LEVELS,
          value_parser = clap::value_parser!(u32).range(0..=ispm::passes::denoise::MAX_LEVELS as i64))]
    pub denoise: u32,
}

pub fn parse_seconds_per_turn(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "{s:?} is not a positive number of seconds per turn (put the scene before \
             --orbit-lights)"
        )),
    }
}

pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("size {s:?} is not WIDTHxHEIGHT"))
    };
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s:?} must be between 1x1 and 16384x16384"));
    }
    Ok((w, h))
}

pub fn gpu(cli_device: Option<usize>) -> anyhow::Result<std::sync::Arc<Gpu>> {
    Gpu::new(&GpuOptions {
        device_index: cli_device,
        ..Default::default()
    })
    .context("cannot start Vulkan")
}

/// Fails when the validation layer reported anything (printing every message first).
pub fn check_validation(gpu: &Gpu) -> anyhow::Result<()> {
    let messages = gpu.validation_messages();
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        eprintln!("validation: {m}");
    }
    anyhow::bail!(
        "the Vulkan validation layer reported {} message(s)",
        messages.len()
    )
}

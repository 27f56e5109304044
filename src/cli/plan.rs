//! `ispm plan`: the effects plan of a scene, no GPU needed (`ispm::plan`).

use super::{load_scene_from, parse_seconds_per_turn, parse_size, SceneArgs};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::ValueEnum;
use ispm::settings::{Density, Effects, Knobs, Method, RenderSettings, DEFAULT_BOUNCES};

#[derive(clap::Args)]
pub struct PlanArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Image size, WIDTHxHEIGHT (the view's aspect ratio).
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    #[arg(long, value_enum, default_value_t, value_parser = gpu_method())]
    method: Method,
    /// Photons emitted per frame, split over the active lights by power (default: what
    /// `render` uses, the `high` preset's for ISPM, else 100000).
    #[arg(long)]
    photons: Option<usize>,
    /// Most scattering events per photon (default: until Russian roulette ends the path, at
    /// most 256).
    #[arg(long, default_value_t = DEFAULT_BOUNCES)]
    bounces: u32,
    /// Photon volumes at 1/N resolution (default: what `render` uses, the `high` preset's for
    /// ISPM, else 1).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    subsample: Option<u32>,
    /// `auto`: plan; `all`: every pass, variant, light and bounce (the unplanned frame).
    #[arg(long, value_enum, default_value_t)]
    effects: Effects,
    /// The density estimator the plan lists (`auto`: what `render` picks on the device
    /// `--device` chooses, or on the first usable one).
    #[arg(long, value_enum, default_value_t)]
    density: Density,
    /// GPU methods: levels of the edge-avoiding à-trous filter over the indirect light (taps up
    /// to ±2·(2^N − 1) pixels apart, on one surface), fewer as still frames accumulate and none
    /// from the 2^N-th on, so the mean converges as without it (0: the raw estimate;
    /// docs/accuracy.md, "The denoiser").
    #[arg(long, value_name = "N", default_value_t = ispm::passes::denoise::DEFAULT_LEVELS,
          value_parser = clap::value_parser!(u32).range(0..=ispm::passes::denoise::MAX_LEVELS as i64))]
    denoise: u32,
    /// Plan the view of the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
    /// Orbit every light about the vertical axis through the scene's centre, one turn per
    /// SECONDS_PER_TURN (default 10), so any scene shows moving light and caustics.
    #[arg(long, value_name = "SECONDS_PER_TURN", num_args = 0..=1, default_missing_value = "10",
          value_parser = parse_seconds_per_turn)]
    orbit_lights: Option<f32>,
}

/// `plan --method`: the methods the GPU renderer draws ([`Method::GPU`]), whose frames have a
/// plan, described as the plan sees them.
fn gpu_method() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(Method::GPU.map(|m| {
        PossibleValue::new(m.name()).help(match m {
            Method::Direct => "Shadow-mapped deferred direct light only",
            _ => "Image Space Photon Mapping: direct light plus photon-mapped indirect light",
        })
    }))
    .try_map(|name| Method::from_str(&name, false))
}

pub fn plan(args: PlanArgs, device: Option<usize>) -> anyhow::Result<()> {
    let scene = load_scene_from(
        args.scene.as_deref(),
        &args.scene_args,
        args.camera,
        args.orbit_lights,
    )?;
    // The knobs `render` would use (its default preset for ISPM).
    let preset = (args.method == Method::Ispm).then(|| ispm::quality::RENDER_DEFAULT.preset());
    let knobs = Knobs {
        method: Some(args.method),
        preset,
        photons: args.photons,
        bounces: Some(args.bounces),
        size: Some(args.size),
        subsample: args.subsample,
        effects: Some(args.effects),
        density: Some(args.density.resolve_for(device)),
        denoise: Some(args.denoise),
        ..Knobs::default()
    };
    let settings = RenderSettings::from_knobs(&knobs, &scene.bounds())?;
    let plan = ispm::plan::EffectsPlan::analyse(&scene, &settings, &scene.camera);
    print!("{plan}");
    let name = args.scene.as_deref().unwrap_or("cornell-box");
    let default_light = if scene.default_light {
        format!(
            "yes — {name} has no lights and no emissive surfaces: light 0 '{}' is a spot over \
             the camera's shoulder (--no-default-light turns it off)",
            scene.lights[0].name
        )
    } else if !scene.lights.is_empty() {
        format!("no — the scene has {} light(s)", scene.lights.len())
    } else if scene.has_emitter() {
        "no — its emissive surfaces light it".to_string()
    } else {
        "no — --no-default-light: nothing in the scene is lit".to_string()
    };
    println!("default light: {default_light}");
    Ok(())
}

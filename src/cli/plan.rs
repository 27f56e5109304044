//! `ispm plan`: the effects plan of a scene, no GPU needed (`ispm::plan`).

use super::{parse_size, EstimateArgs, OrbitArgs, SceneArgs};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::ValueEnum;
use ispm::config::settings::{Effects, Knobs, Method, RenderSettings, DEFAULT_BOUNCES};

#[derive(clap::Args)]
pub struct PlanArgs {
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
    #[command(flatten)]
    estimate: EstimateArgs,
    #[command(flatten)]
    orbit: OrbitArgs,
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
    let scene = args.scene_args.load(&args.orbit)?;
    // The knobs `render` would use (its default preset for ISPM).
    let preset =
        (args.method == Method::Ispm).then(|| ispm::config::quality::RENDER_DEFAULT.preset());
    let knobs = Knobs {
        method: Some(args.method),
        preset,
        photons: args.photons,
        bounces: Some(args.bounces),
        size: Some(args.size),
        subsample: args.subsample,
        effects: Some(args.effects),
        density: Some(args.estimate.density.resolve_for(device)),
        denoise: Some(args.estimate.denoise),
        ..Knobs::default()
    };
    let settings = RenderSettings::from_knobs(&knobs, &scene.bounds())?;
    let plan = ispm::plan::EffectsPlan::analyse(&scene, &settings, &scene.camera);
    print!("{plan}");
    let name = args.scene_args.name();
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

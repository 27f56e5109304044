//! `ispm sweep`: accuracy against time over a grid of settings (`ispm::tools::sweep`).

use super::{check_validation, gpu, parse_size, OrbitArgs, SceneArgs};
use ispm::config::settings::DEFAULT_BOUNCES;
use ispm::tools::sweep::reference::{DEFAULT_REFERENCE_PASSES, DEFAULT_REFERENCE_PHOTONS};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct SweepArgs {
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Folder for results.csv, results.json and the plots (configurations already in its
    /// results.json are not measured again).
    #[arg(long)]
    out: PathBuf,
    /// Knobs and their values, `KNOB=V,V;KNOB=V` (photons, bounces, radius, subsample,
    /// caustic-share, upsample, accumulate, density, method), e.g.
    /// `photons=10k,40k;subsample=1,2`; knobs not named keep their defaults (docs/accuracy.md
    /// §5).
    #[arg(long, default_value = "")]
    grid: String,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "160x120", value_parser = parse_size)]
    size: (u32, u32),
    /// Timed frames per configuration (after one warm-up frame).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Reference: path-tracer samples per pixel, or progressive photon mapping iterations.
    #[arg(long, default_value_t = DEFAULT_REFERENCE_PASSES,
          value_parser = clap::value_parser!(u32).range(1..))]
    reference_passes: u32,
    /// Reference: photons per progressive photon mapping iteration.
    #[arg(long, default_value_t = DEFAULT_REFERENCE_PHOTONS)]
    reference_photons: usize,
    /// Reference: most bounces of a light path (default: until Russian roulette ends it, at
    /// most 256).
    #[arg(long, default_value_t = DEFAULT_BOUNCES)]
    reference_bounces: u32,
    /// Where references are cached (default: $XDG_CACHE_HOME/ispm/references).
    #[arg(long, value_name = "DIR")]
    reference_cache: Option<PathBuf>,
}

pub fn sweep(args: SweepArgs, device: Option<usize>) -> anyhow::Result<()> {
    let grid = ispm::tools::sweep::Grid::parse(&args.grid)?;
    anyhow::ensure!(
        !args.out.is_file(),
        "--out {}: a file, not a folder",
        args.out.display()
    );
    let scene = args.scene_args.load(&OrbitArgs::default())?;
    let scene_name = args.scene_args.name();
    let gpu = gpu(device)?;
    let settings = ispm::tools::sweep::SweepSettings {
        grid,
        width: args.size.0,
        height: args.size.1,
        frames: args.frames,
        reference: ispm::tools::sweep::ReferenceSpec {
            passes: args.reference_passes,
            photons: args.reference_photons,
            bounces: args.reference_bounces,
        },
        reference_cache: args.reference_cache,
    };
    let report = ispm::tools::sweep::run(&gpu, &scene, scene_name, &settings, &args.out)?;
    check_validation(&gpu)?;
    print!("{}", report.table());
    eprintln!(
        "{} configuration(s) measured, {} already in {}; reference {} ({})",
        report.measured,
        report.skipped,
        args.out.join("results.json").display(),
        report.reference_path.display(),
        if report.reference_rendered {
            "rendered"
        } else {
            "cached"
        }
    );
    Ok(())
}

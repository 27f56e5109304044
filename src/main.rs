//! The `ispm` command line (DESIGN.md §7). Parsing and reporting only: the work is in the
//! library. Each command's arguments and run are in `cli/` (one module per command); the
//! settings they give are made in one place, `ispm::config::settings::RenderSettings::from_knobs`.

use clap::{Parser, Subcommand};
use cli::bench::BenchArgs;
use cli::plan::PlanArgs;
use cli::render::RenderArgs;
use cli::sweep::SweepArgs;
use cli::view::ViewArgs;
use std::process::ExitCode;

mod cli;

#[derive(Parser)]
#[command(
    name = "ispm",
    version,
    about = "Real-time global illumination by Image Space Photon Mapping"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Vulkan physical device index (see `ispm info`); default: the best one.
    #[arg(long, global = true)]
    device: Option<usize>,
}

#[derive(Subcommand)]
enum Command {
    /// Render one frame headless to PNG (tonemapped) or EXR (linear HDR).
    Render(RenderArgs),
    /// Print the Vulkan devices, the driver, and the queues the renderer uses.
    Info,
    /// Print the effects plan of a scene: which passes, shader variants, lights and bounces a
    /// frame needs, one line per decision with its reason (no GPU needed).
    Plan(PlanArgs),
    /// Measure the frame per stage, the overlapped schedule against the serial one and the
    /// direct-only frame, side by side in one run.
    Bench(BenchArgs),
    /// Open a window and render the scene live (W A S D Q E fly, right button looks, Esc quits)
    ///
    /// Keys and mouse:
    ///   W / S      fly forward / back along the view
    ///   A / D      fly left / right
    ///   Q / E      fly down / up (the world's vertical)
    ///   right button held + mouse   look around
    ///   wheel      fly speed ×1.25 per notch (starts at a quarter of the scene's diagonal per s)
    ///   F          frame the scene: back away along the view until its bounds fit
    ///   C          the file's next camera (--camera N picks the first one shown)
    ///   Tab        show / hide the overlay (times, effects plan, settings, debug views)
    ///   P          screenshot (PNG) + its stats JSON, into --shots DIR (default: .)
    ///   T          Chrome trace of the next 30 frames, into --shots DIR
    ///   Esc        quit
    ///
    /// With --frames N the camera follows a scripted path instead (a swing about the point
    /// the start camera looks at, and a dolly towards it), frame k at a pose that depends on k
    /// alone: `ispm render --camera-path-frame N` renders the pose of the last frame.
    #[command(verbatim_doc_comment)]
    View(ViewArgs),
    /// Measure accuracy against time: render the scene over a grid of settings, time every
    /// stage and compare with a cached CPU reference; write results.csv, results.json and SVG
    /// plots (the error–time Pareto front) into --out. Resumable.
    Sweep(SweepArgs),
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    // A bug must still end in one clear line, not a backtrace dump.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("ispm: internal error: {info}");
    }));
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => cli::render::render(args, cli.device),
        Command::Info => cli::info::info(cli.device),
        Command::Plan(args) => cli::plan::plan(args, cli.device),
        Command::Bench(args) => cli::bench::bench(args, cli.device),
        Command::View(args) => cli::view::view(args, cli.device),
        Command::Sweep(args) => cli::sweep::sweep(args, cli.device),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ispm: {e:#}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::CommandFactory;

    /// Every command's arguments are consistent (no two with one name, every flattened group
    /// well formed), which clap otherwise checks only when that command is parsed.
    #[test]
    fn every_commands_arguments_are_consistent() {
        Cli::command().debug_assert();
    }

    /// The flags shared through flattened groups reach the commands that take them, and only
    /// those: `sweep` measures with still lights, so it has no `--orbit-lights`.
    #[test]
    fn the_shared_flags_reach_the_commands_that_take_them() {
        use clap::Parser;
        for command in ["render", "view", "bench", "plan"] {
            let args = [
                "ispm",
                command,
                "cornell-box",
                "--camera",
                "0",
                "--orbit-lights",
                "--density",
                "tiled",
                "--denoise",
                "0",
            ];
            assert!(Cli::try_parse_from(args).is_ok(), "{command}");
        }
        let sweep = ["ispm", "sweep", "--out", "x", "--camera", "0"];
        assert!(Cli::try_parse_from(sweep).is_ok());
        let orbit = ["ispm", "sweep", "--out", "x", "--orbit-lights"];
        assert!(Cli::try_parse_from(orbit).is_err());
        for q in ["none", "draft", "interactive", "high", "reference"] {
            assert!(Cli::try_parse_from(["ispm", "render", "--quality", q]).is_ok());
        }
        assert!(Cli::try_parse_from(["ispm", "render", "--quality", "best"]).is_err());
    }
}

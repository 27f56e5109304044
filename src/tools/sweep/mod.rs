//! `ispm sweep`: what accuracy costs in time. Renders one scene over a grid of the knobs that
//! trade accuracy for time ([`grid`]), measures every configuration's per-stage times and its
//! error against a cached CPU reference ([`measure`], [`reference`](mod@reference)), and writes the results
//! and plots into a folder ([`results`], [`plots`]):
//!
//! ```text
//!   DIR/results.json   every record (read back to resume)
//!   DIR/results.csv    one row per record
//!   DIR/pareto.svg     relMSE vs frame time, the Pareto front marked
//!   DIR/stages.svg     stacked stage medians per configuration
//!   DIR/knobs.svg      relMSE vs each knob
//! ```
//!
//! Resumable: a configuration whose key (configuration, scene content hash, size) is in
//! `DIR/results.json` is not measured again; results are written after every configuration.
//! `docs/accuracy.md` §5 is the study made with it.

pub mod grid;
mod hash;
pub mod measure;
pub mod plots;
pub mod reference;
pub mod results;

use crate::gpu::Gpu;
use crate::scene::Scene;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use grid::{Config, Grid};
pub use reference::ReferenceSpec;
pub use results::{Record, Results};

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepSettings {
    pub grid: Grid,
    pub width: u32,
    pub height: u32,
    /// Timed frames per configuration (after one warm-up frame).
    pub frames: u32,
    pub reference: ReferenceSpec,
    /// Where references are cached (`reference::default_cache` when `None`).
    pub reference_cache: Option<PathBuf>,
}

/// What a sweep did.
#[derive(Clone, Debug)]
pub struct SweepReport {
    /// Configurations measured by this run.
    pub measured: usize,
    /// Configurations already in the results (resumed, not redone).
    pub skipped: usize,
    /// The reference was rendered (not read from the cache).
    pub reference_rendered: bool,
    pub reference_path: PathBuf,
    /// This scene's and size's records, front ones marked.
    pub records: Vec<Record>,
}

/// Progress bars on stderr, hidden when stderr is not a terminal.
fn bar(len: u64, template: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
        bar.set_style(style);
    }
    bar
}

/// Runs the sweep of `scene` (named `scene_name` in the results) into `out` (module docs).
pub fn run(
    gpu: &Arc<Gpu>,
    scene: &Scene,
    scene_name: &str,
    settings: &SweepSettings,
    out: &Path,
) -> Result<SweepReport> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create the output folder", out.display()))?;
    let mut results = Results::load(out)?;
    let scene_hash = hash::hex(reference::scene_hash(scene));
    let (width, height) = (settings.width, settings.height);
    // `auto` as this device resolves it, so every record names the estimator that made it.
    let configs = settings
        .grid
        .clone()
        .resolve_density(|d| d.resolve_for_device(&gpu.properties))
        .configs();
    let todo: Vec<&Config> = configs
        .iter()
        .filter(|c| !results.contains(&results::key(c, &scene_hash, width, height)))
        .collect();
    let cache = settings
        .reference_cache
        .clone()
        .unwrap_or_else(reference::default_cache);
    let ref_bar = bar(0, "{msg} [{bar:30}] {pos}/{len} rows, {eta} left");
    let refs = reference::references(scene, &settings.reference, width, height, &cache, &ref_bar)?;
    ref_bar.finish_and_clear();
    let progress = bar(
        todo.len() as u64,
        "sweep [{bar:30}] {pos}/{len} configurations, {eta} left: {msg}",
    );
    for config in &todo {
        progress.set_message(config.label());
        let measurement =
            measure::measure(gpu, scene, config, (width, height), settings.frames, &refs)
                .with_context(|| config.label())?;
        results.records.push(Record {
            key: results::key(config, &scene_hash, width, height),
            label: config.label(),
            scene: scene_name.to_string(),
            scene_hash: scene_hash.clone(),
            width,
            height,
            frames: settings.frames,
            config: (*config).clone(),
            measurement,
            pareto: false,
        });
        results.mark_pareto();
        results.write(out)?;
        progress.inc(1);
    }
    progress.finish_and_clear();
    results.mark_pareto();
    results.write(out)?;
    let records: Vec<Record> = results.of(&scene_hash, width, height).cloned().collect();
    let shown: Vec<&Record> = records.iter().collect();
    plots::write_all(out, &format!("{scene_name} {width}x{height}"), &shown)?;
    Ok(SweepReport {
        measured: todo.len(),
        skipped: configs.len() - todo.len(),
        reference_rendered: refs.rendered,
        reference_path: refs.path,
        records,
    })
}

impl SweepReport {
    /// The table `ispm sweep` prints: every record of this scene and size, front first.
    pub fn table(&self) -> String {
        let mut rows: Vec<&Record> = self.records.iter().collect();
        rows.sort_by(|a, b| {
            b.pareto
                .cmp(&a.pareto)
                .then(a.measurement.frame_ms.total_cmp(&b.measurement.frame_ms))
        });
        let mut out = format!(
            "{:<44} {:>9} {:>10} {:>10} {:>10} {:>7} {}\n",
            "configuration", "frame ms", "relMSE", "direct", "indirect", "FLIP", "front"
        );
        for r in rows {
            let m = &r.measurement;
            out += &format!(
                "{:<44} {:>9.2} {:>10.3e} {:>10.3e} {:>10.3e} {:>7.4} {}\n",
                r.label,
                m.frame_ms,
                m.rel_mse,
                m.rel_mse_direct,
                m.rel_mse_indirect,
                m.flip,
                if r.pareto { "*" } else { "" }
            );
        }
        out
    }
}

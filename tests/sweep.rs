//! `ispm sweep` (issue #7) on lavapipe with validation on: a tiny sweep writes well-formed
//! results and plots and resumes without redoing anything; more photons at a fixed kernel do
//! not make the indirect error worse on any bundled scene.

mod common;

use common::cli::ispm;
use ispm::config::settings::Method;
use ispm::photon::kernel::KernelSettings;
use ispm::tools::sweep::measure::measure;
use ispm::tools::sweep::reference::{method_for, references};
use ispm::tools::sweep::{Config, ReferenceSpec};
use std::path::Path;

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn tiny_sweep(out: &Path, cache: &Path) -> std::process::Output {
    ispm(&[
        "sweep",
        "diffuse-box",
        "--out",
        out.to_str().expect("utf-8 path"),
        "--grid",
        "photons=2k,8k;radius=1;subsample=1,2",
        "--size",
        "64x64",
        "--frames",
        "2",
        "--reference-passes",
        "16",
        "--reference-cache",
        cache.to_str().expect("utf-8 path"),
    ])
}

#[test]
fn tiny_sweep_writes_csv_json_and_plots_and_a_second_run_redoes_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (out, cache) = (dir.path().join("sweep"), dir.path().join("cache"));
    let first = tiny_sweep(&out, &cache);
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(
        stderr(&first).contains("4 configuration(s) measured, 0 already"),
        "{}",
        stderr(&first)
    );

    let csv = std::fs::read_to_string(out.join("results.csv")).expect("results.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 5, "header + 4 rows:\n{csv}");
    let columns = lines[0].split(',').count();
    assert!(lines[0].starts_with("scene,") && lines[0].contains("rel_mse_indirect"));
    assert!(lines[0].contains("ms.cpu.cpu_trace"), "{}", lines[0]);
    for row in &lines[1..] {
        assert_eq!(row.split(',').count(), columns, "ragged row: {row}");
    }

    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).expect("results.json"))
            .expect("results.json parses");
    let records = json["records"].as_array().expect("records");
    assert_eq!(records.len(), 4);
    let mut front = 0;
    for r in records {
        for field in [
            "frame_ms",
            "rel_mse",
            "rel_mse_direct",
            "rel_mse_indirect",
            "flip",
        ] {
            let v = r[field].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v >= 0.0, "{field} = {v} in {r}");
        }
        assert!(r["frame_ms"].as_f64().unwrap() > 0.0);
        assert!(r["flip"].as_f64().unwrap() <= 1.0);
        front += usize::from(r["pareto"].as_bool().expect("pareto flag"));
    }
    assert!(front >= 1, "no Pareto point");

    for plot in ["pareto.svg", "stages.svg", "knobs.svg"] {
        let svg = std::fs::read_to_string(out.join(plot)).expect(plot);
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{plot} is not a whole SVG"
        );
        assert!(svg.contains("<text"), "{plot} has no labels");
    }
    assert!(
        std::fs::read_to_string(out.join("pareto.svg"))
            .unwrap()
            .contains("Pareto front"),
        "the front is not marked"
    );

    let second = tiny_sweep(&out, &cache);
    assert!(second.status.success(), "{}", stderr(&second));
    let text = stderr(&second);
    assert!(
        text.contains("0 configuration(s) measured, 4 already") && text.contains("(cached)"),
        "the second run redid work: {text}"
    );
    let again: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(again["records"], json["records"], "the records changed");
}

#[test]
fn sweep_rejects_bad_input_in_one_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("sweep");
    let one_line = |run: &std::process::Output, needle: &str| {
        assert!(!run.status.success(), "{needle}: succeeded");
        let text = stderr(run);
        assert_eq!(text.trim().lines().count(), 1, "{text}");
        assert!(
            text.starts_with("ispm: ") && text.contains(needle),
            "{text}"
        );
        assert!(!text.contains("panicked"), "{text}");
    };
    let out_arg = out.to_str().unwrap();
    one_line(
        &ispm(&["sweep", "--out", out_arg, "--grid", "photons=lots"]),
        "photons=lots",
    );
    assert!(!out.exists(), "the output folder was created");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("results.json"), "{not json").unwrap();
    one_line(
        &ispm(&["sweep", "diffuse-box", "--out", out_arg, "--size", "8x8"]),
        "results.json: not an `ispm sweep` result",
    );
    assert_eq!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        "{not json",
        "the bad results were overwritten"
    );
}

/// Photon counts of the monotonicity test, ×4 each step.
const PHOTONS: [usize; 3] = [4_000, 16_000, 64_000];
/// Allowed growth of the indirect relMSE and of FLIP from one photon count to the next (module
/// docs of the test below).
const MONOTONIC_TOLERANCE: f64 = 0.10;

/// The scene whose indirect relMSE the test below does not hold to [`MONOTONIC_TOLERANCE`]
/// (its FLIP it does), and why.
const SHARP_CAUSTIC: &str = "caustic-ring";

/// More photons at a fixed kernel clamp never make the estimate worse by more than noise. At a
/// fixed `r_max` (the default for the smallest count) the kernels are the photons' kNN radii
/// (`photon::density`, a fixed k at these counts) under a fixed clamp: more photons shrink them
/// towards the pixel footprint, the photons per kernel stay k, so the bias falls and the noise
/// does not grow; the indirect relMSE against the reference should fall or stay flat. The
/// tolerance, 10 % per ×4 step, covers the estimate's own randomness: one seed per count, and
/// where the error is bias-dominated it is flat and the noise term's decrease is smaller than
/// its seed-to-seed spread. The whole image's mean FLIP is held to the same tolerance: it would
/// catch fireflies (a caustic photon's kernel shrinking below a pixel, docs/accuracy.md §3)
/// anywhere. 48×48, references of 64 passes (path tracer) or 16 × 50k-photon iterations
/// (progressive).
///
/// Not the indirect relMSE of [`SHARP_CAUSTIC`] (measured 0.182, 0.250, 0.286; FLIP 0.094,
/// 0.062, 0.054): its "indirect" part counts the floor the G-buffer holds behind the mirror
/// ring, which the frame never shows, while the reference's counts the cardioid the ring
/// reflects, which ISPM takes from its environment cube. Its FLIP, over what the frame shows,
/// falls with the photons since the reference draws the cardioid sharp (half of each
/// iteration's photons aimed at the ring, `reference::caustic_photons`); against the older
/// reference of one global radius, 0.6× its first after 16 iterations, FLIP was flat (0.113,
/// 0.119, 0.117) and the cardioid's sharp edge lay a pixel off the reference's blurred one.
///
/// cornell-box measured 0.0564, 0.0324, 0.0285 (FLIP 0.152, 0.109, 0.083). Before the glossy
/// lobes were regularised in the estimate (`photon::kernel`, "Glossy lobes in the estimate")
/// its 64k estimate rose to 0.0405: one photon in the exponent-100 lobe of the purple sphere
/// made a sparkle of 1.02 in red where the reference has 0.17.
#[test]
fn more_photons_at_a_fixed_kernel_never_worsen_the_indirect_error() {
    let gpu = common::gpu();
    let cache = tempfile::tempdir().expect("temp dir");
    let size = 48;
    for name in ispm::scene::bundled::BUNDLED {
        let scene = ispm::scene::bundled::resolve(Some(name)).expect("bundled scene");
        let spec = ReferenceSpec {
            passes: if method_for(&scene) == Method::PathTrace {
                64
            } else {
                16
            },
            photons: 50_000,
            bounces: 8,
        };
        let refs = references(
            &scene,
            &spec,
            size,
            size,
            cache.path(),
            &indicatif::ProgressBar::hidden(),
        )
        .expect("reference");
        let bounds = scene.bounds();
        let r_fixed = KernelSettings::scene_relative(&bounds, PHOTONS[0], None).r_max;
        let errors: Vec<(f64, f64)> = PHOTONS
            .iter()
            .map(|&photons| {
                let config = Config {
                    method: Method::Ispm,
                    photons,
                    bounces: 8,
                    radius_scale: r_fixed
                        / KernelSettings::scene_relative(&bounds, photons, None).r_max,
                    subsample: 1,
                    caustic_share: ispm::config::settings::CAUSTIC_SHARE,
                    upsample: Default::default(),
                    accumulate: 1,
                    density: ispm::config::settings::Density::Auto,
                };
                let m = measure(&gpu, &scene, &config, (size, size), 1, &refs).expect("measure");
                assert!(
                    (m.r_max - r_fixed).abs() < 1e-5 * r_fixed,
                    "kernel not fixed"
                );
                (m.rel_mse_indirect, m.flip)
            })
            .collect();
        eprintln!(
            "{name}: (indirect relMSE, FLIP) at {PHOTONS:?} photons (r_max {r_fixed:.4} m): \
             {errors:.4?}"
        );
        for (k, pair) in errors.windows(2).enumerate() {
            let ((relmse0, flip0), (relmse1, flip1)) = (pair[0], pair[1]);
            assert!(
                *name == SHARP_CAUSTIC || relmse1 <= relmse0 * (1.0 + MONOTONIC_TOLERANCE),
                "{name}: {} → {} photons made the indirect relMSE worse: {relmse0:.4} → \
                 {relmse1:.4}",
                PHOTONS[k],
                PHOTONS[k + 1],
            );
            assert!(
                flip1 <= flip0 * (1.0 + MONOTONIC_TOLERANCE),
                "{name}: {} → {} photons made FLIP worse: {flip0:.4} → {flip1:.4}",
                PHOTONS[k],
                PHOTONS[k + 1],
            );
        }
    }
    common::assert_validation_clean(&gpu);
}

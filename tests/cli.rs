//! `ispm render` and `ispm info` as a user runs them: bad input gives one clear line and a
//! non-zero exit, never a panic, and never an output file.

mod common;

use common::cli::{assert_clean_failure, ispm};

#[test]
fn render_of_a_missing_file_fails_with_one_line_naming_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out_png = dir.path().join("out.png");
    let missing = dir.path().join("nope.glb");
    let out = ispm(&[
        "render",
        missing.to_str().expect("utf8"),
        "-o",
        out_png.to_str().expect("utf8"),
    ]);
    assert_clean_failure(&out, "nope.glb", &out_png);
}

#[test]
fn render_of_a_truncated_glb_fails_with_one_line_naming_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bytes = ispm::scene::bundled::bundled("cornell-box").expect("bundled");
    let truncated = dir.path().join("truncated.glb");
    std::fs::write(&truncated, &bytes[..bytes.len() / 3]).expect("write");
    let out_png = dir.path().join("out.png");
    let out = ispm(&[
        "render",
        truncated.to_str().expect("utf8"),
        "-o",
        out_png.to_str().expect("utf8"),
    ]);
    assert_clean_failure(&out, "truncated.glb", &out_png);
}

#[test]
fn render_of_a_directory_fails_with_one_line_naming_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene_dir = dir.path().join("scenes.gltf");
    std::fs::create_dir(&scene_dir).expect("mkdir");
    let out_png = dir.path().join("out.png");
    let out = ispm(&[
        "render",
        scene_dir.to_str().expect("utf8"),
        "-o",
        out_png.to_str().expect("utf8"),
    ]);
    assert_clean_failure(&out, "scenes.gltf", &out_png);
}

#[test]
fn render_to_an_unknown_format_or_missing_folder_fails_cleanly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad_ext = dir.path().join("out.jpg");
    assert_clean_failure(
        &ispm(&["render", "-o", bad_ext.to_str().expect("utf8")]),
        "out.jpg",
        &bad_ext,
    );
    let no_dir = dir.path().join("missing").join("out.png");
    let out = ispm(&[
        "render",
        "--size",
        "32x32",
        "-o",
        no_dir.to_str().expect("utf8"),
    ]);
    assert!(!out.status.success());
    assert!(!no_dir.exists());
}

/// `ispm render ARGS` into `dir`, which must succeed: its stats JSON.
fn render_stats(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let (png, json) = (dir.join("render.png"), dir.join("render.json"));
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.extend(["-o", png.to_str().expect("utf8")]);
    all.extend(["--stats", json.to_str().expect("utf8")]);
    let out = ispm(&all);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(&json).expect("stats")).expect("json")
}

#[test]
fn quality_none_drops_the_default_preset_and_an_unknown_preset_fails_cleanly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let emitted = |quality: &[&str]| {
        let mut args = vec!["--size", "32x24", "--frames", "1"];
        args.extend_from_slice(quality);
        render_stats(dir.path(), &args)["emitted_photons"]
            .as_u64()
            .expect("emitted_photons")
    };
    // `render`'s default preset (`high`: 10k photons) against no preset (100k, the flag's own
    // default), each to within the light views' rounding.
    let (preset, none) = (emitted(&[]), emitted(&["--quality", "none"]));
    assert!((9_000..=11_000).contains(&preset), "{preset}");
    assert!((90_000..=110_000).contains(&none), "{none}");
    let bad = dir.path().join("bad.png");
    let out = ispm(&[
        "render",
        "--quality",
        "best",
        "-o",
        bad.to_str().expect("utf8"),
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("'best'") && stderr.contains("none, draft, interactive, high, reference"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!bad.exists());
}

#[test]
fn caustic_share_multiplies_the_rings_stored_photons_and_rejects_out_of_range_values() {
    let dir = tempfile::tempdir().expect("tempdir");
    let stored = |share: &str| {
        let args = [
            "caustic-ring",
            "--size",
            "32x32",
            "--photons",
            "20000",
            "--caustic-share",
            share,
        ];
        render_stats(dir.path(), &args)["stored_photons"]
            .as_u64()
            .expect("stored_photons")
    };
    let (off, on) = (stored("0"), stored("0.5"));
    assert!(
        on >= 10 * off,
        "{on} photons stored with caustic views, {off} without"
    );
    let bad = dir.path().join("bad.png");
    for share in ["1.5", "-0.1", "half"] {
        let arg = format!("--caustic-share={share}");
        let out = ispm(&["render", &arg, "-o", bad.to_str().expect("utf8")]);
        assert!(!out.status.success(), "{arg} accepted");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("caustic share"),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!bad.exists());
    }
}

#[test]
fn render_writes_png_and_exr_of_the_default_scene_validation_clean() {
    let dir = tempfile::tempdir().expect("tempdir");
    for name in ["out.png", "out.exr"] {
        let path = dir.path().join(name);
        let out = ispm(&[
            "render",
            "--size",
            "64x48",
            "-o",
            path.to_str().expect("utf8"),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let img = image::open(&path).expect("readable image");
        assert_eq!((img.width(), img.height()), (64, 48));
    }
}

#[test]
fn info_names_the_device_and_the_queues_used() {
    let out = ispm(&["info"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "Using:",
        "graphics:",
        "compute:",
        "transfer:",
        "queue family",
    ] {
        assert!(stdout.contains(needle), "{needle} missing from:\n{stdout}");
    }
}

fn plan_stdout(args: &[&str]) -> String {
    let out = ispm(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn plan_prints_one_line_per_decision_naming_the_material_or_light_behind_it() {
    // Photons as `render` would draw them (its default preset, `high`: 10k); full resolution.
    let stdout = plan_stdout(&["plan", "caustic-ring", "--subsample", "1"]);
    for needle in [
        "effects: auto\n",
        "translucent pass + environment map: yes — instance 'ring' has the mirror or \
         transmissive material 'mirror-metal' (1 instance of such materials, 1 environment \
         probe)\n",
        "mirror/refraction lobes (shaders, caustic paths): yes — material 'mirror-metal' is a \
         perfect mirror\n",
        "glossy lobe (shaders, CPU trace): no — no material has a finite-exponent glossy lobe\n",
        "light 0 'sun': direct + 10000 photons",
        "pass upsample: skip — --subsample 1",
    ] {
        assert!(
            stdout.contains(needle),
            "{needle:?} missing from:\n{stdout}"
        );
    }
    for stage in ispm::render::stats::stages() {
        assert!(
            stdout.contains(&format!("pass {stage}: ")),
            "{stage} missing from:\n{stdout}"
        );
    }
    assert!(
        stdout.lines().skip(1).all(|l| l.contains(" — ")),
        "{stdout}"
    );

    let direct = plan_stdout(&["plan", "cornell-box", "--method", "direct"]);
    assert!(
        direct.contains("indirect light (photons): no — --method direct\n")
            && direct.contains("pass bounce_map: skip — --method direct\n"),
        "{direct}"
    );
    let all = plan_stdout(&["plan", "--effects", "all", "--bounces", "3"]);
    assert!(
        all.starts_with("effects: all\n") && all.contains("max bounces: 3 — --effects all"),
        "{all}"
    );
}

#[test]
fn plan_of_a_missing_file_fails_with_one_line_naming_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("nope.glb");
    let out = ispm(&["plan", missing.to_str().expect("utf8")]);
    // `plan` writes no file; the output path only has to stay absent.
    assert_clean_failure(&out, "nope.glb", &dir.path().join("out.png"));
    assert!(out.stdout.is_empty());
}

/// `ispm bench`: the three configurations side by side, every pass with a median, the overlap
/// figures, the JSON and the schedule figure; with the other density estimator and a
/// subsampled estimate in the same chunks.
#[test]
fn bench_measures_overlapped_serial_and_direct_frames_and_writes_json_and_figure() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (json, svg) = (
        dir.path().join("bench.json"),
        dir.path().join("schedule.svg"),
    );
    let out = ispm(&[
        "bench",
        "--size",
        "48x32",
        "--frames",
        "4",
        "--chunks",
        "2",
        "--warmup",
        "1",
        "--photons",
        "2000",
        "--shadow-resolution",
        "64",
        "--json",
        json.to_str().expect("utf8"),
        "--figure",
        svg.to_str().expect("utf8"),
        "--compare-density",
        "--compare-subsample",
        "2",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("serial ÷ overlapped"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid JSON");
    for config in ["overlapped", "serial", "direct_only"] {
        let c = &report[config];
        assert!(
            c["frame_ms"].as_f64().is_some_and(|v| v > 0.0),
            "{config}: {c}"
        );
        assert_eq!(
            c["chunk_frame_ms"].as_array().map(Vec::len),
            Some(2),
            "{config}"
        );
    }
    let stages = &report["overlapped"]["stages"];
    for pass in [
        "gpu.light_gbuffers",
        "gpu.bounce_map",
        "gpu.readback",
        "gpu.upload",
        &format!("gpu.{}", common::estimator_pass()),
        "cpu.cpu_trace",
    ] {
        let t = &stages[pass];
        assert_eq!(t["frames"].as_u64(), Some(4), "{pass}: {stages}");
        let (p10, median, p90) = (
            t["p10"].as_f64().expect("p10"),
            t["median"].as_f64().expect("median"),
            t["p90"].as_f64().expect("p90"),
        );
        assert!(0.0 < p10 && p10 <= median && median <= p90, "{pass}: {t}");
    }
    // The direct-only frame runs no photon pass.
    assert!(report["direct_only"]["stages"]["gpu.photon_volumes"].is_null());
    assert!(report["direct_only"]["stages"]["gpu.photon_tiles"].is_null());
    // Each configuration's last frame records its passes, run and skipped with reasons.
    let names = |config: &str, list: &str| -> Vec<String> {
        report[config][list]
            .as_array()
            .unwrap_or_else(|| panic!("{config}.{list}: {report}"))
            .iter()
            .map(|p| p.as_str().or(p["name"].as_str()).expect("name").to_string())
            .collect()
    };
    assert!(names("overlapped", "passes_run").contains(&"bounce_map".to_string()));
    assert!(names("direct_only", "passes_skipped").contains(&"bounce_map".to_string()));
    assert!(report["direct_only"]["passes_skipped"][0]["reason"].is_string());
    assert!(
        report["planned"].is_null(),
        "planned without --compare-effects"
    );
    assert!(report["overlap"].as_f64().is_some_and(|v| v > 0.0));
    assert!(report["speedup"].as_f64().is_some_and(|v| v > 0.0));
    // --compare-density: the other estimator's frame, in the same chunks.
    let other = match common::estimator_pass() {
        "photon_tiles" => "photon_volumes",
        _ => "photon_tiles",
    };
    let o = &report["other_density"];
    assert_eq!(o["chunk_frame_ms"].as_array().map(Vec::len), Some(2), "{o}");
    assert!(o["stages"][format!("gpu.{other}")]["median"]
        .as_f64()
        .is_some_and(|v| v > 0.0));
    assert!(report["density_speedup"].as_f64().is_some_and(|v| v > 0.0));
    assert!(stdout.contains("density:"), "{stdout}");
    // --compare-subsample 2: the estimate at 1/2 beside the full-resolution one, and its upsample.
    let s = &report["other_subsample"];
    assert_eq!(s["subsample"].as_u64(), Some(2), "{s}");
    assert_eq!(report["overlapped"]["subsample"].as_u64(), Some(1));
    assert!(s["stages"]["gpu.upsample"]["median"]
        .as_f64()
        .is_some_and(|v| v > 0.0));
    let speedup = &report["subsample_speedup"];
    assert_eq!(speedup["factor"].as_u64(), Some(2), "{speedup}");
    assert_eq!(speedup["base_factor"].as_u64(), Some(1), "{speedup}");
    assert!(speedup["estimate_ms"].as_f64().is_some_and(|v| v > 0.0));
    // The estimate is the sum of its passes, the upsample and the fine photons apart among
    // them at 1/2 only.
    let passes = &speedup["passes"];
    let sum: f64 = ["density", "support", "denoise", "upsample", "fine"]
        .iter()
        .map(|p| passes[p].as_f64().expect("pass median"))
        .sum();
    assert!(
        (sum - speedup["estimate_ms"].as_f64().unwrap()).abs() < 1e-9,
        "{speedup}"
    );
    assert!(passes["upsample"].as_f64().is_some_and(|v| v > 0.0));
    assert_eq!(speedup["base_passes"]["upsample"].as_f64(), Some(0.0));
    assert_eq!(speedup["base_passes"]["fine"].as_f64(), Some(0.0));
    assert!(speedup["estimate"].as_f64().is_some_and(|v| v > 0.0));
    assert!(stdout.contains("subsample:"), "{stdout}");
    let figure = std::fs::read_to_string(&svg).expect("figure written");
    assert!(figure.starts_with("<svg") && figure.contains(common::estimator_pass()));
}

/// `ispm bench --compare-effects`: the planned frame beside the unplanned (overlapped) one,
/// with what it skipped and why.
#[test]
fn bench_compare_effects_measures_the_planned_frame_beside_everything_and_records_its_skips() {
    let dir = tempfile::tempdir().expect("tempdir");
    let json = dir.path().join("bench.json");
    let out = ispm(&[
        "bench",
        "--size",
        "48x32",
        "--frames",
        "2",
        "--chunks",
        "2",
        "--warmup",
        "1",
        "--photons",
        "2000",
        "--shadow-resolution",
        "64",
        "--compare-effects",
        "--json",
        json.to_str().expect("utf8"),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("all ÷ planned"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid JSON");
    let planned = &report["planned"];
    assert!(
        planned["frame_ms"].as_f64().is_some_and(|v| v > 0.0),
        "{report}"
    );
    assert_eq!(planned["chunk_frame_ms"].as_array().map(Vec::len), Some(2));
    assert!(report["effects_speedup"].as_f64().is_some_and(|v| v > 0.0));
    // The bundled cornell-box is static: after the warm-up the planned frames reuse the photon
    // map, while the overlapped (`--effects all`) frames trace every time.
    let skipped = planned["passes_skipped"]
        .as_array()
        .expect("passes_skipped");
    let trace = skipped
        .iter()
        .find(|p| p["name"] == "cpu_trace")
        .unwrap_or_else(|| panic!("{planned}"));
    assert!(
        trace["reason"]
            .as_str()
            .is_some_and(|r| r.contains("reused")),
        "{trace}"
    );
    let traced = report["overlapped"]["passes_run"].as_array().expect("run");
    assert!(traced.iter().any(|p| p == "bounce_map"), "{report}");
    assert!(report["overlapped"]["stages"]["cpu.cpu_trace"]["frames"].as_u64() == Some(2));
    assert!(planned["stages"]["cpu.cpu_trace"].is_null(), "{planned}");
}

/// A floor, a box and a sun, seen by two cameras (front, then from above at the side).
fn two_camera_scene(dir: &std::path::Path) -> std::path::PathBuf {
    use glam::{Quat, Vec3};
    use ispm::scene::authoring::{cuboid, quad, GltfWriter, MaterialSpec};
    let mut w = GltfWriter::default();
    let grey = w.material(&MaterialSpec::diffuse("grey", [0.6; 3]));
    let red = w.material(&MaterialSpec::diffuse("red", [0.7, 0.1, 0.1]));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0), grey);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let block = w.mesh("block", &cuboid(Vec3::splat(0.3)), red);
    w.mesh_node("block", block, Vec3::new(0.0, 0.3, 0.0), Quat::IDENTITY);
    w.sun("sun", Vec3::new(-0.3, -1.0, -0.2), [1.0; 3], 2.0);
    w.camera("front", Vec3::new(0.0, 0.8, 3.0), Vec3::ZERO, 0.7);
    w.camera("above", Vec3::new(1.5, 2.5, 0.5), Vec3::ZERO, 0.9);
    let path = dir.join("two-cameras.glb");
    std::fs::write(&path, w.glb()).expect("write glb");
    path
}

#[test]
fn camera_picks_one_of_the_files_cameras_and_a_missing_one_fails_with_one_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = two_camera_scene(dir.path());
    let scene = scene.to_str().expect("utf8");
    let render = |extra: &[&str], name: &str| {
        let out_png = dir.path().join(name);
        let mut args = vec!["render", scene, "--method", "direct", "--size", "32x24"];
        args.extend(extra);
        args.extend(["-o", out_png.to_str().expect("utf8")]);
        let out = ispm(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        image::open(&out_png).expect("png").to_rgba8().into_raw()
    };
    let default = render(&[], "default.png");
    let first = render(&["--camera", "0"], "first.png");
    let second = render(&["--camera", "1"], "second.png");
    assert_eq!(default, first, "--camera 0 is the default camera");
    let differ = first
        .chunks_exact(4)
        .zip(second.chunks_exact(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ > 32 * 24 / 4, "--camera 1 shows the same view");

    let out_png = dir.path().join("out.png");
    let out = ispm(&[
        "render",
        scene,
        "--camera",
        "2",
        "-o",
        out_png.to_str().expect("utf8"),
    ]);
    assert_clean_failure(&out, "--camera 2: ", &out_png);
    assert!(String::from_utf8_lossy(&out.stderr).contains("has 2 cameras (--camera 0 to 1)"));
    let out = ispm(&[
        "render",
        "cornell-box",
        "--camera",
        "1",
        "-o",
        out_png.to_str().expect("utf8"),
    ]);
    assert_clean_failure(
        &out,
        "--camera 1: cornell-box has 1 camera (--camera 0)",
        &out_png,
    );
    for command in ["view", "plan", "bench"] {
        let out = ispm(&[command, "cornell-box", "--camera", "3"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{command}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{command}: {stderr}");
        assert!(
            stderr.contains("--camera 3: cornell-box has 1 camera"),
            "{command}: {stderr}"
        );
    }
}

/// Reads an EXR that `ispm render` wrote: RGBA f32.
fn read_exr(path: &std::path::Path) -> Vec<f32> {
    image::open(path).expect("EXR").to_rgba32f().into_raw()
}

#[test]
fn render_frames_n_writes_the_mean_of_n_frames_and_no_accumulate_the_last_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(format!("{name}.exr"));
        let stats = dir.path().join(format!("{name}.json"));
        let mut args = vec![
            "render",
            "cornell-box",
            "--size",
            "48x36",
            "--photons",
            "3000",
            "-o",
            out.to_str().expect("utf8"),
            "--stats",
            stats.to_str().expect("utf8"),
        ];
        args.extend(extra);
        let o = ispm(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&stats).expect("stats")).expect("JSON");
        (
            read_exr(&out),
            json,
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let (one, json1, _) = run("one", &["--frames", "1"]);
    let (four, json4, said) = run("four", &["--frames", "4"]);
    let (alone, json_alone, _) = run("alone", &["--frames", "4", "--no-accumulate"]);
    assert_eq!(json1["accumulated_frames"], 1);
    assert_eq!(json4["accumulated_frames"], 4);
    assert_eq!(
        json4["photon_sample"], 3,
        "each accumulated frame draws new photons"
    );
    assert!(said.contains("mean of 4 frames"), "{said}");
    assert_eq!(json_alone["accumulated_frames"], 1);
    // Without accumulation the 4th frame reuses the photon map: it is the first frame.
    assert!(
        one == alone,
        "--no-accumulate: the last frame is not the first one again"
    );
    assert!(one != four, "the mean of 4 frames is the first frame");
    // The mean keeps the energy of one frame (the same estimator, new photons).
    let mean = |v: &[f32]| v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64;
    let ratio = mean(&four) / mean(&one);
    assert!(
        (ratio - 1.0).abs() < 0.03,
        "mean of 4 frames / one frame = {ratio}"
    );
}

#[test]
fn render_accumulates_for_the_seconds_asked_and_rejects_a_negative_duration() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("out.png");
    let stats = dir.path().join("stats.json");
    let o = ispm(&[
        "render",
        "caustic-ring",
        "--size",
        "32x24",
        "--photons",
        "2000",
        "--seconds",
        "0",
        "-o",
        out.to_str().expect("utf8"),
        "--stats",
        stats.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&stats).expect("stats")).expect("JSON");
    assert_eq!(json["accumulated_frames"], 1, "--seconds 0: one frame");
    let bad = dir.path().join("bad.png");
    let o = ispm(&[
        "render",
        "--seconds",
        "-1",
        "-o",
        bad.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success());
    assert!(!bad.exists());
}

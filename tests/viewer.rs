//! `ispm view` under Xvfb on lavapipe with validation and synchronization validation on: the
//! viewer's smoke test renders frames along its scripted camera path into a real window and
//! swapchain, survives a resize the test drives, and its screenshot is the headless render of
//! the path's last pose (and not of its first). With the overlay shown and a debug view on,
//! the simulated `P`, `T` and `Tab` keys write a screenshot (the headless render of the same
//! pose and view), its stats JSON and a 30-frame Chrome trace, and toggle the overlay.

mod common;

use common::cli::ispm;
use std::process::Command;

/// Runs `ispm ARGS` inside a fresh virtual X server.
fn under_xvfb(args: &[&str]) -> std::process::Output {
    under_xvfb_with(args, &[])
}

/// [`under_xvfb`] with environment variables.
fn under_xvfb_with(args: &[&str], envs: &[(&str, &str)]) -> std::process::Output {
    let xvfb = Command::new("xvfb-run")
        .arg("--help")
        .output()
        .map(|o| o.status.success() || !o.stdout.is_empty() || !o.stderr.is_empty());
    assert!(
        xvfb.unwrap_or(false),
        "xvfb-run is missing: .ci/deps installs it (package xvfb)"
    );
    Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(env!("CARGO_BIN_EXE_ispm"))
        .args(args)
        .env("ISPM_VALIDATION", "1")
        .envs(envs.iter().copied())
        .output()
        .expect("run xvfb-run")
}

/// Pixels of `a` and `b` (same size) whose channels differ by more than 1 of 255.
fn differing(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels()
        .zip(b.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 1))
        .count()
}

fn headless(args: &[&str], out: &std::path::Path) -> image::RgbaImage {
    let mut args = args.to_vec();
    args.extend(["-o", out.to_str().expect("utf8")]);
    let result = ispm(&args);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    image::open(out).expect("headless").to_rgba8()
}

#[test]
fn view_renders_sixty_frames_along_its_path_through_a_resize_and_ends_at_the_headless_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let shot = dir.path().join("view.png");
    // The same preset for both (`view` and `render` default to different ones).
    let common = [
        "--size",
        "96x64",
        "--photons",
        "4000",
        "--quality",
        "interactive",
    ];
    let mut args = vec!["view", "cornell-box"];
    args.extend(common);
    args.extend([
        "--frames",
        "60",
        "--screenshot",
        shot.to_str().expect("utf8"),
        "--resize-at",
        "20:160x120",
    ]);
    let out = under_xvfb(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "ispm view failed:\n{stderr}");
    assert!(!stderr.contains("validation"), "{stderr}");

    let view = image::open(&shot).expect("screenshot").to_rgba8();

    // The path's last pose, headless. The photon map does not depend on the camera, so the
    // viewer's (traced at frame 1, reused along the path) is the headless one; the glass
    // sphere's environment map was rendered at frame 1's pose and differs from the headless
    // one by rounding (tests/camera.rs: ≤ 2.2e-5 of the peak), below one step of 255.
    // One frame: the viewer's camera moves every frame, so it never accumulates.
    let mut args = vec![
        "render",
        "cornell-box",
        "--frames",
        "1",
        "--camera-path-frame",
        "60",
    ];
    args.extend(common);
    let end = headless(&args, &dir.path().join("end.png"));
    let differ = differing(&view, &end);
    assert_eq!(
        differ, 0,
        "{differ} pixels differ between the viewer's screenshot and the headless render of \
         the path's frame 60"
    );

    // The camera did move: the path's first pose (the file's camera) is another image.
    let mut args = vec!["render", "cornell-box", "--frames", "1"];
    args.extend(common);
    let start = headless(&args, &dir.path().join("start.png"));
    let moved = differing(&view, &start);
    let pixels = (view.width() * view.height()) as usize;
    assert!(
        moved > pixels / 4,
        "only {moved} of {pixels} pixels differ from the start pose: the camera did not move"
    );
}

#[test]
fn view_without_a_display_fails_with_one_line() {
    let out = Command::new(env!("CARGO_BIN_EXE_ispm"))
        .args(["view", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("run ispm");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(!stderr.contains("panicked"), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(lines[0].contains("window"), "{stderr}");
}

#[test]
fn view_with_orbiting_lights_runs_120_clean_frames_and_ends_on_the_headless_render_of_its_time() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = |name: &str| dir.path().join(name).to_str().expect("utf8").to_string();
    let (shot, at, start) = (path("view.png"), path("at.png"), path("start.png"));
    // Half a turn of the sun in 240 frames; the viewer's 120th frame is at 119 steps.
    let common = [
        "caustic-ring",
        "--size",
        "64x64",
        "--photons",
        "4000",
        "--quality",
        "interactive",
        "--orbit-lights",
        "4",
    ];
    let mut args = vec!["view"];
    args.extend(common);
    args.extend(["--frames", "120", "--screenshot", &shot]);
    let out = under_xvfb(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "ispm view failed:\n{stderr}");
    assert!(!stderr.contains("validation"), "{stderr}");

    let time = (119.0 * ispm::scene::FRAME_STEP_SECONDS).to_string();
    for (output, t) in [(&at, time.as_str()), (&start, "0")] {
        let mut args = vec!["render", "--frames", "1"];
        args.extend(common);
        // The camera of the viewer's 120th frame on its scripted path, at both times: only
        // the light differs between `at` and `start`.
        args.extend(["--camera-path-frame", "120", "--time", t, "-o", output]);
        let out = ispm(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let load = |p: &str| image::open(p).expect("png").to_rgba8();
    let (shot, at, start) = (load(&shot), load(&at), load(&start));
    let differing = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 1))
            .count()
    };
    // Scripted time: the viewer's last frame is the scene posed at 119/60 s, as rendered
    // headless by a fresh renderer.
    assert_eq!(
        differing(&shot, &at),
        0,
        "the viewer's last frame is not t = {time} s"
    );
    // And the light did move: shadows and caustic are elsewhere than at t = 0.
    let moved = differing(&shot, &start);
    println!("{moved} of 4096 pixels differ from t = 0");
    assert!(
        moved > 1000,
        "only {moved} of 4096 pixels changed in half a turn (2629 measured)"
    );
}

#[test]
fn view_with_overlay_and_debug_view_writes_screenshot_stats_and_a_30_frame_trace_on_p_and_t() {
    let dir = tempfile::tempdir().expect("tempdir");
    let shots = dir.path().join("shots");
    std::fs::create_dir(&shots).expect("shots dir");
    let common = [
        "--size",
        "96x64",
        "--photons",
        "4000",
        "--quality",
        "interactive",
        "--debug-view",
        "bounce-map",
    ];
    let mut args = vec!["view", "cornell-box"];
    args.extend(common);
    args.extend([
        "--frames",
        "45",
        "--overlay",
        "--press",
        "3:t",
        "--press",
        "40:p",
        "--press",
        "42:tab",
        "--shots",
        shots.to_str().expect("utf8"),
    ]);
    let out = under_xvfb_with(&args, &[("RUST_LOG", "ispm=info")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "ispm view failed:\n{stderr}");
    assert!(!stderr.contains("validation message"), "{stderr}");
    // Drawn in frames 1 … 41, hidden by Tab from frame 42 on.
    let drawn = stderr
        .lines()
        .find_map(|l| {
            l.split_once("overlay drawn in ")
                .map(|(_, rest)| rest.to_string())
        })
        .unwrap_or_else(|| panic!("no overlay report in:\n{stderr}"));
    let numbers: Vec<usize> = drawn
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|w| w.parse().ok())
        .collect();
    assert_eq!(numbers[0], 41, "{drawn}");
    assert!(
        numbers[1] > 100,
        "the overlay drew only {} vertices",
        numbers[1]
    );

    let mut files: Vec<String> = std::fs::read_dir(&shots)
        .expect("shots")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let find = |suffix: &str| {
        let found: Vec<&String> = files
            .iter()
            .filter(|f| f.ends_with(suffix) && (suffix != ".json" || !f.ends_with(".trace.json")))
            .collect();
        assert_eq!(found.len(), 1, "{suffix} in {files:?}");
        shots.join(found[0])
    };
    let (png, stats, trace) = (find(".png"), find(".json"), find(".trace.json"));
    assert_eq!(
        png.with_extension("json"),
        stats,
        "the stats lie beside the screenshot"
    );

    // The screenshot is frame 40's debug view: the headless render of that pose and view.
    let shot = image::open(&png).expect("screenshot PNG").to_rgba8();
    let mut args = vec![
        "render",
        "cornell-box",
        "--frames",
        "1",
        "--camera-path-frame",
        "40",
    ];
    args.extend(common);
    let headless = headless(&args, &dir.path().join("headless.png"));
    let differ = differing(&shot, &headless);
    assert_eq!(
        differ, 0,
        "{differ} pixels differ from the headless debug view"
    );

    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&stats).expect("stats")).expect("stats JSON");
    assert_eq!(
        (stats["width"].as_u64(), stats["height"].as_u64()),
        (Some(96), Some(64))
    );
    let ran: Vec<&str> = stats["passes_run"]
        .as_array()
        .expect("passes_run")
        .iter()
        .filter_map(|v| v.as_str())
        .collect();
    assert!(
        ran.contains(&"debug_view") && ran.contains(&"tonemap"),
        "{ran:?}"
    );
    assert!(stats["ms"]["direct"].as_f64().expect("direct ms") > 0.0);
    let skipped = stats["passes_skipped"].as_array().expect("passes_skipped");
    assert!(
        skipped.iter().any(|p| p["name"] == "cpu_trace"
            && p["reason"].as_str().is_some_and(|r| r.contains("reused"))),
        "frame 40 reuses the photon map: {skipped:?}"
    );

    let trace: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&trace).expect("trace")).expect("trace JSON");
    let events = trace["traceEvents"].as_array().expect("traceEvents");
    let frames: std::collections::BTreeSet<u64> = events
        .iter()
        .filter(|e| e["name"] == "frame" && e["cat"] == "cpu")
        .filter_map(|e| e["args"]["frame"].as_u64())
        .collect();
    assert_eq!(frames.len(), 30, "traced frames {frames:?}");
    let first = *frames.first().expect("a frame");
    assert_eq!(
        frames.iter().copied().collect::<Vec<_>>(),
        (first..first + 30).collect::<Vec<_>>()
    );
    for pass in ["eye_gbuffer", "direct", "debug_view"] {
        let traced = events
            .iter()
            .filter(|e| e["name"] == pass && e["cat"] == "gpu")
            .filter_map(|e| e["args"]["frame"].as_u64())
            .filter(|f| frames.contains(f))
            .count();
        assert_eq!(traced, 30, "GPU spans of {pass} in the traced frames");
    }
}

#[test]
fn view_refuses_a_shots_path_that_is_not_a_directory() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("file");
    std::fs::write(&file, b"x").expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_ispm"))
        .args([
            "view",
            "--frames",
            "1",
            "--shots",
            file.to_str().expect("utf8"),
        ])
        .output()
        .expect("run ispm");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(
        lines[0].contains("--shots") && lines[0].contains("not a directory"),
        "{stderr}"
    );
}

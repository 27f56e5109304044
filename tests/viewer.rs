//! `ispm view` under Xvfb on lavapipe with validation and synchronization validation on: the
//! viewer's smoke test renders frames into a real window and swapchain, survives a resize the
//! test drives, and its screenshot is the headless render of the same camera.

mod common;

use common::cli::ispm;
use std::process::Command;

/// Runs `ispm ARGS` inside a fresh virtual X server.
fn under_xvfb(args: &[&str]) -> std::process::Output {
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
        .output()
        .expect("run xvfb-run")
}

#[test]
fn view_renders_sixty_frames_through_a_resize_and_its_screenshot_is_the_headless_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (shot, headless) = (dir.path().join("view.png"), dir.path().join("headless.png"));
    let common = ["--size", "96x64", "--photons", "4000"];
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

    let mut args = vec!["render", "cornell-box"];
    args.extend(common);
    args.extend(["-o", headless.to_str().expect("utf8")]);
    let out = ispm(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let a = image::open(&shot).expect("screenshot").to_rgba8();
    let b = image::open(&headless).expect("headless").to_rgba8();
    assert_eq!(a.dimensions(), b.dimensions());
    // The same renderer, settings and seed: the 60th frame of a static scene is the first.
    let differing = a
        .pixels()
        .zip(b.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 1))
        .count();
    assert_eq!(
        differing, 0,
        "{differing} pixels differ between the viewer's screenshot and the headless render"
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
        let mut args = vec!["render"];
        args.extend(common);
        args.extend(["--time", t, "-o", output]);
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

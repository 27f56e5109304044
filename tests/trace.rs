//! `--trace`: Chrome Trace Event JSON of GPU passes per queue and CPU work per thread, on one
//! host clock; and `--stats` stage times from the same measurements. Small images, few
//! photons, validation on.

mod common;

use common::cli::{assert_clean_failure, ispm};
use ispm::config::settings::RenderSettings;
use ispm::gpu::{ClockSource, Gpu, GpuOptions, QueueRole};
use ispm::render::frame::Renderer;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::OnceLock;

const FRAMES: u64 = 3;

/// The passes every ISPM frame of the Cornell box runs (GPU scopes), with the density
/// estimator the device runs.
fn gpu_passes() -> [&'static str; 10] {
    [
        "shadow_maps",
        "light_gbuffers",
        "bounce_map",
        "readback",
        "upload",
        "eye_gbuffer",
        "direct",
        common::estimator_pass(),
        "composite",
        "tonemap",
    ]
}

/// One `X` event.
#[derive(Clone, Debug)]
struct Event {
    name: String,
    tid: u64,
    id: u64,
    /// Microseconds.
    ts: f64,
    end: f64,
    frame: Option<u64>,
    gpu: bool,
}

struct Trace {
    json: Value,
    events: Vec<Event>,
    /// Track names by tid.
    tracks: BTreeMap<u64, String>,
    /// Microseconds the GPU clock mapping may be off.
    uncertainty_us: f64,
}

impl Trace {
    fn parse(json: Value) -> Trace {
        let all = json["traceEvents"].as_array().expect("traceEvents");
        let tracks = all
            .iter()
            .filter(|e| e["ph"] == "M" && e["name"] == "thread_name")
            .map(|e| {
                (
                    e["tid"].as_u64().expect("tid"),
                    e["args"]["name"].as_str().expect("thread name").to_string(),
                )
            })
            .collect();
        let events = all
            .iter()
            .filter(|e| e["ph"] == "X")
            .map(|e| {
                let ts = e["ts"].as_f64().expect("ts");
                Event {
                    name: e["name"].as_str().expect("name").to_string(),
                    tid: e["tid"].as_u64().expect("tid"),
                    id: e["id"].as_u64().expect("id"),
                    ts,
                    end: ts + e["dur"].as_f64().expect("dur"),
                    frame: e["args"]["frame"].as_u64(),
                    gpu: e["cat"] == "gpu",
                }
            })
            .collect();
        let uncertainty_us = json["otherData"]["gpu_clock_uncertainty_ns"]
            .as_f64()
            .expect("the GPU clock mapping's uncertainty")
            / 1000.0;
        Trace {
            json,
            events,
            tracks,
            uncertainty_us,
        }
    }

    /// The one span `name` of `frame` (GPU or CPU as `gpu` says).
    fn one(&self, frame: u64, name: &str, gpu: bool) -> &Event {
        let found: Vec<&Event> = self
            .events
            .iter()
            .filter(|e| e.frame == Some(frame) && e.name == name && e.gpu == gpu)
            .collect();
        assert_eq!(found.len(), 1, "frame {frame}: {name} spans: {found:?}");
        found[0]
    }

    fn on_track(&self, tid: u64) -> Vec<&Event> {
        self.events.iter().filter(|e| e.tid == tid).collect()
    }
}

/// One CLI render of three frames with `--trace` and `--stats`, shared by the tests.
fn cli_run() -> &'static (Trace, Value) {
    static RUN: OnceLock<(Trace, Value)> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = tempfile::tempdir().expect("tempdir");
        let (png, trace, stats) = (
            dir.path().join("out.png"),
            dir.path().join("trace.json"),
            dir.path().join("stats.json"),
        );
        let path = |p: &std::path::Path| p.to_str().expect("utf8").to_string();
        let frames = FRAMES.to_string();
        let out = ispm(&[
            "render",
            "--size",
            "48x32",
            "--photons",
            "3000",
            "--shadow-resolution",
            "128",
            "--frames",
            &frames,
            // Every frame traces (a planned frame would reuse the static photon map).
            "--effects",
            "all",
            "-o",
            &path(&png),
            "--trace",
            &path(&trace),
            "--stats",
            &path(&stats),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let read = |p: &std::path::Path| -> Value {
            serde_json::from_slice(&std::fs::read(p).expect("written")).expect("valid JSON")
        };
        (Trace::parse(read(&trace)), read(&stats))
    })
}

#[test]
fn trace_names_one_track_per_gpu_queue_and_per_cpu_thread() {
    let (trace, _) = cli_run();
    let all = trace.json["traceEvents"].as_array().expect("events");
    assert!(all
        .iter()
        .any(|e| e["ph"] == "M" && e["name"] == "process_name" && e["args"]["name"] == "ispm"));
    let used: BTreeSet<u64> = trace.events.iter().map(|e| e.tid).collect();
    for tid in &used {
        assert!(trace.tracks.contains_key(tid), "track {tid} has no name");
    }
    let names: Vec<&str> = trace.tracks.values().map(String::as_str).collect();
    let gpu_tracks: BTreeSet<u64> = trace
        .events
        .iter()
        .filter(|e| e.gpu)
        .map(|e| e.tid)
        .collect();
    // One track per queue of the device that recorded work, named by the roles it serves:
    // lavapipe has one queue for all three; a GPU with dedicated compute and transfer queues
    // (NVIDIA) shows the graphics queue and the transfer queue of the upload and readback.
    let gpu = common::gpu();
    let labels: Vec<String> = (0..gpu.queue_list().len())
        .map(|i| gpu.queue_label(i))
        .collect();
    let graphics = gpu.queue_label(gpu.queue_index(QueueRole::Graphics));
    assert!(
        (1..=labels.len()).contains(&gpu_tracks.len()),
        "{} GPU tracks for the device's queues {labels:?}: {names:?}",
        gpu_tracks.len()
    );
    for tid in &gpu_tracks {
        let name = &trace.tracks[tid];
        assert!(labels.contains(name), "{name} is none of {labels:?}");
    }
    // Each pass on its role's queue: the frame's draws on the graphics queue's track.
    let draws: Vec<_> = (trace.events.iter())
        .filter(|e| e.gpu && e.name == "eye_gbuffer")
        .collect();
    assert!(!draws.is_empty(), "no eye_gbuffer scope: {names:?}");
    for e in draws {
        assert_eq!(trace.tracks[&e.tid], graphics, "{e:?}");
    }
    assert!(names.contains(&"main"), "{names:?}");
    assert!(
        names.iter().any(|n| n.starts_with("trace worker ")),
        "{names:?}"
    );
    for e in trace.events.iter().filter(|e| e.name == "trace_chunk") {
        assert!(trace.tracks[&e.tid].starts_with("trace worker "), "{e:?}");
    }
}

#[test]
fn span_ids_are_unique() {
    let (trace, _) = cli_run();
    let ids: BTreeSet<u64> = trace.events.iter().map(|e| e.id).collect();
    assert_eq!(ids.len(), trace.events.len());
}

/// Spans on one track either hold one another or are disjoint (1 ns of rounding allowed).
fn assert_nested(trace: &Trace) {
    const EPS: f64 = 1e-3;
    for tid in trace.tracks.keys() {
        let mut spans = trace.on_track(*tid);
        spans.sort_by(|a, b| a.ts.total_cmp(&b.ts).then(b.end.total_cmp(&a.end)));
        let mut open: Vec<&Event> = Vec::new();
        for s in spans {
            while open.last().is_some_and(|p| p.end <= s.ts + EPS) {
                open.pop();
            }
            if let Some(parent) = open.last() {
                assert!(
                    s.end <= parent.end + EPS,
                    "{s:?} overlaps {parent:?} on {}",
                    trace.tracks[tid]
                );
            }
            open.push(s);
        }
    }
}

#[test]
fn spans_on_each_track_nest_without_partial_overlap() {
    assert_nested(&cli_run().0);
}

#[test]
fn timestamps_run_forward_on_every_track_frame_after_frame() {
    let (trace, _) = cli_run();
    let mut last_ts = f64::MIN;
    for e in &trace.events {
        assert!(e.ts >= 0.0 && e.end >= e.ts, "{e:?}");
        // Written in start order.
        assert!(
            e.ts >= last_ts,
            "{e:?} starts before the event written before it"
        );
        last_ts = e.ts;
    }
    for tid in trace.tracks.keys() {
        // The outermost spans of a track follow one another, and frames follow in order.
        let mut outer: Vec<&Event> = Vec::new();
        for e in trace.on_track(*tid) {
            if outer.last().is_none_or(|p| e.ts >= p.end) {
                outer.push(e);
            }
        }
        for pair in outer.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            assert!(a.end <= b.ts, "{a:?} then {b:?}");
            // Frames in flight: the host waits for frame N while issuing N + 2 (or at the
            // end), so only the `frame` spans themselves follow the frame order.
            if let (Some(fa), Some(fb)) = (a.frame, b.frame) {
                if a.name == "frame" && b.name == "frame" {
                    assert!(fa < fb, "{a:?} then {b:?}");
                }
            }
        }
    }
}

#[test]
fn every_pass_of_every_frame_appears_with_a_positive_duration() {
    let (trace, _) = cli_run();
    for frame in 0..FRAMES {
        for pass in gpu_passes() {
            let e = trace.one(frame, pass, true);
            assert!(e.end > e.ts, "{e:?}");
        }
        for step in [
            "frame",
            "cpu_trace",
            "readback wait",
            "upload write",
            "host wait",
        ] {
            let e = trace.one(frame, step, false);
            assert!(e.end > e.ts, "{e:?}");
            assert_eq!(trace.tracks[&e.tid], "main", "{e:?}");
        }
        assert!(
            trace
                .events
                .iter()
                .any(|e| e.frame == Some(frame) && e.name == "trace_chunk"),
            "frame {frame} has no trace worker span"
        );
    }
}

#[test]
fn three_frames_give_three_frames_of_spans() {
    let (trace, _) = cli_run();
    // Set-up and image readback submissions belong to no frame.
    let frames: BTreeSet<u64> = trace.events.iter().filter_map(|e| e.frame).collect();
    assert_eq!(frames, (0..FRAMES).collect());
    // The same GPU work every frame, but for the cached environment cube (drawn once).
    let passes = |f: u64| -> BTreeSet<&str> {
        trace
            .events
            .iter()
            .filter(|e| e.gpu && e.frame == Some(f) && e.name != "environment")
            .map(|e| e.name.as_str())
            .collect()
    };
    assert!(
        (1..FRAMES).all(|f| passes(f) == passes(0)),
        "{:?}",
        passes(0)
    );
}

/// In every frame the GPU and the host take turns, so on one clock: each submission's first
/// pass starts after the host began submitting it; the readback ends before the host's wait
/// for it does and before the CPU trace starts, the trace ends before the upload starts, the
/// tonemap ends before the final host wait does; trace workers work inside the CPU trace.
fn assert_one_time_base(trace: &Trace, tolerance_us: f64) {
    let before = |a: f64, b: f64, what: &str| {
        assert!(
            a <= b + tolerance_us,
            "{what}: {a} µs is after {b} µs (tolerance {tolerance_us} µs)"
        );
    };
    for f in 0..FRAMES {
        let gpu = |n| trace.one(f, n, true);
        let cpu = |n| trace.one(f, n, false);
        let (readback, upload, tonemap) = (gpu("readback"), gpu("upload"), gpu("tonemap"));
        let trace_span = cpu("cpu_trace");
        let submits: Vec<&Event> = trace
            .events
            .iter()
            .filter(|e| !e.gpu && e.frame == Some(f) && e.name == "submit")
            .collect();
        // Box A, readback, box B, upload, box D (src/render/frame.rs).
        assert_eq!(submits.len(), 5, "frame {f}: {submits:?}");
        before(
            submits[0].ts,
            gpu("light_gbuffers").ts,
            "submit A → light G-buffers start",
        );
        before(submits[1].ts, readback.ts, "submit → readback start");
        before(
            submits[2].ts,
            gpu("shadow_maps").ts,
            "submit B → shadow maps start",
        );
        before(submits[3].ts, upload.ts, "submit → upload start");
        before(
            submits[4].ts,
            gpu(common::estimator_pass()).ts,
            "submit D → density estimate start",
        );
        before(
            readback.end,
            cpu("readback wait").end,
            "readback end → its wait's end",
        );
        before(
            readback.end,
            trace_span.ts,
            "readback end → CPU trace start",
        );
        before(trace_span.end, upload.ts, "CPU trace end → upload start");
        before(
            cpu("upload write").end,
            upload.ts,
            "upload write end → upload start",
        );
        before(
            tonemap.end,
            cpu("host wait").end,
            "tonemap end → host wait end",
        );
        for chunk in trace
            .events
            .iter()
            .filter(|e| e.frame == Some(f) && e.name == "trace_chunk")
        {
            assert!(
                chunk.ts >= trace_span.ts && chunk.end <= trace_span.end,
                "{chunk:?}"
            );
        }
    }
}

#[test]
fn cpu_and_gpu_tracks_share_one_time_base() {
    let (trace, _) = cli_run();
    let mapping = trace.json["otherData"]["gpu_clock_mapping"]
        .as_str()
        .expect("mapping");
    assert!(!mapping.is_empty());
    assert_one_time_base(trace, trace.uncertainty_us + 10.0);
}

#[test]
fn stats_carry_the_last_frames_stage_times_from_the_same_spans() {
    let (trace, stats) = cli_run();
    let last = FRAMES - 1;
    let ms = &stats["ms"];
    for stage in ispm::render::stats::stages()
        .map(|s| s.name())
        .chain(["frame"])
    {
        assert!(
            ms[stage].as_f64().is_some_and(|v| v >= 0.0),
            "{stage}: {ms}"
        );
    }
    let same = |stage: &str, gpu: bool| {
        let e = trace.one(last, stage, gpu);
        let v = ms[stage].as_f64().expect("ms");
        assert!(
            (v - (e.end - e.ts) / 1000.0).abs() < 1e-5,
            "{stage}: stats {v} ms, trace {e:?}"
        );
    };
    for pass in gpu_passes().iter().filter(|p| **p != "light_gbuffers") {
        same(pass, true);
    }
    same("cpu_trace", false);
    // The frame: from the host's start of issuing it to the end of its last GPU pass.
    let start = trace.one(last, "frame", false).ts;
    let end = trace
        .events
        .iter()
        .filter(|e| e.gpu && e.frame == Some(last))
        .map(|e| e.end)
        .fold(f64::MIN, f64::max);
    let frame = ms["frame"].as_f64().expect("frame ms");
    assert!(
        (frame - (end - start) / 1000.0).abs() < 1e-3,
        "frame: stats {frame} ms, trace {start} → {end} µs"
    );
    assert!(ms["frame"].as_f64() > ms["cpu_trace"].as_f64());
}

#[test]
fn unwritable_trace_path_fails_with_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("out.png");
    let png_arg = png.to_str().expect("utf8");
    let render_with_trace = |trace: &std::path::Path| {
        let trace = trace.to_str().expect("utf8");
        ispm(&["render", "--size", "16x16", "-o", png_arg, "--trace", trace])
    };
    let missing = dir.path().join("missing").join("trace.json");
    assert_clean_failure(&render_with_trace(&missing), "trace.json", &png);
    assert!(!missing.exists());
    let folder = dir.path().join("a-folder");
    std::fs::create_dir(&folder).expect("mkdir");
    assert_clean_failure(&render_with_trace(&folder), "a-folder", &png);
    let exr = dir.path().join("out.exr");
    let trace = dir.path().join("trace.json");
    let out = ispm(&[
        "render",
        "--method",
        "path-trace",
        "-o",
        exr.to_str().expect("utf8"),
        "--trace",
        trace.to_str().expect("utf8"),
    ]);
    assert_clean_failure(&out, "--trace", &trace);
    assert!(!exr.exists());
}

#[test]
fn measured_offset_agrees_with_calibrated_timestamps() {
    let gpu = common::gpu();
    let calibrated = gpu.clock_calibration().expect("calibration");
    let measured = gpu.measure_clock_offset(8).expect("measured offset");
    assert_eq!(measured.source, ClockSource::MeasuredOffset);
    // A submission, a wait and two clock reads: well under 50 ms even on a loaded machine.
    assert!(measured.uncertainty_ns < 50_000_000, "{measured:?}");
    let bits = gpu.queue_list()[0].timestamp_valid_bits;
    let period = f64::from(gpu.properties.timestamp_period);
    let t = measured.device_ticks;
    let (a, b) = (
        calibrated.to_host_ns(t, bits, period).expect("bits"),
        measured.to_host_ns(t, bits, period).expect("bits"),
    );
    let allowed = calibrated.uncertainty_ns + measured.uncertainty_ns + 1;
    assert!(
        a.abs_diff(b) <= allowed,
        "calibrated {calibrated:?} and measured {measured:?} differ by {} ns",
        a.abs_diff(b)
    );
    eprintln!(
        "clock: {} ± {} ns; measured offset ± {} ns, {} ns from it",
        calibrated.source,
        calibrated.uncertainty_ns,
        measured.uncertainty_ns,
        a.abs_diff(b)
    );
    common::assert_validation_clean(&gpu);
}

/// The fallback mapping through the whole frame (the only test here that captures in process).
#[test]
fn measured_clock_still_orders_gpu_passes_around_host_work() {
    let gpu = Gpu::new(&GpuOptions {
        validation: true,
        measured_clock: true,
        ..Default::default()
    })
    .expect("device");
    assert_eq!(gpu.clock_source(), ClockSource::MeasuredOffset);
    let scene = ispm::scene::bundled::resolve(None).expect("cornell box");
    let settings = RenderSettings {
        photons: 3000,
        width: 48,
        height: 32,
        shadow_resolution: 128,
        // Every frame traces (a planned frame would reuse the static photon map).
        effects: ispm::config::settings::Effects::All,
        ..Default::default()
    };
    ispm::timing::start_capture();
    let rendered = Renderer::new(&gpu, &scene, settings)
        .and_then(|mut r| (0..FRAMES).try_for_each(|_| r.render().map(drop)));
    let capture = ispm::timing::finish_capture();
    rendered.expect("render");
    common::assert_validation_clean(&gpu);
    let trace = Trace::parse(capture.chrome_json());
    assert!(trace.json["otherData"]["gpu_clock_mapping"] == "measured offset");
    assert_nested(&trace);
    assert_one_time_base(&trace, trace.uncertainty_us);
}

//! The GPU value check (`--check-values`, `passes/value_check.rs`): a normal frame has no NaN,
//! ±Inf or negative value in any HDR buffer and the check reads every value of each; a bad
//! value written into any kind of buffer (an image, the bounce map's records, the photon map's
//! records, in any buffer of a photon map split over several) is counted, exactly, and what
//! later passes make of it is seen too. Validation and synchronization validation on, lavapipe
//! through `.ci/test`.

mod common;

use ispm::config::settings::Effects;
use ispm::config::settings::{Method, RenderSettings};
use ispm::passes::value_check::{Checked, ValueCheck};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::Scene;

const SIZE: u32 = 48;

fn settings(subsample: u32) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons: 20_000,
        width: SIZE,
        height: SIZE,
        shadow_resolution: 256,
        subsample,
        check_values: true,
        ..Default::default()
    }
}

fn cornell_box() -> Scene {
    ispm::scene::bundled::resolve(Some("cornell-box")).expect("bundled scene")
}

fn check(frame: &FrameImage) -> &ValueCheck {
    frame
        .stats
        .value_check
        .as_ref()
        .expect("check_values: the frame carries its value check")
}

fn counts(check: &ValueCheck, which: Checked) -> (u64, u64, u64) {
    let b = check
        .buffer(which.name())
        .unwrap_or_else(|| panic!("{} not checked: {check:?}", which.name()));
    (b.non_finite, b.negative, b.values)
}

/// The values each buffer of `frame` holds: 4 per pixel, 8 per bounce-map record (one per
/// emitted photon), 12 per stored photon.
fn expected_values(frame: &FrameImage, subsample: u32) -> Vec<(Checked, u64)> {
    let pixels = u64::from(frame.width * frame.height);
    let mut expected = vec![
        (Checked::Direct, 4 * pixels),
        (
            Checked::BounceMap,
            8 * frame.stats.bounce_map_records as u64,
        ),
        (Checked::PhotonMap, 12 * frame.stats.stored_photons as u64),
        (Checked::Indirect, 4 * pixels),
        (Checked::Final, 4 * pixels),
    ];
    if subsample > 1 {
        let (w, h) = ispm::passes::upsample::low_size(frame.width, frame.height, subsample);
        let low = 4 * u64::from(w * h);
        expected.push((Checked::IndirectLowIrradiance, low));
        expected.push((Checked::IndirectLowGlossy, low));
    }
    expected
}

#[test]
fn a_normal_frame_has_no_bad_value_and_the_check_reads_every_value_of_every_buffer() {
    let gpu = common::gpu();
    let scene = cornell_box();
    for subsample in [1, 2] {
        let mut renderer = Renderer::new(&gpu, &scene, settings(subsample)).expect("renderer");
        // Frame 0 traces the photon map, frames 1 and 2 reuse it (their photon map and bounce
        // map are the same buffers, checked again).
        for frame_index in 0..3 {
            let frame = renderer.render().expect("render");
            let check = check(&frame);
            assert_eq!(
                check.total_bad(),
                0,
                "subsample {subsample}, frame {frame_index}: {check:?}"
            );
            let expected = expected_values(&frame, subsample);
            assert_eq!(check.per_buffer.len(), expected.len(), "{check:?}");
            for (which, values) in expected {
                assert_eq!(
                    counts(check, which).2,
                    values,
                    "subsample {subsample}, frame {frame_index}: values of {}",
                    which.name()
                );
            }
            assert!(frame.stats.stored_photons > 1000, "{:?}", frame.stats);
            // The host's own look at the final image agrees.
            assert!(frame.hdr.iter().all(|v| v.is_finite() && *v >= 0.0));
        }
    }
    common::assert_validation_clean(&gpu);
}

#[test]
fn a_frame_that_does_not_ask_for_the_check_has_none() {
    let gpu = common::gpu();
    let mut renderer = Renderer::new(
        &gpu,
        &cornell_box(),
        RenderSettings {
            check_values: false,
            ..settings(1)
        },
    )
    .expect("renderer");
    let frame = renderer.render().expect("render");
    assert!(frame.stats.value_check.is_none());
    assert!(!frame.stats.passes_run.iter().any(|p| p == "value_check"));
    assert!(renderer.inject_value(Checked::Direct, 0, f32::NAN).is_err());
    common::assert_validation_clean(&gpu);
}

/// Float index of texel (x, y), channel c, of a `SIZE`-wide image.
fn texel(x: u64, y: u64, c: u64, width: u64) -> u64 {
    (y * width + x) * 4 + c
}

/// Injects a NaN at texel `nan` (red) and a -1 at texel `negative` (green) of `which`.
fn inject_pixels(
    renderer: &mut Renderer,
    which: Checked,
    width: u64,
    nan: (u64, u64),
    negative: (u64, u64),
) {
    renderer
        .inject_value(which, texel(nan.0, nan.1, 0, width), f32::NAN)
        .unwrap();
    renderer
        .inject_value(which, texel(negative.0, negative.1, 1, width), -1.0)
        .unwrap();
}

#[test]
fn an_injected_nan_and_negative_are_counted_in_every_kind_of_buffer() {
    let gpu = common::gpu();
    let subsample = 2;
    let mut renderer = Renderer::new(
        &gpu,
        &cornell_box(),
        RenderSettings {
            // Every frame emits, traces and uploads again, so injected records are gone from
            // the next frame's bounce map and photon map.
            effects: Effects::All,
            ..settings(subsample)
        },
    )
    .expect("renderer");
    let clean = renderer.render().expect("render");
    assert_eq!(check(&clean).total_bad(), 0, "{:?}", check(&clean));
    let w = u64::from(SIZE);

    // Frame 1: the full-resolution images and the bounce map, whose values nothing later
    // reads on the GPU (the CPU trace read it before).
    inject_pixels(&mut renderer, Checked::Direct, w, (1, 2), (3, 4));
    inject_pixels(&mut renderer, Checked::Indirect, w, (5, 6), (7, 8));
    inject_pixels(&mut renderer, Checked::Final, w, (9, 10), (11, 12));
    // 8 floats a record: power at 0..3, the packed direction at 3..6, where a -5 is no error
    // but an ∞ is.
    renderer
        .inject_value(Checked::BounceMap, 8 * 10 + 1, -1.0)
        .unwrap();
    renderer
        .inject_value(Checked::BounceMap, 8 * 20 + 4, -5.0)
        .unwrap();
    renderer
        .inject_value(Checked::BounceMap, 8 * 30 + 4, f32::INFINITY)
        .unwrap();
    let frame = renderer.render().expect("render");
    let c = check(&frame);
    for which in [Checked::Direct, Checked::Indirect, Checked::BounceMap] {
        assert_eq!(counts(c, which).0, 1, "{}: {c:?}", which.name());
        assert_eq!(counts(c, which).1, 1, "{}: {c:?}", which.name());
    }
    // The final image has its own NaN and those the composite carried over from the direct
    // and indirect images (pixels the translucent pass leaves alone), and its own -1.
    let (non_finite, negative, _) = counts(c, Checked::Final);
    assert!(non_finite >= 3, "final: {c:?}");
    assert!(negative >= 1, "final: {c:?}");
    let host_non_finite = frame.hdr.iter().filter(|v| !v.is_finite()).count() as u64;
    assert_eq!(
        host_non_finite, non_finite,
        "the host finds the GPU's count in the read-back final image"
    );
    assert_eq!(
        counts(c, Checked::PhotonMap),
        (0, 0, 12 * frame.stats.stored_photons as u64)
    );

    // Frame 2: the low-resolution targets; the upsample carries their NaN into the indirect
    // image.
    let low_w = u64::from(ispm::passes::upsample::low_size(SIZE, SIZE, subsample).0);
    inject_pixels(
        &mut renderer,
        Checked::IndirectLowIrradiance,
        low_w,
        (10, 10),
        (2, 3),
    );
    inject_pixels(
        &mut renderer,
        Checked::IndirectLowGlossy,
        low_w,
        (0, 3),
        (4, 1),
    );
    let frame = renderer.render().expect("render");
    let c = check(&frame);
    for which in [Checked::IndirectLowIrradiance, Checked::IndirectLowGlossy] {
        assert_eq!(counts(c, which).0, 1, "{}: {c:?}", which.name());
        assert_eq!(counts(c, which).1, 1, "{}: {c:?}", which.name());
    }
    assert!(counts(c, Checked::Indirect).0 >= 1, "upsampled NaN: {c:?}");
    assert!(counts(c, Checked::Final).0 >= 1, "composited NaN: {c:?}");

    // Frame 3: the photon map (12 floats a photon: power at 0..3, position at 6..9), just
    // before the photon volumes draw it.
    renderer
        .inject_value(Checked::PhotonMap, 12 * 5 + 2, -1.0)
        .unwrap();
    renderer
        .inject_value(Checked::PhotonMap, 12 * 6 + 7, -5.0)
        .unwrap();
    renderer
        .inject_value(Checked::PhotonMap, 12 * 7, f32::NAN)
        .unwrap();
    let frame = renderer.render().expect("render");
    let c = check(&frame);
    assert_eq!(counts(c, Checked::PhotonMap).0, 1, "{c:?}");
    assert_eq!(
        counts(c, Checked::PhotonMap).1,
        1,
        "the -5 position is no error: {c:?}"
    );
    assert_eq!(counts(c, Checked::Direct), (0, 0, 4 * w * w), "{c:?}");

    // Injections are one-shot and the buffers are written again every frame: clean.
    let after = renderer.render().expect("render");
    assert_eq!(check(&after).total_bad(), 0, "{:?}", check(&after));
    common::assert_validation_clean(&gpu);
}

#[test]
fn every_buffer_of_a_split_bounce_map_and_photon_map_is_checked_and_a_nan_in_the_last_is_counted() {
    // Buffers of at most 96 000 bytes: 2000 photons (48 bytes) or 3000 bounce-map records (32
    // bytes). The maps of 20 000 photons span several, each checked into the one count of its
    // map (12 floats a photon, 8 a record: power at 0..3 in both).
    const RANGE: u64 = 96_000;
    const PER_BUFFER: usize = 2000;
    const RECORDS_PER_BUFFER: usize = 3000;
    let gpu = common::gpu();
    let mut renderer = Renderer::new(
        &gpu,
        &cornell_box(),
        RenderSettings {
            storage_buffer_range: Some(RANGE),
            // Every frame traces and uploads again, so the injected photons are gone next frame.
            effects: Effects::All,
            ..settings(1)
        },
    )
    .expect("renderer");
    let clean = renderer.render().expect("render");
    let (stored, buffers) = (clean.stats.stored_photons, clean.stats.photon_buffers);
    let (records, bounce_buffers) = (
        clean.stats.bounce_map_records,
        clean.stats.bounce_map_buffers,
    );
    eprintln!(
        "{stored} photons in {buffers} buffers, {records} records in {bounce_buffers} buffers"
    );
    assert!(buffers >= 3, "{stored} photons in {buffers} buffers");
    assert_eq!(buffers, stored.div_ceil(PER_BUFFER));
    assert!(bounce_buffers >= 3, "{records} records in {bounce_buffers}");
    assert_eq!(bounce_buffers, records.div_ceil(RECORDS_PER_BUFFER));
    let c = check(&clean);
    assert_eq!(c.total_bad(), 0, "{c:?}");
    assert_eq!(counts(c, Checked::PhotonMap), (0, 0, 12 * stored as u64));
    assert_eq!(counts(c, Checked::BounceMap), (0, 0, 8 * records as u64));
    for name in ["photon_map", "bounce_map"] {
        let listed = c.per_buffer.iter().filter(|b| b.name == name).count();
        assert_eq!(listed, 1, "{name} listed once however many buffers: {c:?}");
    }

    // A NaN in the power of the last buffer's first photon and a -1 in the power of the map's
    // last photon (both in the last buffer), a -5 in the position of the second buffer's
    // first photon (no error): the indices count over the whole map. The same in the bounce
    // map, whose -5 lands in a packed direction.
    let maps = [
        (
            Checked::PhotonMap,
            12,
            buffers,
            PER_BUFFER,
            stored,
            [0, 2, 7],
        ),
        (
            Checked::BounceMap,
            8,
            bounce_buffers,
            RECORDS_PER_BUFFER,
            records,
            [1, 0, 4],
        ),
    ];
    for (map, stride, buffers, per_buffer, len, fields) in maps {
        let last_first = ((buffers - 1) * per_buffer) as u64;
        let last = len as u64 - 1;
        let places = [last_first, last, per_buffer as u64];
        for ((record, field), value) in places.into_iter().zip(fields).zip([f32::NAN, -1.0, -5.0]) {
            renderer
                .inject_value(map, stride * record + field, value)
                .unwrap();
        }
    }
    let frame = renderer.render().expect("render");
    assert_eq!(
        (frame.stats.stored_photons, frame.stats.photon_buffers),
        (stored, buffers),
        "the next frame stores the same photons"
    );
    let c = check(&frame);
    assert_eq!(
        counts(c, Checked::PhotonMap),
        (1, 1, 12 * stored as u64),
        "{c:?}"
    );
    assert_eq!(
        counts(c, Checked::BounceMap),
        (1, 1, 8 * records as u64),
        "{c:?}"
    );
    assert_eq!(
        counts(c, Checked::Direct),
        (0, 0, 4 * u64::from(SIZE * SIZE))
    );

    // One-shot: the next frame uploads the map again and is clean.
    let after = renderer.render().expect("render");
    assert_eq!(check(&after).total_bad(), 0, "{:?}", check(&after));
    common::assert_validation_clean(&gpu);
}

#[test]
fn render_check_values_writes_the_counts_into_the_stats_json() {
    let dir = common::image_dir("render_check_values");
    let (out, stats) = (dir.join("frame.exr"), dir.join("stats.json"));
    let o = common::cli::ispm(&[
        "render",
        "diffuse-box",
        "-o",
        out.to_str().unwrap(),
        "--size",
        "32x32",
        "--photons",
        "5000",
        "--check-values",
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let check = &json["value_check"];
    assert_eq!(check["total_bad"], 0, "{check}");
    let buffers = check["per_buffer"].as_array().expect("per_buffer");
    let direct = buffers
        .iter()
        .find(|b| b["name"] == "direct")
        .expect("direct checked");
    assert_eq!(direct["values"], 32 * 32 * 4, "{direct}");
    for name in ["bounce_map", "photon_map", "indirect", "final"] {
        assert!(buffers.iter().any(|b| b["name"] == name), "{name}: {check}");
    }
    // How the maps were split: one buffer each at 5000 photons.
    assert_eq!(json["bounce_map_buffers"], 1, "{json}");
    assert_eq!(json["photon_buffers"], 1, "{json}");
}

//! The debug views (`passes/debug_view.rs`) on lavapipe with validation and synchronization
//! validation on: each writes its own, non-trivial image, shows what it says it shows, and
//! the views of the photon part of the frame refuse a frame without one.

mod common;

use ispm::config::settings::{Method, RenderSettings};
use ispm::passes::debug_view::DebugView;
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use std::collections::HashSet;

fn settings() -> RenderSettings {
    RenderSettings {
        photons: 4_000,
        width: 64,
        height: 64,
        shadow_resolution: 128,
        ..Default::default()
    }
}

fn pixels(frame: &FrameImage) -> Vec<[u8; 3]> {
    frame
        .ldr
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// Pixels whose channels differ by more than 2 of 255.
fn differing(a: &[[u8; 3]], b: &[[u8; 3]]) -> usize {
    a.iter()
        .zip(b)
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 2))
        .count()
}

fn save(name: &str, frame: &FrameImage) {
    let path = common::image_dir("debug_views").join(format!("{name}.png"));
    let _ = ispm::output::write_png(&path, frame.width, frame.height, &frame.ldr);
}

#[test]
fn each_debug_view_writes_a_distinct_non_trivial_image_of_what_it_names() {
    let gpu = common::gpu();
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    let mut renderer = Renderer::new(&gpu, &scene, settings()).expect("renderer");
    let frame = renderer.render().expect("frame");
    save("frame", &frame);
    let mut images = vec![("frame".to_string(), pixels(&frame))];
    let mut frames = Vec::new();
    for view in DebugView::ALL {
        renderer.set_debug_view(Some(view)).expect("view");
        let shown = renderer.render().expect("frame with a debug view");
        save(&format!("{view:?}"), &shown);
        let px = pixels(&shown);
        let colours: HashSet<[u8; 3]> = px.iter().copied().collect();
        let lit = px.iter().filter(|p| p.iter().any(|&c| c > 8)).count();
        assert!(
            colours.len() >= 16 && lit >= px.len() / 10,
            "{view:?}: {} colours, {lit} of {} pixels not black: a trivial image",
            colours.len(),
            px.len()
        );
        images.push((format!("{view:?}"), px));
        frames.push((view, shown));
    }
    for (i, (a, pa)) in images.iter().enumerate() {
        for (b, pb) in &images[i + 1..] {
            let d = differing(pa, pb);
            assert!(
                d >= pa.len() / 10,
                "{a} and {b} differ in only {d} of {} pixels",
                pa.len()
            );
        }
    }
    let get = |v: DebugView| &frames.iter().find(|(w, _)| *w == v).expect("view").1;

    // Eye normals: the floor (bottom centre) faces up: green dominates, red and blue near half.
    let normals = get(DebugView::EyeNormals);
    let at = |f: &FrameImage, x: u32, y: u32| {
        let i = ((y * f.width + x) * 4) as usize;
        [f.ldr[i], f.ldr[i + 1], f.ldr[i + 2]]
    };
    let floor = at(normals, 32, 62);
    assert!(
        floor[1] > 240 && floor[0].abs_diff(128) < 40 && floor[2].abs_diff(128) < 40,
        "floor normal colour {floor:?}, expected about (128, 255, 128)"
    );

    // Direct only + the indirect estimate = the frame, in linear radiance, wherever no glass
    // is drawn over them (the translucent pass covers a small part of the image).
    let direct = &get(DebugView::DirectOnly).hdr;
    let indirect = renderer
        .photons()
        .expect("photon part")
        .read_indirect()
        .expect("indirect");
    let close = frame
        .hdr
        .chunks_exact(4)
        .zip(direct.chunks_exact(4).zip(indirect.chunks_exact(4)))
        .filter(|(f, (d, i))| (0..3).all(|c| (f[c] - d[c] - i[c]).abs() <= 1e-4 + 1e-3 * f[c]))
        .count();
    let n = frame.hdr.len() / 4;
    assert!(
        close >= n * 3 / 4,
        "direct only + indirect matches the frame in only {close} of {n} pixels"
    );
    let mean = |v: &[f32]| v.chunks_exact(4).map(|p| p[0] + p[1] + p[2]).sum::<f32>();
    assert!(
        mean(direct) < mean(&frame.hdr),
        "direct only is not darker than the frame: the indirect light was added"
    );

    // Photon positions: photons drawn over a grey backdrop (coloured pixels), and not many
    // more than there are photons.
    let positions = pixels(get(DebugView::PhotonPositions));
    let coloured = positions
        .iter()
        .filter(|p| p[0].abs_diff(p[1]) > 8 || p[1].abs_diff(p[2]) > 8)
        .count();
    let stored = frame.stats.stored_photons;
    assert!(
        coloured >= 50 && coloured <= stored,
        "{coloured} coloured pixels for {stored} stored photons"
    );

    // Overdraw: the photon volumes cover the lit scene; the alpha of the estimate is the count.
    let counted = indirect.chunks_exact(4).filter(|p| p[3] > 0.0).count();
    let overdraw = pixels(get(DebugView::PhotonOverdraw));
    let black = overdraw
        .iter()
        .filter(|p| p.iter().all(|&c| c == 0))
        .count();
    assert_eq!(
        n - black,
        counted,
        "pixels coloured by the overdraw view vs pixels the volumes shaded"
    );

    // And back to the frame.
    renderer.set_debug_view(None).expect("no view");
    let again = renderer.render().expect("frame");
    assert_eq!(differing(&pixels(&again), &images[0].1), 0);
    common::assert_validation_clean(&gpu);
}

#[test]
fn views_of_the_photon_part_refuse_a_frame_without_indirect_light() {
    let gpu = common::gpu();
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    let settings = RenderSettings {
        method: Method::Direct,
        ..settings()
    };
    let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
    for view in DebugView::ALL {
        let result = renderer.set_debug_view(Some(view));
        if view.needs_photons() {
            let e = result.expect_err("a photon view without photons");
            assert!(e.to_string().contains("needs indirect light"), "{e}");
        } else {
            result.expect("a view of the direct frame");
            let shown = renderer.render().expect("frame");
            assert!(shown.ldr.chunks_exact(4).any(|p| p[..3] != [0, 0, 0]));
        }
    }
    common::assert_validation_clean(&gpu);
}

#[test]
fn the_bounce_map_and_photon_views_of_maps_split_over_buffers_show_every_buffer() {
    // Buffers bound with at most 9 600 bytes: 200 photons or 300 bounce-map records each, so
    // the first light view's records straddle buffers and the photon map spans many.
    let gpu = common::gpu();
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    // The frame with `view` shown, and the records of the first light view.
    let view_of = |settings: RenderSettings, view: DebugView| {
        let mut renderer = Renderer::new(&gpu, &scene, settings).expect("renderer");
        renderer.set_debug_view(Some(view)).expect("view");
        let frame = renderer.render().expect("frame with a debug view");
        let plan = renderer.photons().expect("photon part").plan();
        (frame, plan.texel_range(0..1))
    };
    // Eight bounces keep the photon map (≈ 3 stored photons per photon) within the 64 buffers
    // the volumes draw from; Russian roulette alone would store ≈ 6 per photon here.
    let capped = RenderSettings {
        bounces: 8,
        ..settings()
    };
    let split = RenderSettings {
        storage_buffer_range: Some(9_600),
        ..capped.clone()
    };
    let (one, _) = view_of(capped.clone(), DebugView::BounceMap);
    let (many, first_view) = view_of(split.clone(), DebugView::BounceMap);
    eprintln!(
        "bounce map: {} records in {} buffers, the first view's {first_view:?}",
        many.stats.bounce_map_records, many.stats.bounce_map_buffers
    );
    assert!(first_view.len() > 600, "the first view spans three buffers");
    save("BounceMap-split", &many);
    assert_eq!(differing(&pixels(&many), &pixels(&one)), 0);

    // Photons are Turbo colours over a grey backdrop: where a photon landed is exact, which of
    // the photons landing on one pixel wins is a race (its colour is not compared).
    let photon_pixels = |f: &FrameImage| -> Vec<bool> {
        let chroma = |p: &[u8; 3]| p.iter().max().unwrap() - p.iter().min().unwrap();
        pixels(f).iter().map(|p| chroma(p) > 3).collect()
    };
    let (one, _) = view_of(capped, DebugView::PhotonPositions);
    let (many, _) = view_of(split, DebugView::PhotonPositions);
    save("PhotonPositions-split", &many);
    let (a, b) = (photon_pixels(&many), photon_pixels(&one));
    let shown = a.iter().filter(|&&p| p).count();
    let unlike = a.iter().zip(&b).filter(|(p, q)| p != q).count();
    eprintln!(
        "photon positions: {} photons in {} buffers, {shown} pixels show photons, {unlike} \
         unlike one buffer's",
        many.stats.stored_photons, many.stats.photon_buffers
    );
    assert!(many.stats.photon_buffers >= 10);
    assert!(shown > a.len() / 10, "{shown} pixels show photons");
    assert_eq!(unlike, 0);
    common::assert_validation_clean(&gpu);
}

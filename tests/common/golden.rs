//! Golden-image tests: an HDR render compared with a checked-in OpenEXR under
//! `tests/goldens/<name>.exr` by relative mean squared error.
//!
//! - `relMSE(a, r) = mean over pixels and RGB channels of (a − r)² / (r² + ε)`, `ε = 10⁻²`
//!   ([`rel_mse`], `ispm::tools::metrics`; the same definition as `docs/accuracy.md`).
//! - On failure, `actual.exr/png`, `expected.exr/png` and `difference.png` (|a − r| / (|r| + 0.1),
//!   false colour) are written under `target/tmp/test-images/<name>/` and their paths printed.
//! - `ISPM_BLESS=1` (re)writes the golden from the actual image and passes.

use std::path::{Path, PathBuf};

pub use ispm::tools::metrics::rel_mse;

/// Where the checked-in goldens live.
pub fn golden_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("goldens")
        .join(format!("{name}.exr"))
}

fn display(v: f32) -> u8 {
    // Reinhard, then the sRGB-ish gamma: only for people to look at.
    let x = v.max(0.0);
    ((x / (1.0 + x)).powf(1.0 / 2.2) * 255.0).round() as u8
}

fn to_png(rgba: &[f32]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [display(p[0]), display(p[1]), display(p[2]), 255])
        .collect()
}

/// Blue (equal) → green → red (|a − r| ≥ |r| + 0.1) per pixel, on the worst channel.
fn difference_png(actual: &[f32], expected: &[f32]) -> Vec<u8> {
    actual
        .chunks_exact(4)
        .zip(expected.chunks_exact(4))
        .flat_map(|(a, e)| {
            let d = (0..3)
                .map(|c| (a[c] - e[c]).abs() / (e[c].abs() + 0.1))
                .fold(0.0f32, f32::max)
                .min(1.0);
            let r = (2.0 * d - 1.0).max(0.0);
            let g = 1.0 - (2.0 * d - 1.0).abs();
            let b = (1.0 - 2.0 * d).max(0.0);
            [r, g, b]
                .map(|v| (v * 255.0).round() as u8)
                .into_iter()
                .chain([255])
        })
        .collect()
}

/// Writes actual/expected/difference under `target/tmp/test-images/<name>/`; returns the paths.
pub fn write_failure_images(
    name: &str,
    width: u32,
    height: u32,
    actual: &[f32],
    expected: Option<&[f32]>,
) -> Vec<PathBuf> {
    let dir = super::image_dir(name);
    let mut written = Vec::new();
    let mut put_hdr = |stem: &str, img: &[f32]| {
        let exr = dir.join(format!("{stem}.exr"));
        ispm::output::write_exr(&exr, width, height, img).expect("write EXR");
        let png = dir.join(format!("{stem}.png"));
        ispm::output::write_png(&png, width, height, &to_png(img)).expect("write PNG");
        written.push(exr);
        written.push(png);
    };
    put_hdr("actual", actual);
    if let Some(expected) = expected {
        put_hdr("expected", expected);
        let diff = dir.join("difference.png");
        ispm::output::write_png(&diff, width, height, &difference_png(actual, expected))
            .expect("write PNG");
        written.push(diff);
    }
    for p in &written {
        eprintln!("wrote {}", p.display());
    }
    written
}

/// Compares `actual` (RGBA f32, `width`×`height`) with `tests/goldens/<name>.exr`; panics when
/// relMSE exceeds `threshold` or the golden is missing (run with `ISPM_BLESS=1` to write it).
/// Returns the relMSE.
pub fn assert_matches_golden(
    name: &str,
    width: u32,
    height: u32,
    actual: &[f32],
    threshold: f64,
) -> f64 {
    assert_matches_golden_at(&golden_path(name), name, width, height, actual, threshold)
}

/// [`assert_matches_golden`] against the golden at `path`; failure images go to
/// `target/tmp/test-images/<name>/`.
pub fn assert_matches_golden_at(
    path: &Path,
    name: &str,
    width: u32,
    height: u32,
    actual: &[f32],
    threshold: f64,
) -> f64 {
    if std::env::var_os("ISPM_BLESS").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().expect("goldens dir")).expect("create goldens");
        ispm::output::write_exr(path, width, height, actual).expect("write golden");
        eprintln!("blessed {}", path.display());
        return 0.0;
    }
    let Ok((w, h, expected)) = ispm::output::read_exr(path) else {
        write_failure_images(name, width, height, actual, None);
        panic!(
            "no golden {} (run with ISPM_BLESS=1 to create it)",
            path.display()
        );
    };
    if (w, h) != (width, height) {
        write_failure_images(name, width, height, actual, None);
        panic!("{name}: golden is {w}x{h}, actual {width}x{height} (ISPM_BLESS=1 rewrites it)");
    }
    let error = rel_mse(actual, &expected);
    eprintln!("golden {name}: relMSE {error:.3e} (threshold {threshold:.1e})");
    if error.is_nan() || error > threshold {
        write_failure_images(name, width, height, actual, Some(&expected));
        panic!("{name}: relMSE {error:.3e} against the golden exceeds {threshold:.1e}");
    }
    error
}

//! Writing images: PNG (tonemapped sRGB) and OpenEXR (linear HDR radiance).
//!
//! Outputs are written atomically: into a temporary file beside the target, then renamed over
//! it, so an interrupted or failed render never leaves a half-written file behind.

use anyhow::Context;
use std::path::{Path, PathBuf};

/// The image formats `-o` understands, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    Png,
    Exr,
}

impl OutputFormat {
    pub fn from_path(path: &Path) -> anyhow::Result<OutputFormat> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(OutputFormat::Png),
            Some("exr") => Ok(OutputFormat::Exr),
            _ => anyhow::bail!(
                "{}: unknown output format (use a .png or .exr file name)",
                path.display()
            ),
        }
    }
}

/// Fails, naming `path`, when a file cannot be written there: its folder is missing or the
/// path is a folder.
pub fn check_writable(path: &Path) -> anyhow::Result<()> {
    target_folder(path).map(|_| ())
}

/// The folder `path` is written in, which must exist; `path` must not be a folder itself.
fn target_folder(path: &Path) -> anyhow::Result<PathBuf> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    anyhow::ensure!(
        dir.is_dir(),
        "{}: the folder {} does not exist",
        path.display(),
        dir.display()
    );
    anyhow::ensure!(!path.is_dir(), "{}: is a folder", path.display());
    Ok(dir)
}

/// Writes `bytes` produced by `write` to `path` atomically.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut std::fs::File) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = target_folder(path)?;
    let name = path
        .file_name()
        .with_context(|| format!("{}: not a file name", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut file = std::fs::File::create(&tmp)
            .with_context(|| format!("{}: cannot create", tmp.display()))?;
        write(&mut file)?;
        file.sync_all()
            .with_context(|| format!("{}: cannot write", tmp.display()))?;
        std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes an RGBA8 image as PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgba8: &[u8]) -> anyhow::Result<()> {
    let img = image::RgbaImage::from_raw(width, height, rgba8.to_vec()).with_context(|| {
        format!(
            "{}: image data does not match {width}x{height}",
            path.display()
        )
    })?;
    write_atomically(path, |f| {
        img.write_to(f, image::ImageFormat::Png)
            .with_context(|| format!("{}: PNG encoding failed", path.display()))
    })
}

/// Writes linear RGBA f32 radiance as OpenEXR (alpha set to 1).
pub fn write_exr(path: &Path, width: u32, height: u32, rgba: &[f32]) -> anyhow::Result<()> {
    let mut pixels = rgba.to_vec();
    for px in pixels.chunks_exact_mut(4) {
        px[3] = 1.0;
    }
    let img = image::Rgba32FImage::from_raw(width, height, pixels).with_context(|| {
        format!(
            "{}: image data does not match {width}x{height}",
            path.display()
        )
    })?;
    write_atomically(path, |f| {
        image::DynamicImage::ImageRgba32F(img)
            .write_to(f, image::ImageFormat::OpenExr)
            .with_context(|| format!("{}: EXR encoding failed", path.display()))
    })
}

/// Reads an EXR back as RGBA f32 (tests and `ispm sweep` use it).
pub fn read_exr(path: &Path) -> anyhow::Result<(u32, u32, Vec<f32>)> {
    let img = image::open(path)
        .with_context(|| format!("{}: cannot read EXR", path.display()))?
        .into_rgba32f();
    Ok((img.width(), img.height(), img.into_raw()))
}

/// Mean sRGB value (of 255) below which a tonemapped picture reads as black.
pub const DARK_MEAN_SRGB: f64 = 2.0;

/// For a PNG that came out nearly black (mean sRGB value below [`DARK_MEAN_SRGB`] of 255) though
/// its radiance (`hdr`, before exposure) is not zero: the exposure in stops, rounded to half a
/// stop, that brings the log-average luminance of its lit pixels to mid-grey (0.18), as a
/// camera's metering would. `None` for a picture that is not dark, or that is black because
/// nothing in it is lit.
pub fn exposure_hint(hdr: &[f32], ldr: &[u8]) -> Option<f32> {
    let pixels = ldr.len() / 4;
    if pixels == 0 {
        return None;
    }
    let mean: f64 = ldr
        .chunks_exact(4)
        .map(|p| f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2]))
        .sum::<f64>()
        / (3 * pixels) as f64;
    if mean >= DARK_MEAN_SRGB {
        return None;
    }
    let (mut sum, mut lit) = (0.0f64, 0usize);
    for p in hdr.chunks_exact(4) {
        let y = 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
        if y > 0.0 && y.is_finite() {
            sum += y.ln();
            lit += 1;
        }
    }
    if lit == 0 {
        return None;
    }
    let log_average = (sum / lit as f64).exp();
    let stops = (0.18 / log_average).log2();
    Some(((stops * 2.0).round() / 2.0) as f32)
}

#[cfg(test)]
mod exposure_tests {
    use super::*;

    #[test]
    fn a_dark_picture_gets_the_exposure_that_brings_it_to_mid_grey() {
        // Radiance 0.18 / 2^9 everywhere, tonemapped to black: +9 stops.
        let hdr = [0.18 / 512.0, 0.18 / 512.0, 0.18 / 512.0, 1.0].repeat(16);
        let black = [0u8, 0, 0, 255].repeat(16);
        assert_eq!(exposure_hint(&hdr, &black), Some(9.0));
        // The radiance is before exposure: 0.18 / 2^6 needs +6 in all, whatever the exposure
        // the dark picture was made at.
        let six = [0.18 / 64.0, 0.18 / 64.0, 0.18 / 64.0, 1.0].repeat(16);
        assert_eq!(exposure_hint(&six, &black), Some(6.0));
        // Nothing lit: no hint. Not dark: no hint.
        assert_eq!(
            exposure_hint(&[0.0, 0.0, 0.0, 1.0].repeat(16), &black),
            None
        );
        let grey = [128u8, 128, 128, 255].repeat(16);
        assert_eq!(exposure_hint(&hdr, &grey), None);
    }
}

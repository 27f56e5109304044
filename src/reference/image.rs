//! A linear HDR RGB image and its atomic EXR output.

use anyhow::{Context, Result};
use std::path::Path;

/// Linear RGB, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl HdrImage {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Mean of every channel of every pixel.
    pub fn mean(&self) -> f64 {
        let sum: f64 = self
            .pixels
            .iter()
            .flat_map(|p| p.iter())
            .map(|&c| c as f64)
            .sum();
        sum / (self.pixels.len() * 3).max(1) as f64
    }

    /// Writes an OpenEXR file atomically: a temporary file in the same folder, then a rename,
    /// so no half-written file is ever left at `path`.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        let data: Vec<f32> = self.pixels.iter().flat_map(|p| *p).collect();
        let buffer = image::Rgb32FImage::from_raw(self.width, self.height, data)
            .context("image buffer size does not match its dimensions")?;
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        let name = path
            .file_name()
            .with_context(|| format!("{}: not a file path", path.display()))?;
        let tmp_name = format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id());
        let tmp = dir.map_or_else(|| tmp_name.clone().into(), |d| d.join(&tmp_name));
        let written = buffer
            .save_with_format(&tmp, image::ImageFormat::OpenExr)
            .with_context(|| format!("{}: cannot write EXR", tmp.display()))
            .and_then(|()| {
                std::fs::rename(&tmp, path)
                    .with_context(|| format!("{}: cannot move into place", path.display()))
            });
        if written.is_err() {
            // Best effort: the temporary file may not exist if the write failed early.
            let _ = std::fs::remove_file(&tmp);
        }
        written
    }
}

//! The sweep's reference images, rendered by the CPU references and cached on disk.
//!
//! - **Which renderer**: a scene with a delta-BSDF material (a perfect mirror or glass) has
//!   caustic paths (L S…S D E) that the path tracer cannot reach (punctual lights cannot be hit),
//!   so it gets `progressive` photon mapping; any other scene the path tracer, which is
//!   unbiased there.
//! - **What**: the whole image, and its direct part, `path-trace(bounces 0)` (the first
//!   surface's emission and direct light, after any delta bounces), as the accuracy tests take
//!   it; indirect = whole − direct. Every eye sample goes through the pixel centre
//!   (`RefSettings::jitter` off), as the rasteriser samples, so edges compare like with like.
//! - **The cache**: `<cache>/<key>.exr` and `<key>-direct.exr`, the key a 64-bit FNV-1a hash of
//!   the scene's content (`Debug` of the loaded [`Scene`]: meshes, materials, textures, lights,
//!   camera), of the reference settings and size, and of [`REFERENCE_REVISION`] (the
//!   references' physics: a cache written by an older renderer is not reused). `--reference-cache DIR`, else
//!   `$XDG_CACHE_HOME/ispm/references`, else `~/.cache/ispm/references`. Files are written
//!   atomically, so an interrupted render leaves no cache entry.

use super::hash::{fnv1a, fnv1a_debug, hex};

/// The revision of the CPU references' physics, part of every cache key: bump it whenever a
/// change makes `path-trace` or `progressive` render a scene differently (2: emissive surfaces
/// sampled as lights, emission counted once; 3: Russian-roulette path depth, energy-compensated
/// glossy lobe, glTF dielectric base weighted by 1 − F0; 4: the Fresnel ramp scaled by 1 −
/// roughness; 5: `progressive`'s kernels from each photon's kNN radius, not one global radius,
/// and half its photons aimed at the delta surfaces, `reference::caustic_photons`),
/// so that no cached reference of the old physics is compared with the new renderer.
pub const REFERENCE_REVISION: u32 = 5;
use crate::config::settings::{Method, DEFAULT_BOUNCES};
use crate::reference::{self, RefSettings};
use crate::scene::Scene;
use crate::tools::metrics::rgba;
use anyhow::{Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// How hard the reference works (the CLI's `--reference-*`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ReferenceSpec {
    /// Path tracer: samples per pixel (pixel centres, a fresh random stream each).
    /// Progressive photon mapping: iterations (one sample per pixel each).
    pub passes: u32,
    /// Progressive photon mapping: photons per iteration.
    pub photons: usize,
    /// Most bounces of a light path (default: the safety cap; Russian roulette ends them).
    pub bounces: u32,
}

/// Path-tracer samples per pixel, or progressive iterations (`--reference-passes`).
pub const DEFAULT_REFERENCE_PASSES: u32 = 256;

/// Photons per progressive photon mapping iteration (`--reference-photons`).
pub const DEFAULT_REFERENCE_PHOTONS: usize = 100_000;

impl Default for ReferenceSpec {
    fn default() -> Self {
        Self {
            passes: DEFAULT_REFERENCE_PASSES,
            photons: DEFAULT_REFERENCE_PHOTONS,
            bounces: DEFAULT_BOUNCES,
        }
    }
}

/// The references of one scene at one size, RGBA f32.
pub struct References {
    pub method: Method,
    pub total: Vec<f32>,
    pub direct: Vec<f32>,
    /// `total − direct`.
    pub indirect: Vec<f32>,
    /// The cache file of `total`.
    pub path: PathBuf,
    /// False when it was read from the cache.
    pub rendered: bool,
}

/// `progressive` when the scene has a delta-BSDF material, else `path-trace` (module docs).
pub fn method_for(scene: &Scene) -> Method {
    if scene.materials.iter().any(|m| m.has_delta_lobe()) {
        Method::Progressive
    } else {
        Method::PathTrace
    }
}

/// The hash of what a scene renders as (module docs).
pub fn scene_hash(scene: &Scene) -> u64 {
    fnv1a_debug(scene)
}

/// The default cache folder (module docs).
pub fn default_cache() -> PathBuf {
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(dir).join("ispm").join("references");
    }
    let home = std::env::var_os("HOME").map_or_else(|| PathBuf::from("."), PathBuf::from);
    home.join(".cache").join("ispm").join("references")
}

fn settings(method: Method, spec: &ReferenceSpec, width: u32, height: u32) -> RefSettings {
    RefSettings {
        width,
        height,
        spp: if method == Method::PathTrace {
            spec.passes.max(1)
        } else {
            1
        },
        jitter: false,
        photons: spec.photons,
        bounces: spec.bounces,
        iterations: spec.passes.max(1),
        seed: 0x5ee9,
        ..Default::default()
    }
}

fn read(path: &Path, width: u32, height: u32) -> Option<Vec<f32>> {
    let (w, h, pixels) = crate::output::read_exr(path).ok()?;
    (w == width && h == height).then_some(pixels)
}

fn write(path: &Path, width: u32, height: u32, pixels: &[f32]) -> Result<()> {
    crate::output::write_exr(path, width, height, pixels)
}

/// The references of `scene` at `width`×`height`, from `cache` or rendered into it (with a
/// progress bar on `progress` while rendering).
pub fn references(
    scene: &Scene,
    spec: &ReferenceSpec,
    width: u32,
    height: u32,
    cache: &Path,
    progress: &indicatif::ProgressBar,
) -> Result<References> {
    let method = method_for(scene);
    let total_settings = settings(method, spec, width, height);
    let direct_settings = RefSettings {
        spp: 1,
        bounces: 0,
        ..settings(Method::PathTrace, spec, width, height)
    };
    let key = hex(fnv1a(
        format!(
            "{:016x} {method:?} {total_settings:?} {direct_settings:?} r{REFERENCE_REVISION}",
            scene_hash(scene)
        )
        .as_bytes(),
    ));
    std::fs::create_dir_all(cache)
        .with_context(|| format!("{}: cannot create the reference cache", cache.display()))?;
    let path = cache.join(format!("{key}.exr"));
    let direct_path = cache.join(format!("{key}-direct.exr"));
    let cached = read(&path, width, height).zip(read(&direct_path, width, height));
    let rendered = cached.is_none();
    let (total, direct) = match cached {
        Some(images) => images,
        None => {
            let cancel = AtomicBool::new(false);
            progress.set_message(format!(
                "reference ({}, {} passes)",
                method.name(),
                spec.passes
            ));
            let total = reference::render(scene, method, &total_settings, Some(progress), &cancel)
                .context("reference")?;
            let direct =
                reference::render(scene, Method::PathTrace, &direct_settings, None, &cancel)
                    .context("direct reference")?;
            let (total, direct) = (rgba(&total.pixels), rgba(&direct.pixels));
            write(&direct_path, width, height, &direct)?;
            write(&path, width, height, &total)?;
            (total, direct)
        }
    };
    Ok(References {
        method,
        indirect: crate::tools::metrics::difference(&total, &direct),
        total,
        direct,
        path,
        rendered,
    })
}

//! The sweep's grid: the knobs that trade accuracy for time, their values (`--grid`), and the
//! configurations they expand to.
//!
//! `--grid` is `KNOB=V,V,…;KNOB=…`; a knob not named keeps its default values
//! ([`Grid::default`]). Numbers take a `k` (×1000) or `M` (×10⁶) suffix.
//!
//! | knob | what it sets | default values |
//! |---|---|---|
//! | `photons` | photons emitted per frame (`--photons`) | 10k, 40k, 160k |
//! | `bounces` | most scattering events per photon (`--bounces`) | 256 (the safety cap: Russian roulette ends the paths) |
//! | `radius` | kernel `r_max` as a multiple of the scene-relative default (`--radius`) | 0.5, 1, 2 |
//! | `subsample` | photon volumes at 1/N resolution (`--subsample`) | 1, 2, 4 |
//! | `caustic-share` | bounce-map resolution: the share of photons on the caustic views (`--caustic-share`) | 0.5 |
//! | `upsample` | `joint` (bilateral) or `bilinear` upsampling at subsample > 1 (`--upsample`) | joint |
//! | `method` | `ispm`, or `photon-gather` (the CPU k-d tree baseline) | ispm |
//! | `accumulate` | frames averaged into one image, each with new photons and smaller kernels (`render --frames`; progressive accumulation) | 1 |
//! | `density` | the density estimator, `volumes`, `tiled` or `auto` (`--density`; `auto` is recorded as what it resolves to on the device) | auto |
//!
//! "Bounce-map resolution": one bounce-map texel emits one photon, so a light's texel count *is*
//! its photon count and cannot vary on its own; what does vary independently is how those texels
//! are spread, and `caustic-share` is that knob: the share of each light's texels given to its
//! caustic views (windows around the mirrors and glass it lights), i.e. the texel density, and
//! so the bounce-map resolution, on the caustic casters against the rest of the view.
//!
//! Configurations are normalised before they are deduplicated: at subsample 1 there is no
//! upsampling (the `upsample` value is recorded as `joint`); the `photon-gather` baseline has no
//! subsampling, upsampling, caustic views, accumulation or density estimator (recorded as
//! `volumes`, its kernel's sums). `auto` is resolved for the device ([`Grid::resolve_density`])
//! before the configurations are made, so a record names the estimator that measured it.

use crate::config::settings::{Density, Method, Upsample, CAUSTIC_SHARE, DEFAULT_BOUNCES};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

/// The methods a configuration may render with ([`Grid::method`]): the GPU renderer, and
/// traditional photon mapping on the CPU (k-d tree gather, ISPM's kernel), the baseline.
pub const SWEEP_METHODS: [Method; 2] = [Method::Ispm, Method::PhotonGather];

/// One point of the grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// One of [`SWEEP_METHODS`].
    pub method: Method,
    pub photons: usize,
    pub bounces: u32,
    /// Multiple of the scene-relative kernel `r_max` (`KernelSettings::scene_relative`).
    pub radius_scale: f32,
    pub subsample: u32,
    pub caustic_share: f32,
    pub upsample: Upsample,
    /// Frames averaged into the image (progressive accumulation; 1: one frame). Results
    /// written before the knob existed read as 1.
    #[serde(default = "one")]
    pub accumulate: u32,
    /// The density estimator (never `Auto` once resolved). Results written before the knob
    /// existed were all made by the photon volumes and read as `Volumes`.
    #[serde(default = "volumes")]
    pub density: Density,
}

fn one() -> u32 {
    1
}

fn volumes() -> Density {
    Density::Volumes
}

impl Config {
    /// The configuration as the renderer sees it (module docs, normalisation).
    fn normalised(mut self) -> Self {
        if self.method == Method::PhotonGather {
            self.subsample = 1;
            self.caustic_share = 0.0;
            self.accumulate = 1;
            self.density = Density::Volumes;
        }
        self.accumulate = self.accumulate.max(1);
        if self.subsample <= 1 {
            self.subsample = 1;
            self.upsample = Upsample::Joint;
        }
        self
    }

    /// A short unique name, e.g. `ispm p40000 b8 r1 s2 c0.5 joint`, with ` tiled` for the
    /// tiled gather (the photon volumes' records keep their names from before the knob).
    pub fn label(&self) -> String {
        let upsample = match (self.subsample, self.upsample) {
            (1, _) => "",
            (_, Upsample::Joint) => " joint",
            (_, Upsample::Bilinear) => " bilinear",
        };
        let accumulate = if self.accumulate > 1 {
            format!(" a{}", self.accumulate)
        } else {
            String::new()
        };
        let density = match self.density {
            Density::Tiled => " tiled",
            Density::Volumes | Density::Auto => "",
        };
        format!(
            "{} p{} b{} r{} s{} c{}{}{}{}",
            self.method.name(),
            self.photons,
            self.bounces,
            self.radius_scale,
            self.subsample,
            self.caustic_share,
            upsample,
            accumulate,
            density
        )
    }
}

/// The values of every knob.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub method: Vec<Method>,
    pub photons: Vec<usize>,
    pub bounces: Vec<u32>,
    pub radius: Vec<f32>,
    pub subsample: Vec<u32>,
    pub caustic_share: Vec<f32>,
    pub upsample: Vec<Upsample>,
    pub accumulate: Vec<u32>,
    pub density: Vec<Density>,
}

impl Default for Grid {
    fn default() -> Self {
        Self {
            method: vec![Method::Ispm],
            photons: vec![10_000, 40_000, 160_000],
            bounces: vec![DEFAULT_BOUNCES],
            radius: vec![0.5, 1.0, 2.0],
            subsample: vec![1, 2, 4],
            caustic_share: vec![CAUSTIC_SHARE],
            upsample: vec![Upsample::Joint],
            accumulate: vec![1],
            density: vec![Density::Auto],
        }
    }
}

/// `10k` → 10 000, `1.5M` → 1 500 000, `0.5` → 0.5.
fn number(s: &str) -> Option<f64> {
    let s = s.trim();
    let (digits, scale) = match s.as_bytes().last()? {
        b'k' | b'K' => (&s[..s.len() - 1], 1e3),
        b'm' | b'M' => (&s[..s.len() - 1], 1e6),
        _ => (s, 1.0),
    };
    let v = digits.parse::<f64>().ok()? * scale;
    v.is_finite().then_some(v)
}

fn positive_int(knob: &str, s: &str, max: f64) -> Result<u64> {
    match number(s) {
        Some(v) if v >= 1.0 && v <= max && v.fract() == 0.0 => Ok(v as u64),
        _ => bail!("{knob}={s}: not a whole number from 1 to {max}"),
    }
}

impl Grid {
    /// Parses `--grid` (module docs): the named knobs replace the defaults.
    pub fn parse(spec: &str) -> Result<Self> {
        let mut grid = Grid::default();
        for part in spec.split(';').map(str::trim).filter(|p| !p.is_empty()) {
            let (knob, values) = part
                .split_once('=')
                .with_context(|| format!("--grid: {part:?} is not KNOB=VALUE,VALUE…"))?;
            let knob = knob.trim();
            let values: Vec<&str> = values
                .split(',')
                .map(str::trim)
                .filter(|v| !v.is_empty())
                .collect();
            if values.is_empty() {
                bail!("--grid: {knob} has no values");
            }
            match knob {
                "photons" => {
                    grid.photons = values
                        .iter()
                        .map(|v| positive_int(knob, v, 1e8).map(|n| n as usize))
                        .collect::<Result<_>>()?;
                }
                "bounces" => {
                    grid.bounces = values
                        .iter()
                        .map(|v| positive_int(knob, v, 64.0).map(|n| n as u32))
                        .collect::<Result<_>>()?;
                }
                "subsample" => {
                    grid.subsample = values
                        .iter()
                        .map(|v| positive_int(knob, v, 64.0).map(|n| n as u32))
                        .collect::<Result<_>>()?;
                }
                "radius" => {
                    grid.radius = values
                        .iter()
                        .map(|v| match number(v) {
                            Some(r) if r > 0.0 && r <= 100.0 => Ok(r as f32),
                            _ => bail!("radius={v}: not a scale in (0, 100]"),
                        })
                        .collect::<Result<_>>()?;
                }
                "caustic-share" => {
                    grid.caustic_share = values
                        .iter()
                        .map(|v| match number(v) {
                            Some(c) if (0.0..=0.95).contains(&c) => Ok(c as f32),
                            _ => bail!("caustic-share={v}: not a number from 0 to 0.95"),
                        })
                        .collect::<Result<_>>()?;
                }
                "upsample" => {
                    grid.upsample = values
                        .iter()
                        .map(|v| match *v {
                            "joint" | "on" => Ok(Upsample::Joint),
                            "bilinear" | "off" => Ok(Upsample::Bilinear),
                            _ => bail!("upsample={v}: not joint (on) or bilinear (off)"),
                        })
                        .collect::<Result<_>>()?;
                }
                "accumulate" => {
                    grid.accumulate = values
                        .iter()
                        .map(|v| positive_int(knob, v, 4096.0).map(|n| n as u32))
                        .collect::<Result<_>>()?;
                }
                "density" => {
                    grid.density = values
                        .iter()
                        .map(|v| match *v {
                            "volumes" => Ok(Density::Volumes),
                            "tiled" => Ok(Density::Tiled),
                            "auto" => Ok(Density::Auto),
                            _ => bail!("density={v}: not volumes, tiled or auto"),
                        })
                        .collect::<Result<_>>()?;
                }
                "method" => {
                    grid.method = values
                        .iter()
                        .map(
                            |v| match SWEEP_METHODS.into_iter().find(|m| m.name() == *v) {
                                Some(m) => Ok(m),
                                None => bail!("method={v}: not ispm or photon-gather"),
                            },
                        )
                        .collect::<Result<_>>()?;
                }
                _ => bail!(
                    "--grid: unknown knob {knob:?} (photons, bounces, radius, subsample, \
                     caustic-share, upsample, method, accumulate, density)"
                ),
            }
        }
        Ok(grid)
    }

    /// The grid with `auto` made concrete as `resolve` makes it (the device's choice).
    pub fn resolve_density(mut self, resolve: impl Fn(Density) -> Density) -> Self {
        for d in &mut self.density {
            *d = resolve(*d);
        }
        self
    }

    /// Every combination, normalised and without duplicates, in grid order (`ispm sweep` makes
    /// `auto` densities concrete first, [`Self::resolve_density`]).
    pub fn configs(&self) -> Vec<Config> {
        let mut out: Vec<Config> = Vec::new();
        for &method in &self.method {
            for &photons in &self.photons {
                for &bounces in &self.bounces {
                    for &radius_scale in &self.radius {
                        for &subsample in &self.subsample {
                            for &caustic_share in &self.caustic_share {
                                for &upsample in &self.upsample {
                                    for &accumulate in &self.accumulate {
                                        for &density in &self.density {
                                            let c = Config {
                                                method,
                                                photons,
                                                bounces,
                                                radius_scale,
                                                subsample,
                                                caustic_share,
                                                upsample,
                                                accumulate,
                                                density,
                                            }
                                            .normalised();
                                            if !out.contains(&c) {
                                                out.push(c);
                                            }
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_spec_replaces_the_named_knobs_only() {
        let g = Grid::parse("photons=10k,40k; subsample=1,2").unwrap();
        assert_eq!(g.photons, vec![10_000, 40_000]);
        assert_eq!(g.subsample, vec![1, 2]);
        assert_eq!(g.radius, Grid::default().radius);
        let configs = Grid {
            radius: vec![1.0],
            ..g
        }
        .configs();
        assert_eq!(configs.len(), 4);
    }

    #[test]
    fn configurations_without_upsampling_are_not_repeated() {
        let g = Grid::parse("photons=1k;radius=1;subsample=1,2;upsample=joint,bilinear").unwrap();
        let labels: Vec<String> = g.configs().iter().map(Config::label).collect();
        assert_eq!(
            labels,
            [
                "ispm p1000 b256 r1 s1 c0.5",
                "ispm p1000 b256 r1 s2 c0.5 joint",
                "ispm p1000 b256 r1 s2 c0.5 bilinear"
            ]
        );
    }

    #[test]
    fn accumulated_frames_are_a_knob_the_cpu_baseline_does_not_have() {
        let g =
            Grid::parse("photons=1k;radius=1;subsample=1;accumulate=1,8;method=ispm,photon-gather")
                .unwrap();
        let labels: Vec<String> = g.configs().iter().map(Config::label).collect();
        assert_eq!(
            labels,
            [
                "ispm p1000 b256 r1 s1 c0.5",
                "ispm p1000 b256 r1 s1 c0.5 a8",
                "photon-gather p1000 b256 r1 s1 c0",
            ]
        );
        // Results written before the knob read as one frame.
        let old = r#"{"method":"ispm","photons":1000,"bounces":8,"radius_scale":1.0,
            "subsample":1,"caustic_share":0.5,"upsample":"joint"}"#;
        let c: Config = serde_json::from_str(old).unwrap();
        assert_eq!(c.accumulate, 1);
    }

    #[test]
    fn the_density_estimator_is_a_knob_resolved_before_the_records_are_keyed() {
        let g = Grid::parse(
            "photons=1k;radius=1;subsample=1;density=volumes,tiled,auto;method=ispm,photon-gather",
        )
        .unwrap();
        // `auto` resolved as a CPU device with subgroup operations resolves it: a duplicate of
        // `tiled`, so measured once.
        let resolved = g.resolve_density(|d| d.resolve(true));
        let labels: Vec<String> = resolved.configs().iter().map(Config::label).collect();
        assert_eq!(
            labels,
            [
                "ispm p1000 b256 r1 s1 c0.5",
                "ispm p1000 b256 r1 s1 c0.5 tiled",
                "photon-gather p1000 b256 r1 s1 c0",
            ]
        );
        // Results written before the knob were the photon volumes'.
        let old = r#"{"method":"ispm","photons":1000,"bounces":8,"radius_scale":1.0,
            "subsample":1,"caustic_share":0.5,"upsample":"joint"}"#;
        let c: Config = serde_json::from_str(old).unwrap();
        assert_eq!(c.density, Density::Volumes);
    }

    #[test]
    fn bad_grid_specs_name_the_problem() {
        for (spec, words) in [
            ("photons=0", "photons=0"),
            ("subsample=x", "subsample=x"),
            ("colour=1", "unknown knob"),
            ("photons", "KNOB=VALUE"),
            ("caustic-share=2", "0.95"),
            ("method=path", "photon-gather"),
            ("accumulate=0", "accumulate=0"),
            ("density=splat", "volumes, tiled or auto"),
        ] {
            let e = Grid::parse(spec).unwrap_err().to_string();
            assert!(e.contains(words), "{spec}: {e}");
        }
    }
}

//! The sweep's results: one record per configuration, `results.json` (everything, the file a
//! resumed sweep reads back) and `results.csv` (one row per record, the stage times as columns),
//! both written atomically after every configuration, so an interrupted sweep keeps what it
//! measured and a second run redoes nothing that is there.
//!
//! A record's key is its configuration's label, the scene's content hash and the image size:
//! the same configuration of an edited scene, or at another size, is measured anew. Records of
//! other scenes or sizes in the same folder are kept, and left out of the Pareto front and the
//! plots of this one.

use super::grid::Config;
use super::measure::Measurement;
use crate::output::write_atomically;
use crate::tools::metrics::pareto_front;
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::io::Write;
use std::path::Path;

/// One measured configuration.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Record {
    pub key: String,
    pub label: String,
    pub scene: String,
    /// [`super::reference::scene_hash`] in hex.
    pub scene_hash: String,
    pub width: u32,
    pub height: u32,
    /// Timed frames.
    pub frames: u32,
    pub config: Config,
    #[serde(flatten)]
    pub measurement: Measurement,
    /// On the (frame time, relMSE) Pareto front of its scene and size.
    pub pareto: bool,
}

/// The whole of `results.json`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Results {
    pub records: Vec<Record>,
}

/// The resume key (module docs).
pub fn key(config: &Config, scene_hash: &str, width: u32, height: u32) -> String {
    format!("{} @{scene_hash} {width}x{height}", config.label())
}

impl Results {
    /// Reads `dir/results.json`; empty when there is none.
    pub fn load(dir: &Path) -> Result<Self> {
        let path = dir.join("results.json");
        match std::fs::read(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes).with_context(|| {
                format!(
                    "{}: not an `ispm sweep` result (delete it or choose another --out)",
                    path.display()
                )
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(e) => Err(e).with_context(|| format!("{}: cannot read", path.display())),
        }
    }

    pub fn contains(&self, key: &str) -> bool {
        self.records.iter().any(|r| r.key == key)
    }

    /// The records of one scene and size, in the order they were measured.
    pub fn of<'a>(
        &'a self,
        scene_hash: &'a str,
        width: u32,
        height: u32,
    ) -> impl Iterator<Item = &'a Record> + 'a {
        self.records
            .iter()
            .filter(move |r| r.scene_hash == scene_hash && r.width == width && r.height == height)
    }

    /// Marks the (frame time, relMSE) Pareto front of every scene and size.
    pub fn mark_pareto(&mut self) {
        let groups: BTreeSet<(String, u32, u32)> = self
            .records
            .iter()
            .map(|r| (r.scene_hash.clone(), r.width, r.height))
            .collect();
        for r in &mut self.records {
            r.pareto = false;
        }
        for (hash, w, h) in groups {
            let members: Vec<usize> = (0..self.records.len())
                .filter(|&i| {
                    let r = &self.records[i];
                    r.scene_hash == hash && r.width == w && r.height == h
                })
                .collect();
            let points: Vec<(f64, f64)> = members
                .iter()
                .map(|&i| {
                    let m = &self.records[i].measurement;
                    (m.frame_ms, m.rel_mse)
                })
                .collect();
            for k in pareto_front(&points) {
                self.records[members[k]].pareto = true;
            }
        }
    }

    /// Writes `results.json` and `results.csv` into `dir`, each atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let json = dir.join("results.json");
        write_atomically(&json, |f| {
            serde_json::to_writer_pretty(&mut *f, self)
                .with_context(|| format!("{}: cannot write JSON", json.display()))?;
            f.write_all(b"\n")
                .with_context(|| format!("{}: cannot write", json.display()))
        })?;
        let csv = dir.join("results.csv");
        let text = self.csv();
        write_atomically(&csv, |f| {
            f.write_all(text.as_bytes())
                .with_context(|| format!("{}: cannot write", csv.display()))
        })
    }

    /// The CSV text: fixed columns, then one `ms.STAGE` column per stage any record has.
    pub fn csv(&self) -> String {
        let stages: BTreeSet<&str> = self
            .records
            .iter()
            .flat_map(|r| r.measurement.stages.keys().map(String::as_str))
            .collect();
        let mut out = String::from(
            "scene,scene_hash,width,height,frames,method,photons,bounces,radius_scale,r_max,\
             subsample,caustic_share,upsample,accumulate,density,frame_ms,gpu_ms,cpu_ms,rel_mse,rel_mse_direct,\
             rel_mse_indirect,flip,stored_photons,pareto",
        );
        for s in &stages {
            out += &format!(",ms.{s}");
        }
        out.push('\n');
        for r in &self.records {
            let (c, m) = (&r.config, &r.measurement);
            // Scene names are file paths or bundled names: quote them, doubling quotes.
            out += &format!(
                "\"{}\",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.6e},{:.6e},{:.6e},\
                 {:.6},{},{}",
                r.scene.replace('"', "\"\""),
                r.scene_hash,
                r.width,
                r.height,
                r.frames,
                c.method.name(),
                c.photons,
                c.bounces,
                c.radius_scale,
                m.r_max,
                c.subsample,
                c.caustic_share,
                match c.upsample {
                    crate::config::settings::Upsample::Joint => "joint",
                    crate::config::settings::Upsample::Bilinear => "bilinear",
                },
                c.accumulate,
                match c.density {
                    crate::config::settings::Density::Tiled => "tiled",
                    crate::config::settings::Density::Volumes | crate::config::settings::Density::Auto => "volumes",
                },
                m.frame_ms,
                m.gpu_ms,
                m.cpu_ms,
                m.rel_mse,
                m.rel_mse_direct,
                m.rel_mse_indirect,
                m.flip,
                m.stored_photons,
                r.pareto
            );
            for s in &stages {
                out.push(',');
                if let Some(ms) = m.stages.get(*s) {
                    out += &format!("{ms:.4}");
                }
            }
            out.push('\n');
        }
        out
    }
}

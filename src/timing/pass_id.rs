//! [`PassId`]: every stage of the frame by one name: each GPU pass (its timestamp scope and
//! debug label), the host's photon trace, and the viewer's overlay and present. The effects
//! plan lists passes by it, the stats JSON and `ispm bench`/`ispm sweep` key their times by
//! it, the trace names its spans by it: the name is written here only, so renaming a pass
//! cannot silently zero a stats column.
//!
//! This module depends on nothing, so every floor may use it (`gpu` for the overlay and
//! present scopes, `plan` for its pass list, `frame`, `stats`, `bench`, `sweep`).

use std::fmt;

/// A stage of the frame (module docs), in frame order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PassId {
    /// The light views' G-buffers (box A), one scope around every light's.
    LightGbuffers,
    /// One light's G-buffer, inside [`PassId::LightGbuffers`].
    LightGbuffer,
    BounceMap,
    /// The bounce map's copy to the host.
    Readback,
    /// The CPU photon trace (a host span, not a GPU scope).
    CpuTrace,
    /// The photon map's copy to the GPU.
    Upload,
    ShadowMaps,
    EyeGbuffer,
    Direct,
    PhotonVolumes,
    PhotonTiles,
    Support,
    Denoise,
    Upsample,
    /// The fine photons' full-resolution estimate at `--subsample N > 1`, added after the
    /// upsample (`render/photon_frame/estimate.rs`; the density estimator's pass, timed apart).
    FinePhotons,
    Composite,
    Environment,
    Translucent,
    Accumulate,
    Tonemap,
    ValueCheck,
    DebugView,
    Overlay,
    Present,
}

impl PassId {
    /// Every stage, in frame order.
    pub const ALL: [PassId; 24] = [
        PassId::LightGbuffers,
        PassId::LightGbuffer,
        PassId::BounceMap,
        PassId::Readback,
        PassId::CpuTrace,
        PassId::Upload,
        PassId::ShadowMaps,
        PassId::EyeGbuffer,
        PassId::Direct,
        PassId::PhotonVolumes,
        PassId::PhotonTiles,
        PassId::Support,
        PassId::Denoise,
        PassId::Upsample,
        PassId::FinePhotons,
        PassId::Composite,
        PassId::Environment,
        PassId::Translucent,
        PassId::Accumulate,
        PassId::Tonemap,
        PassId::ValueCheck,
        PassId::DebugView,
        PassId::Overlay,
        PassId::Present,
    ];

    /// The name: the GPU timestamp scope and debug label, the trace's span, the stats key.
    pub const fn name(self) -> &'static str {
        match self {
            PassId::LightGbuffers => "light_gbuffers",
            PassId::LightGbuffer => "light_gbuffer",
            PassId::BounceMap => "bounce_map",
            PassId::Readback => "readback",
            PassId::CpuTrace => "cpu_trace",
            PassId::Upload => "upload",
            PassId::ShadowMaps => "shadow_maps",
            PassId::EyeGbuffer => "eye_gbuffer",
            PassId::Direct => "direct",
            PassId::PhotonVolumes => "photon_volumes",
            PassId::PhotonTiles => "photon_tiles",
            PassId::Support => "support",
            PassId::Denoise => "denoise",
            PassId::Upsample => "upsample",
            PassId::FinePhotons => "fine_photons",
            PassId::Composite => "composite",
            PassId::Environment => "environment",
            PassId::Translucent => "translucent",
            PassId::Accumulate => "accumulate",
            PassId::Tonemap => "tonemap",
            PassId::ValueCheck => "value_check",
            PassId::DebugView => "debug_view",
            PassId::Overlay => "overlay",
            PassId::Present => "present",
        }
    }

    /// The stage named `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Reported in every frame's stats JSON (`ms.NAME`, 0 when it did not run): DESIGN.md §7's
    /// stages and the frame's other passes; not the scope nested in one of them, the
    /// debugging passes (`--check-values`, `--debug-view`) or the viewer's overlay and present.
    pub const fn in_stats(self) -> bool {
        !matches!(
            self,
            PassId::LightGbuffer
                | PassId::ValueCheck
                | PassId::DebugView
                | PassId::Overlay
                | PassId::Present
        )
    }

    /// Runs on the host (a CPU span), not on a GPU queue.
    pub const fn on_host(self) -> bool {
        matches!(self, PassId::CpuTrace)
    }

    /// Its key among `ispm bench`'s and `ispm sweep`'s stage times (`bench::stage_times`):
    /// `gpu.NAME`, or `cpu.NAME` for a host stage.
    pub fn stage_key(self) -> String {
        let unit = if self.on_host() { "cpu" } else { "gpu" };
        format!("{unit}.{}", self.name())
    }
}

impl fmt::Display for PassId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stage_has_one_distinct_name_that_round_trips_and_serialises_as_itself() {
        let mut names: Vec<&str> = PassId::ALL.iter().map(|p| p.name()).collect();
        for p in PassId::ALL {
            assert_eq!(PassId::from_name(p.name()), Some(p));
            assert_eq!(
                serde_json::to_value(p).expect("serialises"),
                serde_json::json!(p.name())
            );
            assert_eq!(p.to_string(), p.name());
        }
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), PassId::ALL.len(), "a name used twice");
        assert_eq!(PassId::from_name("frame"), None);
        assert_eq!(PassId::CpuTrace.stage_key(), "cpu.cpu_trace");
        assert_eq!(PassId::Upsample.stage_key(), "gpu.upsample");
    }

    #[test]
    fn all_lists_every_stage_once_in_declaration_order() {
        // `ALL` is written by hand: entry i must be the variant of discriminant i, and the last
        // variant's discriminant + 1 the count, so a variant left out or out of order fails here
        // (the exhaustive match in `name` already fails to compile without its name).
        for (i, p) in PassId::ALL.iter().enumerate() {
            assert_eq!(*p as usize, i, "{p:?}");
        }
        assert_eq!(PassId::ALL.len(), PassId::Present as usize + 1);
    }
}

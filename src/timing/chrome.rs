//! A [`Capture`] as Chrome Trace Event JSON (the JSON object format), which ui.perfetto.dev
//! and chrome://tracing open.
//!
//! One process (`ispm`, pid 1); one thread track per GPU queue (tid 1 + queue index, named
//! like `GPU graphics+compute+transfer queue`) and per CPU thread (tid 100 + n: `main`,
//! `trace worker 0`, …), named by `M` metadata events. Every span is an `X` (complete) event
//! with `ts`/`dur` in microseconds since the capture's first instant, a unique `id`, and its
//! frame, depth and queue role in `args`. `otherData` says which host clock and which GPU
//! clock mapping the times are on.

use super::{Capture, Span, Track};
use anyhow::Context;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

const PID: u32 = 1;
const FIRST_CPU_TID: u64 = 100;

impl Capture {
    /// The Chrome Trace Event JSON object of this capture.
    pub fn chrome_json(&self) -> Value {
        let origin = self
            .spans
            .iter()
            .map(|s| s.begin_ns)
            .chain([self.start_ns])
            .min()
            .unwrap_or(0);
        let us = |ns: u64| ns.saturating_sub(origin) as f64 / 1000.0;

        let tracks = self.tracks();
        let mut events = vec![json!({
            "ph": "M", "pid": PID, "name": "process_name", "args": { "name": "ispm" }
        })];
        for (sort_index, (tid, name)) in tracks.values().enumerate() {
            events.push(json!({
                "ph": "M", "pid": PID, "tid": tid, "name": "thread_name",
                "args": { "name": name }
            }));
            events.push(json!({
                "ph": "M", "pid": PID, "tid": tid, "name": "thread_sort_index",
                "args": { "sort_index": sort_index }
            }));
        }

        let mut spans: Vec<(u64, &Span)> = self
            .spans
            .iter()
            .map(|s| (tracks[&TrackKey::of(&s.track)].0, s))
            .collect();
        // Parents before children: earlier start, then longer, then shallower.
        spans.sort_by_key(|(tid, s)| (s.begin_ns, std::cmp::Reverse(s.end_ns), s.depth, *tid));
        for (id, (tid, s)) in spans.into_iter().enumerate() {
            let mut args = json!({ "depth": s.depth });
            if let Some(f) = s.frame {
                args["frame"] = json!(f);
            }
            if let Track::Gpu { role, .. } = &s.track {
                args["queue_role"] = json!(role.name());
            }
            events.push(json!({
                "ph": "X",
                "pid": PID,
                "tid": tid,
                "id": id + 1,
                "name": s.name,
                "cat": if s.is_gpu() { "gpu" } else { "cpu" },
                "ts": us(s.begin_ns),
                "dur": s.end_ns.saturating_sub(s.begin_ns) as f64 / 1000.0,
                "args": args,
            }));
        }

        let mut other = json!({
            "host_clock": host_clock_name(),
            "origin_host_ns": origin,
        });
        if let Some(clock) = &self.clock {
            other["gpu_clock_mapping"] = json!(clock.method);
            other["gpu_clock_uncertainty_ns"] = json!(clock.uncertainty_ns);
        }
        json!({
            "traceEvents": events,
            "displayTimeUnit": "ms",
            "otherData": other,
        })
    }

    /// Writes [`Capture::chrome_json`] to `path` atomically.
    pub fn write_chrome(&self, path: &Path) -> anyhow::Result<()> {
        let json = self.chrome_json();
        crate::output::write_atomically(path, |f| {
            let mut w = std::io::BufWriter::new(f);
            serde_json::to_writer(&mut w, &json)
                .map_err(anyhow::Error::from)
                .and_then(|()| Ok(w.flush()?))
                .with_context(|| format!("{}: cannot write the trace", path.display()))
        })
    }

    /// Every track with its tid and name, GPU queues first, then CPU threads in the order
    /// they first recorded (`main` first).
    fn tracks(&self) -> BTreeMap<TrackKey, (u64, String)> {
        let mut tracks = BTreeMap::new();
        for s in &self.spans {
            let key = TrackKey::of(&s.track);
            let entry = match &s.track {
                Track::Gpu { queue, role } => {
                    let name = self.gpu_queues.get(queue).cloned();
                    (
                        1 + *queue as u64,
                        name.unwrap_or(format!("GPU {} queue", role.name())),
                    )
                }
                Track::Cpu { thread, name } => (FIRST_CPU_TID + thread, name.to_string()),
            };
            tracks.insert(key, entry);
        }
        tracks
    }
}

/// Tracks in display order: GPU queues by index, then `main`, then other threads in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum TrackKey {
    Gpu(usize),
    Main(u64),
    Cpu(u64),
}

impl TrackKey {
    fn of(track: &Track) -> TrackKey {
        match track {
            Track::Gpu { queue, .. } => TrackKey::Gpu(*queue),
            Track::Cpu { thread, name } if &**name == "main" => TrackKey::Main(*thread),
            Track::Cpu { thread, .. } => TrackKey::Cpu(*thread),
        }
    }
}

fn host_clock_name() -> &'static str {
    if cfg!(unix) {
        "CLOCK_MONOTONIC"
    } else {
        "std::time::Instant"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timing::QueueRole;

    fn span(name: &str, track: Track, depth: u32, begin_ns: u64, end_ns: u64) -> Span {
        Span {
            name: name.into(),
            track,
            frame: Some(3),
            depth,
            begin_ns,
            end_ns,
        }
    }

    #[test]
    fn chrome_json_names_tracks_and_orders_parents_before_children() {
        let gpu = Track::Gpu {
            queue: 0,
            role: QueueRole::Graphics,
        };
        let worker = Track::Cpu {
            thread: 5,
            name: "trace worker 0".into(),
        };
        let main = Track::Cpu {
            thread: 9,
            name: "main".into(),
        };
        let capture = Capture {
            spans: vec![
                span("direct", gpu.clone(), 1, 2_000, 3_000),
                span("frame", gpu.clone(), 0, 2_000, 9_000),
                span("trace_chunk", worker, 0, 1_500, 1_800),
                span("frame", main, 0, 1_000, 10_000),
            ],
            gpu_queues: [(0, "GPU graphics queue".to_string())].into(),
            clock: None,
            start_ns: 1_000,
            end_ns: 11_000,
        };
        let json = capture.chrome_json();
        let events = json["traceEvents"].as_array().expect("events");
        let names: BTreeMap<u64, &str> = events
            .iter()
            .filter(|e| e["ph"] == "M" && e["name"] == "thread_name")
            .map(|e| {
                (
                    e["tid"].as_u64().expect("tid"),
                    e["args"]["name"].as_str().expect("n"),
                )
            })
            .collect();
        assert_eq!(
            names,
            [
                (1, "GPU graphics queue"),
                (105, "trace worker 0"),
                (109, "main")
            ]
            .into()
        );
        let sort = |tid: u64| {
            events
                .iter()
                .find(|e| e["name"] == "thread_sort_index" && e["tid"] == tid)
                .map(|e| e["args"]["sort_index"].as_u64())
        };
        assert_eq!(
            (sort(1), sort(109), sort(105)),
            (Some(Some(0)), Some(Some(1)), Some(Some(2)))
        );
        let xs: Vec<(&str, u64, f64, f64)> = events
            .iter()
            .filter(|e| e["ph"] == "X")
            .map(|e| {
                (
                    e["name"].as_str().expect("name"),
                    e["tid"].as_u64().expect("tid"),
                    e["ts"].as_f64().expect("ts"),
                    e["dur"].as_f64().expect("dur"),
                )
            })
            .collect();
        assert_eq!(
            xs,
            [
                ("frame", 109, 0.0, 9.0),
                ("trace_chunk", 105, 0.5, 0.3),
                ("frame", 1, 1.0, 7.0),
                ("direct", 1, 1.0, 1.0),
            ]
        );
        let ids: Vec<u64> = events.iter().filter_map(|e| e["id"].as_u64()).collect();
        assert_eq!(ids, [1, 2, 3, 4]);
        assert!(events
            .iter()
            .filter(|e| e["ph"] == "X")
            .all(|e| e["args"]["frame"] == 3));
    }
}

//! Spans of work on one host clock: the recorder behind `--trace` (and the stage times of
//! `--stats`).
//!
//! # The host clock
//! Every span, CPU or GPU, is in nanoseconds of one clock, [`now_ns`]: `CLOCK_MONOTONIC` read
//! through `clock_gettime` (on Linux the clock `std::time::Instant` reads, and the one Mesa's
//! lavapipe stamps its timestamp queries with). `gpu/clock.rs` puts GPU timestamp ticks on it.
//!
//! # CPU spans
//! [`span`] returns a guard that, when dropped while a capture runs, records `[begin, end)` on
//! the calling thread's track: the thread's name (`main`), or `trace worker i` for rayon's
//! worker `i`. Spans on one thread nest (guards drop in reverse order) and carry their depth.
//! Outside a capture a span costs two clock reads and an atomic load; [`SpanGuard::finish`]
//! gives its length either way, so a stage time and its trace span are one measurement.
//!
//! # Frames
//! [`frame`] opens the span `frame` and makes `index` the thread's current frame until it
//! drops; spans opened on that thread meanwhile carry it. Work handed to other threads takes
//! the frame along with [`span_in`] and [`current_frame`] (as `photon/trace.rs` does).
//!
//! # Capture
//! One capture per process at a time: [`start_capture`] … [`finish_capture`] gives the
//! [`Capture`]: the CPU spans, the GPU spans that `gpu::Timestamps::read` adds with
//! [`record_gpu`], the GPU tracks' names and how their clock was mapped. `chrome.rs` writes it
//! as Chrome Trace Event JSON.
//!
//! # Names
//! [`pass_id::PassId`] names every stage of the frame once: the GPU scopes, the stats JSON's
//! stages, the plan's pass list, the sweep's and the bench's columns all take it from there.

mod chrome;
mod clock;
pub mod pass_id;

pub use clock::now_ns;
#[cfg(any(target_os = "linux", target_os = "android"))]
pub use clock::raw_now_ns;

use std::cell::{Cell, OnceCell};
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// What a GPU queue is used for: a GPU track's role (`gpu` re-exports it, its home floor
/// being this one, which `gpu` records into).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum QueueRole {
    Graphics,
    Compute,
    Transfer,
}

impl QueueRole {
    pub const ALL: [QueueRole; 3] = [QueueRole::Graphics, QueueRole::Compute, QueueRole::Transfer];

    pub fn name(self) -> &'static str {
        match self {
            QueueRole::Graphics => "graphics",
            QueueRole::Compute => "compute",
            QueueRole::Transfer => "transfer",
        }
    }
}

/// Where a span ran.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Track {
    /// A device queue: its index among the distinct queues the `Gpu` uses, and the role the
    /// recording was made for (several roles may share one queue).
    Gpu { queue: usize, role: QueueRole },
    /// A CPU thread: a number unique in the process, and its name.
    Cpu { thread: u64, name: Arc<str> },
}

/// One timed piece of work, on the host clock.
#[derive(Clone, Debug, PartialEq)]
pub struct Span {
    pub name: String,
    pub track: Track,
    /// The frame the work belongs to, where known.
    pub frame: Option<u64>,
    /// Spans open around it on the same track (the same command buffer, for GPU spans).
    pub depth: u32,
    /// Host-clock nanoseconds ([`now_ns`]).
    pub begin_ns: u64,
    pub end_ns: u64,
}

impl Span {
    pub fn ms(&self) -> f64 {
        self.end_ns.saturating_sub(self.begin_ns) as f64 * 1e-6
    }

    pub fn is_gpu(&self) -> bool {
        matches!(self.track, Track::Gpu { .. })
    }
}

/// How GPU timestamps were put on the host clock.
#[derive(Clone, Debug, PartialEq)]
pub struct ClockNote {
    /// E.g. `VK_EXT_calibrated_timestamps (CLOCK_MONOTONIC)` or `measured offset`.
    pub method: String,
    /// The largest uncertainty of the mappings used, in nanoseconds.
    pub uncertainty_ns: u64,
}

/// What one capture recorded.
#[derive(Clone, Debug, Default)]
pub struct Capture {
    pub spans: Vec<Span>,
    /// Track names of the GPU queues, by queue index.
    pub gpu_queues: BTreeMap<usize, String>,
    pub clock: Option<ClockNote>,
    pub start_ns: u64,
    pub end_ns: u64,
}

impl Capture {
    /// The spans of frame `index`.
    pub fn frame(&self, index: u64) -> impl Iterator<Item = &Span> {
        self.spans.iter().filter(move |s| s.frame == Some(index))
    }
}

static CAPTURING: AtomicBool = AtomicBool::new(false);
static CAPTURE: Mutex<Option<Capture>> = Mutex::new(None);
static NEXT_THREAD: AtomicU64 = AtomicU64::new(0);

fn capture() -> MutexGuard<'static, Option<Capture>> {
    CAPTURE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Starts recording spans (dropping anything a previous capture left unfinished).
pub fn start_capture() {
    *capture() = Some(Capture {
        start_ns: now_ns(),
        ..Default::default()
    });
    CAPTURING.store(true, Ordering::Release);
}

/// Stops recording and returns what was recorded (empty when no capture was running).
pub fn finish_capture() -> Capture {
    CAPTURING.store(false, Ordering::Release);
    let mut c = capture().take().unwrap_or_default();
    c.end_ns = now_ns();
    c
}

/// Whether a capture is running.
pub fn capturing() -> bool {
    CAPTURING.load(Ordering::Relaxed)
}

/// Adds GPU spans (already on the host clock) to the running capture, with the names of the
/// queue tracks they use and the clock mapping that placed them.
pub fn record_gpu(spans: Vec<Span>, queues: Vec<(usize, String)>, clock: ClockNote) {
    if !capturing() {
        return;
    }
    if let Some(c) = capture().as_mut() {
        c.spans.extend(spans);
        c.gpu_queues.extend(queues);
        match &mut c.clock {
            Some(note) if note.method == clock.method => {
                note.uncertainty_ns = note.uncertainty_ns.max(clock.uncertainty_ns)
            }
            Some(note) => {
                note.method = format!("{}; {}", note.method, clock.method);
                note.uncertainty_ns = note.uncertainty_ns.max(clock.uncertainty_ns);
            }
            None => c.clock = Some(clock),
        }
    }
}

fn record(span: Span) {
    if let Some(c) = capture().as_mut() {
        c.spans.push(span);
    }
}

struct ThreadState {
    depth: Cell<u32>,
    frame: Cell<Option<u64>>,
    track: OnceCell<Track>,
}

thread_local! {
    static THREAD: ThreadState = const {
        ThreadState {
            depth: Cell::new(0),
            frame: Cell::new(None),
            track: OnceCell::new(),
        }
    };
}

fn thread_track(state: &ThreadState) -> Track {
    state
        .track
        .get_or_init(|| {
            let name = match rayon::current_thread_index() {
                Some(i) => format!("trace worker {i}"),
                None => match std::thread::current().name() {
                    Some(n) => n.to_string(),
                    None => format!("{:?}", std::thread::current().id()),
                },
            };
            Track::Cpu {
                thread: NEXT_THREAD.fetch_add(1, Ordering::Relaxed),
                name: name.into(),
            }
        })
        .clone()
}

/// The current thread's frame (set by [`frame`]).
pub fn current_frame() -> Option<u64> {
    THREAD.with(|t| t.frame.get())
}

/// An open CPU span; records itself when dropped (or [`finish`](SpanGuard::finish)ed).
/// Not `Send`: it belongs to the thread whose track and depth it took.
#[must_use = "a span ends when its guard drops"]
pub struct SpanGuard {
    name: &'static str,
    frame: Option<u64>,
    depth: u32,
    begin_ns: u64,
    /// The thread's frame before [`frame`] set it, restored at the end.
    restore_frame: Option<Option<u64>>,
    closed: bool,
    _not_send: PhantomData<*const ()>,
}

/// Opens a span on this thread, in its current frame.
pub fn span(name: &'static str) -> SpanGuard {
    span_in(name, current_frame())
}

/// Opens a span on this thread, in `frame`.
pub fn span_in(name: &'static str, frame: Option<u64>) -> SpanGuard {
    let depth = THREAD.with(|t| {
        let d = t.depth.get();
        t.depth.set(d + 1);
        d
    });
    SpanGuard {
        name,
        frame,
        depth,
        begin_ns: now_ns(),
        restore_frame: None,
        closed: false,
        _not_send: PhantomData,
    }
}

/// Opens the span `frame` of frame `index`, which is this thread's current frame until the
/// guard ends.
pub fn frame(index: u64) -> SpanGuard {
    let previous = THREAD.with(|t| t.frame.replace(Some(index)));
    let mut guard = span_in("frame", Some(index));
    guard.restore_frame = Some(previous);
    guard
}

/// Runs `f` inside a span named `name`.
pub fn timed<T>(name: &'static str, f: impl FnOnce() -> T) -> T {
    let _span = span(name);
    f()
}

impl SpanGuard {
    /// Ends the span now; returns its length in milliseconds.
    pub fn finish(mut self) -> f64 {
        let end = self.close();
        end.saturating_sub(self.begin_ns) as f64 * 1e-6
    }

    fn close(&mut self) -> u64 {
        let end_ns = now_ns();
        self.closed = true;
        THREAD.with(|t| {
            t.depth.set(t.depth.get().saturating_sub(1));
            if let Some(previous) = self.restore_frame {
                t.frame.set(previous);
            }
            if capturing() {
                record(Span {
                    name: self.name.to_string(),
                    track: thread_track(t),
                    frame: self.frame,
                    depth: self.depth,
                    begin_ns: self.begin_ns,
                    end_ns,
                });
            }
        });
        end_ns
    }
}

impl Drop for SpanGuard {
    fn drop(&mut self) {
        if !self.closed {
            self.close();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The only unit test that captures (captures are process-wide); it keeps to its own
    /// thread's track, since other tests' threads may record meanwhile.
    #[test]
    fn cpu_spans_nest_carry_their_frame_and_depth_and_cross_threads_with_span_in() {
        start_capture();
        let outer = frame(7);
        let ms = {
            let inner = span("inner");
            std::thread::sleep(std::time::Duration::from_millis(2));
            inner.finish()
        };
        let handed = current_frame();
        let worker = std::thread::Builder::new()
            .name("helper".into())
            .spawn(move || {
                let _s = span_in("helper work", handed);
            })
            .expect("spawn")
            .join();
        assert!(worker.is_ok());
        drop(outer);
        let after = span("after");
        drop(after);
        let c = finish_capture();
        assert!(ms >= 2.0, "{ms} ms");
        let here = thread_track_here();
        let mine: Vec<&Span> = c.spans.iter().filter(|s| s.track == here).collect();
        let find = |name: &str| {
            *mine
                .iter()
                .find(|s| s.name == name)
                .unwrap_or_else(|| panic!("{name} missing from {mine:?}"))
        };
        let (f, inner, after) = (find("frame"), find("inner"), find("after"));
        assert_eq!((f.depth, inner.depth, after.depth), (0, 1, 0));
        assert_eq!(
            (f.frame, inner.frame, after.frame),
            (Some(7), Some(7), None)
        );
        assert!(f.begin_ns <= inner.begin_ns && inner.end_ns <= f.end_ns);
        assert!(f.end_ns <= after.begin_ns);
        assert!((inner.ms() - ms).abs() < 1e-9);
        let helper = c
            .spans
            .iter()
            .find(|s| s.name == "helper work")
            .expect("the helper thread's span");
        assert_eq!(helper.frame, Some(7));
        assert!(matches!(&helper.track, Track::Cpu { name, .. } if &**name == "helper"));
        assert!(c.start_ns <= f.begin_ns && after.end_ns <= c.end_ns);
    }

    fn thread_track_here() -> Track {
        THREAD.with(thread_track)
    }

    #[test]
    fn spans_outside_a_capture_still_measure_and_keep_depth_balanced() {
        let before = THREAD.with(|t| t.depth.get());
        let s = span_in("not recorded", None);
        assert_eq!(THREAD.with(|t| t.depth.get()), before + 1);
        assert!(s.finish() >= 0.0);
        assert_eq!(THREAD.with(|t| t.depth.get()), before);
    }
}

#!/usr/bin/env python3
"""Derives the `--quality` presets (src/config/quality.rs, docs/accuracy.md §5.3) from the sweep's CSVs.

For every ISPM configuration of the main grid measured on every scene (joint upsampling, the
default bounces and caustic share), it takes the geometric mean over the scenes of the frame
time (for `accumulate` N > 1: the wall time to the mean of N frames) and of the relMSE divided
by that scene's best ISPM relMSE, keeps the configurations no other beats in both (the
aggregate Pareto front; printed with the accumulated configurations, then of single frames
alone), and picks four points of the single frames' front (a preset sets per-frame knobs;
`render` accumulates for its --seconds or --frames whatever the preset): `draft` the fastest, `reference` the most
accurate, `interactive` and `high` the front points nearest to one third and two thirds of the
way from draft to reference in log error (evenly spaced in quality: the front is nearly flat in
error past its middle, where points spaced in time would cost more for nothing). Prints the front and the presets as Markdown.

    python3 docs/tools/presets.py docs/images/sweep-*.csv
"""
import csv
import math
import sys
from collections import defaultdict

KEY = ("photons", "radius_scale", "subsample", "accumulate", "density")
# Columns older CSVs lack, as they were: one frame, the photon volumes.
DEFAULTS = {"accumulate": "1", "density": "volumes"}


def read(paths):
    rows = []
    for p in paths:
        with open(p, newline="") as f:
            rows += list(csv.DictReader(f))
    return rows


def main(paths):
    rows = read(paths)
    ispm = [r for r in rows if r["method"] == "ispm"]
    default_bounces = max(int(r["bounces"]) for r in ispm)
    default_share = max(
        (r["caustic_share"] for r in ispm), key=lambda s: sum(1 for r in ispm if r["caustic_share"] == s))
    main_grid = [r for r in ispm if r["upsample"] == "joint" and int(r["bounces"]) == default_bounces
                 and r["caustic_share"] == default_share]
    scenes = sorted({r["scene"] for r in rows})
    best = {s: min(float(r["rel_mse"]) for r in ispm if r["scene"] == s) for s in scenes}
    by_key = defaultdict(dict)
    for r in main_grid:
        by_key[tuple(r.get(k, DEFAULTS.get(k, "1")) for k in KEY)][r["scene"]] = r
    points = []
    for key, per in by_key.items():
        if set(per) != set(scenes):
            continue
        t = math.exp(sum(math.log(float(per[s]["frame_ms"])) for s in scenes) / len(scenes))
        e = math.exp(sum(math.log(float(per[s]["rel_mse"]) / best[s]) for s in scenes) / len(scenes))
        points.append((t, e, key, per))
    dominated = lambda p, pool: any(q[0] <= p[0] and q[1] <= p[1] and (q[0], q[1]) != (p[0], p[1])
                                    for q in pool)
    label = lambda k: f"{int(k[0]) // 1000}k, r×{float(k[1]):g}, N {k[2]}, {k[3]} frame(s), {k[4]}"
    # The aggregate front of every configuration, accumulated ones included (they show what
    # the frames buy); the presets are points of the front of single frames, since a preset
    # sets per-frame knobs and `render` accumulates them for its own --seconds/--frames.
    everything = sorted(p for p in points if not dominated(p, points))
    print(f"{len(points)} configurations on all of {', '.join(scenes)}; aggregate front:\n")
    print("| configuration | time (geo. mean) | relMSE / best (geo. mean) |")
    print("|---|---|---|")
    for t, e, k, _ in everything:
        print(f"| {label(k)} | {t:.1f} ms | {e:.2f}× |")
    single = [p for p in points if p[2][3] == "1"]
    front = sorted(p for p in single if not dominated(p, single))
    print("\nFront of single frames:\n")
    print("| configuration | time (geo. mean) | relMSE / best (geo. mean) |")
    print("|---|---|---|")
    for t, e, k, _ in front:
        print(f"| {label(k)} | {t:.1f} ms | {e:.2f}× |")
    draft, reference = front[0], front[-1]
    # Evenly spaced in error, not in time: past its middle the single-frame front is nearly flat in
    # error (more photons buy little), so points spaced in time would cost more for nothing.
    lo, hi = math.log(draft[1]), math.log(reference[1])
    # Four distinct points where the front has them: the middle two from the points between.
    inner = front[1:-1]
    pick = lambda f, pool: min(pool, key=lambda p: abs(math.log(p[1]) - (lo + f * (hi - lo))))
    interactive = pick(1 / 3, inner) if inner else draft
    rest = [p for p in inner if p is not interactive]
    high = pick(2 / 3, rest) if rest else interactive
    interactive, high = sorted([interactive, high], key=lambda p: p[0])
    presets = [("draft", draft), ("interactive", interactive), ("high", high),
               ("reference", reference)]
    print("\n| preset | aggregate | " + " | ".join(scenes) + " |")
    print("|---|---|" + "---|" * len(scenes))
    for name, (t, e, k, per) in presets:
        cells = [f"{float(per[s]['frame_ms']):.0f} ms, {float(per[s]['rel_mse']):.4f} / "
                 f"{float(per[s]['rel_mse_indirect']):.3f} / {float(per[s]['flip']):.3f}"
                 + (" ★" if per[s]["pareto"] == "true" else "") for s in scenes]
        print(f"| `{name}` ({label(k)}) | {t:.0f} ms, {e:.2f}× | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])

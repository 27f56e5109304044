#!/usr/bin/env python3
"""ISPM against the CPU photon-gather baseline at equal error (issue #20's headline ratio), from
the sweep's CSVs (docs/sweep.sh; docs/performance.md, "ISPM against photon-gather at equal
error").

Per scene, for each ISPM configuration on that scene's ISPM front (frame time against relMSE,
single frames and accumulations alike), the time the photon-gather baseline needs for the same
relMSE: log-log interpolation between its measured photon counts (10k, 40k, 160k), or ">"/"<"
"not reached" where the error is below its most accurate point (it may need far more photons:
its k-d tree gather has no caustic views, so on a focused caustic its error can even grow with
photons), "<" its fastest point where that point is already as accurate. The ratio is that time
over ISPM's (above 1: ISPM is faster at equal error). Both ran in the same `ispm sweep` process, one
after the other, on the same cores.

    python3 docs/tools/headline.py docs/images/sweep-*.csv
"""
import csv
import math
import sys


def front(points):
    """The (time, error) points no other beats in both, by time."""
    out = []
    for p in sorted(points):
        if not out or p[1] < out[-1][1]:
            out.append(p)
    return out


def gather_time(gather, err):
    """Time the baseline needs for relMSE `err` and how it was found ("=" interpolated, ">" never
    reached, "<" reached by its fastest point already).

    `gather`: (time, error) by photon count; error falls with time between consecutive points
    where the interpolation is used."""
    pts = sorted(gather)
    fastest = pts[0]
    if fastest[1] <= err:
        return fastest[0], "<"  # reached by its fastest point already: less than that
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        # Only where the error falls with time (more photons can make it grow: glass-sphere).
        if e1 < e0 and e1 <= err <= e0:
            f = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), "="
    best = min(pts, key=lambda p: p[1])
    if err < best[1]:
        return best[0], ">"  # never reached: more than its most accurate point's time
    # Reached by a slower point only after the error rose and fell: its first such time.
    return min(t for t, e in pts if e <= err), "="


def main(paths):
    rows = []
    for p in paths:
        with open(p, newline="") as f:
            rows += list(csv.DictReader(f))
    print("| scene | ISPM configuration | ISPM time | relMSE | photon-gather time at that relMSE | ratio |")
    print("|---|---|---:|---:|---:|---:|")
    for scene in sorted({r["scene"] for r in rows}):
        mine = [r for r in rows if r["scene"] == scene]
        ispm = [(float(r["frame_ms"]), float(r["rel_mse"]), r) for r in mine if r["method"] == "ispm"]
        gather = [(float(r["frame_ms"]), float(r["rel_mse"])) for r in mine
                  if r["method"] == "photon-gather"]
        if not gather:
            continue
        for t, e in front([(t, e) for t, e, _ in ispm]):
            r = next(r for tt, ee, r in ispm if (tt, ee) == (t, e))
            g, how = gather_time(gather, e)
            label = (f"{int(r['photons']) // 1000}k, r×{float(r['radius_scale']):g}, "
                     f"N {r['subsample']}, {r.get('accumulate', '1')} frame(s)")
            if how == ">":
                best = min(gather, key=lambda p: p[1])
                print(f"| {scene} | {label} | {t:.0f} ms | {e:.4f} | not reached (best "
                      f"{best[1]:.4f} in {best[0]:.0f} ms) | — |")
                continue
            sign = "< " if how == "<" else ""
            print(f"| {scene} | {label} | {t:.0f} ms | {e:.4f} | {sign}{g:.0f} ms | {sign}{g / t:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1:])

#!/usr/bin/env python3
"""Derives the `--quality` presets (src/quality.rs, docs/accuracy.md §5.3) from the sweep's CSVs.

For every ISPM configuration of the main grid measured on every scene (joint upsampling, the
default bounces and caustic share), it takes the geometric mean over the scenes of the frame
time (for `accumulate` N > 1: the wall time to the mean of N frames) and of the relMSE divided
by that scene's best ISPM relMSE, keeps the configurations no other beats in both (the
aggregate Pareto front), and picks four points of it: `draft` the fastest, `reference` the most
accurate, `interactive` and `high` the front points nearest to one third and two thirds of the
way from draft to reference in log time. Prints the front and the presets as Markdown.

    python3 docs/tools/presets.py docs/images/sweep-*.csv
"""
import csv
import math
import sys
from collections import defaultdict

KEY = ("photons", "radius_scale", "subsample", "accumulate")


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
        by_key[tuple(r.get(k, "1") for k in KEY)][r["scene"]] = r
    points = []
    for key, per in by_key.items():
        if set(per) != set(scenes):
            continue
        t = math.exp(sum(math.log(float(per[s]["frame_ms"])) for s in scenes) / len(scenes))
        e = math.exp(sum(math.log(float(per[s]["rel_mse"]) / best[s]) for s in scenes) / len(scenes))
        points.append((t, e, key, per))
    front = sorted(p for p in points
                   if not any(q[0] <= p[0] and q[1] <= p[1] and (q[0], q[1]) != (p[0], p[1])
                              for q in points))
    label = lambda k: f"{int(k[0]) // 1000}k, r×{float(k[1]):g}, N {k[2]}, {k[3]} frame(s)"
    print(f"{len(points)} configurations on all of {', '.join(scenes)}; aggregate front:\n")
    print("| configuration | time (geo. mean) | relMSE / best (geo. mean) |")
    print("|---|---|---|")
    for t, e, k, _ in front:
        print(f"| {label(k)} | {t:.1f} ms | {e:.2f}× |")
    draft, reference = front[0], front[-1]
    lo, hi = math.log(draft[0]), math.log(reference[0])
    pick = lambda f: min(front, key=lambda p: abs(math.log(p[0]) - (lo + f * (hi - lo))))
    presets = [("draft", draft), ("interactive", pick(1 / 3)), ("high", pick(2 / 3)),
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

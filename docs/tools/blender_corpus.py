#!/usr/bin/env python3
"""Writes a corpus of glTF files with Blender's own exporter and renders each with ispm.

The files are the kinds a Blender user exports: the default startup scene with and without its
light, sun, spot and area lights (the exporter drops area lights), emission-only scenes (an
emissive panel, an emission-textured screen), textured, metallic and glass materials, linked
duplicates, an animated object, a scene with no camera and one with no mesh. Each is rendered
at 96x72 with `--method ispm` (the default) twice: as the renderer does now, and with
`--no-default-light --emitter-lights 0`, which is what it did before emitters became lights and
lightless files got a default light. A render counts as lit when its mean sRGB value is above 2
of 255. Usage (needs the `bpy` wheel: `pip install bpy==4.2.0` in a Python 3.11 venv):

    python docs/tools/blender_corpus.py OUT_DIR [--ispm target/release/ispm]

It prints a Markdown table (docs/scenes.md, "Files from Blender").
"""

import argparse
import os
import subprocess
import sys

import bpy


def reset(startup=False):
    if startup:
        bpy.ops.wm.read_factory_settings()
    else:
        bpy.ops.wm.read_factory_settings(use_empty=True)


def camera(location=(7.36, -6.93, 4.96), rotation=(1.109, 0.0, 0.815)):
    bpy.ops.object.camera_add(location=location, rotation=rotation)
    bpy.context.scene.camera = bpy.context.object


def principled(name, color=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, transmission=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*color, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    p.inputs["Transmission Weight"].default_value = transmission
    return m


def emissive(name, color=(1.0, 0.9, 0.8), strength=10.0, texture=False):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    p.inputs["Emission Color"].default_value = (*color, 1.0)
    p.inputs["Emission Strength"].default_value = strength
    if texture:
        image = checker("screen")
        node = m.node_tree.nodes.new("ShaderNodeTexImage")
        node.image = image
        m.node_tree.links.new(node.outputs["Color"], p.inputs["Emission Color"])
    return m


def checker(name, size=16):
    image = bpy.data.images.new(name, size, size)
    pixels = []
    for y in range(size):
        for x in range(size):
            v = 0.9 if (x // 4 + y // 4) % 2 == 0 else 0.1
            pixels += [v, v * 0.8, v * 0.6, 1.0]
    image.pixels = pixels
    image.pack()
    return image


def textured(name):
    m = principled(name)
    node = m.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = checker(name + "-checker")
    p = m.node_tree.nodes["Principled BSDF"]
    m.node_tree.links.new(node.outputs["Color"], p.inputs["Base Color"])
    return m


def floor(material=None):
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, -1))
    if material:
        bpy.context.object.data.materials.append(material)


def room(material):
    """A closed box the camera sits inside (normals facing in)."""
    bpy.ops.mesh.primitive_cube_add(size=6, location=(0, 0, 2))
    box = bpy.context.object
    box.data.materials.append(material)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode="OBJECT")
    return box


def cube(material=None, location=(0, 0, 0)):
    bpy.ops.mesh.primitive_cube_add(location=location)
    if material:
        bpy.context.object.data.materials.append(material)
    return bpy.context.object


def light(kind, energy, location=(4.08, 1.0, 5.9), rotation=(0.65, 0.05, 1.87)):
    bpy.ops.object.light_add(type=kind, location=location, rotation=rotation)
    bpy.context.object.data.energy = energy


def inside_camera():
    camera(location=(0, -2.5, 2.0), rotation=(1.45, 0.0, 0.0))


CASES = {}


def case(fn):
    CASES[fn.__name__] = fn
    return fn


@case
def default_startup_exporter_defaults():
    reset(startup=True)
    return {"export_cameras": False, "export_lights": False}


@case
def default_startup_with_light_no_camera():
    reset(startup=True)
    return {"export_cameras": False}


@case
def default_startup_with_camera_and_light():
    reset(startup=True)


@case
def sun():
    reset()
    camera()
    floor(principled("floor"))
    cube(principled("red", (0.8, 0.1, 0.1)))
    light("SUN", 3.0)


@case
def spot():
    reset()
    camera()
    floor(principled("floor"))
    cube(principled("grey"))
    light("SPOT", 1000.0)


@case
def area_light_dropped_by_the_exporter():
    reset()
    camera()
    floor(principled("floor"))
    cube(principled("grey"))
    light("AREA", 500.0)


@case
def emissive_panel_room():
    reset()
    room(principled("walls"))
    cube(principled("block", (0.5, 0.6, 0.8)), location=(0.8, 1.0, 0.0))
    bpy.ops.mesh.primitive_plane_add(size=1.5, location=(0, 0, 4.95), rotation=(3.14159, 0, 0))
    bpy.context.object.data.materials.append(emissive("panel", strength=20.0))
    inside_camera()


@case
def emission_textured_screen():
    reset()
    camera()
    floor(principled("floor"))
    bpy.ops.mesh.primitive_plane_add(size=2, location=(0, 0, 0.5), rotation=(1.3, 0, 0.8))
    bpy.context.object.data.materials.append(emissive("screen", strength=8.0, texture=True))


@case
def textured_no_lights():
    reset()
    camera()
    floor(textured("tiles"))
    cube(textured("crate"))


@case
def metal_and_glass_no_lights():
    reset()
    camera()
    floor(principled("floor"))
    cube(principled("gold", (1.0, 0.77, 0.34), metallic=1.0, roughness=0.2), (-1.2, 0, 0))
    bpy.ops.mesh.primitive_uv_sphere_add(location=(1.2, 0, 0))
    bpy.context.object.data.materials.append(principled("glass", transmission=1.0, roughness=0.0))


@case
def linked_duplicates():
    reset()
    camera()
    floor(principled("floor"))
    first = cube(principled("teal", (0.1, 0.6, 0.6)), location=(-2, 0, 0))
    for i in range(1, 4):
        dup = first.copy()  # shares the mesh: a glTF mesh instanced by several nodes
        dup.location = (-2 + 1.5 * i, 0, 0)
        bpy.context.collection.objects.link(dup)
    light("POINT", 800.0)


@case
def animated_cube():
    reset()
    camera()
    floor(principled("floor"))
    c = cube(principled("orange", (0.9, 0.4, 0.1)))
    c.keyframe_insert("location", frame=1)
    c.location = (0, 0, 2)
    c.keyframe_insert("location", frame=48)


@case
def no_camera():
    reset()
    floor(principled("floor"))
    cube(principled("grey"))


@case
def camera_and_light_only():
    reset()
    camera()
    light("POINT", 1000.0)


def export(path, options):
    # The exporter's defaults leave cameras and lights out; a user who set up a shot turns
    # them on, the startup scene keeps the defaults.
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        export_cameras=options.get("export_cameras", True),
        export_lights=options.get("export_lights", True),
    )


def mean_srgb(png):
    from PIL import Image

    im = Image.open(png).convert("RGB")
    px = list(im.getdata())
    return sum(sum(p) for p in px) / (3 * len(px))


def render(ispm, path, out, extra):
    env = dict(os.environ)
    env.setdefault("VK_DRIVER_FILES", "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json")
    env.setdefault("LP_NUM_THREADS", "2")
    cmd = [ispm, "render", path, "-o", out, "--size", "96x72", "--frames", "4", "--photons",
           "20000"] + extra
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        return None, r.stderr.strip().splitlines()[-1] if r.stderr.strip() else "failed"
    return mean_srgb(out), ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--ispm", default="target/release/ispm")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for name, build in CASES.items():
        options = build() or {}
        path = os.path.join(args.out, name + ".glb")
        export(path, options)
        now, err_now = render(args.ispm, path, os.path.join(args.out, name + ".png"), [])
        before, err_before = render(
            args.ispm,
            path,
            os.path.join(args.out, name + "-before.png"),
            ["--no-default-light", "--emitter-lights", "0"],
        )
        rows.append((name, before, now, err_now or err_before))
    lit = lambda v: v is not None and v > 2.0
    print("| file | before: mean sRGB | now: mean sRGB | lit before | lit now |")
    print("|---|---|---|---|---|")
    for name, before, now, err in rows:
        fmt = lambda v: "error" if v is None else f"{v:.1f}"
        note = f" ({err})" if err else ""
        print(f"| {name}{note} | {fmt(before)} | {fmt(now)} | {'yes' if lit(before) else 'no'} "
              f"| {'yes' if lit(now) else 'no'} |")
    print(f"\nlit before: {sum(lit(r[1]) for r in rows)} of {len(rows)}; "
          f"lit now: {sum(lit(r[2]) for r in rows)} of {len(rows)}")


if __name__ == "__main__":
    sys.exit(main())

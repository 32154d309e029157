"""Lightmaps at scale: time and peak memory of a bake with lightmaps on, per case and preset.

    nice -n 10 blender -b --factory-startup --python bench/lightmap_scale.py -- room [--presets draft]
    nice -n 10 blender -b --factory-startup --python bench/lightmap_scale.py -- boxes [--presets draft,default]

Cases, built in the script: `room`, a closed room with a box on its floor and a point lamp, the
room one object with a 4,096 x 4,096 lightmap (the box gets the size the add-on picks); `boxes`,
50 boxes on a floor, each box and the floor with a 512 x 512 lightmap. An existing image is
written at its own size, so the images are made before the bake. Prints and writes the solve's
time, the lightmaps' time (evaluating and writing the images), the texels covered and the
process's peak resident memory (ru_maxrss, which only grows: one case per run, and with several
presets the later rows' peak includes the earlier bakes'). Writes bench/results/lightmap_scale.csv
and .md (tables.py); rows of cases and presets not run this time are kept from the CSV.
"""
import os
import resource
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
from conftest import load_package  # noqa: E402  (the add-on from addon/, its engine from build/engine)
import tables  # noqa: E402

BOXES = 50


def peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024     # Linux reports KiB


def machine_mib():
    with open("/proc/meminfo") as f:
        return int(next(line for line in f if line.startswith("MemTotal")).split()[1]) // 1024


def material(name, rho):
    mat = bpy.data.materials.new(name)
    mat.diffuse_color = (rho, rho, rho, 1)
    mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (rho, rho, rho, 1)
    return mat


def box(name, centre, half, rho, inward=False):
    """An axis-aligned box of six quads; `inward` turns its faces to the inside (a room)."""
    cx, cy, cz = centre
    hx, hy, hz = half
    verts = [(cx + sx * hx, cy + sy * hy, cz + sz * hz) for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    if inward:
        me.flip_normals()
    me.materials.append(material(name, rho))
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def lamp(location, energy):
    ob = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    ob.data.energy = energy
    ob.location = location
    bpy.context.scene.collection.objects.link(ob)


def room():
    box("Room", (0, 0, 1.5), (3, 3, 1.5), 0.7, inward=True)
    box("Box", (0.5, -0.5, 0.5), (0.5, 0.5, 0.5), 0.5)
    lamp((-0.5, 0.5, 2.5), 300.0)
    return {"Room": 4096}


def boxes():
    box("Floor", (0, 0, -0.05), (8, 8, 0.05), 0.6)
    sizes = {"Floor": 512}
    for i in range(BOXES):
        name = f"Box{i:02d}"
        box(name, (-7 + 1.5 * (i % 10), -6 + 3 * (i // 10), 0.4), (0.4, 0.4, 0.4), 0.5)
        sizes[name] = 512
    lamp((0, 0, 6), 3000.0)
    return sizes


CASES = {"room": room, "boxes": boxes}


def measure(pkg, case, preset):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.world = None
    sizes = CASES[case]()
    for name, side in sizes.items():
        bpy.data.images.new(name + "_Radiosity", side, side, float_buffer=True)
    props = scene.radiosity
    props.preset = preset.upper()
    props.lightmaps = True
    timed = {"lightmaps": 0.0}
    still = pkg.lightmap_still.StillBake
    evaluate, commit = still.evaluate, still.commit

    def timing(method):
        def run(self, *args):
            start = time.perf_counter()
            try:
                return method(self, *args)
            finally:
                timed["lightmaps"] += time.perf_counter() - start
        return run

    still.evaluate, still.commit = timing(evaluate), timing(commit)
    try:
        start = time.perf_counter()
        assert bpy.ops.radiosity.bake() == {'FINISHED'}
        seconds = time.perf_counter() - start
    finally:
        still.evaluate, still.commit = evaluate, commit
    for name, side in sizes.items():
        assert tuple(bpy.data.images[name + "_Radiosity"].size) == (side, side)
    rasters = pkg.live_update.lightmap_state[scene.name].rasters
    row = dict(case=case, preset=preset, objects=len(scene.objects) - 1,
               lightmap=" + ".join(f"{n} of {s} x {s}" for s, n in sorted(
                   {s: sum(v == s for v in sizes.values()) for s in set(sizes.values())}.items(), reverse=True)),
               texels=sum(len(r.texel) for _, r in rasters.values()),
               solve_seconds=f"{props.last_seconds:.2f}", lightmap_seconds=f"{timed['lightmaps']:.2f}",
               bake_seconds=f"{seconds:.2f}", peak_mib=f"{peak_mib():.0f}", machine_mib=machine_mib())
    print(row, flush=True)
    return row



def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    case = argv[0] if argv and argv[0] in CASES else "room"
    presets = (argv[argv.index("--presets") + 1] if "--presets" in argv else "draft").split(",")
    pkg = load_package()
    pkg.register()
    rows = [measure(pkg, case, preset) for preset in presets]
    path = tables.path_for("lightmap_scale")
    rows = tables.kept_rows(path, rows, ("case", "preset"))
    tables.write(path, list(rows[0]), rows, "Lightmaps at scale: time and peak memory",
                 [("case", "case", None), ("preset", "preset", None), ("objects", "mesh objects", None),
                  ("lightmap", "lightmaps", None), ("texels", "texels covered", tables.count),
                  ("solve_seconds", "solve", tables.seconds), ("lightmap_seconds", "lightmaps", tables.seconds),
                  ("bake_seconds", "whole bake", tables.seconds), ("peak_mib", "peak memory (MiB)", None),
                  ("machine_mib", "machine memory (MiB)", None)],
                 "bench/lightmap_scale.py, under nice -n 10 on a shared 2-core machine. `room`: one room object "
                 "with a 4,096 x 4,096 lightmap, a box and a lamp in it; `boxes`: 50 boxes on a floor, each "
                 "mesh with a 512 x 512 lightmap. The solve is the engine's (last_seconds); the lightmaps "
                 "are their evaluation (rasterising, the engine's surface_radiance, footprint averaging, "
                 "padding) and writing the images. Peak memory is the Blender process's resident peak "
                 "(ru_maxrss) over the run; with several presets in one run a later row's peak includes the "
                 "earlier bakes'.")


if __name__ == "__main__":
    main()

"""Lightmaps of the sample scenes against Cycles' image bake, per preset.

    blender -b --factory-startup --python bench/lightmaps_vs_cycles.py [-- --presets default,high] [--scenes a,b]

For each sample scene of tests/cycles_reference/lightmap_reference.py (its Cycles references at
8,192 samples, about 0.7% noise; the animated room at frame 1) and each preset: the add-on bakes with lightmaps into
the reference's RadiosityUV maps and image sizes (lightmap_reference.open_with_reference), and the
relative RMS over the covered texels is measured, for the scene and per object. Writes
bench/results/lightmaps_vs_cycles.csv and .md (tables.py); rows of scenes and presets it did not
measure this time are kept from the CSV.
"""
import os
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
from conftest import load_package  # noqa: E402  (the add-on from addon/, its engine from build/engine)
import lightmap_reference  # noqa: E402
import reference  # noqa: E402
import tables  # noqa: E402


def measure(scene_name, frame, preset):
    ref = lightmap_reference.open_with_reference(scene_name, frame)
    props = bpy.context.scene.radiosity
    props.preset = preset.upper()
    props.lightmaps = True
    start, cpu = time.perf_counter(), time.process_time()
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    pairs = lightmap_reference.texel_pairs(ref)
    ours, cycles = (np.concatenate([p[k] for p in pairs.values()]) for k in (0, 1))
    row = dict(scene=scene_name + ("" if frame is None else f"@{frame}"), preset=preset, seconds=f"{seconds:.2f}",
               cpu=f"{cpu:.2f}", texels=len(ours), rms=f"{reference.relative_rms(ours, cycles):.5f}",
               objects=" ".join(f"{n} {100 * reference.relative_rms(*p):.2f}%" for n, p in pairs.items()))
    print(row, flush=True)
    return row



def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    presets = (argv[argv.index("--presets") + 1] if "--presets" in argv else "default,high").split(",")
    scenes = argv[argv.index("--scenes") + 1].split(",") if "--scenes" in argv else list(lightmap_reference.SAMPLE_SCENES)
    load_package().register()
    rows = [measure(name, lightmap_reference.SAMPLE_SCENES[name], preset) for name in scenes for preset in presets]
    path = tables.path_for("lightmaps_vs_cycles")
    rows = tables.kept_rows(path, rows, ("scene", "preset"))
    tables.write(path, list(rows[0]), rows, "Lightmaps against Cycles' image bake",
                 [("scene", "scene", None), ("preset", "preset", None), ("seconds", "bake with lightmaps", tables.seconds),
                  ("texels", "texels", tables.count), ("rms", "relative RMS", tables.percent),
                  ("objects", "per object", None)],
                 "Relative RMS over every texel Cycles baked (lightmap_reference.py, 8,192 samples, about 0.7% noise "
                 "of its own), shadow edges and feet included; the time is the whole bake (solve and lightmaps) on a "
                 "shared 2-core machine, and moves a lot with its load.")


if __name__ == "__main__":
    main()

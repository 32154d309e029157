"""The panel's time estimate against the bakes it estimates: every sample at every preset.

    blender -b --factory-startup --python bench/estimate.py -- [preset ...] [sample ...]

Draft, default and high on every sample unless named; a run that names any writes
bench/results/estimate_<names>.* instead (reference on the Cornell box alone: -- reference cornell_box).

For each sample, opened afresh: the estimate of every preset before any bake of it ("cold": the
machine's rates so far, the counts from the object bounds), then a calibration bake at Default, then
each preset in turn, its estimate taken just before it bakes ("calibrated": also what the scene's
previous bake counted) and the bake's time. Every bake teaches the machine's rates, as in use; the
first sample's cold estimate is the add-on's starting rates'. Printed and written to
bench/results/estimate.csv and .md: the estimates' middles and ranges, the bake's solve time (Last
Bake's time) and their ratios; the goal is every calibrated ratio within 2x.
"""
import math
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
import tables  # noqa: E402
from conftest import load_package  # noqa: E402

SAMPLES = (("cornell_box", None), ("subsurf_room", None), ("animated_room", 1))


def open_sample(name, frame):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", name + ".blend"))
    if frame is not None:
        bpy.context.scene.frame_set(frame)
    return bpy.context.scene


def bake(scene, preset):
    scene.radiosity.preset = preset
    assert bpy.ops.radiosity.bake() == {'FINISHED'}, f"{preset} bake failed"
    return scene.radiosity.last_seconds


def main():
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    samples = [(name, frame) for name, frame in SAMPLES if name in args] or SAMPLES
    presets = [a.upper() for a in args if a not in dict(SAMPLES)] or ["DRAFT", "DEFAULT", "HIGH"]
    pkg = load_package()
    pkg.register()
    est = pkg.estimate
    rows = []
    for name, frame in samples:
        scene = open_sample(name, frame)
        cold = est.preset_times(scene)
        cold_counts = {}
        for preset in presets:
            scene.radiosity.preset = preset
            cold_counts[preset] = est.cost(scene.radiosity, scene)[:2]
        print(f"{name}: calibration bake at default, {bake(scene, 'DEFAULT'):.2f} s", flush=True)
        for preset in presets:
            scene.radiosity.preset = preset
            warm = est.cost(scene.radiosity, scene)[2]
            actual = bake(scene, preset)
            props = scene.radiosity
            row = dict(scene=name + (f"@{frame}" if frame else ""), preset=preset.lower(), actual=f"{actual:.3f}",
                       points=props.last_points, rays=f"{props.last_rays:.0f}",
                       cold_points_ratio=f"{cold_counts[preset][0] / props.last_points:.2f}",
                       cold_rays_ratio=f"{cold_counts[preset][1] / props.last_rays:.2f}")
            for key, (low, high) in (("cold", cold[preset]), ("warm", warm)):
                mid = math.sqrt(low * high)
                row.update({f"{key}_low": f"{low:.3f}", f"{key}_high": f"{high:.3f}", f"{key}_mid": f"{mid:.3f}",
                            f"{key}_ratio": f"{mid / actual:.2f}",
                            f"{key}_in_range": "yes" if low <= actual <= high else "no"})
            rows.append(row)
            print(f"{row['scene']:16} {preset.lower():9} actual {actual:7.2f} s   cold {row['cold_mid']:>8} s "
                  f"(x{row['cold_ratio']}, {row['cold_in_range']})   calibrated {row['warm_mid']:>8} s "
                  f"(x{row['warm_ratio']}, {row['warm_in_range']})", flush=True)
    worst = {k: max(max(float(r[f"{k}_ratio"]), 1 / float(r[f"{k}_ratio"])) for r in rows) for k in ("cold", "warm")}
    print(f"worst ratio (either way): cold {worst['cold']:.2f}, calibrated {worst['warm']:.2f}; goal 2", flush=True)
    fields = list(rows[0])
    tables.write(tables.path_for("_".join(["estimate"] + args)), fields, rows,
                 "The panel's time estimate against the bake",
                 [("scene", "scene", None), ("preset", "preset", None), ("actual", "bake", tables.seconds),
                  ("points", "vertices", tables.count), ("cold_points_ratio", "cold vertices / bake", None),
                  ("rays", "rays", tables.mega), ("cold_rays_ratio", "cold rays / bake", None),
                  ("cold_low", "cold low", tables.seconds), ("cold_high", "cold high", tables.seconds),
                  ("cold_ratio", "cold middle / bake", None), ("cold_in_range", "in range", None),
                  ("warm_low", "calibrated low", tables.seconds), ("warm_high", "calibrated high", tables.seconds),
                  ("warm_ratio", "calibrated middle / bake", None), ("warm_in_range", "in range", None)],
                 f"Solve time of one bake (Last Bake's time) against the panel's estimate. Cold: before any "
                 f"bake of the scene, from the object bounds and the machine's rates so far; calibrated: just "
                 f"before the bake, after a calibration bake of the scene at Default and the presets before it. "
                 f"Every bake of the run teaches the machine's rates. Middle = geometric mean of the range. "
                 f"Worst ratio either way: cold {worst['cold']:.2f}, calibrated {worst['warm']:.2f}; load "
                 f"average {os.getloadavg()[0]:.1f} at the end (2 cores, shared).")


main()
bpy.ops.wm.quit_blender()

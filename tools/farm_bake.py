"""Bake Animation of a .blend on a Dask farm, without the UI (pipelines): submits the frame range to
the scheduler, waits, loads the frames and saves them in the .blend (Keep Frames in File), and exits
non-zero when the bake failed.

    blender -b FILE.blend --python-exit-code 1 --python tools/farm_bake.py -- [--scheduler tcp://HOST:8786]
            [--preset DEFAULT] [--frames FIRST:LAST]

Without --scheduler the scene's own scene.radiosity.farm_scheduler is used; an empty one bakes on
this machine alone. The add-on is the one enabled (--addons dynamic_radiosity), else this source
tree's addon/ with its build/engine. docs/farm.md says how to start the farm.
"""
import argparse
import os
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(prog="farm_bake.py")
    ap.add_argument("--scheduler", help="a Dask scheduler's address; '' for this machine alone")
    ap.add_argument("--preset", help="quality preset: DRAFT, DEFAULT, HIGH or REFERENCE")
    ap.add_argument("--frames", help="FIRST:LAST, else the scene's frame range")
    a = ap.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    if "dynamic_radiosity" not in sys.modules:
        sys.path.insert(0, os.path.join(ROOT, "addon"))
        from farm_chunk import load_addon
        load_addon()
    scene = bpy.context.scene
    props = scene.radiosity
    if a.scheduler is not None:
        props.farm_scheduler = a.scheduler
    if a.preset:
        props.preset = a.preset.upper()
    if a.frames:
        first, last = a.frames.split(":")
        scene.frame_start, scene.frame_end = int(first), int(last)
    start = time.perf_counter()
    if bpy.ops.radiosity.bake_animation() != {'FINISHED'}:
        raise SystemExit("farm_bake: the bake failed")
    print(f"farm_bake: {props.last_frames} frames of {bpy.data.filepath} baked "
          f"{'on ' + props.farm_scheduler if props.farm_scheduler else 'on this machine'} "
          f"in {time.perf_counter() - start:.1f} s", flush=True)
    bpy.ops.wm.save_mainfile()


main()

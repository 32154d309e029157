"""Lightmaps kept current by live update: what they add to a frame, and how far from a fresh bake.

    blender -b --factory-startup --python bench/lightmap_updates.py -- [preset] [texel_density]

preset: draft (default) | default | high; texel_density: texels per metre (the add-on's default, 32).
Scenes: the animated_room sample (a box moves and the point lamp ramps every frame: every lightmap
is evaluated again each frame), and the same with the lamp fixed (only the box moves).

Each scene is baked at its first frame, then played frame by frame with live update (scripts'
frame_set: each frame's update finished before it returns) in three ways: "colours" with Lightmaps
off; "lightmaps" as shipped (lightmap_updates.py: only lightmaps whose light may have changed are
evaluated again, each object's rasterised texels kept); "no raster cache", the same rasterising every
frame anew. "frame" is a frame_set's wall time, "update" the engine's update, "lightmaps" their
evaluation (Solver.surface_radiance, footprints, padding), "write" the colours' and images' write;
"evaluated" lightmaps per frame of all; "rms" the last frame's lightmaps against a fresh bake of it
(relative RMS over covered texels, the worst object), "colours rms" its Radiosity attribute against
the same bake's (the update's own distance from a fresh solve, which the lightmaps carry).
Medians over the frames; no timed asserts.

Writes bench/results/lightmap_updates_PRESET.csv and its .md.
"""
import os
import statistics
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
from conftest import load_package  # noqa: E402
from reference import relative_rms  # noqa: E402
sys.path.insert(0, os.path.join(ROOT, "bench"))
import tables  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
PRESET = (args[0] if args else "draft").upper()
DENSITY = float(args[1]) if len(args) > 1 else 32.0

pkg = load_package()
pkg.register()
live = pkg.live_update
Lightmaps = pkg.lightmap_updates.Lightmaps
_prepare = Lightmaps.prepare


def open_room(lamp_fixed):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", "animated_room.blend"))
    scene = bpy.context.scene
    if lamp_fixed:
        bpy.data.lights["Lamp"].animation_data_clear()
    props = scene.radiosity
    props.preset = PRESET
    props.texel_density = DENSITY
    return scene


def covered_rgb(name):
    image = bpy.data.images[pkg.lightmap.image_name(name)]
    ob = bpy.data.objects[name]
    texel = pkg.lightmap.Raster(ob.data, ob.data.uv_layers["RadiosityUV"], *image.size).texel
    px = np.empty(4 * image.size[0] * image.size[1], np.float32)
    image.pixels.foreach_get(px)
    return px.reshape(-1, 4)[texel, :3].copy()


def play(scene_name, lamp_fixed, mode):
    scene = open_room(lamp_fixed)
    scene.radiosity.lightmaps = mode != "colours"
    Lightmaps.prepare = _prepare
    if mode == "no raster cache":
        def prepare(self, job, props):
            self.rasters.clear()
            return _prepare(self, job, props)
        Lightmaps.prepare = prepare
    scene.frame_set(scene.frame_start)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    scene.radiosity.live_update = True
    rows = {k: [] for k in ("frame", "update", "lightmaps", "write", "evaluated")}
    targets = 0
    for f in range(scene.frame_start + 1, scene.frame_end + 1):
        t = time.perf_counter()
        scene.frame_set(f)
        rows["frame"].append(time.perf_counter() - t)
        info = live.last_sync[scene.name]
        assert info["frame"] == f and info["mode"] == "incremental", info
        rows["update"].append(info["seconds_solve"])
        rows["write"].append(info["seconds_write"])
        rows["lightmaps"].append(info.get("seconds_lightmaps", 0.0))
        rows["evaluated"].append(len(info.get("lightmaps_evaluated", [])))
        targets = max(targets, len(live.lightmap_state[scene.name].rasters) if scene.name in live.lightmap_state else 0)
    Lightmaps.prepare = _prepare
    out = {k: statistics.median(v) for k, v in rows.items()}
    out.update(scene=scene_name, mode=mode, frames=len(rows["frame"]), targets=targets, rms="", colours_rms="")
    if mode == "lightmaps":
        names = sorted(live.lightmap_state[scene.name].rasters)
        updated = {n: covered_rgb(n) for n in names}
        colours = {n: pkg.writeback.read_mesh(bpy.data.objects[n].data)[:, :3].copy() for n in names}
        scene.radiosity.live_update = False
        assert bpy.ops.radiosity.bake() == {'FINISHED'}
        out["rms"] = max(relative_rms(updated[n], covered_rgb(n)) for n in names)
        out["colours_rms"] = relative_rms(
            np.concatenate([colours[n] for n in names]),
            np.concatenate([pkg.writeback.read_mesh(bpy.data.objects[n].data)[:, :3] for n in names]))
        out["texels"] = sum(len(v) for v in updated.values())
    return out


def main():
    rows = []
    for scene_name, lamp_fixed in (("animated_room", False), ("animated_room, lamp fixed", True)):
        for mode in ("colours", "lightmaps", "no raster cache"):
            r = play(scene_name, lamp_fixed, mode)
            rows.append(r)
            print(f"{scene_name:28s} {mode:16s} frame {1000 * r['frame']:7.1f} ms  update {1000 * r['update']:6.1f} ms  "
                  f"lightmaps {1000 * r['lightmaps']:7.1f} ms  write {1000 * r['write']:5.1f} ms  "
                  f"evaluated {r['evaluated']:.0f}/{r['targets']}  rms {r['rms']} colours {r['colours_rms']}")
    fields = ["scene", "mode", "frames", "frame", "update", "lightmaps", "write", "evaluated", "targets",
              "texels", "rms", "colours_rms"]
    ms = lambda s: f"{1000 * float(s):.1f} ms"  # noqa: E731
    tables.write(tables.path_for(f"lightmap_updates_{PRESET.lower()}"), fields, rows,
                 f"Lightmaps in live update, {PRESET.lower()} preset, {DENSITY:g} texels a metre",
                 columns=[("scene", "scene", None), ("mode", "mode", None), ("frame", "frame", ms),
                          ("update", "update", ms), ("lightmaps", "lightmaps", ms), ("write", "write", ms),
                          ("evaluated", "evaluated", None), ("targets", "of", None), ("texels", "texels", None),
                          ("rms", "rms vs fresh", tables.percent),
                          ("colours_rms", "colours rms", tables.percent)],
                 notes="Medians over the frames played (frame_set from a script, each update finished "
                       "before it returns), two cores shared. bench/lightmap_updates.py says what each "
                       "column is.")


main()

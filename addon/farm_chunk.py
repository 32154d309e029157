"""One chunk of a farm's Bake Animation, in a worker's background Blender (farm_task.py starts it):

    blender -b --factory-startup FILE.blend --python .../dynamic_radiosity/farm_chunk.py -- \
        '{"frames": [...], "cache": FOLDER, "result": FILE.json}'

Bakes the frames as Bake Animation does (the first solved in full, each later one an update of the same
Solver), writes each frame's files into the cache folder (farm_cache) as soon as it is solved, and
writes into the result file, as JSON: the frames written, each frame's seconds (a full solve, then
updates: the farm sizes its chunks by them) and the chunk's bake_stats.

The add-on is the package this file sits in (installed, or the source tree's addon/ with its
build/engine), loaded as `dynamic_radiosity`: the worker bakes with the code that sent the chunk.
"""
import importlib.util
import json
import os
import sys
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))


def load_addon():
    spec = importlib.util.spec_from_file_location("dynamic_radiosity", os.path.join(HERE, "__init__.py"),
                                                  submodule_search_locations=[HERE])
    pkg = importlib.util.module_from_spec(spec)
    sys.modules["dynamic_radiosity"] = pkg
    spec.loader.exec_module(pkg)
    pkg.register()
    return pkg


def main():
    args = json.loads(sys.argv[sys.argv.index("--") + 1])
    pkg = load_addon()
    frames, cache = [int(f) for f in args["frames"]], args["cache"]
    seconds, last = [], [time.perf_counter()]

    def write(frame, colours):
        pkg.farm_cache.write_frame(cache, frame, colours)
        now = time.perf_counter()
        seconds.append(now - last[0])
        last[0] = now
    with pkg.live_update.suspended():
        jobs, results = pkg.operators.bake_frames(bpy.context, frames, True, on_frame=write)
    if results is None:
        raise SystemExit("Radiosity farm chunk: the bake was cancelled")
    with open(args["result"], "w", encoding="utf-8") as f:
        json.dump({"frames": sorted(results), "seconds": seconds, "stats": pkg.bake_stats.summary(jobs)}, f)


if __name__ == "__main__":
    main()

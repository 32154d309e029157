#!/usr/bin/python3.11
"""Bakes beside other work: each sample alone, then next to N busy processes (N = cores), in one run.

    bench/under_load.py [preset] [repeats]        (default: default 3)

A bake that shares the machine fairly with N busy processes takes its time alone x (N + cores) / cores
(each of the cores' time slices split between N + cores runnable threads). Printed for each sample
and thread setting (Blender's Render > Performance > Threads: Auto-detect, and Fixed at 1): the median
bake time alone and under load, and their ratio to that fair share. The goal is at most 1.5x.
Writes bench/results/under_load.csv and .md.
"""
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = ("cornell_box", "animated_room", "subsurf_room")
THREADS = (("auto", 0), ("1 thread", 1))


def bake_in_blender():
    """Inside Blender: bake each sample `repeats` times with the given thread setting; print JSON."""
    import bpy
    sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
    from conftest import load_package
    args = sys.argv[sys.argv.index("--") + 1:]
    preset, repeats, threads = args[1].upper(), int(args[2]), int(args[3])
    load_package().register()
    times = {}
    for name in SAMPLES:
        bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", name + ".blend"))
        scene = bpy.context.scene
        scene.radiosity.preset = preset
        scene.render.threads_mode = 'FIXED' if threads else 'AUTO'
        if threads:
            scene.render.threads = threads
        times[name] = []
        for _ in range(repeats):
            assert bpy.ops.radiosity.bake() == {'FINISHED'}
            times[name].append(scene.radiosity.last_seconds)
    print("UNDER_LOAD " + json.dumps(times), flush=True)


def bake_times(preset, repeats, threads):
    out = subprocess.run(["blender", "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                          os.path.abspath(__file__), "--", "bake", preset, str(repeats), str(threads)],
                         capture_output=True, text=True, check=True)
    line = next(l for l in out.stdout.splitlines() if l.startswith("UNDER_LOAD "))
    return json.loads(line[len("UNDER_LOAD "):])


def busy(n):
    """n processes that each keep a core busy, as `yes > /dev/null` does."""
    return [subprocess.Popen(["yes"], stdout=subprocess.DEVNULL) for _ in range(n)]


def main():
    sys.path.insert(0, HERE)
    import tables
    preset = sys.argv[1] if len(sys.argv) > 1 else "default"
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    cores = os.cpu_count()
    load = cores
    fair = (load + cores) / cores
    rows = []
    for label, threads in THREADS:
        alone = bake_times(preset, repeats, threads)
        hogs = busy(load)
        try:
            loaded = bake_times(preset, repeats, threads)
        finally:
            for p in hogs:
                p.kill()
                p.wait()
        for name in SAMPLES:
            a, b = statistics.median(alone[name]), statistics.median(loaded[name])
            row = dict(sample=name, preset=preset, threads=label, cores=cores, busy=load,
                       alone_s=f"{a:.3f}", loaded_s=f"{b:.3f}", loaded_max_s=f"{max(loaded[name]):.3f}",
                       fair_s=f"{a * fair:.3f}", ratio=f"{b / (a * fair):.2f}")
            rows.append(row)
            print(f"{name:14s} {label:9s} alone {a:6.2f} s  beside {load} busy {b:6.2f} s "
                  f"(max {max(loaded[name]):6.2f})  fair share {a * fair:6.2f} s  ratio {b / (a * fair):5.2f}",
                  flush=True)
    tables.write(tables.path_for("under_load"), list(rows[0]), rows,
                 f"Bakes beside {load} busy processes on {cores} cores ({preset}, medians of {repeats})",
                 [("sample", "sample", None), ("threads", "threads", None), ("alone_s", "alone", tables.seconds),
                  ("loaded_s", "under load", tables.seconds), ("loaded_max_s", "slowest", tables.seconds),
                  ("fair_s", "fair share", tables.seconds), ("ratio", "ratio to fair share", None)],
                 "Fair share: the time alone x (busy + cores) / cores. The goal is a ratio of at most 1.5.")


if __name__ == "__main__":
    if "--" in sys.argv and sys.argv[sys.argv.index("--") + 1] == "bake":
        bake_in_blender()
    else:
        main()

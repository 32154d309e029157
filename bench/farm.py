#!/usr/bin/python3.11
"""Farm speed-up: wall time of the animated room's Bake Animation on one process against a farm of
2 single-thread workers on this machine (tools/local_farm.py), each through tools/farm_bake.py (Blender's
start, the save and loading the frames included in both).

    bench/farm.py [--preset DEFAULT] [--workers 2]

Writes bench/results/farm.csv and farm.md and prints the speed-up. On a machine of N cores, N workers
are the most that can run at once: each chunk's Blender solves on one thread.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
from farm_task import blender_env  # noqa: E402

SAMPLE = os.path.join(ROOT, "sample_blends", "animated_room.blend")
RESULTS = os.path.join(ROOT, "bench", "results")


def bake(folder, preset, scheduler):
    """Wall seconds of farm_bake.py on a fresh copy of the sample; scheduler '' = one process."""
    blend = os.path.join(folder, "animated_room.blend")
    shutil.copy(SAMPLE, blend)
    cmd = ["blender", "-b", blend, "--python-exit-code", "1", "--python", os.path.join(ROOT, "tools", "farm_bake.py"),
           "--", "--preset", preset, "--scheduler", scheduler]
    start = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, env=blender_env())
    seconds = time.perf_counter() - start
    if out.returncode != 0:
        raise SystemExit(out.stdout[-3000:] + out.stderr[-3000:])
    said = [l for l in out.stdout.splitlines() if l.startswith("farm_bake:")]
    print(said[-1] if said else "", flush=True)
    return seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="DEFAULT")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="radiosity-farm-bench-") as tmp:
        load = os.getloadavg()[0]
        one = bake(tempfile.mkdtemp(dir=tmp), a.preset, "")
        rows.append({"mode": "one process", "workers": 1, "seconds": one, "load1": load})
        farm = subprocess.Popen([sys.executable, os.path.join(ROOT, "tools", "local_farm.py"), "--workers",
                                 str(a.workers)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        try:
            address = farm.stdout.readline().strip()
            load = os.getloadavg()[0]
            seconds = bake(tempfile.mkdtemp(dir=tmp), a.preset, address)
            rows.append({"mode": "farm", "workers": a.workers, "seconds": seconds, "load1": load})
        finally:
            farm.stdin.close()
            farm.wait()
    for r in rows:
        r.update(scene="animated_room", frames=24, preset=a.preset, speedup=one / r["seconds"])
    fields = ["scene", "frames", "preset", "mode", "workers", "seconds", "speedup", "load1"]
    os.makedirs(RESULTS, exist_ok=True)
    with open(os.path.join(RESULTS, "farm.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fields)
        w.writeheader()
        for r in rows:
            w.writerow({**r, "seconds": f"{r['seconds']:.1f}", "speedup": f"{r['speedup']:.2f}",
                        "load1": f"{r['load1']:.2f}"})
    with open(os.path.join(RESULTS, "farm.md"), "w") as f:
        f.write(f"Bake Animation of animated_room (24 frames, {a.preset}), wall time through tools/farm_bake.py "
                f"on {os.cpu_count()} cores (bench/farm.py; load1: the machine's load when it started).\n\n"
                "| mode | workers | seconds | speed-up | load1 |\n|---|---:|---:|---:|---:|\n")
        for r in rows:
            f.write(f"| {r['mode']} | {r['workers']} | {r['seconds']:.1f} | {r['speedup']:.2f}x | {r['load1']:.2f} |\n")
    print(f"one process {one:.1f} s, farm of {a.workers} workers {rows[-1]['seconds']:.1f} s: "
          f"speed-up {rows[-1]['speedup']:.2f}x")


if __name__ == "__main__":
    main()

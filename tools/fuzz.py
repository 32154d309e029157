#!/usr/bin/python3.11
"""Bakes many random scenes (tests/fuzz_scenes.py), each in its own Blender with a time cap.

    tools/fuzz.py [--seeds 0:200] [--preset DRAFT] [--cap 60]

A seed passes when its Blender exits 0 (the scene baked with finite colours, or was refused with a
message naming an object and its old colours kept). A crash, a broken promise or a bake past the cap
is printed with the seed, so that `blender -b --factory-startup --python tests/fuzz_scenes.py -- SEED`
runs it again. Exits non-zero when any seed failed.
"""
import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "tests", "fuzz_scenes.py")


def run(seed, preset, cap):
    """(verdict, seconds, last line) of one seed's bake in its own Blender process."""
    cmd = ["blender", "-b", "--factory-startup", "--python-exit-code", "1", "--python", SCRIPT,
           "--", str(seed), preset]
    start = time.perf_counter()
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=cap)
    except subprocess.TimeoutExpired:
        return "past the cap", time.perf_counter() - start, ""
    seconds = time.perf_counter() - start
    lines = [l for l in (out.stdout + out.stderr).splitlines() if l.strip()]
    said = next((l for l in reversed(lines) if l.startswith("fuzz seed")), lines[-1] if lines else "")
    if out.returncode == 0:
        return "ok", seconds, said
    if out.returncode < 0:
        return f"crashed (signal {-out.returncode})", seconds, said
    error = next((l for l in reversed(lines) if "Error" in l), said)
    return "failed", seconds, error


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", default="0:100", help="first:last (exclusive), or one seed")
    ap.add_argument("--preset", default="DRAFT")
    ap.add_argument("--cap", type=float, default=60.0, help="seconds a scene may take")
    a = ap.parse_args()
    first, _, last = a.seeds.partition(":")
    seeds = range(int(first), int(last) if last else int(first) + 1)
    bad = []
    for seed in seeds:
        verdict, seconds, said = run(seed, a.preset, a.cap)
        print(f"{seed:6d}  {seconds:6.1f} s  {verdict:10s}  {said}", flush=True)
        if verdict != "ok":
            bad.append(seed)
    print(f"{len(seeds) - len(bad)} passed, {len(bad)} failed" + (f": seeds {bad}" if bad else ""))
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()

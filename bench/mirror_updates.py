"""What a change in a scene with mirrors costs as an update, against a fresh solve of the new state.

    /usr/bin/python3.11 bench/mirror_updates.py [--runs 3] [preset ...]

The scene and its changes are the engine test's (tests/scenes.py: mirrored_box, MIRRORED_STEPS): a
Cornell box with a fixed mirror and a sliding one, a cube, the ceiling, a point lamp and the world;
the cube moves in front of the mirrors, the sliding mirror moves, changes colour, turns rough and
sharp again, vanishes, appears, moves with the cube, and the lamp moves. Per change: Solver.update()
wall seconds and rays, a fresh solve's of the same state, their ratio, and the update's RMS from the
fresh solve (the bound an update keeps: 0.5%). Medians of --runs runs of the whole sequence.
Writes bench/results/mirror_updates.csv and .md.
"""
import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import MIRRORED_STATE, MIRRORED_STEPS, engine, mirrored_box  # noqa: E402
import tables  # noqa: E402

FIELDS = ["preset", "change", "update_s", "update_rays", "fresh_s", "fresh_rays", "ratio", "rms"]


def values(solver, ids):
    return np.concatenate([solver.refined(i)[1] for i in ids])


def solved(state, settings):
    scene, ids, cube, mirror = mirrored_box(state)
    solver = engine.Solver(scene, settings)
    start = time.perf_counter()
    stats = solver.solve()
    return solver, ids, cube, mirror, time.perf_counter() - start, stats["rays"]


def run(preset):
    """Per change: (update seconds, update rays, fresh seconds, fresh rays, RMS) of one run."""
    settings = engine.Settings.preset(preset)
    state = dict(MIRRORED_STATE)
    solver, ids, cube, mirror, _, _ = solved(state, settings)
    out = []
    for name, change, apply in MIRRORED_STEPS:
        state.update(change)
        apply(solver, cube, mirror, state)
        rays_before = solver.stats["rays"]
        start = time.perf_counter()
        stats = solver.update()
        seconds = time.perf_counter() - start
        assert stats["restart"] == "", name
        fresh, _, _, _, fresh_s, fresh_rays = solved(state, settings)
        reference = values(fresh, ids)
        rms = float(np.sqrt(np.mean((values(solver, ids) - reference) ** 2)) / np.mean(reference))
        out.append((name, seconds, stats["rays"] - rays_before, fresh_s, fresh_rays, rms))
        solver.solve()  # settled, as the add-on leaves it before the next edit
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("presets", nargs="*", default=["default"])
    args = parser.parse_args()
    rows = []
    for preset in args.presets:
        runs = [run(preset) for _ in range(args.runs)]
        for k, (name, *_) in enumerate(runs[0]):
            med = [statistics.median(r[k][j] for r in runs) for j in range(1, 6)]
            rows.append(dict(preset=preset, change=name, update_s=med[0], update_rays=int(med[1]), fresh_s=med[2],
                             fresh_rays=int(med[3]), ratio=f"{med[2] / med[0]:.2f}", rms=med[4]))
            print(f"{preset:8} {name:32} update {med[0]:6.3f} s {med[1] / 1e6:6.1f} M rays   fresh {med[2]:6.3f} s "
                  f"{med[3] / 1e6:6.1f} M   fresh / update {med[2] / med[0]:5.2f}   RMS {med[4]:.3%}", flush=True)
    tables.write(tables.path_for("mirror_updates"), FIELDS, rows, "Updates in a scene with mirrors",
                 [("preset", "preset", None), ("change", "change", None), ("update_s", "update", tables.seconds),
                  ("update_rays", "update rays", tables.mega), ("fresh_s", "fresh solve", tables.seconds),
                  ("fresh_rays", "fresh rays", tables.mega), ("ratio", "fresh / update", None),
                  ("rms", "RMS from fresh", tables.percent)],
                 "The engine test's mirrored Cornell box (tests/scenes.py: mirrored_box, MIRRORED_STEPS), each change "
                 "an update of the settled solution before it. Update: Solver.update() wall time and the rays it "
                 f"traced; fresh: a new Solver's solve() of the same state. Medians of {args.runs} runs; 2 shared cores.")


if __name__ == "__main__":
    main()

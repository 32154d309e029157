"""Scaling: a converged solve of the same room at about 1k, 10k and 100k vertices.

    /usr/bin/python3.11 bench/scaling.py [--threads N] [preset] [patch size (m) ...]

Prints points, time and error for each size and the cost ratio of each step, and writes them to
bench/results/scaling.csv and .md. Error is measured on the floor's vertices of the coarsest mesh,
which every finer (uniformly refined) mesh contains, against the finest solve. Target: 10x the
vertices costs at most 20x the time."""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import cornell_box, engine, threads_option  # noqa: E402
from scenes import preset as settings_of  # noqa: E402
import tables  # noqa: E402


def floor_values(solver, room):
    positions, radiance = solver.refined(room)
    floor = (np.abs(positions[:, 2]) < 1e-9) & (np.abs(positions[:, 0]) < 0.999) & (np.abs(positions[:, 1]) < 0.999)
    keys = [tuple(k) for k in np.round(positions[floor, :2], 6)]
    return dict(zip(keys, radiance[floor].sum(axis=1)))


def main():
    threads = threads_option(sys.argv)
    preset = sys.argv[1] if len(sys.argv) > 1 else "default"
    sizes = [float(s) for s in sys.argv[2:]] or [0.25, 0.1, 0.03]  # patch sizes (m): 1.4k, 9k, 135k points
    runs = []
    for patch in sizes:
        scene, ids = cornell_box(patch_size=patch)
        start = time.perf_counter()
        solver = engine.Solver(scene, settings_of(preset, threads))
        stats = solver.solve()
        seconds = time.perf_counter() - start
        runs.append((patch, stats, seconds, floor_values(solver, ids[0])))
        print(f"patch {patch:6.3f} m: {stats['points']:7d} points {stats['patches']:7d} patches "
              f"{stats['shots']:5d} shots {stats['rays'] / 1e6:9.1f} Mrays {seconds:8.2f} s  "
              f"residual {stats['residual']:.1e}", flush=True)
    finest = runs[-1][3]
    coarse_keys = [k for k in runs[0][3] if k in finest]
    reference = np.array([finest[k] for k in coarse_keys])
    print(f"\n{'points':>8} {'time s':>8} {'error vs finest':>16} {'x points':>9} {'x time':>7} {'time/points':>12}")
    rows = []
    for i, (patch, stats, seconds, values) in enumerate(runs):
        err = np.sqrt(np.mean((np.array([values[k] for k in coarse_keys]) - reference) ** 2)) / np.sqrt(np.mean(reference ** 2))
        row = dict(preset=preset, patch_m=patch, points=stats["points"], patches=stats["patches"],
                   shots=stats["shots"], rays=stats["rays"], seconds=f"{seconds:.3f}",
                   error=f"{err:.5f}" if i < len(runs) - 1 else "", x_points="", x_time="",
                   threads=threads or "all cores", load1=f"{os.getloadavg()[0]:.1f}")
        if i == 0:
            print(f"{stats['points']:8d} {seconds:8.2f} {err:15.2%}")
        else:
            p0, s0 = runs[i - 1][1]["points"], runs[i - 1][2]
            growth = stats["points"] / p0
            row.update(x_points=f"{growth:.1f}", x_time=f"{seconds / s0:.1f}")
            print(f"{stats['points']:8d} {seconds:8.2f} {err:15.2%} {growth:9.1f} {seconds / s0:7.1f} "
                  f"{(seconds / s0) / growth:12.2f}")
        rows.append(row)
    print(f"(floor vertices compared: {len(coarse_keys)}; 'time/points' <= 2 meets the target)")
    tables.write(tables.path_for("scaling"), list(rows[0]), rows, f"Scaling ({preset} preset)",
                 [("patch_m", "patch size (m)", None), ("points", "points", tables.count),
                  ("shots", "shots", tables.count), ("rays", "rays", tables.mega), ("seconds", "time", tables.seconds),
                  ("error", "error vs finest", tables.percent), ("x_points", "x points", None),
                  ("x_time", "x time", None), ("threads", "threads", None), ("load1", "load average", None)],
                 "The engine tests' Cornell box (tests/scenes.py) refined to each patch size and solved to the "
                 f"preset's threshold. Error: relative RMS over the floor's {len(coarse_keys)} coarsest vertices "
                 "against the finest solve. Target: 10x the points costs at most 20x the time.")


if __name__ == "__main__":
    main()

"""What each quality preset costs on the engine tests' Cornell box (tests/scenes.py), engine only.

    /usr/bin/python3.11 bench/presets.py [--threads N] [preset ...]   (draft and default unless named)

Prints patches, points, shots, rays, residual, time and the floor centre's radiance for each preset,
and writes them to bench/results/presets.csv and .md. For error against Cycles through the add-on,
see accuracy_vs_time.py. On a shared machine, one thread (--threads 1) gives steadier figures."""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import cornell_box, engine, preset, threads_option  # noqa: E402
import tables  # noqa: E402


def main():
    threads = threads_option(sys.argv)
    presets = sys.argv[1:] or ["draft", "default"]
    print(f"{'preset':10} {'patches':>8} {'points':>8} {'shots':>6} {'rays':>12} {'residual':>9} "
          f"{'time s':>7} {'Mrays/s':>8}  floor centre RGB")
    rows = []
    for name in presets:
        scene, ids = cornell_box()
        start = time.perf_counter()
        solver = engine.Solver(scene, preset(name, threads))
        stats = solver.solve()
        seconds = time.perf_counter() - start
        pos, rad = solver.refined(ids[0])
        floor = np.abs(pos[:, 2]) < 1e-6
        centre = np.argmin(np.where(floor, np.hypot(pos[:, 0], pos[:, 1]), np.inf))
        print(f"{name:10} {stats['patches']:8d} {stats['points']:8d} {stats['shots']:6d} "
              f"{stats['rays']:12d} {stats['residual']:9.2e} {seconds:7.2f} "
              f"{stats['rays'] / seconds / 1e6:8.2f}  {np.round(rad[centre], 4)}", flush=True)
        for w in stats["warnings"]:
            print("  warning:", w)
        rows.append(dict(preset=name, patches=stats["patches"], points=stats["points"], shots=stats["shots"],
                         rays=stats["rays"], residual=f"{stats['residual']:.2e}", seconds=f"{seconds:.3f}",
                         floor_centre=" ".join(f"{v:.4f}" for v in rad[centre]),
                         threads=threads or "all cores", load1=f"{os.getloadavg()[0]:.1f}"))
    tables.write(tables.path_for("presets"), list(rows[0]), rows, "Presets on the engine's Cornell box",
                 [("preset", "preset", None), ("patches", "patches", tables.count), ("points", "points", tables.count),
                  ("shots", "shots", tables.count), ("rays", "rays", tables.mega), ("residual", "residual", None),
                  ("seconds", "solve time", tables.seconds), ("floor_centre", "floor centre RGB", None),
                  ("threads", "threads", None), ("load1", "load average", None)],
                 "One engine solve a preset (tests/scenes.py's Cornell box): wall time of Solver construction "
                 "and solve(), on the threads given.")


if __name__ == "__main__":
    main()

"""Main job until the add-on exists: solve the Cornell box at each preset and print the figures."""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import cornell_box, engine  # noqa: E402


def main():
    presets = sys.argv[1:] or ["draft", "default"]
    print(f"{'preset':10} {'patches':>8} {'points':>8} {'shots':>6} {'rays':>12} {'residual':>9} "
          f"{'time s':>7} {'Mrays/s':>8}  floor centre RGB")
    for name in presets:
        scene, ids = cornell_box()
        start = time.perf_counter()
        solver = engine.Solver(scene, engine.Settings.preset(name))
        stats = solver.solve()
        seconds = time.perf_counter() - start
        pos, rad = solver.refined(ids[0])
        floor = np.abs(pos[:, 2]) < 1e-6
        centre = np.argmin(np.where(floor, np.hypot(pos[:, 0], pos[:, 1]), np.inf))
        print(f"{name:10} {stats['patches']:8d} {stats['points']:8d} {stats['shots']:6d} "
              f"{stats['rays']:12d} {stats['residual']:9.2e} {seconds:7.2f} "
              f"{stats['rays'] / seconds / 1e6:8.2f}  {np.round(rad[centre], 4)}")
        for w in stats["warnings"]:
            print("  warning:", w)


if __name__ == "__main__":
    main()

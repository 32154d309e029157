"""Rays per second of the solver against bare Embree tracing the same rays on the same scene.

    /usr/bin/python3.11 bench/ray_throughput.py [--threads N] [preset ...]

The solver's rate counts the whole solve (form factors, shot building, bookkeeping); the bare rate
replays an even sample of the very batches the solver traced, through rtcOccluded1M on all cores
(or N threads: with one, neither has threads to wait for or a neighbour's load to share, and the
ratio is our work per ray against Embree's, with less noise between runs). Target: ratio >= 0.7.
Writes bench/results/ray_throughput.csv and .md (ray_throughput_1thread.* with --threads 1, and so on)."""
import os
import statistics
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import cornell_box, engine, preset, threads_option  # noqa: E402
import tables  # noqa: E402

THREADS = threads_option(sys.argv)


def measure(name, repeats=3):
    ratios, solver_rates, bare_rates = [], [], []
    for _ in range(repeats):
        scene, _ = cornell_box()
        solver = engine.Solver(scene, preset(name, THREADS))
        stats = solver.solve()
        solver_rate = stats["rays"] / stats["seconds"]
        # Same scene again, keeping every n-th batch of rays (about 10 M rays, 0.6 GB) to replay bare.
        scene, _ = cornell_box()
        recorder = engine.Solver(scene, preset(name, THREADS))
        recorder.record_rays(max(8, stats["rays"] // 10_000_000))
        recorder.solve()
        bare_rate = recorder.replay_recorded_rays()
        solver_rates.append(solver_rate)
        bare_rates.append(bare_rate)
        ratios.append(solver_rate / bare_rate)
    return stats, statistics.median(solver_rates), statistics.median(bare_rates), statistics.median(ratios)


def main():
    threads = THREADS or "all cores"
    print(f"{'scene':12} {'preset':8} {'points':>7} {'rays':>11} {'solver Mrays/s':>15} "
          f"{'bare Mrays/s':>13} {'ratio':>6}   (medians of 3; threads: {threads})")
    rows = []
    for name in sys.argv[1:] or ["draft", "default"]:
        stats, solver_rate, bare_rate, ratio = measure(name)
        print(f"{'cornell_box':12} {name:8} {stats['points']:7d} {stats['rays']:11d} "
              f"{solver_rate / 1e6:15.2f} {bare_rate / 1e6:13.2f} {ratio:6.2f}", flush=True)
        rows.append(dict(scene="cornell_box", preset=name, threads=threads, points=stats["points"],
                         rays=stats["rays"], solver_mrays=f"{solver_rate / 1e6:.2f}",
                         bare_mrays=f"{bare_rate / 1e6:.2f}", ratio=f"{ratio:.3f}",
                         load1=f"{os.getloadavg()[0]:.1f}"))
    name = "ray_throughput" + ("" if threads == "all cores" else f"_{threads}thread")
    tables.write(tables.path_for(name), list(rows[0]), rows, "Ray throughput: the solver against bare Embree",
                 [("scene", "scene", None), ("preset", "preset", None), ("threads", "threads", None),
                  ("points", "points", tables.count), ("rays", "rays", tables.mega),
                  ("solver_mrays", "solver Mrays/s", None), ("bare_mrays", "bare Embree Mrays/s", None),
                  ("ratio", "ratio", tables.fixed(2)), ("load1", "load average", None)],
                 "The solver's rays over its whole solve time against rtcOccluded1M replaying an even sample "
                 "of the same rays on the same scene (the engine tests' Cornell box, tests/scenes.py); "
                 "medians of 3. Target: ratio >= 0.7. One thread (--threads 1) is steadier on a shared machine.")


if __name__ == "__main__":
    main()

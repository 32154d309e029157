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

if "--threads" in sys.argv:  # before OpenMP starts, which reads it once
    at = sys.argv.index("--threads")
    os.environ["OMP_NUM_THREADS"] = sys.argv[at + 1]
    del sys.argv[at:at + 2]
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import cornell_box, engine  # noqa: E402
import tables  # noqa: E402


def measure(preset, repeats=3):
    ratios, solver_rates, bare_rates = [], [], []
    for _ in range(repeats):
        scene, _ = cornell_box()
        solver = engine.Solver(scene, engine.Settings.preset(preset))
        stats = solver.solve()
        solver_rate = stats["rays"] / stats["seconds"]
        # Same scene again, keeping every n-th batch of rays (about 10 M rays, 0.6 GB) to replay bare.
        scene, _ = cornell_box()
        recorder = engine.Solver(scene, engine.Settings.preset(preset))
        recorder.record_rays(max(8, stats["rays"] // 10_000_000))
        recorder.solve()
        bare_rate = recorder.replay_recorded_rays()
        solver_rates.append(solver_rate)
        bare_rates.append(bare_rate)
        ratios.append(solver_rate / bare_rate)
    return stats, statistics.median(solver_rates), statistics.median(bare_rates), statistics.median(ratios)


def main():
    threads = os.environ.get("OMP_NUM_THREADS", "all cores")
    print(f"{'scene':12} {'preset':8} {'points':>7} {'rays':>11} {'solver Mrays/s':>15} "
          f"{'bare Mrays/s':>13} {'ratio':>6}   (medians of 3; threads: {threads})")
    rows = []
    for preset in sys.argv[1:] or ["draft", "default"]:
        stats, solver_rate, bare_rate, ratio = measure(preset)
        print(f"{'cornell_box':12} {preset:8} {stats['points']:7d} {stats['rays']:11d} "
              f"{solver_rate / 1e6:15.2f} {bare_rate / 1e6:13.2f} {ratio:6.2f}", flush=True)
        rows.append(dict(scene="cornell_box", preset=preset, threads=threads, points=stats["points"],
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
                 "medians of 3. Target: ratio >= 0.7. On both cores the ratio means little when the load "
                 "average is above the core count: the solver's OpenMP threads wait on each other where the "
                 "bare replay does not; one thread (--threads 1) is steadier.")


if __name__ == "__main__":
    main()

"""What light through panes and off mirrors costs a solve, and that a scene without them costs nothing more.

    blender -b --factory-startup --python bench/effects_cost.py -- [--scenes cornell_box,...] [--preset default]
        [--runs 3] [--record-baseline]

For each sample scene (animated_room at frame 1), exported as the add-on exports it and solved by the
engine at the preset, on the threads the add-on gives it (Render > Threads):
  optics   the scene as it is;
  removed  every material's transmittance, glass and specular lobes zeroed in the export (a clear pane
           an opaque black one, a mirror its diffuse part alone): what the scene costs without its optics.
Figures: the solve's rays, pane crossings (hits on panes the rays went on through) and rays that crossed
a pane, from the engine's stats; solve() seconds, wall and CPU (the process's, all threads), the median
of --runs. A scene with no such lobe is solved once per run, as it is: removing nothing changes nothing.

Invariant: a scene with no optics traces the rays it traced on an engine where it runs no optics code
(no pane filter, no Crossings, no mirrors): bench/results/effects_baseline.csv, written by
--record-baseline (run in a checkout of the engine to record from). Its ratio is printed; one off 1 by more than 1% fails the bench (exit status 1).
Results: bench/results/effects_cost.csv and .md (tables.py).
"""
import csv
import dataclasses
import os
import statistics
import subprocess
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
from conftest import load_package  # noqa: E402  (the add-on from addon/, its engine from build/engine)
import tables  # noqa: E402

SCENES = {"cornell_box": None, "subsurf_room": None, "animated_room": 1, "interior_room": None,
          "window_room": None, "window_room_glass": None, "mirror_room": None}
LOBES = ("transmittance", "glass", "specular")
TOLERANCE = 0.01   # the bound on an optic-free scene's rays; the engine is meant to keep them equal
FIELDS = ["scene", "preset", "optics", "rays", "rays_removed", "pane_crossings", "rays_through_panes",
          "wall", "wall_removed", "cpu", "cpu_removed", "cpu_per_ray_ratio", "baseline_rays", "baseline_ratio", "threads", "load1"]
COLUMNS = [("scene", "scene", None), ("optics", "optics", None), ("rays", "rays", tables.mega),
           ("rays_removed", "rays, removed", tables.mega), ("pane_crossings", "pane crossings", tables.count),
           ("rays_through_panes", "rays through panes", tables.count), ("wall", "solve", tables.seconds),
           ("wall_removed", "solve, removed", tables.seconds), ("cpu", "CPU", tables.seconds),
           ("cpu_removed", "CPU, removed", tables.seconds),
           ("cpu_per_ray_ratio", "CPU a ray, with / without", tables.fixed(3)), ("baseline_ratio", "rays / baseline", tables.fixed(4))]
NOTES = """Each scene at the preset, solved as it is and with its transmittance, glass and specular lobes
zeroed in the export ("removed": a clear pane then an opaque black one, a mirror its diffuse part
alone). Solve: Solver.solve() wall time, CPU: the process's CPU time over it, medians of the runs.
Rays, pane crossings (hits on panes that rays went on through; one through a shared edge counts
once a quad) and rays through panes (rays that crossed at least one) are the engine's solve stats.
A scene without optics is solved as it is only, and its rays compared with effects_baseline.csv
(an engine where such a scene runs no optics code): the invariant is a ratio of exactly 1.
Removing a pane also changes the light (no sun inside the window room), so the solve's shots and
rays change with it: the seconds are what the scene costs with and without its optics, not the
filter's time alone; the CPU time a ray, with over without, is the nearer measure of what tracing on
through panes adds. 2 shared cores: see the CSV's load1 column."""
BASELINE_FIELDS = ["scene", "preset", "rays", "threads", "commit"]
BASELINE_NOTES = """The rays each optic-free sample traces at the preset, on an engine where it runs no optics
code: no pane filter is attached and no Crossings made where nothing lets light through, and mirrors
are not traced; it does not count pane crossings either. bench/effects_cost.py checks later engines
against them."""


def options():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []

    def get(flag, default):
        return argv[argv.index(flag) + 1] if flag in argv else default
    return dict(scenes=get("--scenes", ",".join(SCENES)).split(","), preset=get("--preset", "default"),
                runs=int(get("--runs", 3)), record_baseline="--record-baseline" in argv)


def label(name):
    return name + (f"@{SCENES[name]}" if SCENES[name] is not None else "")


def export(pkg, name):
    """The sample exported as a bake exports it, and the threads a bake solves it on."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", name + ".blend"))
    scene = bpy.context.scene
    if SCENES[name] is not None:
        scene.frame_set(SCENES[name])
    return pkg.export.export_scene(bpy.context.evaluated_depsgraph_get()), scene.render.threads


def optics_of(sx):
    """'Pane (transmittance, glass)': the materials meshes use with a lobe beyond the diffuse one."""
    used = {int(i) for m in sx.visible_meshes for i in np.unique(m.face_materials)}
    named = []
    for i in sorted(used):
        m = sx.materials[i]
        lobes = [lobe for lobe in LOBES if max(getattr(m, lobe)) > 0]
        if lobes:
            named.append(f"{m.name} ({', '.join(lobes)})")
    return "; ".join(named)


def removed(sx):
    """`sx` with every material's optical lobes zeroed."""
    black = (0.0, 0.0, 0.0)
    return dataclasses.replace(sx, materials=[dataclasses.replace(m, **{lobe: black for lobe in LOBES})
                                              for m in sx.materials])


def solve(pkg, engine, sx, preset, threads):
    """One solve of `sx`: (its stats, wall seconds, CPU seconds)."""
    scene, _ = pkg.export.to_engine(sx, engine)
    settings = engine.Settings.preset(preset)
    settings.threads = threads
    solver = engine.Solver(scene, settings)
    wall, cpu = time.perf_counter(), time.process_time()
    # An engine that counts no pane crossings (one a baseline is recorded on) crosses none.
    stats = {"pane_crossings": 0, "rays_through_panes": 0, **solver.solve()}
    return stats, time.perf_counter() - wall, time.process_time() - cpu


def measure(pkg, engine, sx, preset, threads, runs):
    """Stats of the first solve (the engine's counts are the same every run) and the median wall and
    CPU seconds of `runs` solves."""
    results = [solve(pkg, engine, sx, preset, threads) for _ in range(runs)]
    rays = {int(st["rays"]) for st, _, _ in results}
    if len(rays) > 1:
        print(f"  note: rays differ between runs: {sorted(rays)}", flush=True)
    return (results[0][0], statistics.median(w for _, w, _ in results),
            statistics.median(c for _, _, c in results))


def read_baseline(path):
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        return {(r["scene"], r["preset"]): r for r in csv.DictReader(f)}


def main():
    opt = options()
    pkg = load_package()
    engine = pkg.engine.load_engine()
    print(f"engine: {engine.__file__}; cores {os.cpu_count()}; load average at start {os.getloadavg()}")
    baseline_path = tables.path_for("effects_baseline")
    baseline = read_baseline(baseline_path)
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    rows, recorded, moved = [], [], []
    for name in opt["scenes"]:
        sx, threads = export(pkg, name)
        optics = optics_of(sx)
        st, wall, cpu = measure(pkg, engine, sx, opt["preset"], threads, opt["runs"])
        row = dict(scene=label(name), preset=opt["preset"], optics=optics or "none", rays=st["rays"],
                   pane_crossings=st["pane_crossings"], rays_through_panes=st["rays_through_panes"],
                   wall=f"{wall:.3f}", cpu=f"{cpu:.3f}", threads=threads, load1=f"{os.getloadavg()[0]:.2f}")
        if optics:
            st_off, wall_off, cpu_off = measure(pkg, engine, removed(sx), opt["preset"], threads, opt["runs"])
            per_ray = (cpu / st["rays"]) / (cpu_off / st_off["rays"])
            row.update(rays_removed=st_off["rays"], wall_removed=f"{wall_off:.3f}", cpu_removed=f"{cpu_off:.3f}",
                       cpu_per_ray_ratio=f"{per_ray:.4f}")
            print(f"{row['scene']:16} optics: {optics}\n  {st['rays']:,} rays ({st['rays_through_panes']:,} "
                  f"through panes, {st['pane_crossings']:,} pane crossings), {wall:.2f} s wall, {cpu:.2f} s CPU; "
                  f"removed: {st_off['rays']:,} rays, {wall_off:.2f} s wall, {cpu_off:.2f} s CPU; "
                  f"with / without: rays {st['rays'] / st_off['rays']:.3f}, wall {wall / wall_off:.3f}, "
                  f"CPU {cpu / cpu_off:.3f}, CPU a ray {per_ray:.3f}", flush=True)
        else:
            # Invariant: an optic-free scene's ray count does not move.
            if st["pane_crossings"] or st["rays_through_panes"]:
                moved.append(f"{row['scene']}: {st['pane_crossings']} pane crossings in a scene without panes")
            recorded.append(dict(scene=row["scene"], preset=opt["preset"], rays=st["rays"], threads=threads,
                                 commit=commit))
            base = baseline.get((row["scene"], opt["preset"]))
            ratio = st["rays"] / int(base["rays"]) if base else None
            if base:
                row.update(baseline_rays=base["rays"], baseline_ratio=f"{ratio:.6f}")
                if abs(ratio - 1) > TOLERANCE:
                    moved.append(f"{row['scene']}: {st['rays']:,} rays, baseline {int(base['rays']):,}")
            print(f"{row['scene']:16} no optics: {st['rays']:,} rays, {wall:.2f} s wall, {cpu:.2f} s CPU; "
                  + (f"baseline {int(base['rays']):,} rays (commit {base['commit']}): ratio {ratio:.6f}"
                     if base else "no baseline recorded"), flush=True)
        rows.append(row)
    path = tables.path_for("effects_cost")
    tables.write(path, FIELDS, tables.kept_rows(path, rows, ("scene", "preset")), "What optical effects cost",
                 COLUMNS, NOTES)
    if opt["record_baseline"]:
        tables.write(baseline_path, BASELINE_FIELDS, tables.kept_rows(baseline_path, recorded, ("scene", "preset")),
                     "Rays of the scenes without optics", None,
                     BASELINE_NOTES)
        print("recorded", baseline_path)
    print(f"wrote {path}; load average at end {os.getloadavg()}")
    if moved:
        print("INVARIANT BROKEN: " + "; ".join(moved))
        sys.exit(1)


if __name__ == "__main__":
    main()

"""What alpha cut-outs cost: a few leaf cards read per ray from their alpha image, against the same
cards passing their mean alpha everywhere.

    /usr/bin/python3.11 bench/alpha_cost.py [--threads N] [--runs 3] [preset ...]

The scene: a 6 m floor and a back wall under four 1.2 m leaf cards (tilted, at 1.2-1.8 m), a sun at
40 degrees, a point lamp and a sky. The cards' alpha is one 1024 x 1024 image of random discs (about
half covered); their leaves are green. "alpha": the image and the cards' UVs (Material.alpha,
MeshDesc::corner_uv); "mean": the same transmittance times one minus the image's mean, no image.
Figures, medians of --runs: solve() wall and CPU seconds, its rays, pane crossings and rays through
panes (the engine's stats), then one update after a card moves 0.2 m (wall seconds and rays).
Writes bench/results/alpha_cost.csv and .md (tables.py).
"""
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from scenes import Mesh, engine, preset, threads_option  # noqa: E402
import tables  # noqa: E402

THREADS = threads_option(sys.argv)
LEAF = (0.15, 0.35, 0.08)
CARDS = [((-1.2, -0.8, 1.5), 0.3), ((0.4, -1.0, 1.2), -0.2), ((-0.3, 0.6, 1.8), 0.15), ((1.3, 0.7, 1.4), -0.35)]


def leaves(size=1024, discs=400, seed=7):
    """(size, size) alpha: 1 inside random discs, 0 between them."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size] / size
    alpha = np.zeros((size, size), np.float32)
    for cx, cy, r in zip(rng.random(discs), rng.random(discs), rng.uniform(0.01, 0.03, discs)):
        alpha[(x - cx) ** 2 + (y - cy) ** 2 < r * r] = 1.0
    return alpha


def card_transform(centre, tilt, dx=0.0):
    c, s = np.cos(tilt), np.sin(tilt)
    m = np.eye(4)
    m[:3, :3] = [[1, 0, 0], [0, c, -s], [0, s, c]]
    m[:3, 3] = (centre[0] + dx, centre[1], centre[2])
    return m


def build(kind, alpha, moved=0.0):
    """The scene with the cards' alpha per ray ("alpha") or as its mean ("mean"); card 0 moved by
    `moved` along x. Returns (scene, card 0's id)."""
    scene = engine.Scene()
    white = scene.add_material((0.6, 0.6, 0.6))
    mean = float(alpha.mean(dtype=np.float64))
    rho = tuple(mean * c for c in LEAF)
    leaf = (scene.add_material(rho, transmittance=(1.0, 1.0, 1.0), alpha=alpha) if kind == "alpha"
            else scene.add_material(rho, transmittance=(1 - mean,) * 3))
    room = Mesh()
    room.add_face([(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], white)
    room.add_face([(-3, 3, 0), (3, 3, 0), (3, 3, 2.5), (-3, 3, 2.5)], white)
    room.add_to(scene, refine="bilinear", patch_size=0.25)
    ids = []
    for k, (centre, tilt) in enumerate(CARDS):
        card = Mesh()
        card.add_face([(-0.6, -0.6, 0), (0.6, -0.6, 0), (0.6, 0.6, 0), (-0.6, 0.6, 0)], leaf)
        uv = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], float) if kind == "alpha" else None
        ids.append(card.add_to(scene, refine="bilinear", patch_size=0.3, corner_uv=uv, dynamic=k == 0,
                               transform=card_transform(centre, tilt, moved if k == 0 else 0.0)))
    scene.add_sun_light((0.4, -0.3, -0.77), (3.0, 3.0, 3.0), 0.02)
    scene.add_point_light((0.5, -1.5, 2.3), (10.0, 10.0, 10.0), 0.1)
    scene.set_world((0.1, 0.12, 0.15))
    return scene, ids[0]


def run(kind, alpha, settings):
    scene, card = build(kind, alpha)
    solver = engine.Solver(scene, settings)
    wall, cpu = time.perf_counter(), time.process_time()
    stats = solver.solve()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    solver.set_transform(card, card_transform(*CARDS[0], 0.2))
    moved = time.perf_counter()
    update = solver.update()
    moved = time.perf_counter() - moved
    return stats, wall, cpu, update, moved


def main():
    argv = sys.argv[1:]
    runs = 3
    if "--runs" in argv:
        at = argv.index("--runs")
        runs = int(argv[at + 1])
        del argv[at:at + 2]
    alpha = leaves()
    print(f"alpha image 1024 x 1024, mean {alpha.mean():.3f}; threads {THREADS or 'all cores'}; "
          f"load average {os.getloadavg()[0]:.2f}")
    rows = []
    for name in argv or ["default"]:
        for kind in ("mean", "alpha"):
            results = [run(kind, alpha, preset(name, THREADS)) for _ in range(runs)]
            stats, _, _, update, _ = results[0]
            row = dict(preset=name, cards=kind, rays=stats["rays"], pane_crossings=stats["pane_crossings"],
                       rays_through_panes=stats["rays_through_panes"],
                       wall=f"{statistics.median(r[1] for r in results):.3f}",
                       cpu=f"{statistics.median(r[2] for r in results):.3f}",
                       update_rays=update["rays"], update_wall=f"{statistics.median(r[4] for r in results):.3f}",
                       threads=THREADS or "all", load1=f"{os.getloadavg()[0]:.2f}")
            print(f"{name:8} {kind:5}  solve: {row['rays']:,} rays, {row['rays_through_panes']:,} through panes, "
                  f"{row['pane_crossings']:,} crossings, {row['wall']} s wall, {row['cpu']} s CPU; "
                  f"update after a card moves: {row['update_rays']:,} rays, {row['update_wall']} s", flush=True)
            rows.append(row)
    tables.write(tables.path_for("alpha_cost"), list(rows[0]), tables.kept_rows(
        tables.path_for("alpha_cost"), rows, ("preset", "cards")), "What alpha cut-outs cost",
        [("preset", "preset", None), ("cards", "cards", None), ("rays", "rays", tables.mega),
         ("rays_through_panes", "rays through panes", tables.count), ("pane_crossings", "pane crossings", tables.count),
         ("wall", "solve", tables.seconds), ("cpu", "CPU", tables.seconds), ("update_rays", "update rays", tables.mega),
         ("update_wall", "update", tables.seconds), ("load1", "load average", None)],
        "Four 1.2 m leaf cards over a floor and a wall, lit by a sun, a point lamp and a sky "
        "(bench/alpha_cost.py). alpha: each crossing reads the cards' 1024 x 1024 alpha image at its UV; "
        "mean: the cards pass the image's mean everywhere. Solve and update: wall seconds (update: one "
        "after a card moves 0.2 m), CPU: the process's over the solve; medians of the runs; rays and "
        "crossings are the engine's stats. 2 shared cores: see the load average.")


if __name__ == "__main__":
    main()

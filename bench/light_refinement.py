"""Refinement driven by the light against uniform refinement: patches, time and error against Cycles.

    blender -b --factory-startup --python bench/light_refinement.py -- [--scenes cornell_box,...] [--quick]

For each sample scene (animated_room at frame 1), exported as the add-on exports it, the engine
solves with the default preset's settings but for the refinement:
  uniform    patch_size_relative 1/16, 1/32 (default's), 1/64 (high's), no light refinement;
  light      patches starting at 1/16 or 1/32 and split by the light (Settings.light_refinement
             levels, Settings.light_contrast), down to 1/64 at the finest.
seconds: Solver construction (refinement, with light refinement its rounds) + solve, wall time.
Errors: relative RMS against the cached 4,096-spp dense Cycles bake (tests/cycles_reference/):
  dense_rms  at our refined patch corners, the reference interpolated there (accuracy_vs_time.py's
             dense metric, whose points are our patch corners: light refinement puts more of them
             where the light changes, so this one weighs those places more heavily than uniform);
  grid_rms   at the reference's own points (per-face grids of the flat cages), our solution
             interpolated there within the patch holding each point: the same points for every row.
             Subdivided objects (no grid) are left out of it.
Writes bench/results/light_refinement.csv and .md (tables.py) and prints the table.
"""
import os
import sys
import time
import types

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
from conftest import load_package  # noqa: E402  (the add-on from addon/, its engine from build/engine)
import accuracy_vs_time  # noqa: E402  (dense_error, open_scene, label)
import compare_engine  # noqa: E402  (face_frames)
import reference  # noqa: E402
import tables  # noqa: E402

SCENES = {"cornell_box": None, "subsurf_room": None, "animated_room": 1}
# (label, patch_size_relative, light_refinement, light_contrast)
CONFIGS = [("uniform", 1 / 16, 0, 0.0), ("uniform", 1 / 32, 0, 0.0), ("uniform", 1 / 64, 0, 0.0),
           ("light", 1 / 16, 1, 0.25), ("light", 1 / 16, 2, 0.1), ("light", 1 / 16, 2, 0.25),
           ("light", 1 / 32, 1, 0.1), ("light", 1 / 32, 1, 0.25), ("light", 1 / 32, 2, 0.25)]
QUICK = [CONFIGS[1], CONFIGS[3], CONFIGS[8]]
FIELDS = ["scene", "refinement", "start", "levels", "contrast", "patches", "uniform_patches", "seconds",
          "dense_rms", "grid_rms", "load1"]
COLUMNS = [("scene", "scene", None), ("refinement", "refinement", None), ("start", "start size", None),
           ("levels", "levels", None), ("contrast", "contrast", None), ("patches", "patches", None),
           ("uniform_patches", "uniform to its finest", None), ("seconds", "time", tables.seconds),
           ("dense_rms", "dense RMS (patch corners)", tables.percent),
           ("grid_rms", "dense RMS (reference grid)", tables.percent)]
NOTES = """The default preset's settings, but for the refinement. start: patch_size_relative (a
fraction of the scene's diagonal); levels: Settings.light_refinement, the times a patch may be
split in four where the light across it changes by more than `contrast` (light_contrast); uniform
to its finest: the patches uniform refinement at the smallest patch size the row may reach makes
(stats `uniform_patches`). Time: Solver construction (with its refinement rounds) + solve, wall,
2 shared cores (see load1 in the CSV). Errors: relative RMS against the 4,096-spp dense Cycles bake;
patch corners: at our refined patch corners (accuracy_vs_time's dense metric, whose points follow
our patches); reference grid: at the reference's own grid points on the flat cages, our patches
interpolated there (the same points for every row)."""


def options():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    quick = "--quick" in argv
    scenes = argv[argv.index("--scenes") + 1].split(",") if "--scenes" in argv else (
        ["cornell_box"] if quick else list(SCENES))
    return scenes, quick


def patches_by_face(m, pos, rad):
    """Per face of the flat all-quad cage `m`: its patches' corner (u, v) in the face (P,4,2) and
    radiance (P,4,3), the patches found by plane and facing as compare_engine.grid_lookup finds them."""
    corners = compare_engine.face_frames(m)
    pts, rad = pos.reshape(-1, 4, 3), rad.reshape(-1, 4, 3)
    normal = np.cross(pts[:, 2] - pts[:, 0], pts[:, 3] - pts[:, 1])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    centre = pts.mean(1)
    out = []
    for c in corners:
        e1, e3 = c[1] - c[0], c[3] - c[0]
        fn = np.cross(e1, e3)
        fn /= np.linalg.norm(fn)
        inv = np.linalg.pinv(np.stack([e1, e3], 1))                      # (2,3)
        uv_centre = (centre - c[0]) @ inv.T
        same = ((normal @ fn > 0.999) & (np.abs((centre - c[0]) @ fn) < 1e-4 * (1 + np.abs(c[0]).max()))
                & (uv_centre >= 0).all(1) & (uv_centre <= 1).all(1))
        out.append(((pts[same] - c[0]) @ inv.T, rad[same]))
    return out


def interpolate(uv_patches, rad_patches, uv):
    """Our radiance at points uv (G,2) of a face: bilinear within the patch (an axis-aligned box in
    the face's (u, v)) that holds each point, and whether one does."""
    lo, hi = uv_patches.min(1), uv_patches.max(1)                       # (P,2)
    eps = 1e-9
    inside = ((uv[:, None, :] >= lo[None] - eps) & (uv[:, None, :] <= hi[None] + eps)).all(2)   # (G,P)
    found = inside.any(1)
    p = inside.argmax(1)
    size = np.maximum(hi[p] - lo[p], 1e-300)
    # Each corner's place in its box, (0,0) (1,0) (0,1) (1,1) as 0..3, and its radiance put there.
    at = np.round((uv_patches[p] - lo[p][:, None]) / size[:, None]).astype(int)
    k = at[:, :, 0] + 2 * at[:, :, 1]                                     # (G,4)
    r = np.zeros_like(rad_patches[p])
    np.put_along_axis(r, k[:, :, None], rad_patches[p], 1)
    st = (uv - lo[p]) / size
    s, t = st[:, :1], st[:, 1:]
    value = (1 - s) * (1 - t) * r[:, 0] + s * (1 - t) * r[:, 1] + (1 - s) * t * r[:, 2] + s * t * r[:, 3]
    return value, found


def grid_error(sx, solver, ids, ref):
    """Relative RMS at the reference grid points of the flat cages; emitters and subdivided objects
    left out."""
    ours, refs = [], []
    for m in sx.meshes:
        emissive = np.array([max(sx.materials[i].emission) > 0 for i in m.face_materials])
        if emissive.all() or m.name + ":grid" not in ref:
            continue
        grid = ref[m.name + ":grid"]
        n = grid.shape[1] - 1
        t = np.arange(n + 1) / n
        u, v = np.meshgrid(t, t, indexing="ij")
        uv = np.stack([u.ravel(), v.ravel()], 1)
        pos, rad = solver.refined(ids[m.name])
        for f, (uv_p, rad_p) in enumerate(patches_by_face(m, np.asarray(pos), np.asarray(rad))):
            if emissive[f] or len(uv_p) == 0:
                continue
            value, found = interpolate(uv_p, rad_p, uv)
            ours.append(value[found])
            refs.append(grid[f].reshape(-1, 3)[found])
    return reference.relative_rms(np.concatenate(ours), np.concatenate(refs))


def run(pkg, engine, name, frame, config):
    kind, start, levels, contrast = config
    ref = reference.load(name, frame)
    accuracy_vs_time.open_scene(name, frame)
    sx = pkg.export.export_scene()
    scene, ids = pkg.export.to_engine(sx, engine)
    settings = engine.Settings.preset("default")
    settings.patch_size_relative = start
    settings.light_refinement = levels
    if levels:
        settings.light_contrast = contrast
    t = time.perf_counter()
    solver = engine.Solver(scene, settings)
    st = solver.solve()
    seconds = time.perf_counter() - t
    job = types.SimpleNamespace(export=sx, solver=solver, ids=ids)
    return dict(scene=accuracy_vs_time.label(name, frame), refinement=kind, start=f"1/{round(1 / start)}",
                levels=levels, contrast=contrast if levels else "", patches=st["patches"],
                uniform_patches=st["uniform_patches"], seconds=f"{seconds:.3f}",
                dense_rms=f"{accuracy_vs_time.dense_error(job, ref):.5f}",
                grid_rms=f"{grid_error(sx, solver, ids, ref):.5f}", load1=f"{os.getloadavg()[0]:.2f}")


def main():
    scenes, quick = options()
    pkg = load_package()
    engine = pkg.engine.load_engine()
    rows = []
    print(f"{'scene':16} {'refinement':10} {'start':>6} {'levels':>6} {'contrast':>8} {'patches':>8} "
          f"{'uniform':>8} {'seconds':>8} {'dense':>7} {'grid':>7}")
    for name in scenes:
        for config in QUICK if quick else CONFIGS:
            r = run(pkg, engine, name, SCENES[name], config)
            rows.append(r)
            print(f"{r['scene']:16} {r['refinement']:10} {r['start']:>6} {r['levels']:>6} {str(r['contrast']):>8} "
                  f"{r['patches']:>8} {r['uniform_patches']:>8} {float(r['seconds']):8.2f} "
                  f"{float(r['dense_rms']):7.2%} {float(r['grid_rms']):7.2%}", flush=True)
    tables.write(tables.path_for("light_refinement", quick), FIELDS, rows,
                 "Refinement driven by the light against uniform refinement", COLUMNS, NOTES)


if __name__ == "__main__":
    main()

"""Engine against the Cycles references, on the sample scenes.

    blender -b --factory-startup --python tests/cycles_reference/compare_engine.py [-- --preset default] [--only NAME]

Exports each sample scene with addon/export.py, solves it with the engine (build/engine must hold
the radiosity_engine module), and prints per object and per scene:
  corner: relative RMS and mean ratio (engine/Cycles) at the cage's face corners (ref "<name>:corner");
  dense:  the same over the engine's refined patch corners against the reference grid, bilinearly
          interpolated at each patch corner (flat all-quad cages), or the nearest evaluated vertex
          (subdivided objects).
Emitters are left out (their value is exactly their emission on both sides).
Cycles' own noise is ~0.5% (corners) and ~0.9% (grid) RMS: see README.md.
"""
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "build", "engine"))
import reference  # noqa: E402

SCENES = [("cornell_box", [None]), ("subsurf_room", [None]), ("animated_room", [1, 12, 24]), ("interior_room", [None])]


def load_export():
    """addon/export.py, as part of the add-on package from the source tree."""
    sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
    from conftest import load_package
    return load_package().export


def face_frames(m):
    """World-space corners (F,4,3) of an all-quad cage."""
    M = m.transform
    p = m.positions @ M[:3, :3].T + M[:3, 3]
    return p[m.face_vertices.reshape(-1, 4)]


def grid_lookup(corners, grid, pts, normals):
    """Reference values at engine patch corners: pts (P,4,3), normals (P,3). Returns (P,4,3), mask (P,)."""
    F = len(corners)
    n = grid.shape[1] - 1
    c0 = corners[:, 0]
    e1 = corners[:, 1] - c0
    e3 = corners[:, 3] - c0
    fn = np.cross(e1, e3)
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    centre = pts.mean(1)
    out = np.zeros(pts.shape)
    ok = np.zeros(len(pts), bool)
    # (u, v) by least squares in each face's parallelogram frame
    G = np.stack([e1, e3], 2)                                           # (F,3,2)
    Ginv = np.linalg.pinv(G)                                            # (F,2,3)
    for f in range(F):
        same = (normals @ fn[f] > 0.999) & (np.abs((centre - c0[f]) @ fn[f]) < 1e-4 * (1 + np.abs(c0[f]).max()))
        uvc = (centre - c0[f]) @ Ginv[f].T
        same &= (uvc > -1e-6).all(1) & (uvc < 1 + 1e-6).all(1) & ~ok
        if not same.any():
            continue
        uv = np.clip((pts[same] - c0[f]) @ Ginv[f].T, 0, 1) * n        # (S,4,2)
        i0 = np.minimum(np.floor(uv[..., 0]).astype(int), n - 1)
        j0 = np.minimum(np.floor(uv[..., 1]).astype(int), n - 1)
        a = (uv[..., 0] - i0)[..., None]
        b = (uv[..., 1] - j0)[..., None]
        g = grid[f]
        out[same] = ((1 - a) * (1 - b) * g[i0, j0] + a * (1 - b) * g[i0 + 1, j0]
                     + a * b * g[i0 + 1, j0 + 1] + (1 - a) * b * g[i0, j0 + 1])
        ok |= same
    return out, ok


def stats(v, r):
    v = np.asarray(v, np.float64).reshape(-1, 3)
    r = np.asarray(r, np.float64).reshape(-1, 3)
    return reference.relative_rms(v, r), float(v.sum() / max(r.sum(), 1e-30))


def run(name, frame, preset, export, engine):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", name + ".blend"))
    if frame is not None:
        bpy.context.scene.frame_set(frame)
    ref = reference.load(name, frame)
    sx = export.export_scene()
    s, ids = export.to_engine(sx, engine)
    t = time.perf_counter()
    solver = engine.Solver(s, engine.Settings.preset(preset))
    st = solver.solve()
    dt = time.perf_counter() - t
    label = name + (f"@{frame}" if frame is not None else "")
    print(f"\n{label}: preset {preset}, {dt:.2f} s, stats {st}")
    allc, allcr, alld, alldr = [], [], [], []
    for m in sx.meshes:
        emissive = np.array([max(sx.materials[i].emission) > 0 for i in m.face_materials])
        if emissive.all():
            continue
        keep = ~np.repeat(emissive, m.face_sizes)
        c = solver.corner_radiance(ids[m.name])[keep]
        cr = ref[m.name + ":corner"][keep]
        allc.append(c)
        allcr.append(cr)
        line = f"  {m.name:10s} corner rms {stats(c, cr)[0]*100:6.2f}%  ratio {stats(c, cr)[1]:.4f}"
        pos, rad = solver.refined(ids[m.name])
        pts = pos.reshape(-1, 4, 3)
        rad = rad.reshape(-1, 4, 3)
        if m.name + ":grid" in ref:
            nrm = np.cross(pts[:, 2] - pts[:, 0], pts[:, 3] - pts[:, 1])
            nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
            rv, ok = grid_lookup(face_frames(m), ref[m.name + ":grid"], pts, nrm)
            if (~ok).any():
                line += f"  ({(~ok).sum()} of {len(ok)} patches unmatched)"
            em_face = emissive[0] if emissive.any() else False
            d, dr = rad[ok], rv[ok]
        else:
            M = m.transform
            ep = ref[m.name + ":eval_pos"].astype(np.float64) @ M[:3, :3].T + M[:3, 3]
            q = pts.reshape(-1, 3)
            idx = np.argmin(((q[:, None, :] - ep[None]) ** 2).sum(2), 1)
            dist = np.sqrt(((q - ep[idx]) ** 2).sum(1))
            d, dr = rad.reshape(-1, 3), ref[m.name + ":eval_value"][idx]
            line += f"  (nearest evaluated vertex, median distance {np.median(dist):.3g})"
        alld.append(d.reshape(-1, 3))
        alldr.append(dr.reshape(-1, 3))
        r, q = stats(d, dr)
        line += f"  dense rms {r*100:6.2f}%  ratio {q:.4f}  ({len(d.reshape(-1,3))} patch corners)"
        print(line)
    c, cr = np.concatenate(allc), np.concatenate(allcr)
    d, dr = np.concatenate(alld), np.concatenate(alldr)
    print(f"  {'ALL':10s} corner rms {stats(c, cr)[0]*100:6.2f}%  ratio {stats(c, cr)[1]:.4f}   "
          f"dense rms {stats(d, dr)[0]*100:6.2f}%  ratio {stats(d, dr)[1]:.4f}")
    return stats(c, cr), stats(d, dr), dt


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    preset = argv[argv.index("--preset") + 1] if "--preset" in argv else "default"
    only = argv[argv.index("--only") + 1] if "--only" in argv else None
    import radiosity_engine as engine
    export = load_export()
    for name, frames in SCENES:
        if only and only != name:
            continue
        for f in frames:
            run(name, f, preset, export, engine)


if __name__ == "__main__":
    main()

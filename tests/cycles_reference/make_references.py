"""Cycles reference bakes for the sample scenes.

    blender -b --factory-startup --python tests/cycles_reference/make_references.py [-- --samples N] [--only NAME] [--seed S]
        [--corner-samples N] [--corners-only]

--corners-only bakes the corner layout again into the existing files and keeps their dense layout.

For each sample .blend (the animated room at frames 1, 12 and 24) this writes
tests/cycles_reference/<scene>[_fNNN].npz with Cycles' COMBINED bake (emission included), settings as
in DESIGN.md section 4: no denoising, no adaptive sampling, no clamping, 64 diffuse/max bounces.

Two layouts per mesh object, keyed by object name:

  "<name>:corner"   (K,3) float32  (at "samples_corner", 262,144 unless told: these few points
                    sit on junction lines where the noise is highest, and they are cheap; at 16,384
                    two bakes of the subsurf room differed by 2.4% RMS) baked into a CORNER-domain FLOAT_COLOR attribute on the object as
                    it is in the file, one row per face corner in mesh loop order (exactly what
                    solver.corner_radiance(o) returns; for an object with a Subdivision Surface
                    modifier Blender maps each cage corner to its vertex on the subdivided mesh).
  "<name>:grid"     (F,n+1,n+1,3) float32, only for objects whose faces are all quads and which have
                    no modifiers: each face f is re-meshed (separately, unwelded) into n x n quads
                    and baked into a POINT-domain attribute (the average of the 1-4 corners at each
                    grid vertex). grid[f, i, j] is at u = i/n, v = j/n of the bilinear map
                    P(u,v) = (1-u)(1-v) c0 + u(1-v) c1 + u v c2 + (1-u) v c3, c0..c3 = the face's
                    corners in loop order, object space. "<name>:grid_n" holds n.
  "<name>:eval_pos", "<name>:eval_value"  (V,3) float32, for objects with modifiers: the evaluated
                    (e.g. subdivided) mesh's vertex positions (object space) and POINT-domain values.
  "<name>:matrix_world" (4,4) float64 at the baked frame.

Plus "samples", "samples_corner", "frame", "seconds_corner", "seconds_dense", "blender_version", "layout" (text).
"""
import math
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cycles_settings  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SAMPLES_DIR = os.path.join(ROOT, "sample_blends")
SCENES = [("cornell_box", [None]), ("subsurf_room", [None]), ("animated_room", [1, 12, 24])]
GRID_EDGE = 0.25           # target grid spacing in metres for the dense layout
ATTR = "CyclesRef"


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    def value(flag, default, kind=int):
        return kind(argv[argv.index(flag) + 1]) if flag in argv else default
    # --seed S, for noise estimates, writes <scene>..._seedS.npz next to the references
    return (value("--samples", 4096), value("--only", None, str), value("--seed", 0),
            value("--corner-samples", 262144), "--corners-only" in argv)


def configure(sc, samples, seed=0):
    cycles_settings.unbiased(sc, samples, 64, seed)
    sc.render.bake.target = 'VERTEX_COLORS'
    sc.render.bake.use_selected_to_active = False


def bake(objects, domain):
    bpy.ops.object.select_all(action='DESELECT')
    for ob in objects:
        me = ob.data
        old = me.color_attributes.get(ATTR)
        if old is not None:
            me.color_attributes.remove(old)
        a = me.color_attributes.new(ATTR, 'FLOAT_COLOR', domain)
        me.color_attributes.active_color = a
        me.attributes.active_color = a
        ob.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    t = time.perf_counter()
    bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')
    dt = time.perf_counter() - t
    out = {}
    for ob in objects:
        a = ob.data.color_attributes[ATTR]
        c = np.empty(len(a.data) * 4, np.float32)
        a.data.foreach_get("color", c)
        out[ob.name] = c.reshape(-1, 4)[:, :3].copy()
    return out, dt


def mesh_arrays(me):
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    sizes = np.empty(len(me.polygons), np.int32)
    me.polygons.foreach_get("loop_total", sizes)
    lv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", lv)
    mi = np.empty(len(me.polygons), np.int32)
    me.polygons.foreach_get("material_index", mi)
    return co.reshape(-1, 3), sizes, lv, mi


def grid_mesh(ob, n):
    """Replace ob's quads by n x n unwelded grids, one per face; returns the new mesh."""
    co, sizes, lv, mi = mesh_arrays(ob.data)
    F = len(sizes)
    c = co[lv.reshape(F, 4)]                                       # (F,4,3)
    t = np.arange(n + 1) / n
    u, v = np.meshgrid(t, t, indexing="ij")                        # [i, j] -> u = i/n, v = j/n
    w = np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], -1)   # (n+1,n+1,4)
    verts = np.einsum("ijk,fkd->fijd", w, c).reshape(-1, 3)        # vertex id = (f*(n+1)+i)*(n+1)+j
    idx = np.arange(F * (n + 1) ** 2).reshape(F, n + 1, n + 1)
    q = np.stack([idx[:, :-1, :-1], idx[:, 1:, :-1], idx[:, 1:, 1:], idx[:, :-1, 1:]], -1)  # same winding
    q = q.reshape(-1, 4)
    me = bpy.data.meshes.new(ob.data.name + "_grid")
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", verts.ravel())
    me.loops.add(q.size)
    me.loops.foreach_set("vertex_index", q.ravel().astype(np.int32))
    me.polygons.add(len(q))
    me.polygons.foreach_set("loop_start", np.arange(0, q.size, 4, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(q), 4, np.int32))
    me.polygons.foreach_set("material_index", np.repeat(mi, n * n).astype(np.int32))
    me.update(calc_edges=True)
    me.validate()
    for m in ob.data.materials:
        me.materials.append(m)
    return me


def max_edge(ob):
    co, sizes, lv, _ = mesh_arrays(ob.data)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    nxt = np.arange(len(lv)) + 1
    ends = starts + sizes
    nxt[ends - 1] = starts
    p = co[lv]
    s = np.array(ob.matrix_world.to_scale())
    return float(np.linalg.norm((p[nxt] - p) * s, axis=1).max())


def run_scene(name, frame, samples, seed, samples_corner, corners_only):
    path = os.path.join(SAMPLES_DIR, name + ".blend")
    bpy.ops.wm.open_mainfile(filepath=path)
    sc = bpy.context.scene
    configure(sc, samples, seed)
    if frame is not None:
        sc.frame_set(frame)
    meshes = sorted([o for o in sc.objects if o.type == 'MESH'], key=lambda o: o.name)
    data = {"samples": np.int32(samples), "frame": np.int32(sc.frame_current),
            "blender_version": np.array(bpy.app.version_string),
            "layout": np.array(__doc__.split("Two layouts", 1)[1])}
    out = os.path.join(HERE, name + (f"_f{frame:03d}" if frame is not None else "")
                       + (f"_seed{seed}" if seed else "") + ".npz")
    sc.cycles.samples = samples_corner
    data["samples_corner"] = np.int32(samples_corner)
    corner, t_corner = bake(meshes, 'CORNER')
    sc.cycles.samples = samples
    for ob in meshes:
        data[ob.name + ":corner"] = corner[ob.name]
        data[ob.name + ":matrix_world"] = np.array(ob.matrix_world, np.float64)
    data["seconds_corner"] = np.float64(t_corner)
    n_corner = sum(len(v) for v in corner.values())
    if corners_only:
        with np.load(out) as old:
            kept = {k: old[k] for k in old.files if k not in data}
        np.savez_compressed(out, **{**kept, **data})
        print(f"REF {os.path.basename(out)}: corner layout {n_corner} corners at {samples_corner} spp "
              f"{t_corner:.1f} s (dense layout kept)", flush=True)
        return
    # dense layout
    dg = bpy.context.evaluated_depsgraph_get()
    kinds = {}
    for ob in meshes:
        sizes = mesh_arrays(ob.data)[1]
        if len(ob.modifiers) or (sizes != 4).any():
            ev = ob.evaluated_get(dg)
            me = bpy.data.meshes.new_from_object(ev)
            ob.modifiers.clear()
            ob.data = me
            kinds[ob.name] = ("eval", None)
        else:
            n = int(min(32, max(1, math.ceil(max_edge(ob) / GRID_EDGE))))
            ob.data = grid_mesh(ob, n)
            kinds[ob.name] = ("grid", n)
    dense, t_dense = bake(meshes, 'POINT')
    for ob in meshes:
        kind, n = kinds[ob.name]
        if kind == "grid":
            F = len(ob.data.polygons) // (n * n)
            data[ob.name + ":grid"] = dense[ob.name].reshape(F, n + 1, n + 1, 3)
            data[ob.name + ":grid_n"] = np.int32(n)
        else:
            co = np.empty(len(ob.data.vertices) * 3)
            ob.data.vertices.foreach_get("co", co)
            data[ob.name + ":eval_pos"] = co.reshape(-1, 3).astype(np.float32)
            data[ob.name + ":eval_value"] = dense[ob.name]
    n_dense = sum(len(v) for v in dense.values())
    data["seconds_dense"] = np.float64(t_dense)
    np.savez_compressed(out, **data)
    print(f"REF {os.path.basename(out)}: corner layout {n_corner} corners at {samples_corner} spp {t_corner:.1f} s, "
          f"dense layout {n_dense} points at {samples} spp {t_dense:.1f} s, {os.path.getsize(out)/1024:.0f} KiB",
          flush=True)


def main():
    samples, only, seed, samples_corner, corners_only = args()
    for name, frames in SCENES:
        if only and only != name:
            continue
        for f in frames:
            run_scene(name, f, samples, seed, samples_corner, corners_only)


if __name__ == "__main__":
    main()

"""Cycles reference bakes for the sample scenes.

    blender -b --factory-startup --python tests/cycles_reference/make_references.py [-- --samples N] [--only NAME] [--seed S]
        [--corner-samples N] [--inset F] [--corners-only | --inset-only]

--corners-only bakes the corner layout again into the existing files and keeps their other keys;
--inset-only does the same for the inset corner layout.

For each sample .blend (the animated room at frames 1, 12 and 24) this writes
tests/cycles_reference/<scene>[_fNNN].npz with Cycles' COMBINED bake (emission included), settings as
in DESIGN.md section 4: no denoising, no adaptive sampling, no clamping, 64 diffuse/max/transparent
bounces (cycles_settings.py says why transparent).

Three layouts per mesh object, keyed by object name:

  "<name>:corner"   (K,3) float32  (at "samples_corner", 262,144 unless told: these few points
                    sit on junction lines where the noise is highest, and they are cheap; at 16,384
                    two bakes of the subsurf room differed by 2.4% RMS) baked into a CORNER-domain FLOAT_COLOR attribute on the object as
                    it is in the file, one row per face corner in mesh loop order (exactly what
                    solver.corner_radiance(o) returns; for an object with a Subdivision Surface
                    modifier Blender maps each cage corner to its vertex on the subdivided mesh).
  "<name>:corner_inset" (K,3) float32, rows as in "<name>:corner", at "samples_inset": each corner
                    moved a little into its own face, where the face's value is well-posed. At a
                    corner on a junction with another surface (a box's foot on the floor) Cycles'
                    value is not: on the Cornell ShortBox's -y face it drops by ~40% within a
                    millimetre of the floor. Baked on an invisible copy of the object whose faces are
                    separated, each corner pulled toward its face's centroid by "inset_fraction" of
                    the distance (0.5%: past the drop) and lifted "inset_lift" metres (1e-5 x the
                    scene's diagonal) along the face's normal, so that its rays do not start on the
                    coincident face. For an object with a Subdivision Surface modifier the face is
                    the subdivided face at that corner, the one Cycles renders.
  "<name>:grid"     (F,n+1,n+1,3) float32, only for objects whose faces are all quads and which have
                    no modifiers: each face f is re-meshed (separately, unwelded) into n x n quads
                    and baked into a POINT-domain attribute (the average of the 1-4 corners at each
                    grid vertex). grid[f, i, j] is at u = i/n, v = j/n of the bilinear map
                    P(u,v) = (1-u)(1-v) c0 + u(1-v) c1 + u v c2 + (1-u) v c3, c0..c3 = the face's
                    corners in loop order, object space. "<name>:grid_n" holds n.
  "<name>:eval_pos", "<name>:eval_value"  (V,3) float32, for objects with modifiers: the evaluated
                    (e.g. subdivided) mesh's vertex positions (object space) and POINT-domain values.
  "<name>:matrix_world" (4,4) float64 at the baked frame.

Plus "samples", "samples_corner", "samples_inset", "inset_fraction", "inset_lift", "frame",
"seconds_corner", "seconds_inset", "seconds_dense", "blender_version", "layout" (text).
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
SCENES = [("cornell_box", [None]), ("subsurf_room", [None]), ("animated_room", [1, 12, 24]), ("interior_room", [None])]
GRID_EDGE = 0.25           # target grid spacing in metres for the dense layout
ATTR = "CyclesRef"
INSET = 0.005              # corner_inset: fraction of the corner-to-centroid distance
LIFT = 1e-5                # corner_inset: lift off the face, times the scene's diagonal


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    def value(flag, default, kind=int):
        return kind(argv[argv.index(flag) + 1]) if flag in argv else default
    # --seed S, for noise estimates, writes <scene>..._seedS.npz next to the references
    only = "corners" if "--corners-only" in argv else "inset" if "--inset-only" in argv else None
    return (value("--samples", 4096), value("--only", None, str), value("--seed", 0),
            value("--corner-samples", 262144), value("--inset", INSET, float), only)


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


def world_faces(ob):
    """(positions (L,3), face normals (L,3)) per face corner, and the faces as (n,3) arrays, of a
    mesh object's cage in world space."""
    co, sizes, lv, _ = mesh_arrays(ob.data)
    M = np.array(ob.matrix_world)
    co = co @ M[:3, :3].T + M[:3, 3]
    fn = np.empty(3 * len(ob.data.polygons))
    ob.data.polygons.foreach_get("normal", fn)
    fn = fn.reshape(-1, 3) @ np.linalg.inv(M[:3, :3])     # normals go by the inverse transpose
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    return co[lv], np.repeat(fn, sizes, 0), np.split(co[lv], np.cumsum(sizes)[:-1])


def emitting_corners(ob):
    """Face corners of faces whose material has an Emission node of strength > 0: the corners the
    comparisons leave out (an emitter's value is its emission)."""
    _, sizes, _, mats = mesh_arrays(ob.data)
    emit = np.zeros(len(mats), bool)
    for i, slot in enumerate(ob.material_slots):
        m = slot.material
        if m is not None and m.use_nodes and any(
                n.type == 'EMISSION' and n.inputs["Strength"].default_value > 0 for n in m.node_tree.nodes):
            emit[mats == i] = True
    return np.repeat(emit, sizes)


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


def render_corners(ob, dg):
    """The mesh Cycles renders for ob (object space, to be removed by the caller) and, per cage
    corner, the index of the render mesh's loop that stands for it."""
    if not ob.modifiers:
        return ob.data.copy(), np.arange(len(ob.data.loops))
    assert [m.type for m in ob.modifiers] == ['SUBSURF'], f"{ob.name}: only a Subdivision Surface is handled"
    co, sizes, lv, _ = mesh_arrays(ob.data)
    assert (sizes == 4).all(), f"{ob.name}: the subdivided cage must be all quads"
    me = bpy.data.meshes.new_from_object(ob.evaluated_get(dg))
    _, esizes, elv, _ = mesh_arrays(me)
    # Blender's subdivided mesh keeps the cage's vertices first, in order, and each cage face's
    # children together; the asserts catch it if that ever changes
    m = len(esizes) // len(sizes)
    assert len(esizes) == m * len(sizes) and (esizes == 4).all()
    eloops = elv.reshape(len(sizes), m * 4)
    pick = np.empty(len(lv), np.int64)
    for l, v in enumerate(lv):
        hit = np.flatnonzero(eloops[l // 4] == v)
        assert len(hit) == 1, f"{ob.name}: cage corner {l} not found on the subdivided mesh"
        pick[l] = (l // 4) * m * 4 + hit[0]
    return me, pick


def scene_diagonal(meshes, dg):
    p = np.concatenate([np.array([ob.matrix_world @ v.co for v in ob.evaluated_get(dg).data.vertices])
                        for ob in meshes])
    return float(np.linalg.norm(p.max(0) - p.min(0)))


def inset_copy(ob, me, pick, fraction, lift):
    """An invisible copy of ob (same transform and animation) made of me's faces that hold the
    corners in pick, separated, each corner pulled toward its face's centroid by fraction of the
    way and lifted lift metres (world space) along the face's normal. Returns the copy and, per
    corner in pick, its loop on the copy."""
    co, sizes, lv, mi = mesh_arrays(me)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    face_of = np.repeat(np.arange(len(sizes)), sizes)
    faces = np.unique(face_of[pick])
    loops = np.concatenate([np.arange(starts[f], starts[f] + sizes[f]) for f in faces])
    new_loop = np.full(len(lv), -1)
    new_loop[loops] = np.arange(len(loops))
    fsizes = sizes[faces]
    fstarts = np.concatenate([[0], np.cumsum(fsizes)[:-1]])
    p = co[lv[loops]]
    centroid = np.repeat(np.add.reduceat(p, fstarts) / fsizes[:, None], fsizes, axis=0)
    fn = np.empty(len(sizes) * 3)
    me.polygons.foreach_get("normal", fn)
    # a normal transforms by the inverse transpose; the lift is measured in the world
    M = np.array(ob.matrix_world)[:3, :3]
    n_world = fn.reshape(-1, 3)[faces] @ np.linalg.inv(M)
    n_world /= np.linalg.norm(n_world, axis=1, keepdims=True)
    offset = (lift * n_world) @ np.linalg.inv(M).T
    p = p + fraction * (centroid - p) + np.repeat(offset, fsizes, axis=0)
    me.calc_normals_split()
    ln = np.empty(len(lv) * 3)
    me.loops.foreach_get("normal", ln)
    smooth = np.empty(len(sizes), bool)
    me.polygons.foreach_get("use_smooth", smooth)

    cm = bpy.data.meshes.new(ob.name + "_inset")
    cm.vertices.add(len(p))
    cm.vertices.foreach_set("co", p.ravel())
    cm.loops.add(len(p))
    cm.loops.foreach_set("vertex_index", np.arange(len(p), dtype=np.int32))
    cm.polygons.add(len(faces))
    cm.polygons.foreach_set("loop_start", fstarts.astype(np.int32))
    cm.polygons.foreach_set("loop_total", fsizes.astype(np.int32))
    cm.polygons.foreach_set("material_index", mi[faces].astype(np.int32))
    cm.polygons.foreach_set("use_smooth", smooth[faces])
    cm.update(calc_edges=True)
    cm.validate()
    # separating the faces would flatten a smooth surface's shading: keep the rendered normals
    cm.use_auto_smooth = True
    cm.normals_split_custom_set(ln.reshape(-1, 3)[loops].tolist())
    for m in me.materials:
        cm.materials.append(m)
    copy = ob.copy()
    copy.name = ob.name + "_inset"
    copy.modifiers.clear()
    copy.data = cm
    # Cycles drops an object no ray can see, from the bake too: transmission and volume rays keep
    # it, and the scenes have neither
    for ray in ("camera", "diffuse", "glossy", "shadow"):
        setattr(copy, "visible_" + ray, False)
    bpy.context.scene.collection.objects.link(copy)
    return copy, new_loop[pick]


def bake_corner(sc, meshes, samples_corner):
    sc.cycles.samples = samples_corner
    corner, dt = bake(meshes, 'CORNER')
    data = {"samples_corner": np.int32(samples_corner), "seconds_corner": np.float64(dt)}
    for ob in meshes:
        data[ob.name + ":corner"] = corner[ob.name]
        data[ob.name + ":matrix_world"] = np.array(ob.matrix_world, np.float64)
    n = sum(len(v) for v in corner.values())
    return data, f"corner layout {n} corners at {samples_corner} spp {dt:.1f} s"


def bake_inset(sc, meshes, samples_corner, fraction):
    dg = bpy.context.evaluated_depsgraph_get()
    lift = LIFT * scene_diagonal(meshes, dg)
    copies = []
    for ob in meshes:
        me, pick = render_corners(ob, dg)
        copies.append((ob, *inset_copy(ob, me, pick, fraction, lift)))
        bpy.data.meshes.remove(me)
    bpy.context.view_layer.update()
    for ob, copy, _ in copies:
        assert np.allclose(np.array(copy.matrix_world), np.array(ob.matrix_world), atol=1e-6), copy.name
    sc.cycles.samples = samples_corner
    inset, dt = bake([c for _, c, _ in copies], 'CORNER')
    data = {"samples_inset": np.int32(samples_corner), "seconds_inset": np.float64(dt),
            "inset_fraction": np.float64(fraction), "inset_lift": np.float64(lift)}
    for ob, copy, pick in copies:
        data[ob.name + ":corner_inset"] = inset[copy.name][pick]
        me = copy.data
        bpy.data.objects.remove(copy)
        bpy.data.meshes.remove(me)
    n = sum(len(pick) for *_, pick in copies)
    return data, (f"inset corner layout {n} corners ({sum(len(v) for v in inset.values())} baked) "
                  f"at {samples_corner} spp, inset {fraction:g}, {dt:.1f} s")


def run_scene(name, frame, samples, seed, samples_corner, fraction, only):
    path = os.path.join(SAMPLES_DIR, name + ".blend")
    bpy.ops.wm.open_mainfile(filepath=path)
    sc = bpy.context.scene
    configure(sc, samples, seed)
    if frame is not None:
        sc.frame_set(frame)
    meshes = sorted([o for o in sc.objects if o.type == 'MESH'], key=lambda o: o.name)
    out = os.path.join(HERE, name + (f"_f{frame:03d}" if frame is not None else "")
                       + (f"_seed{seed}" if seed else "") + ".npz")
    data, notes = {}, []
    if only != "inset":
        data.update({"samples": np.int32(samples), "frame": np.int32(sc.frame_current),
                     "blender_version": np.array(bpy.app.version_string),
                     "layout": np.array(__doc__.split("Three layouts", 1)[1])})
        part, note = bake_corner(sc, meshes, samples_corner)
        data.update(part)
        notes.append(note)
    if only != "corners":
        part, note = bake_inset(sc, meshes, samples_corner, fraction)
        data.update(part)
        notes.append(note)
    if only:
        with np.load(out) as old:
            kept = {k: old[k] for k in old.files if k not in data}
        np.savez_compressed(out, **{**kept, **data})
        print(f"REF {os.path.basename(out)}: " + ", ".join(notes) + " (other keys kept)", flush=True)
        return
    sc.cycles.samples = samples
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
    print(f"REF {os.path.basename(out)}: " + ", ".join(notes)
          + f", dense layout {n_dense} points at {samples} spp {t_dense:.1f} s, {os.path.getsize(out)/1024:.0f} KiB",
          flush=True)


def main():
    samples, scene, seed, samples_corner, fraction, only = args()
    for name, frames in SCENES:
        if scene and scene != name:
            continue
        for f in frames:
            run_scene(name, f, samples, seed, samples_corner, fraction, only)


if __name__ == "__main__":
    main()

"""From one export to the next as the engine's Solver takes it: the layout a Solver keeps (align_export),
the calls that send only what changed (diff_exports), and when a new Solver costs less (outgrown).

Everything is compared with numpy (whole arrays, no per-vertex loops); equal data sends nothing."""
from dataclasses import replace

import numpy as np

from . import export as exporter


def _same(a, b):
    if a is None or b is None:
        return a is None and b is None
    return np.array_equal(np.asarray(a), np.asarray(b))


def _lamp_call(index, l):
    """The Solver.set_*_light call (name, args) that sets lamp `index` to LightExport `l`."""
    return f"set_{l.kind}_light", (index, *exporter.lamp_args(l))


# For the messages that report a rebuild.
REBUILD_NOTE = ("the engine takes every change of the scene incrementally, objects, lamps and materials "
                "added included, but for new quality settings, an object added beyond the scene's size, a "
                "deformation that opens a crease, or deleted and replaced objects outweighing the scene")

# Appended (with its index) to the name of a mesh or lamp the Solver keeps but the scene no longer
# has as it was (align_export): no Blender name holds a NUL.
RETIRED = "\0retired"


def _same_layout(a, b):
    """Whether the engine can take mesh `b` in place of `a`: the same patches, points, shading, colours
    and UVs."""
    return (a.refine == b.refine and a.level == b.level and a.deforms == b.deforms
            and a.positions.shape == b.positions.shape
            and np.array_equal(a.face_sizes, b.face_sizes) and np.array_equal(a.face_vertices, b.face_vertices)
            and np.array_equal(a.face_materials, b.face_materials)
            and _same(a.smooth, b.smooth) and _same(a.corner_reflectance, b.corner_reflectance)
            and _same(a.corner_emission, b.corner_emission) and _same(a.corner_uv, b.corner_uv))


def _as_held(a, b, bent):
    """Mesh export `b` as the Solver that holds `a` should take it: deforming (MeshDesc::deforms, each
    flat face keeping its own point at the vertices it shares) once `a` is, or with `bent` where its
    own vertices moved with no modifier or shape key behind them (a script's edit, Edit Mode's once
    left)."""
    flat = b.refine != "catmull_clark" and (b.smooth is None or not np.all(b.smooth))
    moved = a.positions.shape == b.positions.shape and not np.array_equal(a.positions, b.positions)
    return replace(b, deforms=True) if not b.deforms and (a.deforms or (bent and flat and moved)) else b


def align_export(old, new, bent=False):
    """`new` laid out as the Solver that holds `old` will hold it: old's meshes, lamps and materials
    first, by index in old's order, then what `new` adds (diff_exports sends those with Solver.add).

    A mesh or lamp hidden from render, or missing from `new` (deleted, its collection excluded), is
    old's, hidden (lamps dark): the engine keeps what it had, only its visibility changes, and it can
    come back later (undo of a delete). A visible mesh is new's, its material indices mapped to the
    result's list. A mesh the engine cannot change in place (its topology, material assignment,
    smooth / flat shading, texture colours or UVs or whether it deforms changed) or a lamp of another type or area shape keeps
    old's entry, renamed RETIRED and hidden or dark, and comes again after, as new's. `bent`: the
    engine refused `new` as a change of `old` (flat faces bent apart at a vertex they share); flat
    meshes whose own vertices moved go as deforming from then on (_as_held)."""
    materials = list(old.materials)    # a material no object of `new` uses keeps old's values
    mat_index = {m.name: i for i, m in enumerate(materials)}
    for m in new.materials:
        if m.name not in mat_index:
            mat_index[m.name] = len(materials)
            materials.append(m)
        materials[mat_index[m.name]] = m
    to_state = np.array([mat_index[m.name] for m in new.materials] or [0], np.int32)
    fresh = {m.name: replace(m, face_materials=to_state[m.face_materials]) for m in new.meshes}
    meshes, added = [], []
    for i, a in enumerate(old.meshes):
        b = fresh.pop(a.name, None)
        if b is None or not b.visible:
            meshes.append(replace(a, visible=False))
            continue
        b = _as_held(a, b, bent)
        if _same_layout(a, b):
            meshes.append(b)
        else:
            meshes.append(replace(a, name=f"{a.name}{RETIRED}{i}", visible=False))
            added.append(b)
    fresh_lights = {l.name: l if l.visible else exporter.dark(l) for l in new.lights}
    lights, added_lights = [], []
    for i, a in enumerate(old.lights):
        b = fresh_lights.pop(a.name, None)
        if b is None or not b.visible:
            lights.append(exporter.dark(a))
        elif (a.kind, a.shape) != (b.kind, b.shape):
            lights.append(exporter.dark(replace(a, name=f"{a.name}{RETIRED}{i}")))
            added_lights.append(b)
        else:
            lights.append(b)
    return replace(new, meshes=meshes + added + list(fresh.values()), materials=materials,
                   lights=lights + added_lights + list(fresh_lights.values()))


def outgrown(aligned, sx):
    """Why the Solver holding `aligned` (align_export's layout of the scene `sx`) should be dropped for
    a new one, or None. It keeps every object deleted or replaced by another topology, hidden, for its
    life: an edit session that keeps replacing a large object would grow it without end. Once those
    hold more faces than the scene itself (faces stand for the patches they refine to), one full
    solve of the scene as it is costs less than carrying them."""
    names = {m.name for m in sx.meshes}
    dead = [m for m in aligned.meshes if m.name not in names]
    dead_faces = sum(len(m.face_sizes) for m in dead)
    live_faces = sum(len(m.face_sizes) for m in sx.meshes)
    if dead_faces <= live_faces:
        return None
    return (f"{len(dead)} objects deleted or replaced since the last full solve hold more faces than the "
            f"scene ({dead_faces} against {live_faces})")


def diff_exports(old, new, engine):
    """The engine calls [(Solver method name, args)] that turn the scene `old` (a SceneExport as a
    Solver holds it, mesh i its object i) into `new`, laid out alike (align_export): set_* for what
    both hold, one `add` (an engine Scene from the `engine` module) for what `new` holds past old.

    Everything is compared with numpy (whole arrays, no per-vertex loops); equal data sends nothing."""
    calls = []
    for i, (a, b) in enumerate(zip(old.meshes, new.meshes)):
        if a.visible != b.visible:
            calls.append(("set_visible", (i, b.visible)))
        if not np.array_equal(a.transform, b.transform):
            calls.append(("set_transform", (i, b.transform)))
        if not np.array_equal(a.positions, b.positions):
            calls.append(("set_positions", (i, b.positions)))
    for i, (a, b) in enumerate(zip(old.materials, new.materials)):
        if not (_same(a.reflectance, b.reflectance) and a.lobes() == b.lobes()):
            calls.append(("set_material", (i, b.reflectance, *b.lobes().values())))
    for i, (a, b) in enumerate(zip(old.lights, new.lights)):
        ca, cb = _lamp_call(i, a), _lamp_call(i, b)
        if not all(_same(x, y) if isinstance(x, np.ndarray) or isinstance(y, np.ndarray) else x == y
                   for x, y in zip(ca[1], cb[1])):
            calls.append(cb)
    if not (_same(old.world, new.world) and _same(old.world_map, new.world_map)):
        calls.append(("set_world_map", (np.asarray(new.world_map, np.float64),)) if new.world_map is not None
                     else ("set_world", (np.asarray(new.world, np.float64),)))
    if (len(new.meshes), len(new.materials), len(new.lights)) != (len(old.meshes), len(old.materials),
                                                                   len(old.lights)):
        calls.append(("add", (exporter.to_engine(new, engine, after=old)[0],)))
    return calls


def apply_calls(solver, calls):
    for name, args in calls:
        getattr(solver, name)(*args)

"""Helpers to read the Cycles reference bakes (plain numpy, no Blender needed).

    from reference import load, corner_reference, grid_positions, relative_rms
    ref = load("cornell_box")                 # or load("animated_room", frame=12)
    err = relative_rms(engine_corner_values, corner_reference(ref, "Room"))
    err_inset = relative_rms(engine_corner_values, corner_reference(ref, "Room", inset=True))
    open_ = ~junction_faces(corner_positions, corner_normals, faces).any(1)   # off junctions
    traced = traced_reference(load_traced("cornell_box"), "Room")   # None where not traced
    err_limit = relative_rms(engine_corner_values, limit_reference(corner_reference(ref, "Room"), traced, ~open_))

Layouts are documented in make_references.py.
"""
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def path_of(scene, frame=None):
    return os.path.join(HERE, scene + (f"_f{frame:03d}" if frame is not None else "") + ".npz")


def read_npz(path):
    """{key: array} of one .npz file, read whole (the file closed again)."""
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def load(scene, frame=None):
    """{key: array} of one reference file."""
    return read_npz(path_of(scene, frame))


def traced_path_of(scene, frame=None):
    return path_of(scene, frame).replace(".npz", "_traced.npz")


def load_traced(scene, frame=None):
    """{key: array} of the scene's traced corners (trace_corner.py ... all), or None."""
    path = traced_path_of(scene, frame)
    return read_npz(path) if os.path.exists(path) else None


def objects(ref):
    return sorted({k.split(":")[0] for k in ref if ":" in k})


def corner_reference(ref, name, inset=False):
    """(K,3) Cycles values at object name's cage corners, loop order: at the corners themselves, or
    (inset) a little inside each corner's face, which a junction with another surface leaves
    well-posed."""
    key = name + (":corner_inset" if inset else ":corner")
    if key not in ref:
        raise KeyError(f"{key} is not in this file: bake it with make_references.py -- --inset-only")
    return ref[key]


def traced_reference(traced, name):
    """(K,3) a path tracer's values a hair inside object name's cage corners (trace_corner.py), loop
    order; None if it was not traced."""
    key = name + ":corner_traced"
    return None if traced is None or key not in traced else traced[key]


def limit_reference(cycles, inside, junction):
    """Per corner: Cycles' value where it is well-posed, and on a junction (`junction`,
    junction_faces(...).any(1)), where Cycles' vertex bake gives neither limit of the corner's
    value, `inside`: the value a hair inside the corner's face (a path tracer's, trace_corner.py, or
    Cycles' inset bake)."""
    return np.where(np.asarray(junction)[:, None], inside, cycles)


def grid_positions(positions, face_vertices, n, transform=None):
    """(F,n+1,n+1,3) points of the 'grid' layout of an all-quad cage; world space if transform given."""
    c = np.asarray(positions, np.float64)[np.asarray(face_vertices).reshape(-1, 4)]
    t = np.arange(n + 1) / n
    u, v = np.meshgrid(t, t, indexing="ij")
    w = np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], -1)
    p = np.einsum("ijk,fkd->fijd", w, c)
    if transform is not None:
        M = np.asarray(transform, np.float64)
        p = p @ M[:3, :3].T + M[:3, 3]
    return p


def relative_rms(values, reference, mask=None):
    """sqrt(mean |v - r|^2) / mean(r) over all channels (optionally only rows where mask)."""
    v = np.asarray(values, np.float64).reshape(-1, 3)
    r = np.asarray(reference, np.float64).reshape(-1, 3)
    if mask is not None:
        v, r = v[mask], r[mask]
    return float(np.sqrt(np.mean((v - r) ** 2)) / max(np.mean(r), 1e-30))


def junction_faces(positions, normals, faces, tolerance=1e-5):
    """(K, F) bool: which faces each corner (world position, its face's unit normal) lies on where
    they rise in front of its own face, two surfaces meeting at a concave angle: a room's corners,
    a box's feet on the floor. There Cycles' value at the corner itself is ill-posed: the other
    surface is seen edge-on, and its value rises steeply into the face (Cornell ShortBox's foot
    0.053 at the corner, 0.067 1 mm up, 0.072 1 cm up; a room's corner +1.3% in its first 0.1 mm).
    `faces`: (n,3) world-space arrays of corners, one per face of everything that renders (convex);
    tolerance is relative to the scene's size. A corner on none: `~junction_faces(...).any(1)`."""
    p = np.asarray(positions, np.float64).reshape(-1, 3)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    scale = np.ptp(np.concatenate([np.asarray(f, np.float64) for f in faces]), axis=0).max()
    eps = tolerance * scale
    hits = np.zeros((len(p), len(faces)), bool)
    for k, f in enumerate(faces):
        f = np.asarray(f, np.float64)
        fn = np.cross(f[1] - f[0], f[2] - f[0])
        fn /= np.linalg.norm(fn)
        on_plane = np.abs((p - f[0]) @ fn) < eps
        # inside the face or on its boundary: not outside any edge
        edges = np.roll(f, -1, 0) - f
        side = np.einsum("ed,ked->ke", np.cross(edges, fn), p[:, None] - f[None])
        inside = (side <= eps * np.linalg.norm(edges, axis=1)).all(1)
        rises = ((f[None] - p[:, None]) * n[:, None]).sum(2).max(1) > eps  # some of it in front
        crossing = np.abs(n @ fn) < 1 - 1e-6
        hits[:, k] = on_plane & inside & rises & crossing
    return hits

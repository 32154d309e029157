"""Helpers to read the Cycles reference bakes (plain numpy, no Blender needed).

    from reference import load, corner_reference, grid_positions, relative_rms
    ref = load("cornell_box")                 # or load("animated_room", frame=12)
    err = relative_rms(engine_corner_values, corner_reference(ref, "Room"))
    err_inset = relative_rms(engine_corner_values, corner_reference(ref, "Room", inset=True))

Layouts are documented in make_references.py.
"""
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def path_of(scene, frame=None):
    return os.path.join(HERE, scene + (f"_f{frame:03d}" if frame is not None else "") + ".npz")


def load(scene, frame=None):
    """{key: array} of one reference file."""
    with np.load(path_of(scene, frame)) as z:
        return {k: z[k] for k in z.files}


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

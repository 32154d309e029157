"""The Cycles reference files agree with the sample scenes and with export's corner layout."""
import glob
import os
import sys

import numpy as np
import pytest

from conftest import ROOT

REF_DIR = os.path.join(ROOT, "tests", "cycles_reference")
sys.path.insert(0, REF_DIR)
import reference  # noqa: E402
REFS = sorted(p for p in glob.glob(os.path.join(REF_DIR, "*.npz"))
              if "_seed" not in os.path.basename(p) and not p.endswith("_traced.npz"))
TRACED = sorted(glob.glob(os.path.join(REF_DIR, "*_traced.npz")))


def scene_of(path):
    base = os.path.basename(path)[:-4]
    if "_f" in base and base.rsplit("_f", 1)[1].isdigit():
        name, f = base.rsplit("_f", 1)
        return name, int(f)
    return base, None


@pytest.mark.skipif(not REFS, reason="no reference files")
@pytest.mark.parametrize("path", REFS, ids=[os.path.basename(p) for p in REFS])
def test_reference_matches_export(export, open_sample, path):
    name, frame = scene_of(path)
    open_sample(name, frame)
    s = export.export_scene()
    ref = np.load(path)
    assert int(ref["samples"]) >= 1024 and int(ref["samples_corner"]) >= int(ref["samples"])
    if frame is not None:
        assert int(ref["frame"]) == frame
    objs = {k.split(":")[0] for k in ref.files if ":" in k}
    assert objs == {m.name for m in s.meshes}
    for m in s.meshes:
        corner = ref[m.name + ":corner"]
        assert corner.shape == (len(m.face_vertices), 3) and corner.dtype == np.float32
        assert np.isfinite(corner).all() and (corner >= 0).all()
        np.testing.assert_allclose(ref[m.name + ":matrix_world"], m.transform, atol=1e-5)
        if m.name + ":grid" in ref.files:
            g = ref[m.name + ":grid"]
            n = int(ref[m.name + ":grid_n"])
            assert g.shape == (len(m.face_sizes), n + 1, n + 1, 3)
            # the grid's corner points are the cage corners: same values up to Monte Carlo noise
            gc = np.stack([g[:, 0, 0], g[:, -1, 0], g[:, -1, -1], g[:, 0, -1]], 1).reshape(-1, 3)
            assert np.abs(gc - corner).mean() <= 0.05 * corner.mean() + 1e-6
            p = reference.grid_positions(m.positions, m.face_vertices, n, m.transform)
            assert p.shape[:3] == g.shape[:3]
            assert reference.relative_rms(gc, corner) < 0.1
        else:
            assert ref[m.name + ":eval_pos"].shape == ref[m.name + ":eval_value"].shape
    # emitters bake to their emission; at 262,144 spp Cycles' float sums round a constant sample
    # (42.5 lost 0.29% at the Cornell lamp), hence 0.5% rather than exactly
    for m in s.meshes:
        em = np.array([s.materials[i].emission for i in m.face_materials])
        lit = em.max(1) > 0
        if lit.any():
            corner = ref[m.name + ":corner"]
            per_corner = np.repeat(em, m.face_sizes, axis=0)
            sel = np.repeat(lit, m.face_sizes)
            np.testing.assert_allclose(corner[sel], per_corner[sel], rtol=5e-3)


@pytest.mark.parametrize("path", TRACED, ids=[os.path.basename(p) for p in TRACED])
def test_traced_corners_match_export_and_cycles(export, open_sample, path):
    # trace_corner.py's corners: one value per cage corner of each traced object, finite where it
    # does not emit, and on average within a few per cent of Cycles' (they part at junctions only)
    name, frame = scene_of(path[:-len("_traced.npz")] + ".npz")
    open_sample(name, frame)
    meshes = {m.name: m for m in export.export_scene().meshes}
    traced, ref = reference.load_traced(name, frame), reference.load(name, frame)
    for obj in {k.split(":")[0] for k in traced if k.endswith(":corner_traced")}:
        t = reference.traced_reference(traced, obj)
        assert t.shape == (len(meshes[obj].face_vertices), 3)
        lit = np.isfinite(t).all(1)
        assert lit.any()
        assert reference.relative_rms(t[lit], reference.corner_reference(ref, obj)[lit]) < 0.04

"""Stacked copies of a face, in one mesh or across meshes, light the scene as one copy does: a ray
tracer (Cycles) sees the first of coincident surfaces, and k copies left in would reflect k times
the light (a stack of a bright face diverges)."""
import functools
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, engine  # noqa: E402

FLOOR = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
PANEL = [(-0.5, -0.5, 0.5), (-0.5, 0.5, 0.5), (0.5, 0.5, 0.5), (0.5, -0.5, 0.5)]   # facing the floor


@functools.lru_cache(maxsize=None)
def solve(copies, one_mesh):
    """A white floor under a white panel, `copies` times over, lit by a lamp between them."""
    scene = engine.Scene()
    white = scene.add_material((0.8, 0.8, 0.8))
    floor = Mesh()
    floor.add_face(FLOOR, white)
    meshes = [Mesh() for _ in range(1 if one_mesh else copies)]
    for c in range(copies):
        meshes[0 if one_mesh else c].add_face(PANEL, white)
    ids = [m.add_to(scene, refine="bilinear", patch_size=0.1) for m in [floor] + meshes]
    scene.add_point_light((0, 0, 0.25), (5, 5, 5), 0.01)
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    return solver, solver.solve(), ids


@pytest.mark.parametrize("one_mesh", [True, False], ids=["in one mesh", "across meshes"])
def test_five_stacked_copies_light_the_scene_as_one(one_mesh):
    one, _, (floor, panel) = solve(1, True)
    five, stats, ids = solve(5, one_mesh)
    assert not stats["diverged"]
    assert any("stacked" in w for w in stats["warnings"])
    a, b = one.corner_radiance(floor, False), five.corner_radiance(ids[0], False)
    np.testing.assert_allclose(b, a, rtol=0.005)
    single = one.corner_radiance(panel, False).reshape(4, 3)
    for p in ids[1:]:          # every copy's corners show the light of the one the stack is seen as
        for face in five.corner_radiance(p, False).reshape(-1, 4, 3):
            np.testing.assert_allclose(face, single, rtol=0.005)



def panel_scene(copies, one_mesh, lift=0.0, dynamic=False):
    """The floor and a stacked panel as a Scene, the panel `lift` higher."""
    scene = engine.Scene()
    white = scene.add_material((0.8, 0.8, 0.8))
    floor = Mesh()
    floor.add_face(FLOOR, white)
    floor.add_to(scene, refine="bilinear", patch_size=0.1)
    moved = np.eye(4)
    moved[2, 3] = lift
    meshes = [Mesh() for _ in range(1 if one_mesh else copies)]
    for c in range(copies):
        meshes[0 if one_mesh else c].add_face(PANEL, white)
    for m in meshes:
        m.add_to(scene, refine="bilinear", patch_size=0.1, transform=moved, dynamic=dynamic)
    scene.add_point_light((0, 0, 0.25), (5, 5, 5), 0.01)
    return scene


def test_a_stack_in_one_mesh_moves_as_one_copy_does():
    """Its copies move with it: the update equals a fresh solve of the moved scene."""
    settings = engine.Settings.preset("default")
    solver = engine.Solver(panel_scene(3, True, dynamic=True), settings)
    solver.solve()
    moved = np.eye(4)
    moved[2, 3] = 0.2
    solver.set_transform(1, moved)
    solver.update()
    fresh = engine.Solver(panel_scene(3, True, lift=0.2, dynamic=True), settings)
    fresh.solve()
    for o in (0, 1):
        np.testing.assert_allclose(solver.corner_radiance(o, False), fresh.corner_radiance(o, False), rtol=0.005)


def test_moving_one_of_a_stack_across_meshes_asks_for_a_new_solver():
    """Its corners read another object's light: a move would leave them reading what is no longer there."""
    solver = engine.Solver(panel_scene(2, False), engine.Settings.preset("draft"))
    solver.solve()
    moved = np.eye(4)
    moved[2, 3] = 0.1
    solver.set_transform(2, moved)
    with pytest.raises(ValueError, match="added anew"):
        solver.update()

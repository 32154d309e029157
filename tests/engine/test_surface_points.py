"""Solver.surface_radiance: the light at any points of a surface (lightmap texels), each with its own
direct light, against closed forms and the solver's own corners."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, cornell_box, engine  # noqa: E402

RHO = 0.5
LAMP, INTENSITY = np.array([0.0, 0.0, 2.0]), 8.0
# The floor's object transform: turned about z and moved, so positions go in in object space.
TURN = math.radians(30)
FLOOR_MATRIX = np.array([[math.cos(TURN), -math.sin(TURN), 0, 1.0],
                         [math.sin(TURN), math.cos(TURN), 0, -0.5],
                         [0, 0, 1, 0],
                         [0, 0, 0, 1]])


def lamp_over_floor():
    """A 20 m floor of one face in 4 m patches under a point lamp, with a black 0.2 m square 1 m
    above the lamp's foot facing down: its shadow on the floor is 0.4 m across, far inside one
    patch, and nothing the floor receives is reflected light."""
    scene = engine.Scene()
    grey = scene.add_material((RHO, RHO, RHO))
    black = scene.add_material((0.0, 0.0, 0.0))
    floor = Mesh()
    floor.add_face([(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], grey)
    blocker = Mesh()
    blocker.add_face([(-0.1, -0.1, 1), (-0.1, 0.1, 1), (0.1, 0.1, 1), (0.1, -0.1, 1)], black)
    scene.add_point_light(tuple(LAMP), (INTENSITY,) * 3)
    floor_id = floor.add_to(scene, refine="bilinear", patch_size=4.0, transform=FLOOR_MATRIX)
    blocker.add_to(scene, refine="bilinear")
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    return solver, floor_id


def world(local):
    return (FLOOR_MATRIX @ np.c_[local, np.ones(len(local))].T).T[:, :3]


def test_point_lamp_irradiance_at_any_point():
    solver, floor = lamp_over_floor()
    rng = np.random.default_rng(1)
    local = np.c_[rng.uniform(-9.5, 9.5, (200, 2)), np.zeros(200)]
    at = world(local)
    lit = np.linalg.norm(at[:, :2] - LAMP[:2], axis=1) > 0.3  # outside the blocker's shadow
    to_lamp = LAMP - at[lit]
    d2 = np.sum(to_lamp ** 2, axis=1)
    expected = RHO * INTENSITY * (to_lamp[:, 2] / np.sqrt(d2)) / (math.pi * d2)
    got = solver.surface_radiance(floor, np.zeros(len(local), np.int32), local)
    assert got.dtype == np.float32 and got.shape == (200, 3)
    np.testing.assert_allclose(got[lit], np.repeat(expected[:, None], 3, axis=1), rtol=1e-4)


def test_shadow_inside_a_patch_the_corners_cannot_show():
    solver, floor = lamp_over_floor()
    foot = np.linalg.solve(FLOOR_MATRIX, [0, 0, 0, 1])[:3]  # object-space point under the lamp
    beside = np.linalg.solve(FLOOR_MATRIX, [0.5, 0, 0, 1])[:3]
    got = solver.surface_radiance(floor, np.zeros(2, np.int32), np.array([foot, beside]))
    assert np.all(got[0] == 0.0)  # the blocker is black: no direct and no reflected light there
    d2 = 0.25 + 4.0
    assert got[1][0] == pytest.approx(RHO * INTENSITY * (2 / math.sqrt(d2)) / (math.pi * d2), rel=1e-4)
    # The patch corners around the foot are all lit: interpolating them could not show the shadow.
    positions, radiance = solver.refined(floor)
    near = np.linalg.norm(positions[:, :2], axis=1) < 6.0
    assert near.sum() >= 4 and np.all(radiance[near] > 0)


def test_face_corners_agree_with_corner_radiance():
    """At an input face's corner the point is the solver's own receiving point: the same direct
    light, reflected light and reflectance (corner_radiance with the near direct light interpolated,
    as a texel's reflected light is)."""
    scene = engine.Scene()
    grey = scene.add_material((0.7, 0.6, 0.5))
    room, block = Mesh(), Mesh()
    room.add_box((0, 0, 1), (2, 2, 2), grey, inward=True)
    block.add_box((0.3, -0.2, 0.3), (0.6, 0.6, 0.6), grey, angle=0.4)
    scene.add_point_light((-0.3, 0.2, 1.6), (5.0, 5.0, 5.0))
    ids = [m.add_to(scene, refine="bilinear", patch_size=0.25) for m in (room, block)]
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    for obj, mesh in zip(ids, (room, block)):
        faces = np.repeat(np.arange(len(mesh.faces), dtype=np.int32), [len(f) for f in mesh.faces])
        positions = np.array([mesh.positions[i] for f in mesh.faces for i in f], float)
        corners = solver.corner_radiance(obj, exact_near_direct=False)
        assert np.mean(corners.max(axis=1) > 0) > 0.8  # the block's bottom alone is dark
        np.testing.assert_allclose(solver.surface_radiance(obj, faces, positions), corners, rtol=1e-4, atol=1e-7)


def test_a_face_the_object_lacks_is_refused():
    solver, floor = lamp_over_floor()
    with pytest.raises(ValueError):
        solver.surface_radiance(floor, np.array([1], np.int32), np.zeros((1, 3)))


def test_a_stacked_copy_reads_the_light_of_the_face_it_copies():
    """Of coincident faces one takes part in the lighting (coincident_patches.h); points on the others
    read its light, as their corners do."""
    scene = engine.Scene()
    grey = scene.add_material((RHO, RHO, RHO))
    floor = Mesh()
    for _ in range(2):
        floor.add_face([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], grey)
    floor_id = floor.add_to(scene, refine="bilinear", patch_size=1.0)
    scene.add_point_light(tuple(LAMP), (INTENSITY,) * 3)
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    points = np.c_[np.random.default_rng(2).uniform(-1.9, 1.9, (50, 2)), np.zeros(50)]
    first = solver.surface_radiance(floor_id, np.zeros(50, np.int32), points)
    copy = solver.surface_radiance(floor_id, np.ones(50, np.int32), points)
    assert first.min() > 0
    np.testing.assert_array_equal(copy, first)


def test_the_floor_under_a_box_is_dark_though_its_patches_reach_out_into_the_light():
    """A box without a bottom stands on a lit floor, turned across the floor's patches: a point under
    it sees only the box's dark inside, as a ray tracer's point does, though the patches it lies on
    reach out past the box's foot to lit corners. A point it shuts off from those corners does not
    read their light; it reads the corners under the box, which hold the little the floor's
    patches across the foot send into the box (a few percent of the light outside)."""
    scene = engine.Scene()
    grey = scene.add_material((0.7, 0.6, 0.5))
    room, block = Mesh(), Mesh()
    room.add_box((0, 0, 1), (2, 2, 2), grey, inward=True)       # face 0: the floor, z = 0
    block.add_box((0.3, -0.2, 0.3), (0.6, 0.6, 0.6), grey, angle=0.4)
    block.faces, block.materials = block.faces[1:], block.materials[1:]   # no bottom: nothing lies on the floor
    scene.add_point_light((-0.3, 0.2, 1.6), (5.0, 5.0, 5.0))
    room_id, _ = [m.add_to(scene, refine="bilinear", patch_size=0.25) for m in (room, block)]
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    c, s = math.cos(0.4), math.sin(0.4)
    grid = np.stack(np.meshgrid(np.linspace(-0.27, 0.27, 12), np.linspace(-0.27, 0.27, 12)), -1).reshape(-1, 2)
    under = np.c_[0.3 + c * grid[:, 0] - s * grid[:, 1], -0.2 + s * grid[:, 0] + c * grid[:, 1], np.zeros(len(grid))]
    got = solver.surface_radiance(room_id, np.zeros(len(under), np.int32), under)
    lit = solver.surface_radiance(room_id, np.zeros(1, np.int32), np.array([[-0.6, 0.6, 0.0]]))
    assert lit.min() > 0 and got.max() < 0.05 * lit.max()
    # Some floor patch corners just outside the foot are lit: interpolation alone would show light.
    positions, radiance = solver.refined(room_id)
    local = positions[:, :2] - (0.3, -0.2)
    along = np.abs(np.c_[c * local[:, 0] + s * local[:, 1], -s * local[:, 0] + c * local[:, 1]]).max(axis=1)
    beside = (np.abs(positions[:, 2]) < 1e-6) & (along > 0.3) & (along < 0.45)
    assert beside.any() and radiance[beside].max() > 0.5 * lit.max()

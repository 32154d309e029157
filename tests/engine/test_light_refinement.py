"""Refinement driven by the light (Settings.light_refinement): patches split where the light across
them changes, nowhere else, and the solution on them beats uniform patches of at least their number."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, ROOM_STATE, changing_room, engine  # noqa: E402

PLANE_HALF = 1.0          # the lit plane: [-1, 1]^2 at z = 0, facing +z
BASE = 0.25               # its patches before the light splits them: 8 x 8
LEVELS = 3                # splits down to BASE / 8
RHO = 0.6
SUN = 3.0                 # irradiance, straight down
# A black plate over the plane: its shadow, straight below it, has edges on none of the patch grids.
SHADOW = (-0.37, 0.41, -0.29, 0.44)   # x0, x1, y0, y1


def settings(levels, contrast=0.1):
    s = engine.Settings.preset("draft")
    s.threshold = 1e-3
    s.light_refinement = levels
    s.light_contrast = contrast
    return s


def add_plane(scene, patch_size=BASE):
    plane = Mesh()
    h = PLANE_HALF
    plane.add_face([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], scene.add_material((RHO,) * 3))
    return plane.add_to(scene, refine="bilinear", patch_size=patch_size, name="Plane")


def shadowed_plane(patch_size=BASE):
    """The plane in the sun under the black plate; returns (scene, plane id)."""
    scene = engine.Scene()
    plane_id = add_plane(scene, patch_size)
    x0, x1, y0, y1 = SHADOW
    plate = Mesh()
    plate.add_face([(x0, y0, 0.5), (x1, y0, 0.5), (x1, y1, 0.5), (x0, y1, 0.5)], scene.add_material((0.0,) * 3))
    plate.add_to(scene, refine="bilinear", patch_size=10.0, name="Plate")
    scene.add_sun_light((0, 0, -1), (SUN,) * 3)
    return scene, plane_id


def patches(solver, obj):
    """Per patch of the object: (x0, x1, y0, y1) of its corners, and its corners' (x, y) and radiance."""
    pos, rad = solver.refined(obj)
    pos, rad = np.asarray(pos).reshape(-1, 4, 3), np.asarray(rad).reshape(-1, 4, 3)
    box = np.stack([pos[:, :, 0].min(1), pos[:, :, 0].max(1), pos[:, :, 1].min(1), pos[:, :, 1].max(1)], 1)
    return box, pos[:, :, :2], rad


def crossed(box):
    """Whether the shadow's edge runs through each box (x0, x1, y0, y1): it meets the shadow without
    lying inside it."""
    x0, x1, y0, y1 = SHADOW
    meets = (box[:, 0] < x1) & (box[:, 1] > x0) & (box[:, 2] < y1) & (box[:, 3] > y0)
    inside = (box[:, 0] >= x0) & (box[:, 1] <= x1) & (box[:, 2] >= y0) & (box[:, 3] <= y1)
    return meets & ~inside


def interpolated(solver, obj, n=256):
    """The solution on the plane's patches, bilinear within the patch holding each of n x n points
    (cell centres): (points (n*n, 2), values (n*n, 3))."""
    box, corners, rad = patches(solver, obj)
    finest = 2 * PLANE_HALF / 2 ** 10
    raster_n = int(round(2 * PLANE_HALF / finest))
    owner = np.full((raster_n, raster_n), -1)
    cells = np.round((box + PLANE_HALF) / finest).astype(int)
    for p, (i0, i1, j0, j1) in enumerate(cells):
        owner[i0:i1, j0:j1] = p
    t = (np.arange(n) + 0.5) / n * 2 * PLANE_HALF - PLANE_HALF
    xy = np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2)
    ij = np.floor((xy + PLANE_HALF) / finest).astype(int)
    p = owner[ij[:, 0], ij[:, 1]]
    assert (p >= 0).all(), "the patches do not tile the plane"
    lo, size = box[p][:, [0, 2]], box[p][:, [1, 3]] - box[p][:, [0, 2]]
    # each corner's place in its patch, (0,0) (1,0) (0,1) (1,1) as 0..3, its radiance put there
    at = np.round((corners[p] - lo[:, None]) / size[:, None]).astype(int)
    r = np.zeros_like(rad[p])
    np.put_along_axis(r, (at[:, :, 0] + 2 * at[:, :, 1])[:, :, None], rad[p], 1)
    s, u = ((xy - lo) / size)[:, :1], ((xy - lo) / size)[:, 1:]
    return xy, (1 - s) * (1 - u) * r[:, 0] + s * (1 - u) * r[:, 1] + (1 - s) * u * r[:, 2] + s * u * r[:, 3]


def lit_value():
    """Cycles' radiance off a diffuse surface under a sun of irradiance SUN: rho E / pi."""
    return RHO * SUN / math.pi


def analytic(xy):
    x0, x1, y0, y1 = SHADOW
    dark = (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)
    return np.where(dark, 0.0, lit_value())


# ----------------------------------------------------------------------------- (a) flat light
def sky_plane():
    scene = engine.Scene()
    obj = add_plane(scene)
    scene.set_world((0.5, 0.5, 0.5))
    return scene, obj, RHO * 0.5          # an open plane under a uniform sky: rho L on both sides


def furnace():
    scene = engine.Scene()
    box = Mesh()
    box.add_box((0, 0, 0), (1, 1, 1), scene.add_material((0.5,) * 3, (1.0,) * 3), inward=True)
    obj = box.add_to(scene, refine="bilinear", patch_size=BASE)
    return scene, obj, 1.0 / (1 - 0.5)    # E / (1 - rho), emission included


@pytest.mark.parametrize("make", [sky_plane, furnace])
def test_light_that_is_flat_splits_nothing(make):
    scene, obj, exact = make()
    solver = engine.Solver(scene, settings(LEVELS))
    stats = solver.solve()
    base = stats["uniform_patches"] // 4 ** LEVELS
    assert stats["patches"] == base
    radiance = np.asarray(solver.refined(obj)[1])
    assert np.abs(radiance / exact - 1).max() < 0.01


# ----------------------------------------------------------------------------- (b) a sharp shadow
def test_a_sharp_shadow_is_split_along_its_edge_only():
    scene, plane = shadowed_plane()
    solver = engine.Solver(scene, settings(LEVELS))
    stats = solver.solve()
    box, _, _ = patches(solver, plane)
    size = box[:, 1] - box[:, 0]
    split = size < BASE - 1e-9
    assert split.any() and stats["patches"] < stats["uniform_patches"] / 4
    # Each split patch's parent (the cell of twice its size it came from) was marked: the edge runs
    # through it. Base patches the edge runs through were all split.
    parent = np.floor((box[:, [0, 2]] + PLANE_HALF) / (2 * size[:, None])) * 2 * size[:, None] - PLANE_HALF
    parent_box = np.stack([parent[:, 0], parent[:, 0] + 2 * size, parent[:, 1], parent[:, 1] + 2 * size], 1)
    assert crossed(parent_box[split]).all()
    assert not crossed(box[~split]).any()
    # All along the edge, the patches holding it are of the finest size.
    finest = BASE / 2 ** LEVELS
    x0, x1, y0, y1 = SHADOW
    t = np.linspace(0, 1, 101)
    edge = np.concatenate([np.stack([x0 + (x1 - x0) * t, np.full_like(t, y)], 1) for y in (y0, y1)] +
                          [np.stack([np.full_like(t, x), y0 + (y1 - y0) * t], 1) for x in (x0, x1)])
    holds = ((edge[:, None, 0] >= box[None, :, 0]) & (edge[:, None, 0] <= box[None, :, 1]) &
             (edge[:, None, 1] >= box[None, :, 2]) & (edge[:, None, 1] <= box[None, :, 3]))
    assert holds.any(1).all()
    assert np.all(np.abs(size[holds.argmax(1)] - finest) < 1e-9)


# ----------------------------------------------------------------------------- (c) accuracy
def test_the_shadow_is_closer_to_the_exact_one_than_on_as_many_uniform_patches():
    scene, plane = shadowed_plane()
    light = engine.Solver(scene, settings(LEVELS))
    light_patches = light.solve()["patches"]
    # Uniform patches at least as many: the first size, halving from BASE, that makes as many.
    size = BASE
    while (2 * PLANE_HALF / size) ** 2 < light_patches:
        size /= 2
    scene, plane = shadowed_plane(size)
    uniform = engine.Solver(scene, settings(0))
    uniform_patches = uniform.solve()["patches"]
    assert uniform_patches >= light_patches
    errors = {}
    for name, solver in (("light", light), ("uniform", uniform)):
        xy, value = interpolated(solver, plane)
        exact = analytic(xy)
        # Away from the shadow, both hold the exact sunlit value.
        far = np.abs(xy).max(1) > 0.9
        assert np.abs(value[far].mean(1) / exact[far] - 1).max() < 0.01, name
        errors[name] = np.abs(value.mean(1) - exact).mean() / lit_value()
    assert errors["light"] < 0.75 * errors["uniform"], errors


# ----------------------------------------------------------------------------- (d) updates
def room_settings():
    s = settings(1)
    s.threshold = 1e-4
    return s


def values(solver, ids):
    return np.concatenate([np.asarray(solver.refined(i)[1]) for i in ids])


def test_a_move_and_its_undo_on_light_refined_patches_match_a_fresh_solve():
    """The refinement a solve made stays through updates (a moved object keeps its patches): a move
    and the move back come to a fresh solve of the scene as it was, whose light refines it alike."""
    scene, ids, cube = changing_room(ROOM_STATE, patch_size=0.35)
    solver = engine.Solver(scene, room_settings())
    first = solver.solve()
    assert first["patches"] > first["uniform_patches"] // 4      # the light split some patches
    away, back = np.eye(4), np.eye(4)
    away[:3, 3] = (0.0, -0.2, 0.3)
    back[:3, 3] = ROOM_STATE["cube"]
    for transform in (away, back):
        solver.set_transform(cube, transform)
        stats = solver.update()
        assert stats["converged"] and stats["patches"] == first["patches"]
    solver.solve()
    scene, ids, _ = changing_room(ROOM_STATE, patch_size=0.35)
    fresh = engine.Solver(scene, room_settings())
    assert fresh.solve()["patches"] == first["patches"]
    got, expected = values(solver, ids), values(fresh, ids)
    assert np.isfinite(got).all()
    # DESIGN.md section 5: an updated frame within 0.5% RMS of a fresh solve.
    assert np.sqrt(np.mean((got - expected) ** 2)) / np.mean(expected) < 0.005


def test_points_on_light_split_patches_read_the_exact_light():
    """Solver.surface_radiance (lightmaps) reads points among split patches: each its own sunlight or
    shadow (the plate is black: no reflected light to interpolate), across T-junctions too."""
    scene, plane = shadowed_plane()
    solver = engine.Solver(scene, settings(LEVELS))
    solver.solve()
    rng = np.random.default_rng(1)
    xy = rng.uniform(-PLANE_HALF, PLANE_HALF, (400, 2))
    x0, x1, y0, y1 = SHADOW
    off_edge = np.minimum(np.abs(xy[:, :1] - [x0, x1]).min(1), np.abs(xy[:, 1:] - [y0, y1]).min(1)) > 1e-3
    xy = xy[off_edge]
    points = np.concatenate([xy, np.zeros((len(xy), 1))], 1)
    got = np.asarray(solver.surface_radiance(plane, np.zeros(len(xy), np.int32), points)).reshape(-1, 3)
    assert np.abs(got.mean(1) - analytic(xy)).max() < 0.01 * lit_value()

"""The Python module: arrays in and out, lamps against closed forms, progress, cancel, errors."""
import json
import math
import os
import sys
import threading

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, cornell_box, engine  # noqa: E402

RHO = 0.5


def floor_scene(size=20.0):
    """A single upward floor quad with reflectance RHO: nothing else, so only direct light."""
    scene = engine.Scene()
    m = scene.add_material((RHO, RHO, RHO))
    floor = Mesh()
    h = size / 2
    floor.add_face([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], m)
    return scene, floor


def radiance_near(solver, obj, point):
    """(position, radiance) of the patch corner nearest `point`."""
    positions, radiance = solver.refined(obj)
    i = np.argmin(np.linalg.norm(positions - point, axis=1))
    return positions[i], radiance[i]


def solve_floor(add_light, size=20.0):
    scene, floor = floor_scene(size)
    add_light(scene)
    obj = floor.add_to(scene, refine="bilinear", patch_size=0.5)
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    return solver, obj


def test_point_lamp_is_intensity_over_distance_squared():
    solver, obj = solve_floor(lambda s: s.add_point_light((0, 0, 2), (8, 8, 8)))
    for target in [(0, 0, 0), (2, 0, 0), (3, -5, 0)]:
        position, value = radiance_near(solver, obj, target)
        to_lamp = np.array([0, 0, 2]) - position
        d2 = to_lamp @ to_lamp
        assert value[0] == pytest.approx(RHO * 8 * (to_lamp[2] / math.sqrt(d2)) / (math.pi * d2), rel=1e-3)


def test_sphere_lamp_radius_softens_like_cycles():
    solver, obj = solve_floor(lambda s: s.add_point_light((0, 0, 2), (8, 8, 8), radius=0.5))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == pytest.approx(RHO * 8 / (math.pi * 4.25), rel=1e-3)


def test_sun_and_world():
    tilt = math.radians(30)
    solver, obj = solve_floor(lambda s: s.add_sun_light((math.sin(tilt), 0, -math.cos(tilt)), (3, 3, 3)))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == pytest.approx(RHO * 3 * math.cos(tilt) / math.pi, rel=1e-3)
    solver, obj = solve_floor(lambda s: s.set_world((0.4, 0.4, 0.4)))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == pytest.approx(RHO * 0.4, rel=1e-3)


def sky_and_ground(height=32, width=8, sky=(0.6, 0.3, 0.2), ground=(0.05, 0.1, 0.2)):
    """A world map (rows from the bottom): `sky` above the horizon, `ground` below."""
    texels = np.empty((height, width, 3))
    texels[height // 2:], texels[:height // 2] = sky, ground
    return texels


def upward_light(texels):
    """What an upward surface takes of a world map whose rows are each one colour: 2 times the
    integral over the upper hemisphere's latitudes t of L(t) sin t cos t, L read as the engine reads
    it (bilinear between row centres, clamped at the poles)."""
    h = len(texels)
    t = (np.arange(200000) + 0.5) / 200000 * (np.pi / 2)
    y = (0.5 + t / np.pi) * h - 0.5
    r0 = np.clip(np.floor(y).astype(int), 0, h - 1)
    r1 = np.clip(np.floor(y).astype(int) + 1, 0, h - 1)
    f = (y - np.floor(y))[:, None]
    light = (1 - f) * texels[r0, 0] + f * texels[r1, 0]
    return 2 * (light * (np.sin(t) * np.cos(t))[:, None]).sum(0) * (np.pi / 2) / len(t)


def test_a_world_map_lights_by_direction():
    solver, obj = solve_floor(lambda s: s.set_world_map(np.full((4, 8, 3), 0.4)))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == pytest.approx(RHO * 0.4, rel=1e-3)
    texels = sky_and_ground()
    solver, obj = solve_floor(lambda s: s.set_world_map(texels))
    expected = RHO * upward_light(texels)
    # the sky alone but for the half row either side of the horizon, where the map blends it with the ground
    assert expected == pytest.approx(RHO * np.array([0.6, 0.3, 0.2]), rel=0.01)
    assert radiance_near(solver, obj, (0, 0, 0))[1] == pytest.approx(expected, rel=2e-3)
    with pytest.raises(ValueError, match="world map"):
        engine.Scene().set_world_map(np.ones((4, 8)))
    with pytest.raises(ValueError, match="non-negative"):
        scene, floor = floor_scene()
        scene.set_world_map(-texels)
        floor.add_to(scene)
        engine.Solver(scene, engine.Settings.preset("draft"))


def edge_form_factors(points, normal, a, b):
    """Lambert's closed form edge by edge: each straight edge a -> b ((N, E, 3) each) adds the angle it
    spans seen from its point times the cosine between `normal` and the plane through them. Summed
    over a closed polygon wholly in front of the points and divided by 2 pi: the form factor, signed
    by the polygon's turn."""
    ra, rb = a - points[:, None], b - points[:, None]
    cross = np.cross(ra, rb)
    length = np.linalg.norm(cross, axis=2)
    angle = np.arctan2(length, (ra * rb).sum(2))
    return (angle * (cross @ normal) / np.where(length > 0, length, 1.0)).sum(1)


def polygon_form_factor(points, normal, polygon):
    """The form factors from points (N,3) facing `normal` to a polygon (corners (K,3)) wholly in front of them."""
    corners = np.broadcast_to(polygon, (len(points),) + polygon.shape)
    return np.abs(edge_form_factors(points, normal, corners, np.roll(corners, -1, axis=1))) / (2 * math.pi)


def part_inside(a, b, polygon):
    """The part t0..t1 of each segment a + t (b - a), t in [0, 1], inside a convex polygon turning
    counter-clockwise, all in 2D: a, b (N, E, 2), polygon (N, K, 2). None where t1 <= t0."""
    t0, t1 = np.zeros(a.shape[:2]), np.ones(a.shape[:2])
    for c, d in zip(np.moveaxis(polygon, 1, 0), np.moveaxis(np.roll(polygon, -1, axis=1), 1, 0)):
        e = (d - c)[:, None]
        fa = e[..., 0] * (a - c[:, None])[..., 1] - e[..., 1] * (a - c[:, None])[..., 0]  # > 0: inside
        fb = e[..., 0] * (b - c[:, None])[..., 1] - e[..., 1] * (b - c[:, None])[..., 0]
        t = fa / np.where(fa != fb, fa - fb, 1.0)
        t0 = np.where(fb > fa, np.maximum(t0, t), t0)
        t1 = np.where(fb < fa, np.minimum(t1, t), np.where((fa == fb) & (fa < 0), 0.0, t1))
    return t0, t1


def form_factor_through(points, normal, polygon, hole):
    """The form factors from points (N,3) facing `normal` to the part of a polygon (corners (K,3)) they
    see through a convex hole (corners (4,3), in a plane between them and the whole polygon). Seen from
    a point, that part covers the directions of its shadow on the hole's plane cut by the hole: whose
    outline is the pieces of either polygon's edges that lie inside the other."""
    origin, m = hole[0], np.cross(hole[1] - hole[0], hole[3] - hole[0])
    t = ((origin - points) @ m)[:, None] / ((polygon[None] - points[:, None]) @ m)
    shadow = points[:, None] + t[..., None] * (polygon[None] - points[:, None])
    u = (hole[1] - hole[0]) / np.linalg.norm(hole[1] - hole[0])
    basis = np.stack([u, np.cross(m / np.linalg.norm(m), u)], axis=1)

    def flat_ccw(corners):
        """The corners (N, K, 3) in the hole's plane, and in 2D, turned counter-clockwise there."""
        flat = (corners - origin) @ basis
        area = (flat[..., 0] * np.roll(flat[..., 1], -1, -1) - np.roll(flat[..., 0], -1, -1) * flat[..., 1]).sum(1)
        turn = (area < 0)[:, None, None]
        return np.where(turn, corners[:, ::-1], corners), np.where(turn, flat[:, ::-1], flat)

    shadow, shadow_2d = flat_ccw(shadow)
    window, window_2d = flat_ccw(np.broadcast_to(hole, (len(points),) + hole.shape))
    total = np.zeros(len(points))
    for edges, edges_2d, other in ((shadow, shadow_2d, window_2d), (window, window_2d, shadow_2d)):
        ends, ends_2d = np.roll(edges, -1, axis=1), np.roll(edges_2d, -1, axis=1)
        t0, t1 = part_inside(edges_2d, ends_2d, other)
        t1 = np.maximum(t0, t1)
        total += edge_form_factors(points, normal, edges + t0[..., None] * (ends - edges),
                                   edges + t1[..., None] * (ends - edges))
    return np.abs(total) / (2 * math.pi)


def room_with_a_window(scene):
    """A closed 5 x 4 x 2.7 m room of black walls but a 1.6 x 1.2 m hole in its +y wall, and a grey
    floor (its object, finely split): nothing but the floor reflects. Returns the floor and the hole's
    corners."""
    grey, black = scene.add_material((RHO, RHO, RHO)), scene.add_material((0.0, 0.0, 0.0))
    x, y, z = 2.5, 2.0, 2.7
    floor, walls = Mesh(), Mesh()
    floor.add_face([(-x, -y, 0), (x, -y, 0), (x, y, 0), (-x, y, 0)], grey)
    for quad in [[(-x, -y, z), (-x, y, z), (x, y, z), (x, -y, z)], [(-x, -y, 0), (x, -y, 0), (x, -y, z), (-x, -y, z)],
                 [(-x, -y, 0), (-x, -y, z), (-x, y, z), (-x, y, 0)], [(x, -y, 0), (x, y, 0), (x, y, z), (x, -y, z)]]:
        walls.add_face(quad, black)              # the ceiling, the -y, -x and +x walls, facing in
    (x0, x1), (z0, z1) = (-0.8, 0.8), (0.8, 2.0)
    xs, zs = (-x, x0, x1, x), (0.0, z0, z1, z)
    for j in range(3):
        for i in range(3):
            if (i, j) != (1, 1):                 # the +y wall round its hole
                walls.add_face([(xs[i], y, zs[j]), (xs[i + 1], y, zs[j]), (xs[i + 1], y, zs[j + 1]),
                                (xs[i], y, zs[j + 1])], black)
    obj = floor.add_to(scene, refine="bilinear", patch_size=0.1)
    walls.add_to(scene)
    return obj, np.array([(x0, y, z0), (x1, y, z0), (x1, y, z1), (x0, y, z1)])


def test_sky_through_a_window_is_radiance_times_the_windows_form_factor():
    # Each floor corner holds rho * L * F, F its form factor to the hole. A sky sampled in directions
    # fixed but for a turn about the normal sees the hole at the same few elevations from every point,
    # which read it 17% high on average here.
    scene = engine.Scene()
    obj, hole = room_with_a_window(scene)
    scene.set_world((1.0, 1.0, 1.0))
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    positions, radiance = solver.refined(obj)
    expected = RHO * polygon_form_factor(positions, np.array([0.0, 0.0, 1.0]), hole)
    assert radiance[:, 0].mean() == pytest.approx(expected.mean(), rel=0.02)
    # and each corner near its own: a lamp's few rays find the hole a few times at most
    assert np.sqrt(((radiance[:, 0] - expected) ** 2).mean()) < 0.15 * expected.mean()


def test_an_area_lamp_through_a_window_lights_by_what_the_window_shows_of_it():
    # A 2 x 1.5 m rectangle lamp outside the window, 1.2 m from the wall and tilted 25 degrees down
    # through it: each floor corner holds rho * L * F, F its form factor to the part of the lamp it sees
    # through the hole. Rays ending at the same points of the lamp from every receiver (its cells'
    # centres) judge that part by which of those points clear the window's frame, alike for whole bands
    # of the floor: 0.25 m strips of it read up to 15% off, the corners 6-7% (RMS).
    scene = engine.Scene()
    obj, hole = room_with_a_window(scene)
    tilt, radiance = math.radians(25.0), 4.0
    centre, u, v = np.array([0.0, 3.2, 2.3]), np.array([1.0, 0.0, 0.0]), 0.75 * np.array([0.0, math.sin(tilt), -math.cos(tilt)])
    scene.add_area_light(tuple(centre), tuple(u), tuple(v), (radiance,) * 3)  # emits along -(u x v): into the room
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    positions, ours = solver.refined(obj)
    lamp = np.array([centre - u - v, centre - u + v, centre + u + v, centre + u - v])
    expected = RHO * radiance * form_factor_through(positions, np.array([0.0, 0.0, 1.0]), lamp, hole)
    lit = expected > 0.1 * expected.max()
    ours, expected, strip = ours[lit, 0], expected[lit], np.floor(positions[lit, 1] / 0.25)
    assert ours.mean() == pytest.approx(expected.mean(), rel=0.01)
    worst = max(abs(ours[strip == s].mean() / expected[strip == s].mean() - 1) for s in np.unique(strip))
    assert worst < 0.03
    assert np.sqrt(((ours - expected) ** 2).mean()) < 0.04 * expected.mean()


def test_spot_lamp_cone():
    solver, obj = solve_floor(lambda s: s.add_spot_light((0, 0, 2), (0, 0, -1), (8, 8, 8), spot_size=math.radians(60),
                                                         spot_blend=0.0))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == pytest.approx(RHO * 8 / (math.pi * 4), rel=1e-3)
    assert radiance_near(solver, obj, (2, 0, 0))[1][0] == 0.0  # 45 degrees: outside a 60 degree cone


def test_rectangle_lamp_is_radiance_times_form_factor():
    # Unit square lamp 1 m up, facing down: the centre below sees F = 0.239456470461.
    solver, obj = solve_floor(lambda s: s.add_area_light((0, 0, 1), (0.5, 0, 0), (0, 0.5, 0), (2, 2, 2)))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == pytest.approx(RHO * 2 * 0.239456470461, rel=2e-3)
    # One-sided: turned to face up, it lights nothing below.
    solver, obj = solve_floor(lambda s: s.add_area_light((0, 0, 1), (0, 0.5, 0), (0.5, 0, 0), (2, 2, 2)))
    assert radiance_near(solver, obj, (0, 0, 0))[1][0] == 0.0


@pytest.mark.parametrize("reflected", [False, True])
def test_box_standing_on_the_floor_is_lit_at_its_foot(reflected):
    # Sun straight down: the box's sides see only the lit floor, which fills half of what a point at
    # their foot sees (form factor 1/2 as the point nears the floor), so the foot's radiance is
    # rho_box / 2 times the floor's, rho E / pi, plus under 7% the floor gets back from the box. The
    # floor's patches run under the box: a cell whose centre lies under it is dark there.
    scene, floor = floor_scene(6.0)
    box_rho = 0.5
    scene.add_sun_light((0, 0, -1), (3, 3, 3))
    floor.add_to(scene, refine="bilinear", patch_size=0.5)
    box = Mesh()
    box.add_box((0.13, 0.21, 0.4), (0.8, 0.8, 0.8), scene.add_material((box_rho,) * 3), angle=0.3)
    del box.faces[0], box.materials[0]  # standing open on the floor, as the samples' boxes do
    obj = box.add_to(scene, refine="bilinear", patch_size=0.5)
    settings = engine.Settings.preset("default")
    settings.exact_near_reflected = reflected  # the floor's light at the pieces the foot sees, all of it
    solver = engine.Solver(scene, settings)
    solver.solve()
    corners = np.array(box.positions)[np.concatenate(box.faces)]
    foot = solver.corner_radiance(obj)[np.abs(corners[:, 2]) < 1e-9, 0]
    expected = box_rho / 2 * RHO * 3 / math.pi
    assert len(foot) == 8
    assert foot.min() > 0.97 * expected and foot.max() < 1.1 * expected


def test_the_light_at_a_box_foot_is_gathered_at_the_solves_own_sampling():
    # The pieces by the tall block's feet gather every shooter's reflected light at this preset's own
    # sampling: these corners read what 32 or 64 far samples a shooter give (the values below).
    scene, ids = cornell_box(patch_size=0.2)
    settings = engine.Settings.preset("default")
    settings.exact_near_reflected = True
    solver = engine.Solver(scene, settings)
    solver.solve()
    feet = solver.corner_radiance(ids[2], True)[[8, 9, 21], 0]
    assert feet == pytest.approx([0.1268, 0.1782, 0.1292], rel=0.01)


@pytest.mark.parametrize("rise", [0.0, 0.05, 0.2])
def test_every_corner_of_a_quad_that_is_not_flat_is_lit(rise):
    # A 1 m quad with one corner raised, under a sun straight down: Embree traces it as two
    # triangles folded along a diagonal, and the points of the other diagonal, nudged towards the
    # quad's centre, lie under the triangle beside them: they still get the sun. Flat-shaded, each corner
    # takes the quad's normal, half the cross product of its diagonals: (rise, -rise, 2) here.
    scene = engine.Scene()
    scene.add_sun_light((0, 0, -1), (3, 3, 3))
    quad = Mesh()
    quad.add_face([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, rise)], scene.add_material((RHO,) * 3))
    obj = quad.add_to(scene)
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    solver.solve()
    cos = 2 / math.sqrt(4 + 2 * rise ** 2)
    assert solver.corner_radiance(obj)[:, 0] == pytest.approx(np.full(4, RHO * 3 * cos / math.pi), rel=1e-3)


@pytest.mark.parametrize("rise", [0.01, 0.2])
def test_a_quad_that_is_not_flat_sends_all_its_light(rise):
    # A glowing quad with one corner raised, over a floor, against the two triangles Embree traces
    # for it. Its cells behind those triangles still see the quad's own corners and send their light:
    # taken as hidden, they would leave the floor 0.53 of it, however slight the rise.
    def floor_light(triangles):
        scene = engine.Scene()
        glow = scene.add_material((RHO,) * 3, (1.0,) * 3)
        c = [(0, 1, 1 + rise), (1, 1, 1), (1, 0, 1), (0, 0, 1)]  # facing down
        quad, floor = Mesh(), Mesh()
        for face in ([c[0], c[1], c[3]], [c[2], c[3], c[1]]) if triangles else (c,):
            quad.add_face(face, glow)
        quad.add_to(scene)
        floor.add_face([(-1.5, -1.5, 0), (2.5, -1.5, 0), (2.5, 2.5, 0), (-1.5, 2.5, 0)],
                       scene.add_material((RHO,) * 3))
        obj = floor.add_to(scene, refine="bilinear", patch_size=0.25)
        settings = engine.Settings.preset("default")
        settings.max_shots = 0
        solver = engine.Solver(scene, settings)
        solver.solve()
        return solver.refined(obj)[1][:, 0]
    assert floor_light(False).sum() == pytest.approx(floor_light(True).sum(), rel=1e-3)


def bumpy_box(scene, jitter, rho=RHO):
    """A closed cube of 6 x 6 quads a face glowing with radiance 1, facing in, its vertices moved
    in or out by up to jitter / 2: its quads are not flat."""
    rng = np.random.default_rng(1)
    m = scene.add_material((rho,) * 3, (1.0,) * 3)
    box, t = Mesh(), np.linspace(-1, 1, 7)
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3  # e_u x e_v = e_axis
        for sign in (-1, 1):
            for i in range(6):
                for j in range(6):
                    corners = np.zeros((4, 3))
                    corners[:, axis] = sign
                    corners[:, u] = t[[i, i + 1, i + 1, i]]
                    corners[:, v] = t[[j, j, j + 1, j + 1]]
                    box.add_face(corners[::-1] if sign > 0 else corners, m)  # facing in
    box.weld()
    box.positions = list(np.array(box.positions) * (1 + jitter * (rng.random((len(box.positions), 1)) - 0.5)))
    return box.add_to(scene)


@pytest.mark.parametrize("jitter, rho, mean_within, within", [(0.02, RHO, 5e-3, 5e-3), (0.1, 0.9, 5e-3, 0.1)])
def test_a_bumpy_furnace_keeps_its_light(jitter, rho, mean_within, within):
    # Case 10 on a box bumpy by 1%, and by 5% at rho = 0.9 (ten bounces' worth of the bumps' own
    # error, 9% at worst): every corner keeps E / (1 - rho). Each cell sends light from its own
    # corners, so that at 4 x 4 cells a patch the corners at its folds, which lie behind the planes of
    # the cells beside them, still get those cells' reflected light.
    scene = engine.Scene()
    obj = bumpy_box(scene, jitter, rho)
    settings = engine.Settings.preset("default")
    settings.threshold = 1e-4
    solver = engine.Solver(scene, settings)
    assert solver.solve()["converged"]
    b = solver.corner_radiance(obj)[:, 0] * (1 - rho)
    assert abs(b.mean() - 1) < mean_within
    assert np.abs(b - 1).max() < within


@pytest.mark.parametrize("jitter, samples, within", [(0.05, 16, 1e-2), (0.05, 64, 1e-2), (0.05, 256, 1e-2),
                                                     (0.1, 256, 3e-2)])
def test_every_corner_of_a_bumpier_box_gets_its_first_bounce_at_any_sample_count(jitter, samples, within):
    # One bounce in a box bumpy by 2.5% and 5%: each corner gets 1 + RHO, all it sees glowing with 1.
    # The ends of rays to a patch are lifted off it by how far the patch lies off its triangles at
    # each end, not by its whole bulge, which from 64 samples a shooter would clear a corner's
    # neighbour; a cell by the box's fold whose lift takes it through the other wall tries again,
    # lifted by what its own place needs.
    scene = engine.Scene()
    obj = bumpy_box(scene, jitter)
    settings = engine.Settings.preset("default")
    settings.max_shots = 0
    settings.samples_direct = samples
    solver = engine.Solver(scene, settings)
    solver.solve()
    assert solver.corner_radiance(obj)[:, 0] == pytest.approx(np.full(6 * 6 * 6 * 4, 1 + RHO), rel=within)


def test_every_corner_of_a_gently_bumpy_flat_shaded_grid_gets_its_facets_light():
    # A 12 x 12 grid with random heights (slopes up to 5 degrees) under a sun straight down: a
    # height field, so nothing shadows, and its folds are too shallow to light each other (0.1%).
    # Each corner gets RHO E cos / pi, cos its face's: its point sits on the traced triangles, not
    # under them in the dark, and a point holding two opposite faces of a vertex goes into one of
    # them, not Lambert's formula at the other faces' corners.
    n = 12
    a, b = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    heights = 0.08 / n * np.random.default_rng(1).random(a.size)
    positions = np.stack([a.ravel(), b.ravel(), heights], 1)
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    quads = np.stack([i, i + 1, i + n + 2, i + n + 1], -1).reshape(-1, 4)
    scene = engine.Scene()
    scene.add_sun_light((0, 0, -1), (3, 3, 3))
    obj = scene.add_mesh(positions, np.full(n * n, 4, np.int32), quads.ravel().astype(np.int32),
                         np.full(n * n, scene.add_material((RHO,) * 3), np.int32))
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    solver.solve()
    q = positions[quads]
    facing = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
    cos = facing[:, 2] / np.linalg.norm(facing, axis=1)
    got = solver.corner_radiance(obj)[:, 0].reshape(-1, 4) / (RHO * 3 / math.pi * cos[:, None])
    assert got.min() > 0.995 and got.max() < 1.005


def lit_wedge_form_factor(height, inset, a, n=2000):
    """Form factor, from a point `height` over the floor on a wall facing +v and `inset` along it
    (towards -u) from a corner at the origin, to the floor where u > -a v (v > 0): the floor beside
    the corner lit, a shadow edge leaving the corner along (-a, 1). Polar about the point's foot,
    rho = height tan(t) so the kernel's peak under the point is sampled finely."""
    p = (np.arange(n) + 0.5) / n * math.pi
    t = (np.arange(n) + 0.5) / n * math.pi / 2
    p, t = np.meshgrid(p, t, indexing="ij")
    rho = height * np.tan(t)
    u, v = -inset + rho * np.cos(p), rho * np.sin(p)
    kernel = v * height / (math.pi * (rho ** 2 + height ** 2) ** 2) * rho * height / np.cos(t) ** 2
    return float((kernel * (u > -a * v)).sum() * (math.pi / n) * (math.pi / 2 / n))


@pytest.mark.parametrize("patch_size, reflected", [(0.5, False), (0.2, False), (0.1, False), (0.2, True)])
def test_foot_where_a_shadow_edge_starts_sees_the_lit_floor_exactly(patch_size, reflected):
    # A slanting sun: the box's shadow edge leaves its corner (1, -1) along (-a, -1), in the box's
    # frame, so the foot of its -y face sees the floor lit on one side of that edge and dark on the
    # other. Patches straddle the edge at any size, and interpolating them gives 1.3-2.1 times the
    # value below; exact_near_direct evaluates the floor's direct light at the pieces the foot sees
    # (0.99-1.03 times it). The point sits on its corner patch's diagonal, a hair off the floor and the corner (the
    # ratio of the two is what counts, the wedge looks the same at every scale): there it gets
    # RHO E cos / pi times the lit wedge's form factor. The box reflects little (box_rho): what the
    # floor gets back from it stays below 0.5%.
    a, box_rho, angle = 0.5, 0.1, 0.3
    scene, floor = floor_scene(6.0)
    travel = np.array([-a, -1.0, -1.5]) / np.linalg.norm([-a, -1.0, -1.5])
    c, s = math.cos(angle), math.sin(angle)
    scene.add_sun_light((c * travel[0] - s * travel[1], s * travel[0] + c * travel[1], travel[2]), (3, 3, 3))
    floor.add_to(scene, refine="bilinear", patch_size=patch_size)
    box = Mesh()
    box.add_box((0.13, 0.21, 0.4), (0.8, 0.8, 0.8), scene.add_material((box_rho,) * 3), angle=angle)
    del box.faces[0], box.materials[0]
    obj = box.add_to(scene, refine="bilinear", patch_size=patch_size)
    expected = box_rho * RHO * 3 * -travel[2] / math.pi * lit_wedge_form_factor(1.0, 1.0, a)
    settings = engine.Settings.preset("default")
    settings.exact_near_reflected = reflected
    solver = engine.Solver(scene, settings)
    solver.solve()
    assert solver.corner_radiance(obj)[5, 0] == pytest.approx(expected, rel=0.04)  # -y face, corner (1, -1, -1)
    # Read without it (live update while the animation plays): interpolated, as without the setting.
    assert solver.corner_radiance(obj, exact_near_direct=False)[5, 0] > 1.2 * expected


@pytest.mark.parametrize("split", [8, 16, 32])
def test_a_partly_hidden_emitter_lights_alike_however_finely_split(split):
    # A 1 m emitter 2 m up, a wall up to its height that hides the part of it where m.y > c from
    # the floor's centre: that point gets RHO L times the rest's form factor. 64 direct samples
    # see the emitter as 8 x 8 clusters whatever its patches: a far sample aims at its cluster's
    # centroid, not at its anchor patch's centre (a quarter of a cluster off once 2 x 2 patches tile
    # it), which would move the grid of samples with the split (up to 1.069 times the value).
    a, top, c, turn = 0.5, 1.999, 0.2, math.radians(30)
    scene, floor = floor_scene(6.0)
    obj = floor.add_to(scene, refine="bilinear", patch_size=0.5)
    emitter = Mesh()
    corners = [np.array(p, float) for p in [(-a, -a, 2), (a, -a, 2), (a, a, 2), (-a, a, 2)]]
    emitter.add_face(corners[::-1], scene.add_material((0, 0, 0), (1, 1, 1)))  # facing down
    emitter.add_to(scene, refine="bilinear", patch_size=2 * a / split)
    m = np.array([math.cos(turn), math.sin(turn), 0.0])
    along, base = np.cross((0, 0, 1), m), c * m
    wall = Mesh()
    wall.add_face([base - 3 * along, base + 3 * along, base + 3 * along + (0, 0, top), base - 3 * along + (0, 0, top)],
                  scene.add_material((0, 0, 0)))
    wall.add_to(scene, refine="bilinear", patch_size=0.5)
    seen = []  # the emitter where m.y <= c: its top edge, 1 mm under the emitter, bounds the view
    for p, q in zip(corners, corners[1:] + corners[:1]):
        fp, fq = m @ p - c, m @ q - c
        if fp <= 0:
            seen.append(p)
        if (fp < 0) != (fq < 0):
            seen.append(p + fp / (fp - fq) * (q - p))
    expected = RHO * engine.polygon_form_factor((0, 0, 0), (0, 0, 1), np.array(seen))
    solver = engine.Solver(scene, engine.Settings.preset("default"))
    solver.solve()
    position, value = radiance_near(solver, obj, (0, 0, 0))
    assert np.allclose(position, 0)
    assert value[0] == pytest.approx(expected, rel=0.015)


def test_arrays_progress_and_stats():
    scene, ids = cornell_box()
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    calls = []
    stats = solver.solve(progress=lambda fraction, residual: calls.append((fraction, residual)))
    assert stats["converged"] and not stats["cancelled"]
    assert stats["residual"] <= engine.Settings.preset("draft").threshold
    assert calls and calls[-1][0] == 1.0
    corners = solver.corner_radiance(ids[0])
    assert corners.dtype == np.float32 and corners.shape[1] == 3
    assert np.isfinite(corners).all() and (corners >= 0).all()
    lamp = solver.corner_radiance(ids[1])
    assert lamp.min() >= 15.0  # emission is part of the output, as in Cycles' COMBINED bake
    assert solver.vertex_radiance(ids[2]).shape == (48, 3)  # two unwelded boxes


def test_cancel_returns_cleanly_and_resumes():
    scene, ids = cornell_box()
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    stats = solver.solve(progress=lambda fraction, residual: False)
    assert stats["cancelled"] and not stats["converged"]
    assert np.isfinite(solver.corner_radiance(ids[0])).all()
    assert solver.solve()["converged"]


def test_callback_errors_propagate():
    scene, _ = cornell_box()
    solver = engine.Solver(scene, engine.Settings.preset("draft"))

    def fail(fraction, residual):
        raise RuntimeError("from the callback")
    with pytest.raises(RuntimeError, match="from the callback"):
        solver.solve(progress=fail)


def test_solve_releases_the_gil():
    scene, _ = cornell_box()
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    thread = threading.Thread(target=solver.solve)
    ticks = 0
    thread.start()
    while thread.is_alive():
        ticks += 1
        thread.join(0.001)
    assert ticks > 10


def test_bad_input_raises_value_error():
    scene, floor = floor_scene()
    floor.positions[0] = np.array([np.nan, 0, 0])
    floor.add_to(scene)
    with pytest.raises(ValueError, match="NaN"):
        engine.Solver(scene)
    scene = engine.Scene()
    scene.add_material((1.2, 0.5, 0.5))
    with pytest.raises(ValueError, match="reflectance"):
        engine.Solver(scene)
    for lobes, message in (({"transmittance": (0.6, 0.5, 0.5)}, "add up to more than 1"),
                           ({"glass": (0.2, -0.1, 0.2)}, "glass colour must be in"),
                           ({"specular": (0.2, math.nan, 0.2)}, "NaN or infinite specular"),
                           ({"ior": 0.9}, "index of refraction"), ({"roughness": 1.5}, "roughness")):
        scene = engine.Scene()
        scene.add_material((0.5, 0.5, 0.5), **lobes)
        with pytest.raises(ValueError, match=message):
            engine.Solver(scene)
    with pytest.raises(ValueError, match="preset"):
        engine.Settings.preset("ultra")
    for knob, value in (("threshold", 0.0), ("threshold", math.nan), ("relaxation", 2.5), ("relaxation", 0.5),
                        ("samples_indirect", 0), ("patch_size_relative", 0.0), ("db_cache_mb", -1.0)):
        settings = engine.Settings.preset("draft")
        setattr(settings, knob, value)
        with pytest.raises(ValueError, match=knob):
            engine.Solver(cornell_box()[0], settings)
    scene = engine.Scene()
    grey = scene.add_material((0.5, 0.5, 0.5))
    quad = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float64)
    scene.add_mesh(quad, np.array([4], np.int32), np.arange(4, dtype=np.int32), np.array([grey], np.int32),
                   smooth=np.array([True, False]))
    with pytest.raises(ValueError, match="1 faces but 2 smooth flags"):
        engine.Solver(scene)


def mixed_faces(material, light):
    """A triangle, a quad and a pentagon side by side (1 m each) under an emitting quad."""
    m = Mesh()
    m.add_face([(0, 0, 0), (1, 0, 0), (0.5, 1, 0)], material)
    m.add_face([(1, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0)], material)
    m.add_face([(2, 0, 0), (3, 0, 0), (3.3, 0.6, 0), (2.5, 1, 0), (2, 0.6, 0)], material)
    lamp = Mesh()
    lamp.add_face([(0, 0, 2), (0, 1, 2), (3, 1, 2), (3, 0, 2)], light)
    return m, lamp


@pytest.mark.parametrize("refine, level", [("bilinear", 0), ("bilinear", 1), ("bilinear", 3),
                                           ("catmull_clark", 2)])
def test_a_scene_past_the_patch_limit_is_refused_before_it_is_refined(refine, level):
    """The limit is checked on a count worked out from the faces; it must be the refiner's own count,
    exactly: faces at level 0 (a triangle as one quad), else n * 4^(level - 1) per n-gon, a quad 4^level.
    The pentagon needs a level to become quads: a bilinear mesh's other faces need not take it (each
    face is split as far as its own edges need), a Catmull-Clark mesh's take its level. The lamp's
    one quad always stays one patch."""
    scene = engine.Scene()
    grey, light = scene.add_material((0.5, 0.5, 0.5)), scene.add_material((0.5, 0.5, 0.5), (1, 1, 1))
    faces, lamp = mixed_faces(grey, light)
    patch = 1.2 / 2 ** level if refine == "bilinear" else 0.0   # the longest edge is 1.166 m
    faces.add_to(scene, refine=refine, level=level, patch_size=patch, name="Faces")
    lamp.add_to(scene, name="Lamp", patch_size=10.0)
    levels = {n: max(level, 1 if n == 5 or refine != "bilinear" else 0) for n in (3, 4, 5)}
    expected = 1 + sum(n * 4 ** (levels[n] - 1) if levels[n] else 1 for n in (3, 4, 5))
    settings = engine.Settings.preset("draft")
    settings.max_patches = expected
    solver = engine.Solver(scene, settings)
    assert solver.stats["patches"] == expected
    settings.max_patches = expected - 1
    with pytest.raises(ValueError, match=f"refine to {expected} patches.*object 'Faces' alone makes {expected - 1}"):
        engine.Solver(scene, settings)


def floor_tile_and_box(scene, material, light, joined):
    """A 4 m floor of three welded quads (a 4 x 3.6 field; a 3.6 x 0.4 strip and a 0.4 tile sharing a
    0.4 m edge) and a 0.4 m box on it, as one mesh or as four objects; an emitting quad above."""
    parts = [Mesh() for _ in range(4)]
    parts[0].add_face([(-2, -2, 0), (2, -2, 0), (2, 1.6, 0), (-2, 1.6, 0)], material)
    parts[1].add_face([(-1.6, 1.6, 0), (2, 1.6, 0), (2, 2, 0), (-1.6, 2, 0)], material)
    parts[2].add_face([(-2, 1.6, 0), (-1.6, 1.6, 0), (-1.6, 2, 0), (-2, 2, 0)], material)
    parts[3].add_box((0.5, 0.3, 0.2), (0.4, 0.4, 0.4), material, angle=0.4)
    del parts[3].faces[0], parts[3].materials[0]  # standing open on the floor
    if joined:
        one = Mesh()
        for part in parts:
            for face, m in zip(part.faces, part.materials):
                one.add_face([part.positions[i] for i in face], m)
        parts = [one.weld()]
    ids = [part.add_to(scene, refine="bilinear", patch_size=0.25) for part in parts]
    lamp = Mesh()
    lamp.add_face([(-0.5, -0.5, 2), (-0.5, 0.5, 2), (0.5, 0.5, 2), (0.5, -0.5, 2)], light)
    lamp.add_to(scene, patch_size=10.0)
    return ids


def test_each_face_of_a_mesh_is_split_as_far_as_its_own_edges_need():
    """A floor with a box joined to it is split as the two would be apart: the box's faces by their
    0.4 m edges (4 patches each), not the floor's 4 m (256), and the tile beside the strip likewise,
    meeting the strip's 17 points on their common edge with its 3 (T-junctions). The light agrees
    with the objects solved apart, where such junctions have always been, to the sampling's noise."""
    solved = {}
    for joined in (False, True):
        scene = engine.Scene()
        grey, light = scene.add_material((0.6, 0.6, 0.6)), scene.add_material((0.5, 0.5, 0.5), (5, 5, 5))
        ids = floor_tile_and_box(scene, grey, light, joined)
        solver = engine.Solver(scene, engine.Settings.preset("default"))
        solver.solve()
        solved[joined] = (solver.stats, np.concatenate([solver.corner_radiance(i) for i in ids]))
    (apart, alone), (together, joint) = solved[False], solved[True]
    assert together["patches"] == apart["patches"] == 256 + 256 + 4 + 5 * 4 + 1
    assert np.all(np.isfinite(joint)) and joint.min() > 0
    assert np.sqrt(np.mean((joint - alone) ** 2)) / alone.mean() < 0.005


def uneven_sphere():
    """A unit sphere facing in, its 24 meridians crossed by 4 wide rings below the equator and 16
    narrow ones above: faces split 4x apart, meeting along rings in T-junctions."""
    lat = np.concatenate([np.linspace(0.15, 1.2, 4), np.linspace(1.3, 2.9, 16)])
    lon = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    pos = [(0, 0, -1)] + [(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), -np.cos(t)) for t in lat for p in lon]
    pos.append((0, 0, 1))
    n, top, last = len(lon), len(pos) - 1, 1 + (len(lat) - 1) * len(lon)
    faces = [[0, 1 + j, 1 + (j + 1) % n] for j in range(n)]
    for i in range(len(lat) - 1):
        for j in range(n):
            a, b = 1 + i * n + j, 1 + i * n + (j + 1) % n
            faces.append([a, a + n, b + n, b])
    faces += [[last + j, top, last + (j + 1) % n] for j in range(n)]
    return np.array(pos, float), faces


@pytest.mark.parametrize("smooth, bound", [(False, 0.001), (True, 0.01)])
def test_faces_split_unevenly_keep_a_closed_emitter_uniform(smooth, bound):
    """Case 11 on a sphere whose faces take different levels: inside, uniform emission E with
    reflectance rho gives E / (1 - rho) everywhere, T-junctions or not. Smooth-shaded patches of a
    curved surface come out a little dark (README, known limits)."""
    pos, faces = uneven_sphere()
    scene = engine.Scene()
    m = scene.add_material((0.5, 0.5, 0.5), (1, 1, 1))
    sphere = scene.add_mesh(pos, np.array([len(f) for f in faces], np.int32), np.array(sum(faces, []), np.int32),
                            np.full(len(faces), m, np.int32), refine="bilinear", patch_size=0.2,
                            smooth=np.full(len(faces), smooth))
    settings = engine.Settings.preset("default")
    settings.threshold = 1e-4
    solver = engine.Solver(scene, settings)
    solver.solve()
    longest = [max(np.linalg.norm(pos[f[i]] - pos[f[i - 1]]) for i in range(len(f))) for f in faces]
    levels = [max(0, int(np.ceil(np.log2(e / 0.2)))) for e in longest]
    assert set(levels) == {0, 1}  # the top rings alone, the rest split in four
    assert solver.stats["patches"] == sum(4 ** l if len(f) == 4 else 3 * 4 ** (l - 1) if l else 1
                                          for f, l in zip(faces, levels))
    radiance = solver.corner_radiance(sphere)
    assert np.abs(radiance / 2.0 - 1).max() < bound


def test_an_addition_past_the_patch_limit_is_refused_whole():
    scene = engine.Scene()
    grey, light = scene.add_material((0.5, 0.5, 0.5)), scene.add_material((0.5, 0.5, 0.5), (1, 1, 1))
    faces, lamp = mixed_faces(grey, light)
    faces.add_to(scene, refine="bilinear", patch_size=0.3, name="Faces")
    lamp.add_to(scene, name="Lamp", patch_size=10.0)
    settings = engine.Settings.preset("draft")
    settings.max_patches = 200
    solver = engine.Solver(scene, settings)
    solver.solve()
    patches, before = solver.stats["patches"], solver.corner_radiance(0)
    more = engine.Scene()
    floor = Mesh()
    floor.add_face([(0, -1, -0.1), (3, -1, -0.1), (3, 2, -0.1), (0, 2, -0.1)], 0)
    floor.add_to(more, refine="bilinear", patch_size=0.1, name="Floor")    # 32 x 32 patches
    with pytest.raises(ValueError, match="past the limit of 200.*object 'Floor'"):
        solver.add(more)
    solver.update()
    assert solver.stats["patches"] == patches
    assert np.array_equal(solver.corner_radiance(0), before)


@pytest.mark.parametrize("level", [1, 2])
def test_a_smooth_mesh_whose_faces_disagree_on_the_front_stays_finite(level):
    # Found by fuzzing: a triangle and two quads, two of them naming a shared edge in the same
    # direction. Some limit normals turn more than a right angle from their facets; sending on the
    # reflected light divided by those facets' shares (corner_view.h) made the solve diverge: NaN
    # residual, inf radiance, and two million shots (128 s) to the shot limit.
    positions = np.array([[-15.93, 19.78, 1.31], [-9.66, -25.83, -8.50], [0.27, -9.11, 42.75],
                          [33.26, -89.57, -62.41], [-5.77, -13.95, 7.06]])
    scene = engine.Scene()
    m = scene.add_material((0.5, 0.5, 0.5))
    obj = scene.add_mesh(positions, np.array([3, 4, 4], np.int32),
                         np.array([2, 1, 3, 4, 1, 2, 0, 0, 4, 3, 1], np.int32), np.zeros(3, np.int32),
                         refine="catmull_clark", level=level)
    scene.add_point_light((-7.96, 66.2, -76.47), (8.5, 1.2, 7.3), 0.094)
    settings = engine.Settings.preset("draft")
    settings.max_shots = 5000
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    assert stats["converged"] and stats["residual"] <= settings.threshold
    radiance = solver.corner_radiance(obj)
    assert np.isfinite(radiance).all() and (radiance >= 0).all()
    # The lamp lights the faces' back sides, which corner_radiance does not show; a runaway solve
    # shows in the balance: light held and absorbed past what landed, or not finite.
    balance = solver.power_balance()
    assert all(math.isfinite(v) for v in balance.values())
    # Signed: over-relaxation leaves the patches it shot owing a little (negative unshot).
    assert abs(balance["unshot"]) <= settings.threshold * balance["injected"]
    assert 0.45 * balance["injected"] < balance["absorbed"] <= balance["injected"]


def test_a_solve_that_diverges_stops_and_says_so():
    # Found by fuzzing: a crumpled Catmull-Clark object 7 cm across, 2.5 km from a 1 cm quad. The
    # ray offset (1e-5 of the scene's size, 3 cm) is as large as the object, so its points see each
    # other with no ray between and the unshot light grows; the solve ran on to 1e46 and inf.
    positions = np.array([[0.005069, -0.003808, -0.007053], [0.009679, -0.009473, 0.002181],
                          [-0.00912, -4.8e-05, -0.005745], [0.015235, 0.002068, 0.002013],
                          [0.022331, -0.036548, -0.013566], [-0.034651, 0.000704, 0.006438],
                          [0.009067, 0.004177, -0.01062], [0.02335, 0.004573, -0.00278],
                          [-0.013946, 0.005996, -0.005834]])
    faces = [[1, 6, 5, 0], [4, 6, 1, 1, 7], [5, 7, 3], [4, 2, 1, 8, 6], [6, 0, 2, 3], [4, 2, 7, 7], [2, 6, 7, 0, 4]]
    scene = engine.Scene()
    m = scene.add_material((0.5, 0.5, 0.5))
    crumpled = scene.add_mesh(positions, np.array([len(f) for f in faces], np.int32),
                              np.array(sum(faces, []), np.int32), np.zeros(len(faces), np.int32),
                              refine="catmull_clark", level=2, name="Crumpled")
    far = Mesh()
    far.add_face([(-836, -1716, 1812), (-835.99, -1716, 1812), (-835.99, -1715.99, 1812), (-836, -1715.99, 1812)], m)
    far.add_to(scene)
    scene.set_world((0.5, 0.5, 0.5))
    settings = engine.Settings.preset("draft")
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    assert stats["diverged"] and not stats["converged"] and stats["shots"] < 200
    assert "diverged" in stats["warnings"][-1] and "most of it in 'Crumpled'" in stats["warnings"][-1]
    assert np.isfinite(solver.corner_radiance(crumpled)).all()


def boxes_standing_in_each_other(threshold):
    scene = engine.Scene()
    grey = scene.add_material((0.8, 0.8, 0.8))
    floor = Mesh()
    floor.add_face([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], grey)
    floor.add_to(scene, name="Floor")
    boxes = []
    for i, centre in enumerate([(0.0, 0.0, 0.15), (0.08, 0.004, 0.15)]):
        box = Mesh()
        box.add_box(centre, (0.3, 0.3, 0.3), grey)
        boxes.append(box.add_to(scene, name=f"Box{i}"))
    scene.add_sun_light((0.3, 0.2, -1.0), (3, 3, 3))
    settings = engine.Settings.preset("draft")
    settings.threshold = threshold
    solver = engine.Solver(scene, settings)
    return solver, solver.solve(), boxes


def test_boxes_standing_in_each_other_see_the_floor_and_their_tops_once():
    """Two boxes standing in each other on a floor: inside them the floor and both bottoms lie in one
    plane, and where they overlap so do their tops. Each of those surfaces is seen once, as Cycles'
    first hit sees one (visibility.h, Coincident). Seen more than once, the floor would make the
    boxes' insides reflect more than they take in, and at a tight threshold the light would grow
    without end."""
    solver, stats, boxes = boxes_standing_in_each_other(1e-6)
    assert stats["converged"] and not stats["diverged"] and stats["shots"] < 200
    # Nothing anywhere, inside or out, brighter than the sunlit tops: rho E cos / pi.
    sunlit = 0.8 * 3 / np.pi / np.linalg.norm((0.3, 0.2, -1.0))
    for b in boxes:
        v = solver.corner_radiance(b)
        assert np.isfinite(v).all() and v.max() < sunlit * (1 + 1e-6)
    assert abs(solver.corner_radiance(boxes[1])[4:8] / sunlit - 1).max() < 1e-6  # Box1's top


@pytest.mark.parametrize("floor_first", [True, False])
def test_a_furnace_standing_on_a_floor_sees_its_bottom_once(floor_first):
    """An emitting box (rho 0.9) facing in, on a floor of its own footprint, emitting and reflecting
    as it does: inside, the floor and the box's bottom lie in one plane, and every point is
    E / (1 - rho) only if it sees that plane once. Seen twice, the bottom's 0.2 of a wall's view made
    rho times the view 1.08 and the light grew without end. Whichever object comes first is seen."""
    rho = 0.9
    scene = engine.Scene()
    m = scene.add_material((rho,) * 3, (1.0, 1.0, 1.0))
    floor, box = Mesh(), Mesh()
    floor.add_face([(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)], m)
    box.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
    meshes = [floor, box] if floor_first else [box, floor]
    objects = [mesh.add_to(scene) for mesh in meshes]
    settings = engine.Settings.preset("draft")
    settings.threshold = 1e-4
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    assert stats["converged"] and not stats["diverged"]
    for obj in objects:
        b = solver.corner_radiance(obj)[:, 0] * (1 - rho)
        assert np.abs(b - 1).max() < 2e-3, b


def test_faces_doubled_in_one_mesh_are_seen_once():
    """An emitting box facing in (rho 0.9) with every face doubled in its one mesh: a point inside
    sees each wall once only if, of a face and its double, the patch of lower index blocks rays to
    the other (visibility.h, Coincident). Seen twice, rho times the view is 1.8 and the solve ran
    away."""
    rho = 0.9
    scene = engine.Scene()
    m = scene.add_material((rho,) * 3, (1.0, 1.0, 1.0))
    box = Mesh()
    box.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
    box.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
    obj = box.add_to(scene)
    settings = engine.Settings.preset("draft")
    settings.threshold = 1e-4
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    assert stats["converged"] and not stats["diverged"]
    b = solver.corner_radiance(obj)[:, 0] * (1 - rho)
    assert np.abs(b - 1).max() < 2e-3, b


def closed_objects_scene(weld):
    """Boxes over a floor, and a closed box facing in with a glowing cube inside it. Welded, each
    box is a closed surface (patch_mesh.h: enclosed_side); not, the same faces are open ones."""
    scene = engine.Scene()
    grey = scene.add_material((0.7, 0.7, 0.7))
    glow = scene.add_material((0.5, 0.5, 0.5), (20.0, 20.0, 20.0))
    floor = Mesh()
    floor.add_face([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], grey)
    ids = [floor.add_to(scene)]
    rng = np.random.default_rng(2)
    boxes = [Mesh() for _ in range(10)]
    for box in boxes[:8]:
        box.add_box((*rng.uniform(-1.6, 1.6, 2), rng.uniform(0.2, 0.8)), (0.3, 0.3, 0.3), grey, angle=rng.uniform(0, 1))
    boxes[8].add_box((0.0, 0.0, 1.5), (0.8, 0.8, 0.8), grey, inward=True)
    boxes[9].add_box((0.0, 0.0, 1.5), (0.1, 0.1, 0.1), glow)
    ids += [(box.weld() if weld else box).add_to(scene, refine="bilinear") for box in boxes]
    scene.add_sun_light((0.3, 0.2, -1.0), (3, 3, 3))
    scene.set_world((0.1, 0.1, 0.15))
    settings = engine.Settings.preset("draft")
    settings.threshold = 1e-4
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    return np.concatenate([solver.corner_radiance(i) for i in ids]), stats["rays"], solver.corner_radiance(ids[-2])


def test_closed_objects_inside_and_outside_trace_no_rays_to_each_other():
    """A closed surface's inside sees nothing beyond its sphere, nor is seen from there: gathers
    skip those rays, which it would block. The same boxes as closed surfaces and as open ones give
    the same light (within the 0.13% that welding moves the samples; 1e-7 against the same closed
    boxes with every ray traced, measured), for 27% fewer rays; the glowing cube inside the box
    facing in still lights it (its shot is within the box's sphere), and the sun does not."""
    open_light, open_rays, open_inside = closed_objects_scene(False)
    light, rays, inside = closed_objects_scene(True)
    assert rays < 0.8 * open_rays
    assert np.sqrt(np.mean((light - open_light) ** 2)) / np.mean(open_light) < 3e-3
    assert inside.mean() > 0.3 and abs(inside.mean() / open_inside.mean() - 1) < 1e-3


def test_catmull_clark_refines_onto_the_limit_surface():
    scene = engine.Scene()
    m = scene.add_material((0.5, 0.5, 0.5))
    cube = Mesh()
    cube.add_box((0, 0, 0), (2, 2, 2), m)
    obj = cube.weld().add_to(scene, refine="catmull_clark", level=3)
    scene.add_point_light((0, 0, 5), (10, 10, 10))
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    stats = solver.solve()
    assert stats["patches"] == 6 * 4 ** 3
    positions, radiance = solver.refined(obj)
    r = np.linalg.norm(positions, axis=1)
    assert 0.5 < r.min() and r.max() < 1.01  # the limit surface shrinks inside the cage's corners
    top = radiance[positions[:, 2] > 0.55, 0]
    bottom = radiance[positions[:, 2] < -0.55, 0]
    assert top.min() > 0 and bottom.max() == 0.0  # lit on top, the underside in shadow


def test_a_refined_furnace_keeps_its_light():
    # Case 10 at the default preset's refinement, where reflected light shoots from clusters: a far
    # cluster's form factor holds off its axis too (the disc approximation, right on its axis only,
    # falls 15% short beside a room's edges).
    rho = 0.9
    scene = engine.Scene()
    m = scene.add_material((rho,) * 3, (1.0, 1.0, 1.0))
    box = Mesh()
    box.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
    obj = box.add_to(scene, refine="bilinear")
    settings = engine.Settings.preset("default")
    settings.threshold = 1e-4
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    assert stats["converged"] and stats["patches"] == 6144
    b = solver.refined(obj)[1][:, 0] * (1 - rho)
    assert abs(b.mean() - 1) < 1e-3 and np.abs(b - 1).max() < 2e-3


def test_automatic_relaxation_follows_the_light_the_scene_sends_back():
    # Relaxation 0 measures, over the first shots at 1.0, the share of their light that comes back
    # to be shot again, and over-relaxes by 0.3 times it: a closed furnace sends back rho; the
    # Cornell box, open in front, 0.7; a lone floor, nothing.
    chosen = {}
    for name, rho in (("furnace", 0.9), ("floor", 0.5)):
        scene = engine.Scene()
        m = scene.add_material((rho,) * 3, (1.0,) * 3 if name == "furnace" else (0.0,) * 3)
        mesh = Mesh()
        if name == "furnace":
            mesh.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
        else:
            mesh.add_face([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], m)
            scene.add_point_light((0, 0, 1), (10.0,) * 3, 0.05)
        mesh.add_to(scene, refine="bilinear")
        stats = engine.Solver(scene, engine.Settings.preset("draft")).solve()
        chosen[name] = stats["relaxation"]
        assert stats["shots"] > 8  # past the measuring shots
    assert 1.26 < chosen["furnace"] < 1.28 and chosen["floor"] == 1.0
    # The Cornell box at draft: fewer shots than at 1.0 or 1.3 (606, 645; automatic 1.21: 512), to
    # the same light within the threshold's reach.
    shots, light = {}, {}
    for relaxation in (0.0, 1.0, 1.3):
        scene, ids = cornell_box()
        settings = engine.Settings.preset("draft")
        settings.relaxation = relaxation
        solver = engine.Solver(scene, settings)
        stats = solver.solve()
        assert stats["converged"]
        shots[relaxation], light[relaxation] = stats["shots"], solver.refined(ids[0])[1]
        chosen[relaxation] = stats["relaxation"]
    assert 1.18 < chosen[0.0] < 1.24
    assert shots[0.0] < 0.9 * min(shots[1.0], shots[1.3])
    assert np.abs(light[0.0].mean(0) / light[1.0].mean(0) - 1).max() < 0.03


def glowing_cube(rho, settings, **refine):
    """Solved inside a closed 2 m cube (welded, refined as `refine` asks) whose inner side emits 1
    and reflects rho: (solver, object id)."""
    scene = engine.Scene()
    m = scene.add_material((rho,) * 3, (1.0, 1.0, 1.0))
    cube = Mesh()
    cube.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
    obj = cube.weld().add_to(scene, **refine)
    solver = engine.Solver(scene, settings)
    assert solver.solve()["converged"]
    return solver, obj


def curved_furnace(rho, level=3):
    """Inside a closed Catmull-Clark surface that emits 1 and reflects rho: the solved inner side."""
    settings = engine.Settings.preset("default")
    settings.threshold = 1e-4
    solver, obj = glowing_cube(rho, settings, refine="catmull_clark", level=level)
    return solver.refined(obj)[1]


def test_a_curved_objects_far_clusters_send_all_its_light():
    # A glowing Catmull-Clark cube in a dark closed room: what the walls gather from it with 16
    # samples per shot (its far clusters stand for their patches) against 256 (its patches' cells
    # everywhere). A far sample's ray to its anchor patch's bilinear surface, which on a twisted patch
    # lies behind Embree's triangles, must not count the whole cluster as hidden (12% of the light),
    # nor may a cluster curved up to 26 degrees count its members seen edge-on against the rest (3%).
    gathered = []
    for samples in (16, 256):
        scene = engine.Scene()
        wall = scene.add_material((0.5,) * 3)
        glow = scene.add_material((0.0,) * 3, (1.0,) * 3)
        box, cube = Mesh(), Mesh()
        box.add_box((0, 0, 1.25), (4, 4, 2.5), wall, inward=True)
        walls = box.add_to(scene)
        cube.add_box((0, 0, 1.0), (1, 1, 1), glow, angle=0.5)
        cube.weld().add_to(scene, refine="catmull_clark", level=2)
        settings = engine.Settings.preset("default")
        settings.samples_direct = samples
        settings.max_shots = 0  # the cube's light as it lands, nothing reflected
        solver = engine.Solver(scene, settings)
        solver.solve()
        gathered.append(solver.refined(walls)[1].mean())
    assert gathered[0] == pytest.approx(gathered[1], rel=0.01)


def test_smooth_shaded_corners_take_the_light_cycles_facets_let_in():
    # Cycles' diffuse BSDF samples about the shading normal and drops what falls under the facet it
    # shades (bsdf_diffuse_sample), so a smooth-shaded corner reflects only (1 + cos tilt) / 2 of the
    # light reflected towards it from all round. A small Catmull-Clark cube in a furnace (every
    # surface emits E and reflects rho): its corners' limit normals lie along the diagonals; each
    # sees only the box, whose radiance B is E emitted, taken whole, and B - E reflected, taken in part.
    # (B is the box's solved value, 10.03 here: E / (1 - rho) = 10 holds to 0.3-0.8% with a small
    # cube inside, curved or flat, at rho = 0.9.)
    rho, e = 0.9, 1.0
    scene = engine.Scene()
    m = scene.add_material((rho,) * 3, (e,) * 3)
    box, cube = Mesh(), Mesh()
    box.add_box((0, 0, 0), (2, 2, 2), m, inward=True)
    walls = box.add_to(scene)
    cube.add_box((0, 0, 0), (0.1, 0.1, 0.1), m)
    obj = cube.weld().add_to(scene, refine="catmull_clark", level=1)
    settings = engine.Settings.preset("default")
    settings.threshold = 1e-5
    solver = engine.Solver(scene, settings)
    assert solver.solve()["converged"]
    positions, radiance = solver.refined(obj)
    quads = positions.reshape(-1, 4, 3)
    at_corner = np.abs(quads).sum(2) > 0.999 * np.abs(quads).sum(2).max()   # the 8 limit corners
    shares = []
    for q, c in zip(*np.nonzero(at_corner)):
        at = quads[q, c]
        facet = np.cross(quads[q, (c + 1) % 4] - at, quads[q, (c + 3) % 4] - at)
        shares.append((1 + facet @ np.sign(at) / np.linalg.norm(facet) / math.sqrt(3)) / 2)
    assert len(shares) == 24 and np.ptp(shares) < 1e-9
    b = solver.refined(walls)[1].mean()
    expected = e + rho * (e + shares[0] * (b - e))
    assert 1 - expected / b > 0.05                                        # 0.92 of the reflected light
    got = radiance.reshape(-1, 4, 3)[at_corner]
    assert np.abs(got / expected - 1).max() < 1e-3


def test_inside_a_smooth_shaded_cube_as_cycles_bakes_it():
    # The level-0 case of curved_furnace.json: the cube itself, its flat faces shaded smooth, as the
    # add-on sends it (split to a preset's patch size). Each corner's normal lies along a diagonal,
    # 54.7 degrees off its three facets, and reflects (1 + cos) / 2 = 0.79 of the light round it;
    # inside the faces the normals tilt less, and send on more. Cycles' corners: 0.615 of
    # E / (1 - rho) (min 0.608, max 0.622); ours 0.634, at draft and default alike (unsplit
    # faces, 0.617). Random walks of Cycles' model of the same cube without Cycles
    # (smooth_cube_walk.py) give 0.6310 +- 0.0005: ours +0.5%, Cycles' bake -2.5%.
    with open(os.path.join(os.path.dirname(__file__), "..", "cycles_reference", "curved_furnace.json")) as f:
        cycles = json.load(f)
    rho = cycles["rho"]
    solver, obj = glowing_cube(rho, engine.Settings.preset("draft"), refine="bilinear", smooth=np.ones(6, bool))
    ours = np.asarray(solver.corner_radiance(obj)).mean(1) * (1 - rho)
    assert abs(ours.mean() / 0.6310 - 1) < 0.01 and abs(ours.mean() / cycles["levels"]["0"]["mean"] - 1) < 0.04


def test_rays_reach_a_twisted_patch():
    # Nearly no reflection: B - E is rho times the light gathered from the whole surface, most of
    # one bounce and rho of the next; no more than 1 / (1 - rho) in all. A point inside sees all of
    # the surface but what lies under its corners' facets (0.4% at level 3). Rays ending on a
    # twisted patch short of its bulge off Embree's triangles are not blocked (else 0.93 at level 3).
    rho = 0.01
    gathered = (curved_furnace(rho)[:, 0] - 1.0) / rho
    assert gathered.min() > 0.99 and gathered.max() < 1 / (1 - rho)


@pytest.mark.parametrize("level, bound", [(1, 0.025), (2, 0.01), (3, 0.005)])
def test_inside_a_curved_furnace_as_cycles_bakes_it(level, bound):
    # Inside a closed surface every patch emits E and reflects rho: B = E / (1 - rho) on flat
    # faces. Cycles' smooth-shaded corners drop what lies under their facets, and on a concave
    # surface the facets next to a corner show it the rest at close range (corner_view.h), which the
    # point, gathering nothing from the patches it lies on, takes from them. Inside a face Cycles'
    # shading normal tilts less from the facet than at the corners, so the face sends on more light
    # than its corners show: the patch sends its interior share over the corner's. Its points are set
    # off in front of a concave surface, not along its tangent plane. Against Cycles' bake of the same
    # cube (curved_furnace.json) that leaves -0.94 / -0.15 / -0.10% at levels 1-3.
    with open(os.path.join(os.path.dirname(__file__), "..", "cycles_reference", "curved_furnace.json")) as f:
        cycles = json.load(f)
    ours = curved_furnace(cycles["rho"], level).mean(1) * (1 - cycles["rho"])
    assert abs(ours.mean() / cycles["levels"][str(level)]["mean"] - 1) < bound

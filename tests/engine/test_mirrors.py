"""Planar mirrors: a sharp specular plane passes on the light of the images of what shines on it,
through its outline, times its colour (Cycles' Glossy BSDF: no Fresnel). Checked on the direct light
(max_shots 0), where it is exact: a lamp's image adds R I cos / (pi d^2) at the floor points whose
path to the image crosses the mirror, a sun's image R E cos / pi, the world R times the sky the wall
hides, and an emitter's image what an emitter of R times its radiance at the image's place would
send. A rough specular lobe reflects diffusely. Updates of scenes with mirrors equal fresh solves."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import (MIRRORED_STATE, MIRRORED_STEPS, Mesh, cornell_box, engine, follow_updates,  # noqa: E402
                    mirrored_box, placed, room_balance)

RHO = 0.5
R = 0.8
WALL = 2.0      # the mirror stands in the plane x = WALL, facing -x, at the floor's edge
LAMP = (0.13, -0.07, 1.0)  # off the patches' grid
INTENSITY = 8.0


def settings(direct_only=True):
    s = engine.Settings.preset("default")
    s.threads = 1
    if direct_only:
        s.max_shots = 0
    return s


def floor(scene):
    """Object: a 4 x 4 floor at z = 0 facing up, its +x edge on the mirror's plane."""
    m = Mesh()
    m.add_face([(-2, -2, 0), (WALL, -2, 0), (WALL, 2, 0), (-2, 2, 0)], scene.add_material((RHO, RHO, RHO)))
    return m.add_to(scene, refine="bilinear", patch_size=0.1)


def mirror(scene, half=20.0, z=(0.0, 20.0), roughness=0.0, **kwargs):
    """A mirror in the plane x = WALL facing -x, `half` wide each way from y = 0, between heights z."""
    m = Mesh()
    material = scene.add_material((0.0, 0.0, 0.0), specular=(R, R, R), roughness=roughness)
    m.add_face([(WALL, half, z[0]), (WALL, -half, z[0]), (WALL, -half, z[1]), (WALL, half, z[1])], material)
    return m.add_to(scene, **kwargs)


def image(p):
    return np.array([2 * WALL - p[0], p[1], p[2]])


def lamp_term(points, lamp):
    """I cos / (pi d^2) at floor points from a point lamp: the irradiance over pi it sends."""
    d = np.asarray(lamp) - points
    d2 = (d * d).sum(1)
    return INTENSITY * d[:, 2] / np.sqrt(d2) / (math.pi * d2)


def solved(build, direct_only=True):
    scene = engine.Scene()
    ids = build(scene)
    solver = engine.Solver(scene, settings(direct_only))
    solver.solve()
    return solver, ids


def floor_radiance(solver, ids):
    positions, radiance = solver.refined(ids[0])
    positions, radiance = np.asarray(positions).reshape(-1, 3), np.asarray(radiance).reshape(-1, 3)
    off_wall = positions[:, 0] < WALL - 0.01  # points on the mirror's plane take nothing of it
    return positions[off_wall], radiance[off_wall].mean(1)


def with_lamp(**mirror_kwargs):
    def build(scene):
        ids = [floor(scene), mirror(scene, **mirror_kwargs)]
        scene.add_point_light(LAMP, (INTENSITY,) * 3)
        return ids
    return build


def test_a_mirror_plane_adds_the_image_lamps_light():
    points, ours = floor_radiance(*solved(with_lamp()))
    expected = RHO * (lamp_term(points, LAMP) + R * lamp_term(points, image(LAMP)))
    np.testing.assert_allclose(ours, expected, rtol=1e-3)


def test_a_square_mirror_lights_only_what_sees_the_image_through_it():
    half, z = 0.5, (0.5, 1.5)
    points, ours = floor_radiance(*solved(with_lamp(half=half, z=z)))
    # Where the segment from each floor point to the image lamp crosses the mirror's plane.
    to_image = image(LAMP) - points
    t = (WALL - points[:, 0]) / to_image[:, 0]
    y, height = points[:, 1] + t * to_image[:, 1], points[:, 2] + t * to_image[:, 2]
    margin = np.minimum.reduce([half - np.abs(y), height - z[0], z[1] - height])
    inside, outside = margin > 0.02, margin < -0.02  # clear of the outline
    assert inside.sum() > 20 and outside.sum() > 200
    direct = RHO * lamp_term(points, LAMP)
    np.testing.assert_allclose(ours[outside], direct[outside], rtol=1e-3)
    np.testing.assert_allclose(ours[inside], direct[inside] + RHO * R * lamp_term(points[inside], image(LAMP)),
                               rtol=1e-3)


def test_a_mirror_plane_adds_the_reflected_sun():
    t = math.radians(30.0)
    sun = 3.0

    def build(scene):
        ids = [floor(scene), mirror(scene)]
        scene.add_sun_light((math.sin(t), 0.0, -math.cos(t)), (sun, sun, sun))
        return ids
    points, ours = floor_radiance(*solved(build))
    np.testing.assert_allclose(ours, RHO * sun * math.cos(t) / math.pi * (1 + R), rtol=1e-3)


def test_a_mirror_plane_shows_the_world():
    """A uniform world: where a black wall hides the sky the mirror shows it, times R. The world is
    sampled by the same directions either way (a fixed pattern per receiver), so with F the sampled
    part of each floor point's view the wall fills, black = RHO L (1 - F) and mirror = RHO L (1 - F + R F)."""
    sky = 0.3

    def wall(specular):
        def build(scene):
            ids = [floor(scene)]
            m = Mesh()
            material = scene.add_material((0.0, 0.0, 0.0), specular=(specular,) * 3, roughness=0.0)
            m.add_face([(WALL, 20, 0), (WALL, -20, 0), (WALL, -20, 20), (WALL, 20, 20)], material)
            ids.append(m.add_to(scene))
            scene.set_world((sky, sky, sky))
            return ids
        return build
    _, mirrored = floor_radiance(*solved(wall(R)))
    _, black = floor_radiance(*solved(wall(0.0)))
    assert (black < 0.7 * RHO * sky).all()  # the wall hides much of the sky
    np.testing.assert_allclose(mirrored, black + R * (RHO * sky - black), rtol=1e-4)


EMITTER = [(0.3, 0.2, 1.2), (0.7, 0.2, 1.2), (0.7, 0.5, 1.2), (0.3, 0.5, 1.2)]  # facing down
EMISSION = 5.0


def emitter(scene, corners, radiance):
    m = Mesh()
    m.add_face(corners, scene.add_material((0.0, 0.0, 0.0), emission=(radiance,) * 3))
    return m.add_to(scene)


def test_an_emitters_image_sends_what_an_emitter_there_would_times_the_mirrors_colour():
    def mirrored(scene):
        ids = [floor(scene), mirror(scene)]
        emitter(scene, EMITTER, EMISSION)
        scene.add_area_light((0.0, -1.0, 1.5), (0.2, 0.0, 0.0), (0.0, 0.15, 0.0), (EMISSION,) * 3)
        return ids

    def unfolded(scene):  # no mirror: the images as real emitters of R times the radiance
        ids = [floor(scene)]
        emitter(scene, EMITTER, EMISSION)
        emitter(scene, [image(c) for c in EMITTER][::-1], R * EMISSION)
        scene.add_area_light((0.0, -1.0, 1.5), (0.2, 0.0, 0.0), (0.0, 0.15, 0.0), (EMISSION,) * 3)
        scene.add_area_light(tuple(image((0.0, -1.0, 1.5))), (0.2, 0.0, 0.0), (0.0, 0.15, 0.0), (R * EMISSION,) * 3)
        return ids
    points, ours = floor_radiance(*solved(mirrored))
    _, theirs = floor_radiance(*solved(unfolded))
    # The same form factors of the same cells; the images' shots sample as their shooters' do,
    # the real emitters' by clusters of their own (a far sample's error: under 0.5%).
    np.testing.assert_allclose(ours, theirs, rtol=5e-3)
    assert np.abs(ours / theirs - 1).mean() < 1e-3


def test_a_mirror_does_not_show_its_own_light_again():
    """An emitting (or diffusely reflecting) mirror's image of itself lies in its own plane: it is
    the mirror itself, which a receiver sees once. The wall shoots in clusters with a dark shelf at
    its foot, whose images are made (they lie off the plane) and send the shelf's light alone."""
    def glowing_wall(specular):
        def build(scene):
            ids = [floor(scene)]
            m = Mesh()
            glow = scene.add_material((0.0, 0.0, 0.0), emission=(2.0, 2.0, 2.0), specular=(specular,) * 3, roughness=0.0)
            m.add_face([(WALL, 2, 0.5), (WALL, -2, 0.5), (WALL, -2, 2), (WALL, 2, 2)], glow)
            m.add_face([(WALL - 0.5, -2, 0.5), (WALL, -2, 0.5), (WALL, 2, 0.5), (WALL - 0.5, 2, 0.5)],
                       scene.add_material((0.0, 0.0, 0.0)))
            ids.append(m.add_to(scene, refine="bilinear", patch_size=0.25))
            return ids
        return build
    mirrored, ids = solved(glowing_wall(R))
    plain, _ = solved(glowing_wall(0.0))
    np.testing.assert_array_equal(mirrored.refined(ids[0])[1], plain.refined(ids[0])[1])


def test_a_rough_specular_plane_reflects_as_a_diffuse_one_of_its_colour():
    def wall(lobes):
        def build(scene):
            ids = [floor(scene)]
            m = Mesh()
            m.add_face([(WALL, 2, 0), (WALL, -2, 0), (WALL, -2, 2), (WALL, 2, 2)], scene.add_material(**lobes))
            ids.append(m.add_to(scene, refine="bilinear", patch_size=0.25))
            scene.add_point_light(LAMP, (INTENSITY,) * 3)
            return ids
        return build
    rough, _ = solved(wall(dict(reflectance=(0.25,) * 3, specular=(0.5,) * 3, roughness=0.3)), False)
    diffuse, ids = solved(wall(dict(reflectance=(0.75,) * 3)), False)
    np.testing.assert_array_equal(rough.refined(ids[0])[1], diffuse.refined(ids[0])[1])


def test_power_balance_holds_with_a_mirror():
    # A mirror on a wall near the lamp.
    room_balance([(1.99, 0.9, 0.1), (1.99, -0.9, 0.1), (1.99, -0.9, 1.9), (1.99, 0.9, 1.9)],
                 (((0.05, 0.05, 0.05),), dict(specular=(R, 0.7, 0.6), roughness=0.0)), (1.2, 0.1, 1.1))


@pytest.mark.parametrize("preset, threshold, settled_bound", [
    ("default", None, 0.01),
    # Converged tightly, an update and a fresh solve agree far closer.
    ("draft", 1e-4, 3e-4),
])
def test_updates_with_mirrors_match_a_fresh_solve(preset, threshold, settled_bound):
    """An object moves in front of mirrors, a mirror moves, changes colour, stops being one and
    becomes one again, vanishes and appears, and a lamp moves: each an update like any other (no
    restart), within an updated frame's bound of a fresh solve of the new state, and once settled
    within `settled_bound`."""
    s = engine.Settings.preset(preset)
    if threshold:
        s.threshold = threshold
    follow_updates(mirrored_box, MIRRORED_STATE, MIRRORED_STEPS, s, settled_bound)


def test_a_curved_mirror_in_a_furnace_keeps_the_furnace_uniform():
    """Every surface of a closed room emits E and reflects RHO, a curved mirror inside (a
    Catmull-Clark cube: no few planes) among them with its RHO all specular: the room's radiance is
    E / (1 - RHO) everywhere, which holds only if the curved mirror passes on what it receives (it
    reflects diffusely). Reflecting nothing, it would darken the room by a few percent."""
    e = 1.0
    scene = engine.Scene()
    box, cube = Mesh(), Mesh()
    box.add_box((0, 0, 1), (2, 2, 2), scene.add_material((RHO,) * 3, (e,) * 3), inward=True)
    walls = box.add_to(scene, refine="bilinear", patch_size=0.25)
    cube.add_box((0, 0, 1), (0.8, 0.8, 0.8), scene.add_material((0.0,) * 3, (e,) * 3, specular=(RHO,) * 3,
                                                                 roughness=0.0), angle=0.4)
    cube.weld().add_to(scene, refine="catmull_clark", level=2)
    s = engine.Settings.preset("default")
    s.threshold = 1e-4
    solver = engine.Solver(scene, s)
    stats = solver.solve()
    assert any("is curved" in w and "reflects diffusely" in w for w in stats["warnings"])
    np.testing.assert_allclose(np.asarray(solver.refined(walls)[1]), e / (1 - RHO), rtol=0.01)


# The Cornell box with a chrome blob (a Catmull-Clark cube: a curved mirror) that moves, turns rough,
# sharp again, changes colour, vanishes and appears.
CHROME_STATE = dict(place=(0.3, -0.4, 0.5), specular=(0.9, 0.9, 0.9), roughness=0.0, visible=True)
CHROME_MATERIAL = 4  # after the box's four


def chrome_box(state):
    scene, ids = cornell_box(0.35, emission=1.0)
    chrome = scene.add_material((0.05, 0.05, 0.05), specular=state["specular"], roughness=state["roughness"])
    assert chrome == CHROME_MATERIAL
    blob = Mesh()
    blob.add_box((0, 0, 0), (0.4, 0.4, 0.4), chrome)
    blob_id = blob.weld().add_to(scene, refine="catmull_clark", level=2, transform=placed(state["place"]),
                                 dynamic=True, visible=state["visible"])
    return scene, ids + [blob_id], blob_id


def chrome_material(s, state):
    s.set_material(CHROME_MATERIAL, (0.05, 0.05, 0.05), specular=state["specular"], roughness=state["roughness"])


CHROME_STEPS = [
    ("the blob moves", dict(place=(-0.2, -0.3, 0.3)), lambda s, b, st: s.set_transform(b, placed(st["place"]))),
    ("it turns rough", dict(roughness=0.4), lambda s, b, st: chrome_material(s, st)),
    ("sharp again", dict(roughness=0.0), lambda s, b, st: chrome_material(s, st)),
    ("it changes colour", dict(specular=(0.9, 0.5, 0.2)), lambda s, b, st: chrome_material(s, st)),
    ("it vanishes", dict(visible=False), lambda s, b, st: s.set_visible(b, False)),
    ("it appears", dict(visible=True), lambda s, b, st: s.set_visible(b, True)),
]


def test_updates_of_a_curved_mirror_match_a_fresh_solve():
    """A curved mirror reflects diffusely through every change: each an update within an updated
    frame's bound of a fresh solve, and within 1% once settled."""
    follow_updates(chrome_box, CHROME_STATE, CHROME_STEPS, engine.Settings.preset("default"), 0.01)

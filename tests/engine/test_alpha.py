"""Alpha-mapped panes (leaf cards, lace curtains): a ray crossing one passes (1 - alpha) of its
transmittance where it crosses, alpha read from the material's image at the crossing's UV. A
floor under a card lit by a sun or a point lamp gets the image's shadow: the unoccluded analytic
light where the image is clear, none where it is opaque; updates of such a card match fresh solves."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, engine, follow_updates, placed  # noqa: E402

RHO = 0.5
TAU = (0.9, 0.6, 0.3)  # what the card's clear parts pass, per channel
SUN = 3.0              # the sun's irradiance
HALF = 2.0             # the floor and the card reach HALF each way from the z axis
CARD_Z = 1.0


def settings():
    s = engine.Settings.preset("default")
    s.threads = 1
    return s


def halves(size=64):
    """Alpha 0 on the image's left half (u < 0.5), 1 on its right."""
    image = np.zeros((size, size), np.float32)
    image[:, size // 2:] = 1.0
    return image


def checkers(size=64, squares=8):
    """An 8 x 8 checkerboard, alpha 1 on the square at the image's bottom left."""
    i = np.arange(size) * squares // size
    return ((i[:, None] + i[None, :]) % 2 == 0).astype(np.float32)


def square(z, material):
    """A horizontal square at height z, facing up; its corners from (-HALF, -HALF) counter-clockwise."""
    m = Mesh()
    m.add_face([(-HALF, -HALF, z), (HALF, -HALF, z), (HALF, HALF, z), (-HALF, HALF, z)], material)
    return m


def floor(scene):
    """Object 0, of reflectance RHO, under the card."""
    return square(0.0, scene.add_material((RHO, RHO, RHO))).add_to(scene, refine="bilinear", patch_size=0.125)


# The card's corners' UVs: the unit square over the card, u along x and v along y ...
PLAIN_UV = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
# ... and turned a quarter (u along y, v against x), shifted by a quarter in u.
TURNED_UV = np.array([(0.25, 1.0), (0.25, 0.0), (1.25, 0.0), (1.25, 1.0)])


def card_uv(uv, x, y):
    """Where a point (x, y) of the card reads the image: bilinear in its corners' UVs, as a
    texture is mapped over a flat quad (what the engine should do, worked out independently)."""
    s, t = (x + HALF) / (2 * HALF), (y + HALF) / (2 * HALF)
    w = [(1 - s) * (1 - t), s * (1 - t), s * t, (1 - s) * t]
    return sum(w[k][..., None] * uv[k] for k in range(4))


def texel_alpha(image, uv):
    """The image's texel at uv (repeating), and whether uv lies more than a texel from any other
    value (where bilinear reading between texel centres gives the texel itself)."""
    h, w = image.shape
    x, y = uv[..., 0] * w, uv[..., 1] * h
    col, row = np.floor(x).astype(int) % w, np.floor(y).astype(int) % h
    alpha = image[row, col]
    clean = np.ones(alpha.shape, bool)
    for dc in (-1, 0, 1):
        for dr in (-1, 0, 1):
            clean &= image[(row + dr) % h, (col + dc) % w] == alpha
    return alpha, clean


def card_scene(image, light, uv=PLAIN_UV, refine=dict(refine="bilinear", patch_size=0.5), **card):
    """A floor (object 0) under an alpha card of reflectance 0 (object 1) lit by `light(scene)`:
    nothing reflects light back to the floor, so its radiance is RHO times its direct light."""
    scene = engine.Scene()
    floor_id = floor(scene)
    leaf = scene.add_material((0.0, 0.0, 0.0), transmittance=TAU, alpha=image)
    card_id = square(CARD_Z, leaf).add_to(scene, corner_uv=uv, **refine, **card)
    light(scene)
    return scene, floor_id, card_id


def solved(image, light, **kwargs):
    scene, floor, _ = card_scene(image, light, **kwargs)
    solver = engine.Solver(scene, settings())
    solver.solve()
    return solver.refined(floor)


def sun(scene):
    scene.add_sun_light((0.0, 0.0, -1.0), (SUN, SUN, SUN))


def expect_pattern(positions, radiance, alpha, clean, direct, rtol=1e-4):
    """Where the card is clear the floor gets TAU of `direct`; where it is opaque, nothing."""
    assert clean.sum() > 200 and (alpha[clean] == 0).any() and (alpha[clean] == 1).any()
    want = (1 - alpha[clean])[:, None] * direct[clean][:, None] * np.array(TAU)
    np.testing.assert_allclose(radiance[clean], want, rtol=rtol, atol=1e-6)


@pytest.mark.parametrize("image, uv", [(halves(), PLAIN_UV), (checkers(), PLAIN_UV), (checkers(), TURNED_UV)],
                         ids=["halves", "checkers", "checkers turned and shifted"])
def test_a_sun_straight_down_casts_the_image(image, uv):
    positions, radiance = solved(image, sun, uv=uv)
    alpha, clean = texel_alpha(image, card_uv(uv, positions[:, 0], positions[:, 1]))
    expect_pattern(positions, radiance, alpha, clean, np.full(len(positions), RHO * SUN / math.pi))


LAMP = (0.13, -0.07, 2.0)


def lamp(scene):
    scene.add_point_light(LAMP, (8.0, 8.0, 8.0))


def test_a_point_lamp_casts_the_image_onto_the_floor_from_its_place():
    image = halves()
    positions, radiance = solved(image, lamp, refine=dict(refine="none"))
    lamp_at = np.array(LAMP)
    # The ray from a floor point to the lamp crosses the card's plane at this point.
    along = (CARD_Z - positions[:, 2]) / (lamp_at[2] - positions[:, 2])
    crossing = positions + along[:, None] * (lamp_at - positions)
    inside = (np.abs(crossing[:, :2]) < HALF - 0.1).all(axis=1)
    alpha, clean = texel_alpha(image, card_uv(PLAIN_UV, crossing[:, 0], crossing[:, 1]))
    to_lamp = lamp_at - positions
    d2 = (to_lamp ** 2).sum(axis=1)
    direct = RHO * 8.0 * to_lamp[:, 2] / np.sqrt(d2) / (math.pi * d2)
    # The engine lights a receiving point slightly inside its patches, not at the vertex.
    expect_pattern(positions, radiance, alpha, clean & inside, direct, rtol=1e-3)


def test_a_card_with_no_uvs_passes_its_mean():
    positions, radiance = solved(halves(), sun, uv=None)
    np.testing.assert_allclose(radiance, np.broadcast_to(0.5 * RHO * SUN / math.pi * np.array(TAU), radiance.shape),
                               rtol=1e-4)


def test_faces_split_to_different_levels_carry_the_uvs():
    """The UVs reach the patches when the card's faces are split alone, each as far as its size
    needs (a big face and two small ones), not only by OpenSubdiv's uniform steps."""
    image = checkers()
    scene = engine.Scene()
    floor_id = floor(scene)
    leaf = scene.add_material((0.0, 0.0, 0.0), transmittance=TAU, alpha=image)
    m = Mesh()
    corners = [[(-HALF, -HALF), (0.5, -HALF), (0.5, HALF), (-HALF, HALF)],
               [(0.5, -HALF), (HALF, -HALF), (HALF, 0.0), (0.5, 0.0)],
               [(0.5, 0.0), (HALF, 0.0), (HALF, HALF), (0.5, HALF)]]
    for face in corners:
        m.add_face([(x, y, CARD_Z) for x, y in face], leaf)
    xy = np.array([c for face in corners for c in face])
    m.add_to(scene, refine="bilinear", patch_size=0.4, corner_uv=card_uv(PLAIN_UV, xy[:, 0], xy[:, 1]))
    sun(scene)
    solver = engine.Solver(scene, settings())
    solver.solve()
    positions, radiance = solver.refined(floor_id)
    alpha, clean = texel_alpha(image, card_uv(PLAIN_UV, positions[:, 0], positions[:, 1]))
    expect_pattern(positions, radiance, alpha, clean, np.full(len(positions), RHO * SUN / math.pi))


def test_bad_alpha_and_uvs_are_refused_with_a_message():
    def scene_with(image=halves(), uv=PLAIN_UV):
        scene, _, _ = card_scene(image, sun, uv=uv)
        return engine.Solver(scene, settings())

    nan = halves()
    nan[3, 3] = np.nan
    with pytest.raises(ValueError, match="alpha map"):
        scene_with(nan)
    with pytest.raises(ValueError, match="alpha map"):
        scene_with(halves() - 0.5)
    with pytest.raises(ValueError, match="alpha map"):
        scene_with(np.zeros(16, np.float32))
    with pytest.raises(ValueError, match="4 face corners but 3 corner UVs"):
        scene_with(uv=PLAIN_UV[:3])
    with pytest.raises(ValueError, match="NaN or infinite UV"):
        scene_with(uv=np.where(PLAIN_UV == 1.0, np.inf, PLAIN_UV))


def card_room(state):
    """A floor and a back wall under a dynamic leaf card lit by a lamp, the card placed by
    state["card"]."""
    scene = engine.Scene()
    white = scene.add_material((0.6, 0.6, 0.6))
    leaf = scene.add_material((0.3, 0.4, 0.2), transmittance=TAU, alpha=state["image"])
    room = Mesh()
    room.add_face([(-HALF, -HALF, 0.0), (HALF, -HALF, 0.0), (HALF, HALF, 0.0), (-HALF, HALF, 0.0)], white)
    room.add_face([(-HALF, HALF, 0.0), (HALF, HALF, 0.0), (HALF, HALF, 2.0), (-HALF, HALF, 2.0)], white)
    ids = [room.add_to(scene, refine="bilinear", patch_size=0.25)]
    card = Mesh()
    card.add_face([(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0)], leaf)
    card_id = card.add_to(scene, refine="bilinear", patch_size=0.25, corner_uv=PLAIN_UV, dynamic=True,
                          transform=placed(state["card"]))
    scene.add_point_light((0.3, -0.4, 2.5), (20.0, 20.0, 20.0), 0.05)
    scene.set_world((0.05, 0.05, 0.08))
    return scene, ids + [card_id], card_id


def test_updates_of_an_alpha_card_match_a_fresh_solve():
    steps = [
        ("the card slides", dict(card=(0.3, 0.2, 1.0)), lambda s, c, st: s.set_transform(c, placed(st["card"]))),
        ("the card drops", dict(card=(0.3, 0.2, 0.6)), lambda s, c, st: s.set_transform(c, placed(st["card"]))),
        ("its image changes", dict(image=halves()),
         lambda s, c, st: s.set_material(1, (0.3, 0.4, 0.2), transmittance=TAU, alpha=st["image"])),
    ]
    follow_updates(card_room, dict(card=(0.0, 0.0, 1.0), image=checkers()), steps, settings(), 0.01)

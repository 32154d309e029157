"""trace_corner.py's path tracer, the limit reference at junctions, against closed forms: an area
lamp's light is its radiance times its form factor, a mirror passes on a lamp's light as the
lamp's image behind it, times its colour, a pane passes what it lets through of a lamp's and of
the world's light, and a sun gives its irradiance times the cosine."""
import math
import os
import sys

import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
import trace_corner  # noqa: E402

RHO, MIRROR, RADIANCE = 0.5, 0.9, 3.0
UP = np.array([0.0, 0.0, 1.0])


def polygon_form_factor(point, normal, polygon):
    """Lambert's closed form: the form factor from a point facing `normal` to a polygon (corners (K,3))
    wholly in front of it."""
    r = polygon - point
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    after = np.roll(r, -1, axis=0)
    edges = np.cross(r, after)
    angles = np.arccos(np.clip((r * after).sum(1), -1.0, 1.0))
    return abs((angles * (edges @ normal) / np.linalg.norm(edges, axis=1)).sum()) / (2 * math.pi)


def quad(corners):
    """The two triangles of a quad (corners (4,3))."""
    c = np.asarray(corners, float)
    return [c[[0, 1, 2]], c[[0, 2, 3]]]


def rectangle(centre, u, v):
    """Corners (4,3) of the rectangle centre +- u +- v."""
    c, u, v = (np.asarray(a, float) for a in (centre, u, v))
    return np.array([c - u - v, c + u - v, c + u + v, c - u + v])


def traced(lamp, mirror_x=None):
    """Radiance and standard error leaving a small grey floor patch at the origin, facing up (so
    small that light it reflects does not come back), lit by the rectangular area lamp `lamp`
    (centre, half axes u and v, the direction its light travels), with a mirror in the plane
    x = mirror_x facing the patch, large enough to show the lamp's whole image."""
    tris = quad(rectangle((0, 0, 0), (0.01, 0, 0), (0, 0.01, 0)))
    rho, mirror = [(RHO,) * 3] * 2, [(0.0,) * 3] * 2
    if mirror_x is not None:
        tris += quad(rectangle((mirror_x, 0, 1.5), (0, 0, 2.5), (0, 4, 0)))
        rho, mirror = rho + [(0.0,) * 3] * 2, mirror + [(MIRROR,) * 3] * 2
    areas = tuple(np.array([a], float) for a in lamp) + (np.array([[RADIANCE] * 3]),)
    tracer = trace_corner.Tracer(np.array(tris), np.array(rho), np.zeros((len(tris), 3)), np.array(mirror),
                                 ((np.zeros((0, 3)), np.zeros((0, 3))), areas), seed=3)
    value, error = tracer.radiance(np.zeros(3), UP, 400_000)
    return value.mean(), error.mean()


def test_area_lamp_is_radiance_times_form_factor():
    centre, u, v = (0.6, 0, 0.5), (0.5, 0, 0), (0, 0.4, 0)
    value, error = traced((centre, u, v, (0, 0, -1)))
    expected = RHO * RADIANCE * polygon_form_factor(np.zeros(3), UP, rectangle(centre, u, v))
    assert error < 0.005 * expected
    assert abs(value - expected) < 4 * error


def test_mirror_shows_a_lamp_turned_away_as_its_image_times_its_colour():
    # the lamp faces the mirror, its back to the patch: all the patch gets comes by way of the
    # mirror, through the lamp (lamps do not block rays)
    u, v = (0, 0.5, 0), (0, 0, 0.4)
    value, error = traced(((-0.2, 0, 0.6), u, v, (-1, 0, 0)), mirror_x=-0.4)
    image = rectangle((-0.6, 0, 0.6), u, v)                  # the lamp reflected about x = -0.4
    expected = RHO * RADIANCE * MIRROR * polygon_form_factor(np.zeros(3), UP, image)
    assert error < 0.01 * expected
    assert abs(value - expected) < 4 * error


def pane_between(transparent=(0.0,) * 3, glass=(0.0,) * 3, ior=1.5):
    """A floor patch under a 2 m square slab 6 mm thick at z = 0.3 (two faces, each crossing one),
    of a transparent colour or glass: its triangles, reflectances, mirror colours and panes."""
    tris = quad(rectangle((0, 0, 0), (0.01, 0, 0), (0, 0.01, 0)))
    for z in (0.3, 0.306):
        tris += quad(rectangle((0, 0, z), (1, 0, 0), (0, 1, 0)))
    n = len(tris)
    straight = np.array([(0.0,) * 3] * 2 + [transparent] * (n - 2), float)
    glassy = np.array([(0.0,) * 3] * 2 + [glass] * (n - 2), float)
    rho = np.array([(RHO,) * 3] * 2 + [(0.0,) * 3] * (n - 2), float)
    return np.array(tris), rho, np.zeros((n, 3)), (straight, glassy, np.full(n, ior))


def test_a_pane_passes_its_colour_of_a_lamp_and_of_the_world():
    centre, u, v = (0.2, 0, 1.0), (0.3, 0, 0), (0, 0.2, 0)
    tris, rho, zero, panes = pane_between(transparent=(0.6, 0.6, 0.6))
    areas = tuple(np.array([a], float) for a in (centre, u, v, (0, 0, -1))) + (np.array([[RADIANCE] * 3]),)
    sky = 0.4
    tracer = trace_corner.Tracer(tris, rho, zero, zero, ((np.zeros((0, 3)), np.zeros((0, 3))), areas), seed=5,
                                 panes=panes, world=(sky,) * 3)
    value, error = (a.mean() for a in tracer.radiance(np.zeros(3), UP, 200_000))
    slab = rectangle((0, 0, 0.3), (1, 0, 0), (0, 1, 0))
    through = 0.6 * 0.6  # two faces
    expected = RHO * through * (RADIANCE * polygon_form_factor(np.zeros(3), UP, rectangle(centre, u, v))
                                + sky * polygon_form_factor(np.zeros(3), UP, slab))
    expected += RHO * sky * (1 - polygon_form_factor(np.zeros(3), UP, slab))  # the open sky beside it
    assert error < 0.01 * expected
    assert abs(value - expected) < 4 * error


def test_glass_passes_one_minus_fresnel_at_each_face_and_a_sun_its_irradiance_times_the_cosine():
    tris, rho, zero, panes = pane_between(glass=(0.9, 0.9, 0.9))
    irradiance, up = 2.0, math.radians(50.0)
    direction = np.array([[-math.cos(up), 0.0, -math.sin(up)]])  # the way the light travels
    tracer = trace_corner.Tracer(tris, rho, zero, zero, ((np.zeros((0, 3)), np.zeros((0, 3))), tuple(
        np.zeros((0, 3)) for _ in range(5))), seed=5, panes=panes,
        suns=(direction, np.array([0.0]), np.array([[irradiance] * 3])))
    value, error = (a.mean() for a in tracer.radiance(np.zeros(3), UP, 20_000))
    f = trace_corner.fresnel(math.sin(up), 1.5)  # the glass's normal is the floor's: cos = sin(elevation)
    expected = RHO / math.pi * irradiance * math.sin(up) * (0.9 * (1 - f)) ** 2
    assert abs(value - expected) < 1e-3 * expected + 4 * error
    # Fresnel's closed form at normal incidence: ((n - 1) / (n + 1))^2
    assert trace_corner.fresnel(1.0, 1.5) == pytest.approx(0.04)

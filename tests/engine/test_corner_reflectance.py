"""Reflectance given per face corner (a colour texture sampled at the corners) in place of the
materials'."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, engine  # noqa: E402


def lit_floor(corner_reflectance=None, rho=0.5, refine="bilinear", level=0, max_shots=None, mirror=1.0):
    """A 2 x 2 floor (one quad) under a lamp inside a grey room: (solver, floor id)."""
    scene = engine.Scene()
    grey = scene.add_material((0.6, 0.6, 0.6))
    floor_material = scene.add_material((rho,) * 3)
    room = Mesh()
    room.add_box((0, 0, 1), (4, 4, 2), grey, inward=True)
    room.add_to(scene)
    floor = Mesh()
    floor.add_face([(-1, -1, 0.01), (1, -1, 0.01), (1, 1, 0.01), (-1, 1, 0.01)], floor_material)
    kwargs = {} if corner_reflectance is None else {"corner_reflectance": np.asarray(corner_reflectance, float)}
    obj = floor.add_to(scene, refine=refine, level=level, transform=np.diag([mirror, 1.0, 1.0, 1.0]), **kwargs)
    scene.add_point_light((0.3, 0.2, 1.5), (20, 20, 20))
    settings = engine.Settings.preset("draft")
    if max_shots is not None:
        settings.max_shots = max_shots
    return engine.Solver(scene, settings), obj


@pytest.mark.parametrize("refine,level", [("bilinear", 0), ("catmull_clark", 2)])
def test_the_materials_reflectance_given_per_corner_changes_nothing(refine, level):
    plain, floor = lit_floor(refine=refine, level=level)
    plain.solve()
    given, same = lit_floor([(0.5, 0.5, 0.5)] * 4, refine=refine, level=level)
    given.solve()
    np.testing.assert_array_equal(given.refined(same)[1], plain.refined(floor)[1])
    np.testing.assert_array_equal(given.corner_radiance(same), plain.corner_radiance(floor))


@pytest.mark.parametrize("mirror", [1.0, -1.0])
def test_each_corner_reflects_its_own_and_patches_inside_interpolate(mirror):
    # Direct light only: radiance is reflectance times irradiance at every refined patch corner,
    # the reflectance bilinear across the face from its four corners' (each channel its own). A
    # mirroring transform turns the patches' corners round: their reflectance must turn with them.
    rho = np.array([(0.1, 0.2, 0.3), (0.9, 0.5, 0.1), (0.4, 0.4, 0.4), (0.2, 0.8, 0.6)])
    plain, floor = lit_floor(rho=0.5, max_shots=0, mirror=mirror)
    plain.solve()
    textured, same = lit_floor(rho, rho=0.05, max_shots=0, mirror=mirror)
    textured.solve()
    positions, radiance = textured.refined(same)
    irradiance = plain.refined(floor)[1] / 0.5
    u = (mirror * positions[:, 0:1] + 1) / 2
    v = (positions[:, 1:2] + 1) / 2
    expected = (1 - u) * (1 - v) * rho[0] + u * (1 - v) * rho[1] + u * v * rho[2] + (1 - u) * v * rho[3]
    assert len(positions) > 100
    np.testing.assert_allclose(radiance, expected * irradiance, rtol=1e-6)  # float32 out
    np.testing.assert_allclose(textured.corner_radiance(same), rho * plain.corner_radiance(floor) / 0.5, rtol=1e-6)


def test_reflectance_per_corner_carries_the_bounces():
    # A floor given 0.8 per corner over a material of 0.1 reflects as the material of 0.8 does.
    given, floor = lit_floor([(0.8, 0.8, 0.8)] * 4, rho=0.1)
    given.solve()
    plain, same = lit_floor(rho=0.8)
    plain.solve()
    np.testing.assert_array_equal(given.corner_radiance(floor), plain.corner_radiance(same))


def test_a_material_change_leaves_a_textured_objects_reflectance_alone():
    textured, floor = lit_floor([(0.3, 0.3, 0.3)] * 4, rho=0.5)
    textured.solve()
    before = textured.corner_radiance(floor).copy()
    textured.set_material(1, (0.9, 0.9, 0.9))
    stats = textured.update()
    assert stats["converged"]
    np.testing.assert_allclose(textured.corner_radiance(floor), before, rtol=1e-9)


@pytest.mark.parametrize("rho,match", [([(0.5, 0.5, 0.5)] * 3, "4 face corners but 3"),
                                       ([(0.5, 0.5, 0.5)] * 3 + [(1.0, 0.5, 0.5)], "face corner 3: reflectance"),
                                       ([(0.5, 0.5, 0.5)] * 3 + [(np.nan, 0.5, 0.5)], "face corner 3: NaN")])
def test_bad_corner_reflectance_is_refused(rho, match):
    with pytest.raises(ValueError, match=match):
        lit_floor(rho)


# ----------------------------------------------------------------------------- emission per corner
def glowing_panel(corner_emission=None, emission=2.0):
    """A 1 x 1 panel at height 1, facing down, over a 6 x 6 floor (both sides emit, as Cycles' mesh
    lights do), nothing else: (solver, panel id, floor id)."""
    scene = engine.Scene()
    floor_material = scene.add_material((0.5, 0.5, 0.5))
    glow = scene.add_material((0.0, 0.0, 0.0), (emission,) * 3)
    floor = Mesh()
    floor.add_face([(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor_material)
    floor_id = floor.add_to(scene, refine="bilinear", patch_size=0.25)
    panel = Mesh()
    panel.add_face([(-0.5, -0.5, 1), (-0.5, 0.5, 1), (0.5, 0.5, 1), (0.5, -0.5, 1)], glow)
    kwargs = {} if corner_emission is None else {"corner_emission": np.asarray(corner_emission, float)}
    panel_id = panel.add_to(scene, refine="bilinear", patch_size=0.25, **kwargs)
    settings = engine.Settings.preset("default")
    settings.max_shots = 0   # direct light only
    return engine.Solver(scene, settings), panel_id, floor_id


def test_emission_per_corner_lights_as_its_interpolation_does():
    plain, panel, floor = glowing_panel()
    plain.solve()
    given, _, _ = glowing_panel([(2.0, 2.0, 2.0)] * 4)
    given.solve()
    np.testing.assert_array_equal(given.refined(floor)[1], plain.refined(floor)[1])   # the material's: the same
    # 1 to 3 across x, 2 on average: the panel shows it at its corners; below its middle the floor
    # takes what a panel of 2 sends there (the slope cancels by symmetry); below its edges, what the
    # slope's integral over the panel gives.
    ramp = [(1.0,) * 3, (1.0,) * 3, (3.0,) * 3, (3.0,) * 3]
    sloped, _, _ = glowing_panel(ramp)
    sloped.solve()
    np.testing.assert_allclose(sloped.corner_radiance(panel), np.array(ramp), rtol=1e-6)
    middle = lambda s: radiance_at(s, floor, (0.0, 0.0))[1]   # noqa: E731
    assert middle(sloped)[0] == pytest.approx(middle(plain)[0], rel=2e-3)
    for x in (-0.5, 0.5, 1.0):
        at, value = radiance_at(sloped, floor, (x, 0.0))
        assert value[0] == pytest.approx(0.5 * below_ramp(at[0], at[1]), rel=0.01), at


def below_ramp(x, y):
    """What a point at (x, y, 0) takes, over pi, from the unit panel at height 1 sending 2 + 2 x'."""
    n = 1000
    u = (np.arange(n) + 0.5) / n - 0.5
    px, py = np.meshgrid(u, u)
    r2 = (px - x) ** 2 + (py - y) ** 2 + 1
    return ((2 + 2 * px) / (np.pi * r2 ** 2)).sum() / n ** 2


def radiance_at(solver, obj, xy):
    """(position, radiance) of the patch corner of `obj` nearest `xy`."""
    positions, radiance = solver.refined(obj)
    i = np.argmin(np.linalg.norm(positions[:, :2] - xy, axis=1))
    return positions[i], radiance[i]


def test_a_material_change_leaves_a_textured_objects_emission_alone():
    ramp = [(1.0,) * 3, (1.0,) * 3, (3.0,) * 3, (3.0,) * 3]
    solver, panel, floor = glowing_panel(ramp)
    solver.solve()
    before = solver.refined(floor)[1]
    solver.set_material(1, (0.0, 0.0, 0.0), (9.0, 9.0, 9.0))
    solver.update()
    np.testing.assert_allclose(solver.corner_radiance(panel), np.array(ramp), rtol=1e-6)
    np.testing.assert_allclose(solver.refined(floor)[1], before, rtol=1e-9)
    with pytest.raises(ValueError, match="emission must be finite and not negative"):
        glowing_panel([(1.0,) * 3, (-1.0,) * 3, (1.0,) * 3, (1.0,) * 3])[0]

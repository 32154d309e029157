"""The panel's estimate: counts from the scene's bounds, times from what this machine's bakes took."""
import os

import bpy
import pytest

from conftest import SAMPLES


def open_blend(name):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, name + ".blend"))
    return bpy.context.scene


@pytest.fixture
def fresh(addon):
    """The machine's rates back at the add-on's starting values."""
    m = addon.preferences.machine()
    m.seconds_per_point, m.seconds_per_ray = addon.preferences.SECONDS_PER_POINT, addon.preferences.SECONDS_PER_RAY
    m.ratios = ""
    return m


def test_counts_are_in_the_right_range(addon, fresh):
    # Against what bakes of the Cornell box count (bench/results/accuracy_vs_time.csv): draft 1,815
    # points, 2 M rays; default 6,655 points, 32 M rays.
    scene = open_blend("cornell_box")
    for preset, pts, rays in (('DRAFT', 1815, 2e6), ('DEFAULT', 6655, 32e6)):
        scene.radiosity.preset = preset
        points, r, (low, high) = addon.estimate.cost(scene.radiosity, scene)
        assert pts / 2 < points < pts * 2 and rays / 3 < r < rays * 3 and 0 < low < high


def test_the_machine_rates_are_the_median_of_its_last_bakes(addon, fresh):
    """Bakes twice as slow as the starting rates make them twice as slow; one bake ten times slower
    moves them no further; only the last KEEP count."""
    scene = open_blend("cornell_box")
    P, R = 5000.0, 2e7
    base = addon.preferences.SECONDS_PER_POINT * P + addon.preferences.SECONDS_PER_RAY * R
    for factor in (2.0, 2.0, 2.0, 20.0):
        addon.estimate.record(scene, {"points": P, "rays": R, "seconds": factor * base})
    assert fresh.seconds_per_ray == pytest.approx(2.0 * addon.preferences.SECONDS_PER_RAY, rel=1e-3)
    assert fresh.seconds_per_point == pytest.approx(2.0 * addon.preferences.SECONDS_PER_POINT, rel=1e-3)
    for _ in range(addon.estimate.KEEP):
        addon.estimate.record(scene, {"points": P, "rays": R, "seconds": 0.5 * base})
    assert fresh.seconds_per_ray == pytest.approx(0.5 * addon.preferences.SECONDS_PER_RAY, rel=1e-3)
    assert len(fresh.ratios.split()) == addon.estimate.KEEP


def test_a_bake_teaches_the_estimate_the_scene_and_the_machine(addon, fresh):
    """After one bake the estimate of the same knobs is that bake's counts, and its range holds its
    time; the Quality menu's time for that preset is the same range."""
    scene = open_blend("cornell_box")
    props = scene.radiosity
    props.preset = 'DRAFT'
    before = addon.estimate.cost(props, scene)[2]
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    points, rays, (low, high) = addon.estimate.cost(props, scene)
    assert points == pytest.approx(props.last_points, rel=0.01) and rays == pytest.approx(props.last_rays, rel=0.01)
    assert low < props.last_seconds < high and high / low < before[1] / before[0]
    assert addon.estimate.preset_times(scene)['DRAFT'] == pytest.approx((low, high))
    times = addon.estimate.preset_times(scene)
    assert times['DRAFT'][1] < times['DEFAULT'][1] < times['HIGH'][1] < times['REFERENCE'][1]


def test_the_rates_are_kept_in_the_preferences(addon):
    """Enabled, the add-on learns into its AddonPreferences (saved with Blender's preferences)."""
    addons = bpy.context.preferences.addons
    entry = addons.get("dynamic_radiosity")
    if entry is None:
        entry = addons.new()
        entry.module = "dynamic_radiosity"
    try:
        m = addon.preferences.machine()
        assert isinstance(m, bpy.types.AddonPreferences)
        scene = open_blend("cornell_box")
        addon.estimate.record(scene, {"points": 1000.0, "rays": 1e7, "seconds": 3.0})
        assert m.ratios and m.seconds_per_ray > 0
    finally:
        addons.remove(entry)

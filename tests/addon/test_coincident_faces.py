"""Stacked copies of a quad in one mesh bake as one quad does: Cycles sees the first of coincident
faces, and the bake says which object holds them."""
import bpy
import numpy as np

from conftest import load_package


def bake_floor_and_panel(copies):
    """A floor under a panel of `copies` stacked quads (separate vertices, one mesh), a lamp between."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    floor = bpy.data.meshes.new("Floor")
    floor.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    quad = np.array([(-0.5, -0.5, 0.5), (-0.5, 0.5, 0.5), (0.5, 0.5, 0.5), (0.5, -0.5, 0.5)])
    panel = bpy.data.meshes.new("Panel")
    panel.from_pydata(np.tile(quad, (copies, 1)).tolist(), [], np.arange(4 * copies).reshape(copies, 4).tolist())
    obs = []
    for me in (floor, panel):
        ob = bpy.data.objects.new(me.name, me)
        scene.collection.objects.link(ob)
        obs.append(ob)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    lamp.data.energy = 50.0
    lamp.location = (0, 0, 0.25)
    scene.collection.objects.link(lamp)
    scene.radiosity.preset = 'DEFAULT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    return scene, [load_package().writeback.read_mesh(ob.data)[:, :3] for ob in obs]


def test_five_stacked_quads_bake_as_one(addon):
    _, (floor_one, panel_one) = bake_floor_and_panel(1)
    assert floor_one.min() > 0 and panel_one.min() > 0          # both lit, so a copy would show
    scene, (floor_five, panel_five) = bake_floor_and_panel(5)
    assert "'Panel': faces stacked exactly on its own" in scene.radiosity.last_warnings
    np.testing.assert_allclose(floor_five, floor_one, rtol=0.005)
    np.testing.assert_allclose(panel_five, np.tile(panel_one, (5, 1)), rtol=0.005)


def test_moving_a_face_stacked_on_another_objects_starts_a_new_solver_and_says_why(addon):
    """A copy of the floor lying exactly on it, both static, is merged with it across objects; the
    engine cannot move it incrementally, so live update solves afresh, and its record says the engine refused
    the change (the reason the panel shows), not only the console."""
    live = addon.live_update
    scene, _ = bake_floor_and_panel(1)
    decal = bpy.data.meshes.new("Decal")
    decal.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    ob = bpy.data.objects.new("Decal", decal)
    scene.collection.objects.link(ob)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    scene.radiosity.live_update = True
    ob.location.x = 0.3
    bpy.context.view_layer.update()
    info = live.last_sync[scene.name]
    assert info["mode"] == "full", info
    assert "refused" in (info["reason"] or ""), info

"""Live update of the change kinds that test_live_update.py leaves out: deformation by a
modifier (of a box, and of a flat floor bent apart at its vertices), a shape key and an armature, and lamps (colour, position, the direction of spot, sun and
area lamps). Each one is a single edit of a baked edit_scene. The edit must reach the Solver as one
call on the edited object, and the result must match a fresh bake of the edited state, with
test_live_update's bound and settings.
"""
import bpy
import numpy as np
import pytest

# clean_scene_after is autouse: imported, it leaves the files after this one an empty scene too.
from test_live_update import (BOUND, call_names, check_like_a_fresh_bake, clean_scene_after,  # noqa: F401
                              edit_scene, fresh_bake, ms, read, relative_rms, stacked)


# Each setup prepares the scene before the bake, so that the change it returns is the only
# difference from the baked state: an edit of something that is already there, not an addition.
def simple_deform(scene):
    mod = scene.objects["Box"].modifiers.new("Taper", 'SIMPLE_DEFORM')
    mod.deform_method = 'TAPER'
    mod.factor = 0.0
    return lambda: setattr(mod, "factor", 0.8)


def bent_floor(scene):
    # A shape key raising a pyramid in the floor: its flat faces bend apart at the vertices they
    # share. Taken in place because a deforming object's flat faces keep a point each
    # (MeshDesc::deforms); sharing one, they would be refused and the scene solved anew.
    floor = scene.objects["Floor"]
    floor.shape_key_add(name="Basis")
    key = floor.shape_key_add(name="Pyramid")
    co = np.empty(3 * len(key.data), np.float32)
    key.data.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, 2] += 0.3 * np.clip(1.0 - np.abs(co[:, :2] - 1.0).max(1), 0.0, None)  # beside the box
    key.data.foreach_set("co", co.ravel())
    return lambda: setattr(key, "value", 1.0)


def shape_key(scene):
    box = scene.objects["Box"]
    box.shape_key_add(name="Basis")
    key = box.shape_key_add(name="Squash")
    co = np.empty(3 * len(key.data), np.float32)
    key.data.foreach_get("co", co)
    co[2::3] *= 0.5
    key.data.foreach_set("co", co)
    return lambda: setattr(key, "value", 1.0)


def armature(scene):
    box = scene.objects["Box"]
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode='EDIT')                 # bones can only be made in Edit Mode
    bone = rig.data.edit_bones.new("Bone")
    bone.head, bone.tail = (0.0, 0.0, 0.0), (0.0, 0.0, 0.6)
    bpy.ops.object.mode_set(mode='OBJECT')
    box.vertex_groups.new(name="Bone").add(range(len(box.data.vertices)), 1.0, 'REPLACE')
    box.modifiers.new("Armature", 'ARMATURE').object = rig
    pose = rig.pose.bones["Bone"]
    pose.rotation_mode = 'XYZ'
    return lambda: setattr(pose, "rotation_euler", (0.6, 0.0, 0.0))


def lamp_colour(scene):
    return lambda: setattr(bpy.data.lights["Lamp"], "color", (1.0, 0.3, 0.1))


def lamp_position(scene):
    return lambda: setattr(scene.objects["Lamp"], "location", (-0.8, 0.6, 1.5))


def spot_rotation(scene):
    spot = ms.lamp("Spot", 'SPOT', (1.0, 1.0, 1.5), color=(1.0, 0.8, 0.6), energy=300.0)
    return lambda: setattr(spot, "rotation_euler", (0.5, 0.3, 0.0))


def sun_rotation(scene):
    sun = ms.lamp("Sun", 'SUN', (0.0, 0.0, 3.0), rotation=(0.3, 0.0, 0.0), energy=2.0)
    return lambda: setattr(sun, "rotation_euler", (0.9, 0.4, 0.0))


def area_move_and_rotation(scene):
    area = ms.lamp("Area", 'AREA', (0.0, 1.5, 1.5), energy=100.0)

    def change():
        area.location = (0.5, -1.0, 1.2)
        area.rotation_euler = (0.8, 0.0, 0.0)
    return change


@pytest.mark.parametrize("setup,call,target", [
    (simple_deform, "set_positions", "Box"),
    (bent_floor, "set_positions", "Floor"),
    (shape_key, "set_positions", "Box"),
    (armature, "set_positions", "Box"),
    (lamp_colour, "set_point_light", "Lamp"),
    (lamp_position, "set_point_light", "Lamp"),
    (spot_rotation, "set_spot_light", "Spot"),
    (sun_rotation, "set_sun_light", "Sun"),
    (area_move_and_rotation, "set_area_light", "Area"),
], ids=lambda p: getattr(p, "__name__", None))
def test_change_is_incremental_and_matches_fresh_bake(addon, setup, call, target):
    live = addon.live_update
    scene = edit_scene()
    change = setup(scene)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    scene.radiosity.live_update = True
    before = read(scene)
    change()
    bpy.context.view_layer.update()                       # depsgraph_update_post -> live update
    info = live.last_sync[scene.name]
    job = live.live_jobs[scene.name]
    assert info["mode"] == "incremental" and call_names(job) == [call], (info, job.calls)
    held = job.export.meshes if call == "set_positions" else job.export.lights
    assert held[job.calls[0][1][0]].name == target
    check_like_a_fresh_bake(scene, before, setup.__name__)


def raise_floor(scene, height):
    """The flat floor's own vertices raised into a pyramid beside the box (as a script, or leaving
    Edit Mode, moves them): its flat faces bend apart at the vertices they share."""
    floor = scene.objects["Floor"].data
    co = np.empty(3 * len(floor.vertices), np.float32)
    floor.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, 2] = height * np.clip(1.0 - np.abs(co[:, :2] - 1.0).max(1), 0.0, None)
    floor.vertices.foreach_set("co", co.ravel())
    floor.update()


def test_vertices_moved_without_a_modifier_bend_a_flat_floor_in_place(addon):
    """The first such edit sends the floor once more as deforming (the old one hidden for good, the
    new one added: no new Solver), the next a set_positions of that one; then as a fresh bake."""
    live = addon.live_update
    scene = edit_scene()
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    scene.radiosity.live_update = True
    before = read(scene)
    for height, calls in ((0.15, ["add", "set_visible"]), (0.3, ["set_positions"])):
        raise_floor(scene, height)
        bpy.context.view_layer.update()
        info = live.last_sync[scene.name]
        job = live.live_jobs[scene.name]
        assert info["mode"] == "incremental" and call_names(job) == calls, (info, job.calls)
    check_like_a_fresh_bake(scene, before, "floor's vertices raised")


def test_a_floor_bent_in_the_edit_that_adds_an_object_is_solved_anew(addon):
    """The added object went to the Solver when its call was made: sent again after the refusal, it
    would come twice. So that edit is a new Solver and a full solve."""
    live = addon.live_update
    scene = edit_scene()
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    scene.radiosity.live_update = True
    ms.box("Box2", (0.3, 0.3, 0.3), (-1.0, -1.0, 0.0), 0.0, ms.diffuse("Blue", (0.1, 0.1, 0.8)))
    raise_floor(scene, 0.3)
    bpy.context.view_layer.update()
    job = live.live_jobs[scene.name]
    assert not job.incremental and "refused" in job.rebuild_reason, job.rebuild_reason
    assert [m.name for m in job.export.meshes].count("Box2") == 1
    now = stacked(read(scene))
    assert relative_rms(now, stacked(fresh_bake(scene))) < BOUND

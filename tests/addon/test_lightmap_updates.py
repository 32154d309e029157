"""Lightmaps kept current: by live update (only those whose light may have changed are evaluated
again) and by Bake Animation (an OpenEXR sequence an image), each against a fresh bake of the same
state: the invariant that an update is a fresh solve, within 0.5% relative RMS over the covered
texels (reference.relative_rms)."""
import os
import sys
import threading

import bpy
import numpy as np
import pytest

from conftest import ROOT, load_engine, load_package

load_engine()   # when collected: a missing or broken engine fails the run (conftest.load_engine)
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
from reference import relative_rms  # noqa: E402

BOUND = 0.005


@pytest.fixture(scope="module", autouse=True)
def clean_scene_after():
    yield
    bpy.ops.wm.read_factory_settings(use_empty=True)


def plane(scene, name, corners, rho):
    """A one-sided quad (corners counter-clockwise seen from its front) of grey Diffuse BSDF `rho`."""
    me = bpy.data.meshes.new(name)
    me.from_pydata(corners, [], [(0, 1, 2, 3)])
    ob = bpy.data.objects.new(name, me)
    scene.collection.objects.link(ob)
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (rho, rho, rho, 1)
    mat.node_tree.links.new(bsdf.outputs[0], nodes["Material Output"].inputs[0])
    me.materials.append(mat)
    return ob


def blocker_scene():
    """A point lamp 2 m over a grey 4 m floor with a grey wall at its side, a black square blocker
    halfway up, and a grey panel (Far) below the floor's level 5 m away, facing the lamp. Far sees
    the lamp past the floor's edge and nothing the blocker changes: the floor hides the wall from
    it, the floor and the wall face away, and the blocker (black) reflects nothing and stays out of
    the lamp's rays to it."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    plane(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], 0.6)
    plane(scene, "Wall", [(-2, -2, 0), (-2, 2, 0), (-2, 2, 1), (-2, -2, 1)], 0.7)
    plane(scene, "Blocker", [(-0.2, -0.2, 1), (-0.2, 0.2, 1), (0.2, 0.2, 1), (0.2, -0.2, 1)], 0.0)
    plane(scene, "Far", [(5, 1, -2.5), (5, -1, -2.5), (5, -1, -1), (5, 1, -1)], 0.5)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    lamp.data.energy, lamp.data.shadow_soft_size = 300.0, 0.0
    lamp.location = (0, 0, 2)
    scene.collection.objects.link(lamp)
    scene.world = None
    props = scene.radiosity
    props.preset = 'DRAFT'
    props.threshold = 1e-3
    props.lightmaps = True
    props.texel_density, props.lightmap_min_size = 12.0, 16
    return scene


def pixels(image):
    out = np.empty(4 * image.size[0] * image.size[1], np.float32)
    image.pixels.foreach_get(out)
    return out.reshape(image.size[1], image.size[0], 4)


def covered(addon, name, image):
    """Flat indices of the texels of object `name`'s lightmap that lie on its faces."""
    ob = bpy.data.objects[name]
    return addon.lightmap.Raster(ob.data, ob.data.uv_layers["RadiosityUV"], *image.size).texel


def lightmaps(addon, names):
    """{name: (covered texels' rgb)} of the objects' lightmap images as they are."""
    out = {}
    for name in names:
        image = bpy.data.images[name + "_Radiosity"]
        out[name] = pixels(image)[..., :3].reshape(-1, 3)[covered(addon, name, image)].copy()
    return out


def fresh_lightmaps(addon, scene, names):
    """The lightmaps of a full bake of the scene as it is."""
    live = scene.radiosity.live_update
    scene.radiosity.live_update = False
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    scene.radiosity.live_update = live
    return lightmaps(addon, names)


def square(x, y, z, half, emission=0.0):
    """A horizontal square's MeshExport-like record (what shadow_reach reads)."""
    from types import SimpleNamespace
    return SimpleNamespace(positions=np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], float),
                           transform=np.array([[1, 0, 0, x], [0, 1, 0, y], [0, 0, 1, z], [0, 0, 0, 1]], float),
                           visible=True, corner_emission=None, face_materials=np.array([1 if emission else 0]))


def exported(meshes, lights=(), world=(0, 0, 0)):
    from types import SimpleNamespace
    materials = [SimpleNamespace(emission=(0, 0, 0)), SimpleNamespace(emission=(5, 5, 5))]
    return SimpleNamespace(meshes=meshes, materials=materials, lights=list(lights), world=np.array(world, float),
                           world_map=None)


def point_lamp(x, y, z):
    from types import SimpleNamespace
    return SimpleNamespace(kind="point", position=np.array([x, y, z], float), radius=0.0, visible=True,
                           intensity=np.ones(3), irradiance=None, radiance=None)


def test_a_move_reaches_the_objects_it_may_shade_from_a_direct_source(addon):
    """Two floors under a lamp, a small blocker moving: the floor below it is reached, the one
    beside whose rays to the lamp it stays far from is not; every object is, if the mover emits or
    the world lights the scene. The sun's rays come from far along its direction."""
    reached = addon.shadow_reach.reached
    lamp = point_lamp(0, 0, 3)
    floors = [square(0, 0, 0, 1.0), square(6, 0, 0, 1.0)]
    old = exported(floors + [square(0.2, 0, 1.5, 0.1)], [lamp])
    new = exported(floors + [square(-0.2, 0, 1.5, 0.1)], [lamp])
    assert reached(old, new, {2}, [0, 1]) == {0}
    # Moved over the far floor's rays, where it was or where it is: reached.
    assert reached(old, exported(floors + [square(3, 0, 1.5, 0.1)], [lamp]), {2}, [0, 1]) == {0, 1}
    assert reached(exported(floors + [square(0.2, 0, 1.5, 0.1, emission=1)], [lamp]), new, {2}, [0, 1]) == {0, 1}
    assert reached(old, exported(floors + [square(-0.2, 0, 1.5, 0.1)], [lamp], world=(0.1, 0.1, 0.1)), {2},
                   [0, 1]) == {0, 1}
    # An emitting mesh is a source like a lamp: the blocker between it and the far floor reaches it.
    glow = square(6, 0, 3, 0.5, emission=1)
    assert reached(exported(floors + [square(6, 0, 1.5, 0.1), glow]), exported(floors + [square(6.2, 0, 1.5, 0.1), glow]),
                   {2}, [0, 1]) == {1}
    from types import SimpleNamespace
    sun = SimpleNamespace(kind="sun", direction=np.array([0, 0, -1.0]), angle=0.01, visible=True,
                          intensity=None, irradiance=np.ones(3), radiance=None)
    high = [square(6, 0, 20, 0.5), square(6.1, 0, 20, 0.5)]     # far above the far floor
    assert reached(exported(floors + [high[0]], [sun]), exported(floors + [high[1]], [sun]), {2}, [0, 1]) == {1}


def test_live_update_keeps_lightmaps_a_fresh_bakes_and_leaves_those_whose_light_stays(addon):
    """Moving the blocker moves its shadow on the floor and what the floor and the wall reflect.
    After the live update the floor's and the wall's lightmaps are a fresh bake's of the new state;
    Far's light does not change, and its lightmap is not evaluated again (the update's record names
    the lightmaps it evaluated) and stays as it was."""
    live = addon.live_update
    scene = blocker_scene()
    names = ("Floor", "Wall", "Far")
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    before = lightmaps(addon, names)
    scene.radiosity.live_update = True
    bpy.data.objects["Blocker"].location = (0.3, -0.25, 0.0)
    bpy.context.view_layer.update()                   # depsgraph_update_post -> live update
    # The bake hands what it evaluated on: already the first update evaluates only what the move
    # reaches, and so does each later one.
    for step in range(2):
        if step:
            bpy.data.objects["Blocker"].location = (0.35, -0.3, 0.0)
            bpy.context.view_layer.update()
        info = live.last_sync[scene.name]
        assert info["mode"] == "incremental", info
        assert {"Floor", "Wall", "Blocker"} <= set(info["lightmaps_evaluated"]), info
        assert "Far" not in info["lightmaps_evaluated"], info
    updated = lightmaps(addon, names)
    assert relative_rms(updated["Floor"], before["Floor"]) > 0.05     # the shadow moved
    fresh = fresh_lightmaps(addon, scene, names)
    for name in names:
        err = relative_rms(updated[name], fresh[name])
        print(f"{name}: live update against a fresh bake: {100 * err:.3f}% RMS over {len(fresh[name])} texels")
        assert err < BOUND, name
    np.testing.assert_allclose(updated["Far"], before["Far"], rtol=1e-5)


def animated_blocker_scene(folder):
    """blocker_scene() with the blocker keyframed over frames 1-3, saved into `folder`; the floor's
    material reads its lightmap through an Image Texture node."""
    scene = blocker_scene()
    blocker = bpy.data.objects["Blocker"]
    for frame, x in ((1, -0.3), (2, 0.0), (3, 0.3)):
        blocker.location.x = x
        blocker.keyframe_insert("location", frame=frame)
    scene.frame_start, scene.frame_end = 1, 3
    scene.frame_set(1)
    image = bpy.data.images.new("Floor_Radiosity", 40, 40, alpha=True, float_buffer=True)
    node = bpy.data.materials["Floor"].node_tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "anim.blend"))
    return bpy.context.scene, node


def read_exr(path):
    image = bpy.data.images.load(path, check_existing=False)
    try:
        return pixels(image).copy()
    finally:
        bpy.data.images.remove(image)


def test_bake_animation_writes_each_frames_lightmaps_as_an_exr_sequence(addon, tmp_path):
    """One EXR a frame and object in <file>_lightmaps/<image>/, the images sequences of them that
    the Image Texture node plays frame by frame, and frame k's file a fresh bake of frame k."""
    scene, node = animated_blocker_scene(str(tmp_path))
    names = ("Floor", "Wall", "Blocker", "Far")
    assert bpy.ops.radiosity.bake_animation() == {'FINISHED'}
    folder = tmp_path / "anim_lightmaps"
    files = {name: [folder / f"{name}_Radiosity" / f"{name}_Radiosity_{k:04d}.exr" for k in (1, 2, 3)]
             for name in names}
    assert sorted(p.name for p in folder.iterdir()) == sorted(f"{n}_Radiosity" for n in names)
    for name in names:
        assert sorted(folder.joinpath(f"{name}_Radiosity").iterdir()) == files[name]
        image = bpy.data.images[f"{name}_Radiosity"]
        assert image.source == 'SEQUENCE' and image.packed_file is None
        assert bpy.path.abspath(image.filepath) == str(files[name][0])
    assert (node.image_user.frame_start, node.image_user.frame_duration, node.image_user.frame_offset) == (1, 3, 0)
    assert node.image_user.use_auto_refresh
    scene.radiosity.live_update = True      # past the baked range it updates, and leaves the sequences
    for k in (1, 2, 3, 4):                  # the node shows file k on frame k, the last one after it
        scene.frame_set(k)
        material = bpy.data.materials["Floor"].evaluated_get(bpy.context.evaluated_depsgraph_get())
        assert material.node_tree.nodes[node.name].image_user.frame_current == min(k, 3)
    assert addon.live_update.last_sync[scene.name]["frame"] == 4
    assert all(bpy.data.images[f"{name}_Radiosity"].source == 'SEQUENCE' for name in names)
    scene.radiosity.live_update = False
    baked = {name: [read_exr(str(p)) for p in files[name]] for name in names}
    assert relative_rms(baked["Floor"][2][..., :3], baked["Floor"][0][..., :3]) > 0.05   # the shadow moved
    for k in (1, 2, 3):
        scene.frame_set(k)
        assert bpy.ops.radiosity.bake() == {'FINISHED'}       # a still again, frame k's
        for name in names:
            image = bpy.data.images[f"{name}_Radiosity"]
            assert image.source != 'SEQUENCE'
            texel = covered(addon, name, image)
            fresh = pixels(image)[..., :3].reshape(-1, 3)[texel]
            err = relative_rms(baked[name][k - 1][..., :3].reshape(-1, 3)[texel], fresh)
            print(f"frame {k} {name}: EXR against a fresh bake: {100 * err:.3f}% RMS over {len(texel)} texels")
            assert err < BOUND, (k, name)


def test_a_failed_bake_animation_leaves_the_lightmaps_and_their_files_as_they_were(addon, tmp_path, monkeypatch):
    scene, _node = animated_blocker_scene(str(tmp_path))
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    before = pixels(bpy.data.images["Floor_Radiosity"]).copy()
    colours = addon.job.BakeJob.colours

    def fail_on_frame_3(job, *args, **kwargs):
        if job.frame == 3:
            raise RuntimeError("frame 3 failed")
        return colours(job, *args, **kwargs)
    monkeypatch.setattr(addon.job.BakeJob, "colours", fail_on_frame_3)
    with pytest.raises(RuntimeError, match="frame 3 failed"):
        bpy.ops.radiosity.bake_animation()
    image = bpy.data.images["Floor_Radiosity"]
    assert image.source != 'SEQUENCE' and image.packed_file is not None
    np.testing.assert_array_equal(pixels(image), before)
    assert list((tmp_path / "anim_lightmaps").iterdir()) == []


def test_bake_animation_of_an_unsaved_file_says_where_lightmaps_would_go(addon):
    scene = blocker_scene()
    scene.frame_start, scene.frame_end = 1, 2
    assert bpy.ops.radiosity.bake_animation() == {'FINISHED'}
    assert "save the .blend first" in scene.radiosity.last_warnings
    assert "Floor_Radiosity" not in bpy.data.images


def test_the_uis_bake_animation_evaluates_lightmaps_in_its_worker_and_writes_nothing_on_esc(addon, tmp_path, monkeypatch):
    """The modal path (test_addon.modal_bake): each frame's lightmaps evaluated in the worker thread,
    written on success; Esc after the first frame leaves the images and their folder as they were."""
    from test_addon import modal_bake
    scene, _node = animated_blocker_scene(str(tmp_path))
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    before = pixels(bpy.data.images["Floor_Radiosity"]).copy()
    on_main = []
    evaluate = addon.lightmap_updates.Lightmaps.evaluate
    monkeypatch.setattr(addon.lightmap_updates.Lightmaps, "evaluate", lambda self, *args: (
        on_main.append(threading.current_thread() is threading.main_thread()), evaluate(self, *args))[1])
    result, reports, _ = modal_bake(addon, animation=True, stop=lambda op: op._index == 1)
    assert result == {'CANCELLED'}, reports
    image = bpy.data.images["Floor_Radiosity"]
    assert image.source != 'SEQUENCE'
    np.testing.assert_array_equal(pixels(image), before)
    assert list((tmp_path / "anim_lightmaps").iterdir()) == []
    result, reports, _ = modal_bake(addon, animation=True)
    assert result == {'FINISHED'}, reports
    assert on_main and not any(on_main)
    assert image.source == 'SEQUENCE'
    assert len(list((tmp_path / "anim_lightmaps" / "Floor_Radiosity").iterdir())) == 3


def test_the_uis_bake_evaluates_lightmaps_in_its_worker_and_writes_them_only_when_done(addon, monkeypatch):
    """A still bake from the UI (modal): its lightmaps are evaluated in the worker thread (on the main
    thread Blender would freeze for seconds), and written only once the bake is done; Esc before
    that leaves them as they were."""
    from test_addon import modal_bake
    blocker_scene()
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    image = bpy.data.images["Floor_Radiosity"]
    before = pixels(image).copy()
    bpy.data.objects["Blocker"].location = (0.3, -0.25, 0.0)
    bpy.context.view_layer.update()
    on_main = []
    evaluate = addon.lightmap_updates.Lightmaps.evaluate
    monkeypatch.setattr(addon.lightmap_updates.Lightmaps, "evaluate", lambda self, *args: (
        on_main.append(threading.current_thread() is threading.main_thread()), evaluate(self, *args))[1])
    result, reports, _ = modal_bake(addon, stop=lambda op: True)
    assert result == {'CANCELLED'}, reports
    np.testing.assert_array_equal(pixels(image), before)
    result, reports, _ = modal_bake(addon)
    assert result == {'FINISHED'}, reports
    assert on_main and not any(on_main)
    assert relative_rms(pixels(image)[..., :3], before[..., :3]) > 0.05      # the shadow moved

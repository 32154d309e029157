"""The add-on package: registration, operators, write-back, cancel, error reports.

The package is loaded from the source tree (addon/) as `dynamic_radiosity`; the engine comes from
build/engine (the add-on's fallback when it is not installed next to it).
"""
import json
import os
import threading

import bmesh
import bpy
import numpy as np
import pytest

from conftest import SAMPLES, load_engine, load_package

load_engine()   # when collected: a missing or broken engine fails the run (conftest.load_engine)


def open_blend(name, frame=None, preset='DRAFT'):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, name + ".blend"))
    scene = bpy.context.scene
    if frame is not None:
        scene.frame_set(frame)
    scene.radiosity.preset = preset
    return scene


def colours(ob):
    return load_package().writeback.read_mesh(ob.data)


def meshes(scene):
    return [ob for ob in scene.objects if ob.type == 'MESH' and not ob.hide_render]


def empty_with_plane(light=True, world=(0, 0, 0)):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    me = bpy.data.meshes.new("Plane")
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    ob = bpy.data.objects.new("Plane", me)
    scene.collection.objects.link(ob)
    if light:
        ld = bpy.data.lights.new("Lamp", 'POINT')
        ld.energy = 100.0
        lo = bpy.data.objects.new("Lamp", ld)
        lo.location = (0, 0, 2)
        scene.collection.objects.link(lo)
    if world is not None:
        w = bpy.data.worlds.new("World")
        w.color = world
        scene.world = w
    scene.radiosity.preset = 'DRAFT'
    bpy.context.view_layer.objects.active = ob
    return scene, ob


# ----------------------------------------------------------------------------- registration
def test_register_round_trip(addon):
    assert hasattr(bpy.types.Scene, "radiosity")
    assert hasattr(bpy.ops.radiosity, "bake")
    addon.unregister()
    assert not hasattr(bpy.types.Scene, "radiosity")
    assert not any(getattr(h, "__name__", "") == "on_frame_change" for h in bpy.app.handlers.frame_change_post)
    addon.register()
    addon.live_update.register_handlers()                            # idempotent
    assert sum(getattr(h, "__name__", "") == "on_frame_change" for h in bpy.app.handlers.frame_change_post) == 1
    assert addon.bl_info["category"] == "Lighting" and addon.bl_info["blender"][:2] == (3, 4)
    assert type(bpy.context.scene.radiosity).bl_rna.properties["preset"].default == 'DEFAULT'


def test_preset_fills_knobs(addon):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    p = bpy.context.scene.radiosity
    eng = addon.engine.load_engine()
    for name in ('DRAFT', 'HIGH', 'DEFAULT'):
        p.preset = name
        s = eng.Settings.preset(name.lower())
        assert p.samples_direct == s.samples_direct and p.samples_indirect == s.samples_indirect
        assert p.patch_size_relative == pytest.approx(s.patch_size_relative, rel=1e-6)
        assert p.threshold == pytest.approx(s.threshold, rel=1e-6)
        assert p.exact_near_reflected == s.exact_near_reflected == (name == 'HIGH')
    p.samples_direct = 7
    assert addon.settings.engine_settings(p).samples_direct == 7
    p.live_update = True


# ----------------------------------------------------------------------------- sample bakes
@pytest.mark.parametrize("name,frame", [("cornell_box", None), ("subsurf_room", None), ("animated_room", 12)])
def test_bake_sample(addon, name, frame):
    scene = open_blend(name, frame)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    obs = meshes(scene)
    assert obs
    for ob in obs:
        a = ob.data.color_attributes.get("Radiosity")
        assert a is not None, ob.name
        assert a.data_type == 'FLOAT_COLOR' and a.domain == 'CORNER'
        v = colours(ob)
        assert v.shape == (len(ob.data.loops), 4)
        assert np.isfinite(v).all() and (v[:, :3] >= 0).all()
        assert (v[:, 3] == 1).all()
        assert v[:, :3].max() > 1e-3, ob.name
        assert v[:, :3].std() > 0 or ob.name == "Light", ob.name
    p = scene.radiosity
    assert p.has_results and p.last_seconds > 0 and p.last_patches > 0 and p.last_points > 0
    assert p.last_rays > 0 and ("emission" in p.last_effects or " lamp" in p.last_effects)
    assert 1.1 < p.last_relaxation < 1.25     # automatic: the samples send back 0.47-0.65 of a shot
    if name == "subsurf_room":
        assert "Catmull-Clark" in p.last_effects
    assert bpy.ops.radiosity.clear() == {'FINISHED'}
    assert all(ob.data.color_attributes.get("Radiosity") is None for ob in obs)


def test_bake_animation_caches_frames(addon):
    scene = open_blend("animated_room", 1)
    scene.frame_start, scene.frame_end, scene.frame_step = 1, 24, 23     # frames 1 and 24
    assert bpy.ops.radiosity.bake_animation() == {'FINISHED'}
    assert scene.frame_current == 1 and scene.radiosity.last_frames == 2
    cache = addon.operators.frame_cache[scene.name]
    assert sorted(cache) == [1, 24]
    obs = meshes(scene)
    first = {ob.name: colours(ob).copy() for ob in obs}
    for ob in obs:
        np.testing.assert_array_equal(first[ob.name], cache[1][ob.name])
    scene.frame_set(24)
    later = {ob.name: colours(ob).copy() for ob in obs}
    assert any(not np.array_equal(first[k], later[k]) for k in first)
    for ob in obs:
        np.testing.assert_array_equal(later[ob.name], cache[24][ob.name])
    scene.frame_set(12)                                  # not baked: colours stay
    for ob in obs:
        np.testing.assert_array_equal(colours(ob), later[ob.name])
    scene.frame_set(1)
    for ob in obs:
        np.testing.assert_array_equal(colours(ob), first[ob.name])
    bpy.ops.radiosity.clear()
    assert scene.name not in addon.operators.frame_cache


# ----------------------------------------------------------------------------- the modal bake
class _WindowManager:
    """What the modal operator asks of the window manager, without a window (background mode)."""

    def __init__(self):
        self.timers = 0
        self.progress = None

    def event_timer_add(self, step, window=None):
        self.timers += 1
        return self

    def event_timer_remove(self, timer):
        self.timers -= 1

    def progress_begin(self, low, high):
        self.progress = low

    def progress_update(self, value):
        self.progress = value

    def progress_end(self):
        self.progress = None

    def modal_handler_add(self, operator):
        pass


class _Context:
    """bpy.context, with a window manager the test reads and no window, area or workspace."""

    def __init__(self):
        self.window_manager = _WindowManager()
        self.window = self.area = self.workspace = None

    def __getattr__(self, name):
        return getattr(bpy.context, name)


def _event(kind):
    return type("Event", (), {"type": kind, "value": 'PRESS'})()


def modal_bake(addon, animation=False, stop=None):
    """Runs the bake operators' modal path as the UI would (invoke, then timer events), pressing Esc
    once `stop(operator)` holds. (result, reports, context)."""
    reports = []
    base = addon.operators._Bake
    op = type("ModalBake", (base,), {"animation": animation,
                                      "report": lambda self, kind, text: reports.append((kind, text))})()
    context = _Context()
    result = op.invoke(context, _event('NONE'))
    while result == {'RUNNING_MODAL'} or result == {'PASS_THROUGH'}:
        result = op.modal(context, _event('ESC' if stop is not None and stop(op) else 'TIMER'))
    return result, reports, context


def test_modal_bake_writes_on_success_and_nothing_on_esc_or_failure(addon, monkeypatch):
    """Each ending of the UI's bake: finished, it writes; Esc part-way through an animation (after its
    first frame solved) or a failure of ours writes nothing and hands the UI and live update back.
    The colours are read in the worker too: with the exact contact light a read takes seconds."""
    live = addon.live_update
    scene = open_blend("animated_room", 1)
    scene.frame_start, scene.frame_end, scene.frame_step = 1, 24, 23
    on_main = []
    read = addon.job.BakeJob.colours
    monkeypatch.setattr(addon.job.BakeJob, "colours", lambda job, *args, **kwargs: (
        on_main.append(threading.current_thread() is threading.main_thread()), read(job, *args, **kwargs))[1])
    result, reports, context = modal_bake(addon)
    assert result == {'FINISHED'}, reports
    assert on_main == [False]
    obs = meshes(scene)
    baked = {ob.name: colours(ob).copy() for ob in obs}
    assert all(v is not None for v in baked.values())
    assert context.window_manager.timers == 0 and context.window_manager.progress is None
    assert not live.blocked()

    def check_untouched(result, reports, context):
        assert result == {'CANCELLED'}, reports
        assert scene.frame_current == 1 and scene.name not in addon.operators.frame_cache
        for ob in obs:
            np.testing.assert_array_equal(colours(ob), baked[ob.name])
        assert context.window_manager.timers == 0 and context.window_manager.progress is None
        assert not live.blocked()

    scene.objects["Box"].location.x += 0.5                 # the lighting would change
    outcome = modal_bake(addon, animation=True, stop=lambda op: op._index == 1)
    check_untouched(*outcome)
    assert outcome[1][-1][0] == {'WARNING'} and "cancelled" in outcome[1][-1][1]

    def broken_colours(job, *args, **kwargs):
        raise RuntimeError("broken read")
    monkeypatch.setattr(addon.job.BakeJob, "colours", broken_colours)
    outcome = modal_bake(addon, animation=True)
    check_untouched(*outcome)
    assert outcome[1][-1][0] == {'ERROR'} and "broken read" in outcome[1][-1][1]


def test_animation_bake_locks_the_interface_for_renders(addon):
    """A render writes each baked frame's colours from its own thread: the viewport must not draw
    meanwhile (Render > Lock Interface), so the animation bake turns it on and says so."""
    scene = open_blend("animated_room", 1)
    scene.frame_start, scene.frame_end, scene.frame_step = 1, 24, 23
    scene.render.use_lock_interface = False
    result, reports, _ = modal_bake(addon, animation=True)
    assert result == {'FINISHED'} and scene.render.use_lock_interface
    assert any("Lock Interface" in text for kind, text in reports if kind == {'INFO'})


def test_cancel_from_another_thread(addon):
    scene = open_blend("cornell_box", preset='HIGH')
    job = addon.job.BakeJob(scene, bpy.context.evaluated_depsgraph_get(), scene.radiosity)
    started = threading.Event()

    def progress(fraction, residual):
        started.set()
        return True
    t = threading.Thread(target=lambda: job.solve(progress))
    t.start()
    assert started.wait(60)
    job.cancel()
    t.join(60)
    assert not t.is_alive() and job.done and not job.succeeded


# ----------------------------------------------------------------------------- bad scenes
def test_nan_vertex_is_reported(addon):
    scene, ob = empty_with_plane()
    ob.data.vertices[2].co = (float("nan"), 1.0, 0.0)
    with pytest.raises(RuntimeError, match="Plane"):
        bpy.ops.radiosity.bake()
    assert ob.data.color_attributes.get("Radiosity") is None


def test_a_scene_past_the_patch_limit_is_reported_and_keeps_its_colours(addon):
    scene, ob = empty_with_plane()
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    before = colours(ob).copy()
    scene.radiosity.max_patches = 1000
    scene.radiosity.patch_size_relative = 1e-3
    with pytest.raises(RuntimeError, match="past the limit of 1000.*object 'Plane'"):
        bpy.ops.radiosity.bake()
    np.testing.assert_array_equal(colours(ob), before)


def test_relaxation_is_automatic_unless_set_and_presets_make_it_automatic(addon):
    scene, ob = empty_with_plane()
    p = scene.radiosity
    assert p.auto_relaxation
    p.auto_relaxation, p.relaxation = False, 1.5
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert p.last_relaxation == pytest.approx(1.5)
    p.preset = 'HIGH'
    assert p.auto_relaxation and p.relaxation == pytest.approx(1.5)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert p.last_relaxation != pytest.approx(1.5)


def test_no_lights_is_reported(addon):
    scene, ob = empty_with_plane(light=False)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert "no light" in scene.radiosity.last_warnings
    assert np.all(colours(ob)[:, :3] == 0)


def test_empty_scene_is_reported(addon):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with pytest.raises(RuntimeError, match="nothing to bake"):
        bpy.ops.radiosity.bake()


def test_edit_mode_is_reported(addon):
    scene, ob = empty_with_plane()
    ob.select_set(True)
    bpy.ops.object.mode_set(mode='EDIT')
    try:
        assert ob.mode == 'EDIT'
        with pytest.raises(RuntimeError, match="Edit Mode"):
            bpy.ops.radiosity.bake()
    finally:
        bpy.ops.object.mode_set(mode='OBJECT')
    assert ob.data.color_attributes.get("Radiosity") is None


def test_a_diverging_solve_is_an_error_and_keeps_the_colours(addon):
    # The engine's fuzzed case (test_module.py: test_a_solve_that_diverges_stops_and_says_so), built
    # in Blender: a crumpled Subdivision Surface object 7 cm across, 2.5 km from a 1 cm quad, so the
    # ray offset is as large as the object. The engine stops and says so; the add-on must not write
    # what it stopped with.
    scene, _ = empty_with_plane(light=False, world=(0.5, 0.5, 0.5))
    bpy.data.objects.remove(scene.objects["Plane"])
    positions = [(0.005069, -0.003808, -0.007053), (0.009679, -0.009473, 0.002181),
                 (-0.00912, -4.8e-05, -0.005745), (0.015235, 0.002068, 0.002013),
                 (0.022331, -0.036548, -0.013566), (-0.034651, 0.000704, 0.006438),
                 (0.009067, 0.004177, -0.01062), (0.02335, 0.004573, -0.00278),
                 (-0.013946, 0.005996, -0.005834)]
    faces = [(1, 6, 5, 0), (4, 6, 1, 1, 7), (5, 7, 3), (4, 2, 1, 8, 6), (6, 0, 2, 3), (4, 2, 7, 7),
             (2, 6, 7, 0, 4)]
    obs = []
    for name, p, f in (("Crumpled", positions, faces),
                       ("Far", [(-836, -1716, 1812), (-835.99, -1716, 1812), (-835.99, -1715.99, 1812),
                                (-836, -1715.99, 1812)], [(0, 1, 2, 3)])):
        me = bpy.data.meshes.new(name)
        me.from_pydata(p, [], f)
        ob = bpy.data.objects.new(name, me)
        scene.collection.objects.link(ob)
        addon.writeback.write_mesh(me, np.full((len(me.loops), 4), 0.25, np.float32))
        obs.append(ob)
    sub = obs[0].modifiers.new("Subdivision", 'SUBSURF')
    sub.levels = sub.render_levels = 2
    with pytest.raises(RuntimeError, match="diverged"):
        bpy.ops.radiosity.bake()
    for ob in obs:
        assert np.all(colours(ob) == 0.25), ob.name


def test_cubes_standing_in_each_other_on_a_floor_bake(addon):
    """400 Blender cubes (0.3 m) dropped at random on a 40 m plane under the sun: some stand in each
    other, their bottoms in the floor's plane and their tops in each other's. Each coincident face
    is seen once (engine: visibility.h, Coincident): the bake converges, and no face is much brighter
    than a sunlit one."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    me = bpy.data.meshes.new("Plane")
    me.from_pydata([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)], [], [(0, 1, 2, 3)])
    obs = [bpy.data.objects.new("Plane", me)]
    cube = bpy.data.meshes.new("Cube")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=0.3)
    bm.to_mesh(cube)
    bm.free()
    rng = np.random.default_rng(0)
    for i in range(400):
        obs.append(bpy.data.objects.new(f"Cube{i}", cube))
        obs[-1].location = (*rng.uniform(-19, 19, 2), 0.15)
    for ob in obs:
        scene.collection.objects.link(ob)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    scene.collection.objects.link(sun)
    scene.radiosity.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    sunlit = 0.8 * 3.0 / np.pi
    for ob in obs:
        c = colours(ob)[:, :3]
        assert np.isfinite(c).all() and c.max() < 1.1 * sunlit, (ob.name, c.max())


def test_degenerate_face_warns(addon):
    scene, ob = empty_with_plane()
    me = bpy.data.meshes.new("Sliver")
    me.from_pydata([(0, 0, 0.5), (0.5, 0, 0.5), (1.0, 0, 0.5)], [], [(0, 1, 2)])
    o2 = bpy.data.objects.new("Sliver", me)
    scene.collection.objects.link(o2)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert "degenerate" in scene.radiosity.last_warnings
    assert np.isfinite(colours(ob)).all()


def test_render_hidden_skipped_and_linked_not_written(addon, tmp_path):
    scene, ob = empty_with_plane()
    lib = str(tmp_path / "lib.blend")
    bpy.data.libraries.write(lib, {ob.data})
    ob2 = ob.copy()
    ob2.data = ob.data.copy()
    ob2.location.z = 0.5
    ob2.hide_render = True
    scene.collection.objects.link(ob2)
    with bpy.data.libraries.load(lib, link=True) as (src, dst):
        dst.meshes = ["Plane"]
    linked = dst.meshes[0]
    assert linked.library is not None
    ob3 = bpy.data.objects.new("LinkedPlane", linked)
    ob3.location = (0, 0, -0.5)
    scene.collection.objects.link(ob3)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert ob.data.color_attributes.get("Radiosity") is not None
    assert ob2.data.color_attributes.get("Radiosity") is None
    assert linked.color_attributes.get("Radiosity") is None
    assert "linked library" in scene.radiosity.last_warnings


class _FakeLayout:
    """Accepts any layout call: enough to run the panels' draw code in background mode."""
    def __init__(self):
        self.labels = []

    def label(self, text="", **_kw):
        self.labels.append(text)

    def __getattr__(self, _name):
        return lambda *a, **k: self

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)


def test_the_bake_says_what_it_simulated_and_what_it_left_out(addon):
    """The report and the panel list the light the scene calls for, counted, and what a diffuse bake
    leaves out."""
    scene, ob = empty_with_plane(world=(0.1, 0.1, 0.1))
    ld = bpy.data.lights.new("Sun", 'SUN')
    scene.collection.objects.link(bpy.data.objects.new("Sun", ld))
    infos = []
    addon.operators.finish(bpy.context, *addon.operators.bake_frames(bpy.context, [scene.frame_current], False),
                           False, lambda kind, text: infos.append(text) if kind == {'INFO'} else None)
    effects = scene.radiosity.last_effects
    assert effects.startswith("1 point lamp, 1 sun lamp, world light")
    assert "diffuse interreflection" in effects and effects.endswith("(a diffuse bake)")
    assert "emission" not in effects and "Catmull-Clark" not in effects
    assert len(infos) >= 2 and infos[-2].endswith("simulated: " + effects)
    assert infos[-1] == f"Radiosity: baked 1 object in {scene.radiosity.last_seconds:.1f} s; Show Bake shows it"
    listed = json.loads(scene.radiosity.last_effect_items)
    assert [short for kind, short, *_ in listed if kind == "simulated"][:3] == ["1 point lamp", "1 sun lamp",
                                                                              "World light"]
    assert {kind for kind, *_ in listed} == {"simulated", "left out"}


def test_panels_draw(addon):
    scene = open_blend("cornell_box")
    lay = _FakeLayout()
    addon.panels.draw_main(lay, bpy.context)
    addon.panels.draw_settings(lay, bpy.context)
    addon.panels.draw_results(lay, bpy.context)
    assert any(" vertices · " in t for t in lay.labels) and "No bake yet" in lay.labels
    scene.radiosity.has_results = True
    scene.radiosity.last_residual = 0.001
    addon.panels.draw_results(lay, bpy.context)
    assert "Converged (0.1% light left)" in lay.labels


def test_an_object_whose_modifiers_add_faces_gets_the_colours_of_the_faces_it_has(addon):
    """Mirror, Array and Solidify keep the original faces where they were and add copies: the
    original faces' corners get what the same object with its modifiers applied gets there."""
    scene, floor = empty_with_plane()
    floor.scale = (3, 3, 1)
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.4, 0.2, 0.3))
    ob = bpy.context.object
    ob.modifiers.new("Mirror", 'MIRROR')
    ob.modifiers.new("Array", 'ARRAY').relative_offset_displace = (0, 1.5, 0)
    ob.modifiers.new("Solidify", 'SOLIDIFY').thickness = 0.05
    applied = bpy.data.objects.new("Applied", bpy.data.meshes.new_from_object(ob.evaluated_get(
        bpy.context.evaluated_depsgraph_get())))
    scene.collection.objects.link(applied)
    applied.matrix_world = ob.matrix_world
    applied.hide_render = True
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    ours = colours(ob)
    assert ours is not None and len(ours) == len(ob.data.loops) and len(applied.data.loops) > 4 * len(ours)
    ob.hide_render, applied.hide_render = True, False
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    # each original loop against the applied mesh's corner at the same place on the same face
    keys = addon.export._corner_keys
    a = keys(*addon.export.mesh_arrays(ob.data)[:3])
    b = keys(*addon.export.mesh_arrays(applied.data)[:3])
    where = {tuple(row): i for i, row in reversed(list(enumerate(b)))}
    same = colours(applied)[[where[tuple(row)] for row in a]]
    assert np.ptp(ours[:, :3]) > 0.05                        # lit and shaded faces
    assert np.allclose(ours, same, rtol=1e-5, atol=1e-7), np.abs(ours - same).max()

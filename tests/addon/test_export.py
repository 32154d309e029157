"""Export (depsgraph -> numpy arrays) checked on the sample scenes and small synthetic scenes."""
import math
import time

import bmesh
import bpy
import numpy as np
import pytest

PI = math.pi


def rgb(a):
    return np.asarray(a, np.float64)


def check_mesh_arrays(m):
    assert m.positions.dtype == np.float64 and m.positions.ndim == 2 and m.positions.shape[1] == 3
    assert m.face_sizes.dtype == np.int32 and m.face_vertices.dtype == np.int32
    assert m.face_materials.dtype == np.int32
    assert m.face_sizes.sum() == len(m.face_vertices)
    assert len(m.face_materials) == len(m.face_sizes)
    assert m.face_vertices.min() >= 0 and m.face_vertices.max() < len(m.positions)
    assert m.transform.shape == (4, 4) and m.transform.dtype == np.float64


# ----------------------------------------------------------------------------- sample scenes
def test_cornell(export, open_sample):
    open_sample("cornell_box")
    s = export.export_scene()
    names = sorted(m.name for m in s.meshes)
    assert names == ["Ceiling", "Light", "Room", "ShortBox", "TallBox"]
    for m in s.meshes:
        check_mesh_arrays(m)
        assert m.refine == "bilinear" and m.level == 0 and m.loop_indices is None and m.matches_original
    mats = {m.name: m for m in s.materials}
    assert set(mats) == {"White", "Red", "Green", "LightEmission"}
    np.testing.assert_allclose(mats["White"].reflectance, (0.725, 0.71, 0.68), rtol=1e-6)
    np.testing.assert_allclose(mats["White"].emission, (0, 0, 0))
    np.testing.assert_allclose(mats["Red"].reflectance, (0.63, 0.065, 0.05), rtol=1e-6)
    np.testing.assert_allclose(mats["LightEmission"].emission, (50.0, 42.5, 35.0), rtol=1e-6)
    np.testing.assert_allclose(mats["LightEmission"].reflectance, (0, 0, 0))
    room = s.mesh("Room")
    assert room.positions.shape == (8, 3) and list(room.face_sizes) == [4, 4, 4, 4]
    order = [s.materials[i].name for i in room.face_materials]
    assert order == ["White", "White", "Red", "Green"]
    # face normals of the room point inwards (towards the box centre)
    p = room.positions[room.face_vertices.reshape(-1, 4)]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert (((np.array([0, 0, 2.75]) - p.mean(1)) * n).sum(1) > 0).all()
    tall = s.mesh("TallBox")
    np.testing.assert_allclose(tall.transform[:3, 3], (-0.95, 0.75, 0.0), atol=1e-6)
    np.testing.assert_allclose(tall.transform[:3, :3],
                               [[math.cos(math.radians(17)), -math.sin(math.radians(17)), 0],
                                [math.sin(math.radians(17)), math.cos(math.radians(17)), 0], [0, 0, 1]], atol=1e-6)
    assert tall.positions[:, 2].max() == pytest.approx(3.3)
    assert s.lights == []
    np.testing.assert_allclose(s.world, (0, 0, 0))
    light = s.mesh("Light")
    assert s.materials[light.face_materials[0]].name == "LightEmission"


def test_subsurf_room(export, open_sample):
    open_sample("subsurf_room")
    s = export.export_scene()
    blob = s.mesh("Blob")
    check_mesh_arrays(blob)
    assert blob.refine == "catmull_clark" and blob.level == 2
    assert blob.positions.shape == (8, 3), "the cage, not the subdivided mesh, is exported"
    assert np.abs(blob.positions).max() == pytest.approx(0.5)
    assert blob.matches_original
    room = s.mesh("Room")
    assert room.refine == "bilinear" and room.level == 0 and len(room.face_sizes) == 6
    pl = s.light("PointLamp")
    assert pl.kind == "point"
    np.testing.assert_allclose(pl.position, (-1.2, 1.0, 1.9), atol=1e-6)
    np.testing.assert_allclose(pl.intensity, rgb((1.0, 0.9, 0.8)) * 40.0 / (4 * PI), rtol=1e-6)
    assert pl.radius == pytest.approx(0.1)
    al = s.light("AreaLamp")
    assert al.kind == "area" and al.shape == "rect"
    assert al.area == pytest.approx(0.6)
    np.testing.assert_allclose(al.radiance, rgb((0.8, 0.9, 1.0)) * 40.0 / (4 * 0.6), rtol=1e-6)
    np.testing.assert_allclose(al.u_half_axis, (0.5, 0, 0), atol=1e-7)
    np.testing.assert_allclose(al.v_half_axis, (0, 0.3, 0), atol=1e-7)
    np.testing.assert_allclose(al.direction, (0, 0, -1), atol=1e-7)
    np.testing.assert_allclose(al.position, (0.8, -0.8, 2.45), atol=1e-6)


@pytest.mark.parametrize("frame", [1, 12, 24])
def test_animated_room(export, open_sample, frame):
    open_sample("animated_room", frame)
    s = export.export_scene()
    assert s.frame == frame
    box = s.mesh("Box")
    x = -1.5 + 3.0 * (frame - 1) / 23.0
    np.testing.assert_allclose(box.transform[:3, 3], (x, 0.3, 0.0), atol=1e-5)
    assert box.animated and not s.mesh("Room").animated
    lamp = s.light("Lamp")
    P = 30.0 + 90.0 * (frame - 1) / 23.0
    np.testing.assert_allclose(lamp.intensity, np.full(3, P / (4 * PI)), rtol=1e-5)


# ----------------------------------------------------------------------------- synthetic scenes
@pytest.fixture
def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def add_lamp(kind, **props):
    ld = bpy.data.lights.new(kind, kind)
    rot = props.pop("rotation", (0, 0, 0))
    loc = props.pop("location", (0, 0, 0))
    scale = props.pop("scale", (1, 1, 1))
    for k, v in props.items():
        setattr(ld, k, v)
    ob = bpy.data.objects.new(kind, ld)
    ob.location, ob.rotation_euler, ob.scale = loc, rot, scale
    bpy.context.scene.collection.objects.link(ob)
    return ob


def test_lamp_conversions(export, empty_scene):
    add_lamp('SPOT', energy=100.0, color=(1.0, 0.5, 0.25), spot_size=math.radians(60), spot_blend=0.3,
             shadow_soft_size=0.2, rotation=(math.radians(90), 0, 0), location=(1, 2, 3))
    add_lamp('SUN', energy=3.0, color=(1, 1, 0.5), angle=0.01, rotation=(math.radians(30), 0, 0))
    add_lamp('AREA', energy=100.0, shape='DISK', size=2.0, scale=(2.0, 1.0, 1.0), location=(0, 0, 4))
    s = export.export_scene()
    sp = s.light("SPOT")
    np.testing.assert_allclose(sp.intensity, rgb((1, 0.5, 0.25)) * 100 / (4 * PI), rtol=1e-6)
    assert sp.spot_size == pytest.approx(math.radians(60)) and sp.spot_blend == pytest.approx(0.3)
    np.testing.assert_allclose(sp.direction, (0, 1, 0), atol=1e-6)     # -Z rotated 90 deg about X
    np.testing.assert_allclose(sp.position, (1, 2, 3), atol=1e-6)
    sun = s.light("SUN")
    np.testing.assert_allclose(sun.irradiance, (3, 3, 1.5), rtol=1e-6)
    np.testing.assert_allclose(sun.direction, (0, math.sin(math.radians(30)), -math.cos(math.radians(30))), atol=1e-6)
    assert sun.angle == pytest.approx(0.01)
    ar = s.light("AREA")
    assert ar.shape == "disc" and ar.area == pytest.approx(PI * 2.0 * 1.0)
    assert any("elliptic" in w for w in s.warnings)
    u, v = ar.u_half_axis, ar.v_half_axis
    np.testing.assert_allclose(-np.cross(u, v) / np.linalg.norm(np.cross(u, v)), ar.direction, atol=1e-9)
    np.testing.assert_allclose(ar.radiance, np.full(3, 100.0 / (4 * PI * 2.0)), rtol=1e-6)


@pytest.mark.parametrize("scale", [(1, 1, 1), (-1, 1, 1), (1, 1, -1)])
def test_area_lamp_direction_mirrored(export, empty_scene, scale):
    # Measured in Cycles 3.4.1: the lamp emits along -(matrix Z column): scale (1,1,-1) emits up.
    add_lamp('AREA', energy=10.0, shape='SQUARE', size=1.0, scale=scale)
    ar = export.export_scene().light("AREA")
    want = np.array([0, 0, -1.0]) * np.sign(scale[2])
    np.testing.assert_allclose(ar.direction, want, atol=1e-12)
    c = -np.cross(ar.u_half_axis, ar.v_half_axis)
    np.testing.assert_allclose(c / np.linalg.norm(c), want, atol=1e-12)


def test_world_and_materials(export, empty_scene):
    w = bpy.data.worlds.new("W")
    w.use_nodes = True
    bg = w.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.5, 0.25, 1.0, 1)
    bg.inputs["Strength"].default_value = 2.0
    bpy.context.scene.world = w
    bpy.ops.mesh.primitive_plane_add()
    ob = bpy.context.object
    p = bpy.data.materials.new("P")
    p.use_nodes = True                                 # default Principled BSDF
    pr = p.node_tree.nodes["Principled BSDF"]
    pr.inputs["Base Color"].default_value = (0.2, 0.4, 0.6, 1)
    pr.inputs["Emission"].default_value = (1, 1, 1, 1)
    pr.inputs["Emission Strength"].default_value = 0.5
    ob.data.materials.append(p)
    ob.data.materials.append(None)                     # empty slot -> default grey
    ob.data.polygons[0].material_index = 1
    s = export.export_scene()
    np.testing.assert_allclose(s.world, (1.0, 0.5, 2.0), rtol=1e-6)
    m = s.mesh("Plane")
    mat = s.materials[m.face_materials[0]]
    assert mat.name == "<default>" and mat.reflectance == pytest.approx((0.8, 0.8, 0.8))
    pm = s.materials[s.material_index("P")]
    assert pm.reflectance == pytest.approx((0.2, 0.4, 0.6)) and pm.emission == pytest.approx((0.5, 0.5, 0.5))


def test_subsurf_after_other_modifier_sends_cage(export, empty_scene):
    bpy.ops.mesh.primitive_cube_add()
    ob = bpy.context.object
    ob.modifiers.new("Mirror", 'MIRROR')
    sub = ob.modifiers.new("Sub", 'SUBSURF')
    sub.levels, sub.render_levels = 1, 3
    s = export.export_scene()
    m = s.mesh("Cube")
    assert m.refine == "catmull_clark" and m.level == 3
    assert len(m.face_sizes) == 12      # mirrored cube cage (not merged: mirror across x = 0 of a centred cube)
    assert sub.show_viewport, "modifier state restored"
    # with the subdivision last but disabled for render, nothing is refined
    sub.show_render = False
    m = export.export_scene().mesh("Cube")
    assert m.refine == "bilinear" and m.level == 0


def test_large_mesh_is_vectorised(export, empty_scene):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=400, y_subdivisions=400)
    t = time.perf_counter()
    s = export.export_scene()
    dt = time.perf_counter() - t
    m = s.mesh("Grid")
    check_mesh_arrays(m)
    assert len(m.positions) == len(bpy.data.objects["Grid"].data.vertices) > 150_000
    assert dt < 2.0, f"export took {dt:.2f} s for 160k vertices"


def test_hidden_from_render_is_exported_hidden(export, empty_scene):
    """Kept in the export (a Solver built from it can show them later), out of the lighting."""
    bpy.ops.mesh.primitive_plane_add()
    bpy.context.object.hide_render = True
    add_lamp('POINT', energy=10.0, location=(0, 0, 2)).hide_render = True
    add_lamp('SUN', energy=3.0).hide_render = True
    s = export.export_scene()
    assert [(m.name, m.visible) for m in s.meshes] == [("Plane", False)] and s.visible_meshes == []
    assert len(s.mesh("Plane").face_sizes) == 1
    point, sun = s.light("POINT"), s.light("SUN")
    assert not point.visible and point.kind == "point" and not sun.visible and sun.kind == "sun"
    np.testing.assert_array_equal(point.intensity, 0.0)
    np.testing.assert_array_equal(sun.irradiance, 0.0)
    np.testing.assert_allclose(point.position, (0, 0, 2))          # the lamp is there, dark
    bpy.data.objects["POINT"].hide_render = False
    np.testing.assert_allclose(export.export_scene().light("POINT").intensity, rgb((1, 1, 1)) * 10 / (4 * PI))


def test_collections_hidden_from_render_hide_their_objects(export, empty_scene):
    """Cycles renders an object in a collection hidden from render (or inside one) only if it is also
    linked into a collection that is rendered."""
    outer = bpy.data.collections.new("Outer")
    inner = bpy.data.collections.new("Inner")
    bpy.context.scene.collection.children.link(outer)
    outer.children.link(inner)
    planes = {}
    for name, home in (("InInner", inner), ("InOuter", outer), ("Twice", inner)):
        ob = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        ob.data.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
        home.objects.link(ob)
        planes[name] = ob
    bpy.context.scene.collection.objects.link(planes["Twice"])
    visible = lambda: {m.name: m.visible for m in export.export_scene().meshes}
    assert visible() == {"InInner": True, "InOuter": True, "Twice": True}
    outer.hide_render = True
    assert visible() == {"InInner": False, "InOuter": False, "Twice": True}
    outer.hide_render, inner.hide_render = False, True
    assert visible() == {"InInner": False, "InOuter": True, "Twice": True}


def test_text_goes_once_itself_and_once_per_collection_instance(export, empty_scene):
    """The depsgraph lists a text object, and each instance of it, twice: as the text and as its
    mesh. Each goes once, where it stands."""
    source = bpy.data.collections.new("Source")
    empty_scene.collection.children.link(source)
    text = bpy.data.objects.new("Sign", bpy.data.curves.new("Sign", 'FONT'))
    text.data.body, text.data.extrude = "OK", 0.02
    text.location = (0.0, 0.0, 1.0)
    source.objects.link(text)
    holder = bpy.data.objects.new("Holder", None)
    holder.instance_type, holder.instance_collection = 'COLLECTION', source
    holder.location = (0.0, 5.0, 0.0)
    empty_scene.collection.objects.link(holder)
    sx = export.export_scene()
    assert [(m.name, m.object_type) for m in sx.meshes] == [("Sign", 'FONT'), ("Sign[0]", 'FONT')]
    assert np.allclose(sx.meshes[0].transform[:3, 3], (0, 0, 1)) and np.allclose(sx.meshes[1].transform[:3, 3], (0, 5, 1))
    assert len(sx.meshes[0].face_sizes) == len(sx.meshes[1].face_sizes) > 10


def sky_world(scene, sun=True, strength=3.0, turn=0.0):
    """A world lit by a 256 x 128 equirectangular image: 0.5 below the horizon, (2, 1, 0.5) above
    it but for a quarter (0.5, 1, 2) round +y, and (sun) a 3 x 3-texel sun of 20,000 at latitude 40
    degrees, longitude 60 (x towards y); with `turn` (degrees), looked up through a Mapping node
    turning directions about z."""
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    scene.world = world
    image = bpy.data.images.new("Sky", 256, 128, float_buffer=True)
    px = np.ones((128, 256, 4), np.float32)
    px[64:, :, :3] = (2.0, 1.0, 0.5)      # rows count from the bottom: the upper half
    px[64:, 32:96, :3] = (0.5, 1.0, 2.0)  # longitudes 45-135 degrees: u = 0.5 - longitude / 360
    px[:64, :, :3] = 0.5
    if sun:  # Cycles' u = 0.5 - longitude / 2 pi, v = 0.5 + latitude / pi
        row, col = int((0.5 + 40 / 180) * 128), int((0.5 - 60 / 360) * 256)
        px[row - 1:row + 2, col - 1:col + 2, :3] = 20000.0
    image.pixels.foreach_set(px.ravel())
    tree = world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = image
    background = tree.nodes["Background"]
    tree.links.new(env.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = strength
    if turn:
        mapping = tree.nodes.new("ShaderNodeMapping")
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, np.radians(turn))
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], mapping.inputs["Vector"])
        tree.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    return world, env


def test_an_environment_texture_lights_as_its_suns_and_the_mean_of_the_rest(export, empty_scene):
    """Its rows weighted by their solid angle: here the upper and lower halves of the sphere, equal
    in solid angle, average to the mean of their two colours; the sun, brighter than 50 times the
    mean, goes as a sun lamp where it is, carrying its texels' light."""
    world, env = sky_world(empty_scene)
    sx = export.export_scene()
    upper = (3 * np.array([2.0, 1.0, 0.5]) + np.array([0.5, 1.0, 2.0])) / 4
    assert np.allclose(sx.world, 3.0 * (upper + 0.5) / 2, rtol=2e-3), sx.world   # 9 texels less
    [sun] = sx.lights
    lat, lon = np.radians(40), np.radians(60)
    towards = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    assert np.degrees(np.arccos(-sun.direction @ towards)) < 1.5
    texel = (2 * np.pi / 256) * (np.pi / 128) * np.cos(lat)
    assert np.allclose(sun.irradiance, 3.0 * 20000 * 9 * texel, rtol=0.02), sun.irradiance
    assert any("1 sun lamp(s) and a 128 x 64 map of the rest" in w for w in sx.warnings), sx.warnings
    env.image = None
    assert any("TEX_ENVIRONMENT" in w for w in export.export_scene().warnings)


# ----------------------------------------------------------------------------- hidden, instanced, far, open
def test_modifiers_go_as_they_render_not_as_the_viewport_shows_them(export, empty_scene):
    """A Cycles bake evaluates for render: a modifier shown in renders only counts, one shown in the
    viewport only does not, a Subdivision Surface before the last one subdivides to its render level;
    the viewport's settings are left as they were."""
    ob = box("Arrayed", (0, 0, 0.5))
    array = ob.modifiers.new("Array", 'ARRAY')                # two boxes side by side, in renders
    array.show_viewport = False
    solidify = ob.modifiers.new("Solidify", 'SOLIDIFY')       # a box inside each, in the viewport
    solidify.show_render = False
    m = export.export_scene().mesh("Arrayed")
    assert m.positions.shape == (16, 3) and np.ptp(m.positions[:, 0]) == pytest.approx(0.8)
    assert not array.show_viewport and solidify.show_viewport
    smooth = box("Smooth", (2, 0, 0.5))
    first = smooth.modifiers.new("First", 'SUBSURF')
    first.levels, first.render_levels = 0, 1
    last = smooth.modifiers.new("Last", 'SUBSURF')
    last.levels, last.render_levels = 1, 2
    m = export.export_scene().mesh("Smooth")
    assert m.refine == "catmull_clark" and m.level == 2 and len(m.face_sizes) == 24
    assert first.levels == 0 and last.show_viewport and len(smooth.evaluated_get(
        bpy.context.evaluated_depsgraph_get()).data.polygons) == 6 * 4


def box(name, location, collection=None, modifier=None):
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=0.4)
    bm.to_mesh(me)
    bm.free()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    (collection or bpy.context.scene.collection).objects.link(ob)
    if modifier:
        ob.modifiers.new(modifier, modifier)
    return ob


@pytest.fixture
def plane_and_lamp(addon):
    """A 2 m plane lit by a point lamp 2 m above, draft quality; Blender's empty factory scene after
    (the modules that follow start from its defaults)."""
    from test_addon import empty_with_plane
    yield empty_with_plane(world=None)
    bpy.ops.wm.read_factory_settings(use_empty=True)


def test_objects_hidden_in_the_viewport_light_the_scene_as_cycles_renders_them(export, addon, plane_and_lamp):
    """Cycles renders what is hidden in the viewport. Hidden with H, an object is still evaluated: it
    goes as shown. Disabled in viewports (its own or its collection's monitor icon) it is not: it goes
    as its own data where that is what renders (no modifier but a last Subdivision Surface, sent as
    cage and level anyway), placed from its location and its parent; hiding or disabling sends the
    live Solver no change."""
    scene, plane = plane_and_lamp
    held = box("Held", (0.5, 0, 0.5), modifier='SOLIDIFY')          # H
    plain = box("Plain", (-0.5, 0, 0.5))                              # disabled
    smooth = box("Smooth", (0, 0.5, 0.5), modifier='SUBSURF')         # disabled, cage + level
    shelf = bpy.data.collections.new("Shelf")
    scene.collection.children.link(shelf)
    kept = box("Kept", (0, -0.5, 0.5), collection=shelf)             # its collection disabled
    holder = bpy.data.objects.new("Holder", None)
    scene.collection.objects.link(holder)
    holder.location = (0, 0, 1)
    child = box("Child", (0, 0, 0.2))
    child.parent = holder
    lamp = bpy.data.objects["Lamp"]
    shown = export.export_scene()
    held.hide_set(True)
    for ob in (plain, smooth, child, lamp):
        ob.hide_viewport = True
    shelf.hide_viewport = True
    bpy.context.view_layer.update()
    assert not any(ob.visible_get() for ob in (held, plain, smooth, kept, child, lamp))
    hidden = export.export_scene()
    assert sorted(m.name for m in hidden.visible_meshes) == sorted(m.name for m in shown.meshes) and not hidden.warnings
    engine = addon.engine.load_engine()
    assert addon.scene_diff.diff_exports(shown, addon.scene_diff.align_export(shown, hidden), engine) == []
    assert hidden.mesh("Held").positions.shape == (16, 3)              # solidified
    assert hidden.mesh("Smooth").refine == "catmull_clark" and len(hidden.mesh("Smooth").positions) == 8
    # Moved while disabled: from their stored location, and their parent's evaluated place.
    plain.location.x = -0.6
    holder.location.x = 0.3
    lamp.location.z = 2.5
    bpy.context.view_layer.update()
    moved = export.export_scene()
    np.testing.assert_allclose(moved.mesh("Plain").transform[:3, 3], (-0.6, 0, 0.5), atol=1e-6)
    np.testing.assert_allclose(moved.mesh("Child").transform[:3, 3], (0.3, 0, 1.2), atol=1e-6)
    np.testing.assert_allclose(moved.light("Lamp").position, (0, 0, 2.5), atol=1e-6)
    # Baked with all of them hidden, the plane gets the light it gets with them shown (within the
    # solver's noise: the objects come in another order).
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    lit_hidden = addon.writeback.read_mesh(plane.data).copy()
    assert addon.writeback.read_mesh(held.data) is not None
    held.hide_set(False)
    for ob in (plain, smooth, child, lamp, shelf):
        ob.hide_viewport = False
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    np.testing.assert_allclose(lit_hidden, addon.writeback.read_mesh(plane.data), rtol=1e-3)


@pytest.mark.parametrize("what, why", [("modifier", "its modifier Solidify"), ("shape keys", "its shape keys"),
                                       ("animation", "the animation, constraints or physics of Box"),
                                       ("bone parent", "its parenting to Rig (bone)")])
def test_an_object_disabled_in_viewports_that_only_an_evaluation_gives_is_named(export, empty_scene, what, why):
    ob = box("Box", (0, 0, 0.5))
    if what == "modifier":
        ob.modifiers.new("Solidify", 'SOLIDIFY')
    elif what == "shape keys":
        ob.shape_key_add(name="Basis")
    elif what == "animation":
        ob.keyframe_insert("location", frame=1)
    else:
        rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
        empty_scene.collection.objects.link(rig)
        ob.parent, ob.parent_type = rig, 'BONE'
    ob.hide_viewport = True
    sx = export.export_scene()
    assert [m.name for m in sx.meshes] == []
    [w] = sx.warnings
    assert w.startswith("'Box' is disabled in viewports but renders") and why in w and "Enable it in viewports" in w


def test_instanced_meshes_are_named_in_a_warning(addon, tmp_path, plane_and_lamp):
    """They light the scene, but their mesh, shared, holds no colours of their own: local and linked
    collection instances alike."""
    scene, plane = plane_and_lamp
    source = bpy.data.collections.new("Props")
    box("Crate", (0, 0, 0), collection=source)
    library = str(tmp_path / "props.blend")
    bpy.data.libraries.write(library, {source})
    scene.collection.children.link(source)
    source.hide_render = True                        # shown through its instances only
    with bpy.data.libraries.load(library, link=True) as (_, linked):
        linked.collections = ["Props"]
    for name, collection, x in (("Here", source, 0.5), ("There", linked.collections[0], -0.5)):
        holder = bpy.data.objects.new(name, None)
        holder.instance_type, holder.instance_collection = 'COLLECTION', collection
        holder.location = (x, 0, 0.5)
        scene.collection.objects.link(holder)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    warnings = scene.radiosity.last_warnings
    assert "instanced meshes light the scene but get no colours" in warnings
    assert "Here (Crate)" in warnings and "There (Crate)" in warnings and "Make Instances Real" in warnings
    assert {m.name for m in addon.export.export_scene().visible_meshes} == {"Plane", "Crate[0]", "Crate[1]"}


@pytest.mark.parametrize("where", ["vertex 1e30", "vertex inf", "scale 1e20"])
def test_a_vertex_absurdly_far_is_an_error_naming_its_object(addon, where, plane_and_lamp):
    """Instead of a black bake blamed on the lamps (the scene's size sets the engine's tolerances)."""
    scene, plane = plane_and_lamp
    far = box("Far", (0, 0, 0.5))
    if where == "vertex 1e30":
        far.data.vertices[0].co.x = 1e30
    elif where == "vertex inf":
        far.data.vertices[0].co.x = float("inf")   # stored as FLT_MAX
    else:
        far.scale = (1e20, 1, 1)
    with pytest.raises(RuntimeError, match=r"object 'Far': a vertex lies \S+ m from the world origin, past 1e\+15 m"):
        bpy.ops.radiosity.bake()
    assert plane.data.color_attributes.get("Radiosity") is None


def test_a_scene_far_from_the_origin_still_bakes(addon, plane_and_lamp):
    """The limit is on absurd coordinates, not on where a scene stands: the engine works about its centre."""
    scene, plane = plane_and_lamp
    for ob in scene.objects:
        ob.location.x += 1e6
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert addon.writeback.read_mesh(plane.data)[:, :3].max() > 0


def test_open_meshes_are_information_not_a_warning(addon, plane_and_lamp):
    """A floor plane is lit on both sides, as Cycles lights it: said among the effects, not as a
    warning; a closed box is not named, one with a flipped face is (the engine solves its inside too)."""
    scene, plane = plane_and_lamp
    box("Closed", (0.5, 0, 0.5))
    flipped = box("Flipped", (-0.5, 0, 0.5))
    bm = bmesh.new()
    bm.from_mesh(flipped.data)
    bm.faces.ensure_lookup_table()
    bmesh.ops.reverse_faces(bm, faces=[bm.faces[0]])
    bm.to_mesh(flipped.data)
    bm.free()
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    p = scene.radiosity
    assert "open" not in p.last_warnings and "manifold" not in p.last_warnings
    assert "both sides of open meshes or ones with flipped faces (Plane, Flipped)" in p.last_effects


# ----------------------------------------------------------------------------- material lobes
def shaded_plane(shader, **inputs):
    """A plane whose material is one `shader` node (bl_idname) with `inputs` set, into the output;
    returns (material, node)."""
    bpy.ops.mesh.primitive_plane_add()
    m = bpy.data.materials.new(shader)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    node = nt.nodes.new(shader)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    bpy.context.object.data.materials.append(m)
    return m, node


def exported(export, m):
    s = export.export_scene()
    return s.materials[s.material_index(m.name)]


def test_transparent_glass_and_glossy_become_their_lobes(export, empty_scene):
    clear, _ = shaded_plane("ShaderNodeBsdfTransparent", Color=(0.9, 0.92, 0.5, 1))
    glass, _ = shaded_plane("ShaderNodeBsdfGlass", Color=(0.8, 0.9, 1.0, 1), IOR=1.5, Roughness=0.0)
    frosted, _ = shaded_plane("ShaderNodeBsdfGlass", Color=(1, 1, 1, 1), Roughness=0.3)
    mirror, _ = shaded_plane("ShaderNodeBsdfGlossy", Color=(0.9, 0.8, 0.7, 1), Roughness=0.05)
    c, g, f, s = (exported(export, m) for m in (clear, glass, frosted, mirror))
    assert c.transmittance == pytest.approx((0.9, 0.92, 0.5)) and c.reflectance == (0, 0, 0) and not c.notes
    assert g.glass == pytest.approx((0.8, 0.9, 1.0)) and g.ior == pytest.approx(1.5) and g.transmittance == (0, 0, 0)
    assert export.FROSTED in f.notes and export.FROSTED not in g.notes
    assert s.specular == pytest.approx((0.9, 0.8, 0.7)) and s.roughness == pytest.approx(0.05)
    assert s.reflectance == (0, 0, 0) and s.glass == (0, 0, 0)
    assert not any(w for m in (c, g, f, s) for w in m.warnings)


def test_principled_splits_into_diffuse_metal_and_glass(export, empty_scene):
    """Blender 3.4's Principled BSDF: diffuse C (1 - m)(1 - t), metal C m, glass C t (1 - m)."""
    C = np.array((0.8, 0.6, 0.4))
    metal, _ = shaded_plane("ShaderNodeBsdfPrincipled", **{"Base Color": (*C, 1), "Metallic": 0.75,
                                                            "Roughness": 0.2})
    glass, _ = shaded_plane("ShaderNodeBsdfPrincipled", **{"Base Color": (*C, 1), "Metallic": 0.25,
                                                            "Transmission": 0.6, "IOR": 1.5, "Roughness": 0.0})
    m, g = exported(export, metal), exported(export, glass)
    np.testing.assert_allclose(m.reflectance, C * 0.25, rtol=1e-6)
    np.testing.assert_allclose(m.specular, C * 0.75, rtol=1e-6)
    assert m.roughness == pytest.approx(0.2) and m.glass == (0, 0, 0)
    np.testing.assert_allclose(g.reflectance, C * 0.75 * 0.4, rtol=1e-6)
    np.testing.assert_allclose(g.glass, C * 0.6 * 0.75, rtol=1e-6)
    np.testing.assert_allclose(g.specular, C * 0.25, rtol=1e-6)
    assert g.ior == pytest.approx(1.5) and export.FROSTED not in g.notes
    # its default Specular 0.5 reflects off the dielectric part: named, not simulated
    assert export.SPECULAR_LAYER in m.notes and export.SPECULAR_LAYER in g.notes
    assert not any("diffuse loss" in w for w in m.warnings + g.warnings)


def test_principled_alpha_mixes_every_lobe_with_a_transparent_one(export, empty_scene):
    C = np.array((0.5, 0.4, 0.3))
    mat, _ = shaded_plane("ShaderNodeBsdfPrincipled", **{"Base Color": (*C, 1), "Metallic": 0.5, "Alpha": 0.3,
                                                          "Emission": (1, 1, 1, 1), "Emission Strength": 2.0})
    m = exported(export, mat)
    np.testing.assert_allclose(m.reflectance, C * 0.5 * 0.3, rtol=1e-6)
    np.testing.assert_allclose(m.specular, C * 0.5 * 0.3, rtol=1e-6)
    np.testing.assert_allclose(m.transmittance, (0.7, 0.7, 0.7), rtol=1e-6)
    np.testing.assert_allclose(m.emission, (0.6, 0.6, 0.6), rtol=1e-6)


def link_mix(mat, a, b, fac):
    """Material `mat` becomes Mix Shader(fac, a, b) of two new nodes (bl_idname, inputs)."""
    nt = mat.node_tree
    out = next(n for n in nt.nodes if n.type == 'OUTPUT_MATERIAL')
    mix = nt.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = fac
    for socket, (shader, inputs) in zip((mix.inputs[1], mix.inputs[2]), (a, b)):
        node = nt.nodes.new(shader)
        for key, value in inputs.items():
            node.inputs[key].default_value = value
        nt.links.new(node.outputs[0], socket)
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    return mix


def test_mix_weighs_every_lobe_by_its_factor_and_add_sums_them(export, empty_scene):
    mixed, _ = shaded_plane("ShaderNodeBsdfDiffuse")
    link_mix(mixed, ("ShaderNodeBsdfTransparent", {"Color": (1, 1, 1, 1)}),
             ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.4, 0.2, 1)}), 0.25)
    added, node = shaded_plane("ShaderNodeAddShader")
    nt = added.node_tree
    for socket, (shader, colour, roughness) in zip(node.inputs, (("ShaderNodeBsdfDiffuse", (0.3, 0.3, 0.3, 1), 0.0),
                                                                 ("ShaderNodeBsdfGlossy", (0.5, 0.5, 0.5, 1), 0.1))):
        n = nt.nodes.new(shader)
        n.inputs["Color"].default_value = colour
        n.inputs["Roughness"].default_value = roughness
        nt.links.new(n.outputs[0], socket)
    m, a = exported(export, mixed), exported(export, added)
    np.testing.assert_allclose(m.transmittance, (0.75, 0.75, 0.75), rtol=1e-6)
    np.testing.assert_allclose(m.reflectance, (0.2, 0.1, 0.05), rtol=1e-6)
    np.testing.assert_allclose(a.reflectance, (0.3, 0.3, 0.3), rtol=1e-6)
    np.testing.assert_allclose(a.specular, (0.5, 0.5, 0.5), rtol=1e-6)
    assert a.roughness == pytest.approx(0.1)        # the specular lobe's own, not averaged with nothing


def test_lobes_that_would_make_light_are_scaled_to_one_and_named(export, empty_scene):
    added, node = shaded_plane("ShaderNodeAddShader")
    nt = added.node_tree
    for socket, shader in zip(node.inputs, ("ShaderNodeBsdfDiffuse", "ShaderNodeBsdfTransparent")):
        n = nt.nodes.new(shader)
        n.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1)
        nt.links.new(n.outputs[0], socket)
    a = exported(export, added)
    total = np.array(a.reflectance) + a.transmittance + a.glass + a.specular
    np.testing.assert_allclose(total, (1, 1, 1), rtol=1e-9)
    np.testing.assert_allclose(a.reflectance, a.transmittance, rtol=1e-9)
    assert any("scaled down to one" in w for w in a.warnings)


def test_a_mix_factor_from_an_image_alpha_the_engine_cannot_read_by_place_goes_as_its_mean(export, empty_scene):
    """Mix(Transparent, Diffuse) by an image's alpha that does not repeat (Extend): the engine reads
    alpha by place only as Repeat does, so this one goes as one value a material, the alpha's mean,
    named as approximated (tests/addon/test_alpha.py: the Repeat one, read by place)."""
    mixed, _ = shaded_plane("ShaderNodeBsdfDiffuse")
    mix = link_mix(mixed, ("ShaderNodeBsdfTransparent", {"Color": (1, 1, 1, 1)}),
                   ("ShaderNodeBsdfDiffuse", {"Color": (0.5, 0.5, 0.5, 1)}), 1.0)
    image = bpy.data.images.new("Leaf", 2, 2, alpha=True, float_buffer=True)
    image.pixels.foreach_set(np.array([[1, 1, 1, a] for a in (0.0, 1.0, 0.25, 0.75)], np.float32).ravel())
    tex = mixed.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.extension = 'EXTEND'
    mixed.node_tree.links.new(tex.outputs["Alpha"], mix.inputs["Fac"])
    m = exported(export, mixed)
    np.testing.assert_allclose(m.transmittance, (0.5, 0.5, 0.5), rtol=1e-6)
    np.testing.assert_allclose(m.reflectance, (0.25, 0.25, 0.25), rtol=1e-6)
    assert export.MEAN_FACTOR in m.notes and m.coverage is None


def test_the_engine_takes_the_lobes_and_a_lobe_change_is_a_material_change(addon, open_sample):
    """to_engine passes every lobe to Scene.add_material; a live update sends a pane's new colour
    as Solver.set_material with all of them."""
    from dataclasses import replace
    open_sample("window_room")
    export, engine = addon.export, addon.engine.load_engine()
    a = export.export_scene()
    export.to_engine(a, engine)          # validated by the engine: lobes in range
    i = a.material_index("Pane")
    b = replace(a, materials=list(a.materials))
    b.materials[i] = replace(a.materials[i], transmittance=(0.5, 0.5, 0.5))
    calls = addon.scene_diff.diff_exports(a, b, engine)
    assert calls == [("set_material", (i, a.materials[i].reflectance, *b.materials[i].lobes().values()))]
    assert calls[0][1][3] == (0.5, 0.5, 0.5)


# ----------------------------------------------------------------------------- effect plan rows
OPTICS_ROWS = {"Transmission", "Refraction (direction kept)", "Frosted glass", "Mix factors as means", "Alpha cut-outs",
               "Mirrors (1 plane)", "Mirrors (2 planes)", "Rough reflection as diffuse", "Curved mirrors",
               "Mirror to mirror", "World in mirrors", "Glass reflections", "Principled specular"}


def test_effects_name_the_materials_and_objects_that_call_for_them(addon, open_sample):
    effects = addon.effects
    open_sample("window_room")
    rows = {short: (kind, detail) for kind, short, detail in effects.items(addon.export.export_scene())}
    assert rows["Transmission"] == (effects.SIMULATED, "light through transparent and glass surfaces, filtered "
                                                      "by their colour (Pane on Pane)")
    assert not OPTICS_ROWS - {"Transmission"} & set(rows)
    open_sample("mirror_room")
    rows = {short: (kind, detail) for kind, short, detail in effects.items(addon.export.export_scene())}
    assert rows["Mirrors (1 plane)"] == (effects.SIMULATED, "planar mirrors and smooth metal passing on the light "
                                                            "that reaches them (Mirror on Mirror)")
    assert not OPTICS_ROWS - {"Mirrors (1 plane)"} & set(rows)


def test_a_scene_without_glass_or_mirrors_lists_no_optics(addon, open_sample):
    open_sample("cornell_box")
    listed = addon.effects.items(addon.export.export_scene())
    assert not OPTICS_ROWS & {short for _, short, _ in listed}
    sentence = addon.effects.sentence(listed)
    assert "transmission" not in sentence.lower() and "mirror" not in sentence.lower()
    assert sentence.endswith("left out: volumes and subsurface scattering (a diffuse bake)")


def test_glass_metal_and_alpha_rows_fit_the_sidebar(addon, empty_scene):
    """Every optics row, each naming its material and object; the panel lists the short words as an
    icon button's text (test_panel_fit.leaf), which must fit uncut."""
    import test_panel_fit as panel
    export, effects = addon.export, addon.effects
    shaded_plane("ShaderNodeBsdfGlass", Roughness=0.3)
    shaded_plane("ShaderNodeBsdfPrincipled", Metallic=0.5)
    leaves, _ = shaded_plane("ShaderNodeBsdfDiffuse")
    mix = link_mix(leaves, ("ShaderNodeBsdfTransparent", {}), ("ShaderNodeBsdfDiffuse", {}), 1.0)
    tex = leaves.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("Leaf", 2, 2, alpha=True)
    tex.image.pixels.foreach_set(np.tile(np.float32([1, 1, 1, 0.5]), 4))
    tex.extension = 'EXTEND'   # not read by place: as its mean
    leaves.node_tree.links.new(tex.outputs["Alpha"], mix.inputs["Fac"])
    mirror, _ = shaded_plane("ShaderNodeBsdfGlossy", Roughness=0.0)
    bpy.ops.mesh.primitive_plane_add(location=(0, 0, 1), rotation=(1.0, 0, 0))  # a second plane of it
    bpy.context.object.data.materials.append(mirror)
    bpy.ops.mesh.primitive_uv_sphere_add(location=(3, 0, 0))                      # curved
    bpy.context.object.data.materials.append(mirror)
    card, _ = shaded_plane("ShaderNodeBsdfPrincipled")                           # alpha read by place
    card.name = "Card"
    tex = card.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = leaves.node_tree.nodes["Image Texture"].image
    card.node_tree.links.new(tex.outputs["Alpha"], card.node_tree.nodes["Principled BSDF"].inputs["Alpha"])
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.1, 0.1, 0.1, 1.0)
    bpy.context.scene.world = world
    listed = effects.items(export.export_scene())
    rows = {short: (kind, detail) for kind, short, detail in listed}
    assert OPTICS_ROWS - {"Mirrors (1 plane)"} <= set(rows)
    assert rows["Curved mirrors"] == (effects.APPROXIMATED, "smooth reflection off curved surfaces spread as "
                                      "diffuse light (ShaderNodeBsdfGlossy on Sphere)")
    assert rows["Mirror to mirror"][1].endswith("(ShaderNodeBsdfGlossy on Plane.003, Plane.004)")
    assert rows["Rough reflection as diffuse"][1].endswith("(ShaderNodeBsdfPrincipled on Plane.001)")
    assert rows["Refraction (direction kept)"] == (effects.APPROXIMATED, "glass passing light on straight, not "
                                                   "bent (ShaderNodeBsdfGlass on Plane)")
    assert rows["Transmission"][1].endswith("(ShaderNodeBsdfGlass on Plane; ShaderNodeBsdfDiffuse on Plane.002; "
                                            "Card on Plane.005)")
    assert rows["Principled specular"][0] == effects.LEFT_OUT and rows["Glass reflections"][0] == effects.LEFT_OUT
    assert rows["Mix factors as means"][1].endswith("(ShaderNodeBsdfDiffuse on Plane.002)")
    assert rows["Alpha cut-outs"] == (effects.SIMULATED, "light through the clear parts of an image's alpha (a Mix "
                                      "with a Transparent BSDF, a Principled Alpha), ray by ray (Card on Plane.005)")
    cut = []
    for short in rows:
        panel.fits(short, panel.WIDTHS["sidebar"] - panel.PAD - panel.CLIP - panel.ICON, "effects", cut)
    assert not cut, cut


def test_a_textured_metal_keeps_its_texture_diffuse_and_its_mean_as_mirror(export, empty_scene):
    """A Principled base colour from an image: the diffuse lobe varies per corner (the texture, times
    1 - metallic), the metal lobe, one colour a material, is the image's mean times metallic."""
    mat, node = shaded_plane("ShaderNodeBsdfPrincipled", Metallic=0.5)
    image = bpy.data.images.new("Base", 2, 2, float_buffer=True)
    image.pixels.foreach_set(np.array([[0.2, 0.4, 0.6, 1], [0.6, 0.4, 0.2, 1]] * 2, np.float32).ravel())
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = 'Closest'          # each corner reads its own texel
    mat.node_tree.links.new(tex.outputs["Color"], node.inputs["Base Color"])
    s = export.export_scene()
    m = s.materials[s.material_index(mat.name)]
    np.testing.assert_allclose(m.specular, (0.2, 0.2, 0.2), rtol=1e-6)
    np.testing.assert_allclose(m.reflectance, (0.2, 0.2, 0.2), rtol=1e-6)
    corners = s.mesh("Plane").corner_reflectance
    np.testing.assert_allclose(np.sort(corners[:, 0]), (0.1, 0.1, 0.3, 0.3), rtol=1e-6)

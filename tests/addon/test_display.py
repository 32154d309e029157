"""Show Bake: the lit meshes' materials emit the baked light, so that the viewport and renders show it,
and turning it off leaves the materials as they were."""
import os

import bpy
import numpy as np
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from mathutils.geometry import intersect_point_tri
from mathutils.interpolate import poly_3d_calc


def tree_state(material):
    """A material's nodes (in order, with what each holds) and links, as comparable data."""
    def value(socket):
        v = getattr(socket, "default_value", None)
        return tuple(v) if hasattr(v, "__len__") and not isinstance(v, str) else v

    tree = material.node_tree
    return ([(n.name, n.bl_idname, n.label, tuple(n.location), n.parent and n.parent.name,
              getattr(n, "is_active_output", None), getattr(n, "target", None),
              getattr(n, "image", None) and n.image.name, [(i.identifier, value(i)) for i in n.inputs])
             for n in tree.nodes],
            [(l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
             for l in tree.links])


def test_the_first_bake_shows_itself_and_hiding_restores_the_materials(addon, open_sample):
    scene = open_sample("cornell_box")
    scene.radiosity.preset = 'DRAFT'
    before = {m.name: tree_state(m) for m in bpy.data.materials if m.use_nodes}
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert scene.radiosity.show_bake
    first = addon.writeback.read_mesh(scene.objects["Room"].data)
    shown = [m for m in bpy.data.materials if m.use_nodes and addon.display.NODE in m.node_tree.nodes]
    assert {m.name for m in shown} == set(before)          # every lit mesh's material, the emitter's too
    scene.radiosity.show_bake = False
    assert {m.name: tree_state(m) for m in bpy.data.materials if m.use_nodes} == before
    assert addon.display.GROUP not in bpy.data.node_groups
    scene.radiosity.show_bake = True
    assert bpy.ops.radiosity.bake() == {'FINISHED'}        # a later bake keeps the one node a material has
    # and reads the materials as they are, not the display: the same colours
    np.testing.assert_array_equal(addon.writeback.read_mesh(scene.objects["Room"].data), first)
    assert all(sum(n.name.startswith(addon.display.OUTPUT) for n in m.node_tree.nodes) == 1 for m in shown)


def test_a_render_shows_the_baked_light(addon, open_sample, tmp_path):
    """Cycles renders a point of the back wall at the bake's value there (the attribute interpolated
    across the triangle holding it) times the display's exposure, through the Standard view transform
    into a float image. One stop up, so that a render of the scene's own light, which the bake
    matches, cannot pass for it."""
    scene = open_sample("cornell_box")
    scene.radiosity.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    room = scene.objects["Room"]
    me = room.data
    colours = addon.writeback.read_mesh(me)[:, :3]
    point = room.matrix_world @ Vector((1.0, 2.75, 4.5))     # the back wall's upper right, clear of the boxes
    camera = scene.camera.matrix_world.translation
    hit, _, _, _, hit_object, _ = scene.ray_cast(bpy.context.evaluated_depsgraph_get(), camera, point - camera)
    assert hit and hit_object.name == "Room"
    scene.radiosity.display_exposure = 1.0
    local = room.matrix_world.inverted() @ point
    wall = [t for t in me.loop_triangles if abs(t.normal.y) > 0.9]          # the back wall, y = 2.75
    triangle = next(t for t in wall if intersect_point_tri(local, *(me.vertices[v].co for v in t.vertices)))
    weights = poly_3d_calc([me.vertices[v].co for v in triangle.vertices], local)
    expected = sum(w * colours[loop] for w, loop in zip(weights, triangle.loops))
    scene.render.engine = 'CYCLES'
    scene.cycles.samples = 4
    scene.cycles.use_denoising = False
    scene.view_settings.view_transform = 'Standard'
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 64, 100
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.filepath = os.path.join(str(tmp_path), "render.exr")
    bpy.ops.render.render(write_still=True)
    pixels = np.array(bpy.data.images.load(scene.render.filepath).pixels[:], np.float32).reshape(64, 64, 4)
    u, v, _ = world_to_camera_view(scene, scene.camera, point)
    np.testing.assert_allclose(pixels[int(v * 64), int(u * 64), :3], 2 * expected, rtol=0.03)


# A lightmap of SIDE x SIDE texels, each its own value, on a 2 x 2 plane whose RadiosityUV map spans
# the image; the attribute holds another light, so that a display showing it cannot pass for the map.
SIDE = 8
ATTRIBUTE_LIGHT = 0.05


def lightmap_values(seed):
    rgb = np.random.default_rng(seed).uniform(0.5, 2.0, (SIDE, SIDE, 3)).astype(np.float32)
    return np.concatenate([rgb, np.ones((SIDE, SIDE, 1), np.float32)], axis=2)


def lit_plane(addon, name, material, x=0.0, values=None):
    """A lit 2 x 2 plane at (x, 0, 0) facing up, with `material`, its lightmap `values`
    (lightmap_values(0) if None)."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    me.uv_layers.new(name="UVMap")          # the material's own map, active: the display must not read it
    layer = me.uv_layers.new(name=addon.uv_charts.UV_MAP)
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    corners = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", corners)
    layer.data.foreach_set("uv", ((co.reshape(-1, 3)[corners, :2] + 1) / 2).ravel())
    light = me.color_attributes.new(addon.writeback.ATTRIBUTE, 'FLOAT_COLOR', 'CORNER')
    light.data.foreach_set("color", np.tile([ATTRIBUTE_LIGHT] * 3 + [1.0], len(me.loops)).astype(np.float32))
    me.materials.append(material)
    ob = bpy.data.objects.new(name, me)
    ob.location.x = x
    bpy.context.scene.collection.objects.link(ob)
    values = lightmap_values(0) if values is None else values
    addon.lightmap.write_image(addon.lightmap.image_name(name), SIDE, SIDE, values)
    return ob


def own_material(name):
    """A material with nodes of its own: a texture through a mapping into a Principled BSDF, and two
    outputs, the second one active."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    texture = nodes.new('ShaderNodeTexImage')
    texture.image = bpy.data.images.new(name + " texture", 4, 4)
    mapping = nodes.new('ShaderNodeMapping')
    mapping.inputs["Scale"].default_value = (2.0, 3.0, 1.0)
    links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
    second = nodes.new('ShaderNodeOutputMaterial')
    second.location = (300, -400)
    links.new(nodes["Principled BSDF"].outputs[0], second.inputs["Surface"])
    second.is_active_output = True
    return m


def empty_scene():
    bpy.ops.wm.read_homefile(use_empty=True)
    return bpy.context.scene


def shown_light(addon, material):
    """(the type of the node feeding the display, its image's name or None)."""
    light = material.node_tree.nodes[addon.display.LIGHT]
    return light.bl_idname, getattr(light, "image", None) and light.image.name


def test_a_lightmap_is_shown_through_its_map_and_hiding_leaves_the_material_as_it_was(addon):
    scene = empty_scene()
    material = own_material("Own")
    ob = lit_plane(addon, "Plane", material)
    image = bpy.data.images["Plane_Radiosity"]
    before, users = tree_state(material), {i.name: i.users for i in bpy.data.images}
    groups = set(bpy.data.node_groups.keys())
    scene.radiosity.lightmaps = True
    scene.radiosity.show_bake = True
    nodes = material.node_tree.nodes
    assert shown_light(addon, material) == ('ShaderNodeTexImage', image.name)
    assert nodes[addon.display.UV].uv_map == "RadiosityUV" and ob.data.uv_layers.active.name == "UVMap"
    assert nodes[addon.display.OUTPUT].is_active_output
    scene.radiosity.lightmaps = False                   # no lightmaps wanted: the attribute
    assert shown_light(addon, material) == ('ShaderNodeAttribute', None)
    assert addon.display.UV not in nodes
    scene.radiosity.lightmaps = True
    assert shown_light(addon, material) == ('ShaderNodeTexImage', image.name)
    scene.radiosity.show_bake = False
    assert tree_state(material) == before
    assert {i.name: i.users for i in bpy.data.images} == users
    assert set(bpy.data.node_groups.keys()) == groups


def test_a_display_saved_by_an_older_group_without_a_light_input_is_made_anew(addon):
    scene = empty_scene()
    material = own_material("Own")
    lit_plane(addon, "Plane", material)
    old = bpy.data.node_groups.new(addon.display.GROUP, 'ShaderNodeTree')    # the attribute inside, no input
    old.inputs.new('NodeSocketFloat', "Exposure")
    node = material.node_tree.nodes.new('ShaderNodeGroup')
    node.node_tree, node.name = old, addon.display.NODE
    output = material.node_tree.nodes.new('ShaderNodeOutputMaterial')
    output.name = addon.display.OUTPUT
    scene.radiosity.show_bake = True
    assert shown_light(addon, material) == ('ShaderNodeAttribute', None)
    assert material.node_tree.nodes[addon.display.NODE].node_tree.inputs.get("Light") is not None


def test_a_bake_that_makes_lightmaps_brings_the_shown_display_to_them(addon):
    scene = empty_scene()
    me = bpy.data.meshes.new("Floor")
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    material = own_material("Floor")
    me.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new("Floor", me))
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    lamp.location.z = 2.0
    scene.collection.objects.link(lamp)
    scene.radiosity.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}       # the first bake shows itself: the attribute
    assert shown_light(addon, material) == ('ShaderNodeAttribute', None)
    scene.radiosity.lightmaps = True                       # no lightmap yet
    assert shown_light(addon, material) == ('ShaderNodeAttribute', None)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert shown_light(addon, material) == ('ShaderNodeTexImage', "Floor_Radiosity")


def test_a_material_several_lit_objects_use_shows_the_attribute_and_says_so(addon):
    scene = empty_scene()
    scene.radiosity.lightmaps = True
    shared, own, plain = (bpy.data.materials.new(n) for n in ("Shared", "Own", "Plain"))
    for m in (shared, own, plain):
        m.use_nodes = True
    first, second = lit_plane(addon, "A", shared, 0.0), lit_plane(addon, "B", shared, 3.0)
    lit_plane(addon, "C", own, 6.0)
    for name, x in (("D", 9.0), ("E", 12.0)):          # no lightmaps: the attribute, nothing to say
        bpy.data.images.remove(bpy.data.images[lit_plane(addon, name, plain, x).name + "_Radiosity"])
    scene.radiosity.show_bake = True
    assert shown_light(addon, shared) == ('ShaderNodeAttribute', None)
    assert shown_light(addon, plain) == ('ShaderNodeAttribute', None)
    assert shown_light(addon, own) == ('ShaderNodeTexImage', "C_Radiosity")
    note = scene.radiosity.display_note
    assert "'Shared'" in note and "Own" not in note and "Plain" not in note
    second.material_slots[0].material = shared.copy()     # a copy each: each its own lightmap
    addon.display.show(scene)
    assert shown_light(addon, first.material_slots[0].material) == ('ShaderNodeTexImage', "A_Radiosity")
    assert shown_light(addon, second.material_slots[0].material) == ('ShaderNodeTexImage', "B_Radiosity")
    assert scene.radiosity.display_note == ""
    scene.radiosity.show_bake = False
    assert all(addon.display.OUTPUT not in m.node_tree.nodes for m in bpy.data.materials)


def render(scene, engine, path):
    """scene rendered by `engine` through a camera looking straight down at the plane at the origin,
    one pixel a texel: (SIDE, SIDE, 3) float pixels, bottom row first as the image's."""
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = 'ORTHO', 2.0
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.engine = engine
    scene.cycles.samples, scene.cycles.use_denoising = 4, False
    scene.cycles.filter_width = 0.01           # each pixel a point: its texel, not a blend of neighbours
    scene.eevee.taa_render_samples = 1
    scene.render.filter_size = 0.0
    scene.view_settings.view_transform = 'Standard'
    scene.render.resolution_x = scene.render.resolution_y = SIDE
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.filepath = path
    try:
        bpy.ops.render.render(write_still=True)
    finally:
        bpy.data.objects.remove(camera)
    image = bpy.data.images.load(path)
    try:
        return np.array(image.pixels[:], np.float32).reshape(SIDE, SIDE, 4)[..., :3]
    finally:
        bpy.data.images.remove(image)


def test_cycles_renders_each_texel_times_two_to_the_exposure(addon, tmp_path):
    """Emission shows radiance as it is, so each pixel is its texel's value times 2^exposure, up to
    the image's float precision and the pixel's 0.01 px jitter across neighbouring texels."""
    scene = empty_scene()
    scene.radiosity.lightmaps = True
    lit_plane(addon, "Plane", own_material("Own"))
    scene.radiosity.show_bake = True
    values = lightmap_values(0)[..., :3]
    for exposure in (0.0, 1.0):
        scene.radiosity.display_exposure = exposure
        pixels = render(scene, 'CYCLES', str(tmp_path / f"cycles_{exposure}.exr"))
        np.testing.assert_allclose(pixels, values * 2 ** exposure, rtol=0.01)


def test_eevee_renders_the_lightmap_times_two_to_the_exposure(addon, tmp_path):
    """Eevee's render filter blends neighbouring pixels, so the lightmap is two halves of one value
    each, read away from where they meet."""
    scene = empty_scene()
    scene.radiosity.lightmaps = True
    halves = np.ones((SIDE, SIDE, 4), np.float32)
    halves[:, SIDE // 2:, :3] = 2.0
    lit_plane(addon, "Plane", own_material("Own"), values=halves)
    scene.radiosity.show_bake = True
    scene.radiosity.display_exposure = 1.0
    pixels = render(scene, 'BLENDER_EEVEE', str(tmp_path / "eevee.exr"))
    away = np.r_[:SIDE // 2 - 1, SIDE // 2 + 1:SIDE]
    np.testing.assert_allclose(pixels[:, away], 2 * halves[:, away, :3], rtol=0.01)


def test_shown_after_bake_animation_the_lightmap_plays_its_frames(addon, tmp_path):
    """Bake Animation's sequence, made as it makes it (two frames' files, the image pointed at them),
    then shown: each frame renders its own file."""
    scene = empty_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "anim.blend"))
    scene.radiosity.lightmaps = True
    lit_plane(addon, "Plane", own_material("Own"))
    sequence = addon.lightmap_sequence
    folder = sequence.folder_for(bpy.data.filepath)
    for frame in (1, 2):
        sequence.save_exr(lightmap_values(frame), sequence.frame_path(folder, "Plane_Radiosity", frame))
    sequence.point("Plane_Radiosity", sequence.frame_path(folder, "Plane_Radiosity", 1), 1, 2, (SIDE, SIDE))
    bpy.data.images.remove(bpy.data.images[sequence.SCRATCH])
    scene.radiosity.show_bake = True
    user = bpy.data.materials["Own"].node_tree.nodes[addon.display.LIGHT].image_user
    assert (user.frame_start, user.frame_duration, user.frame_offset) == (1, 2, 0)
    for frame in (1, 2):
        scene.frame_set(frame)
        pixels = render(scene, 'CYCLES', str(tmp_path / f"frame_{frame}.exr"))
        np.testing.assert_allclose(pixels, lightmap_values(frame)[..., :3], rtol=0.01)

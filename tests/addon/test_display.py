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
    """A material's nodes and links, as comparable data."""
    tree = material.node_tree
    return (sorted((n.name, n.bl_idname, getattr(n, "is_active_output", None)) for n in tree.nodes),
            sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
                   for l in tree.links))


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

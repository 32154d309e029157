"""Cycles' COMBINED image bake of a small scene's lightmaps: the reference test_lightmaps.py compares
the add-on's lightmaps with.

    blender -b --factory-startup --python tests/cycles_reference/lightmap_reference.py [-- --samples N]

The scene (build()): a 4 m grey floor of one quad, a grey 0.8 m box standing on it, a point lamp
without radius off to one side, no world light. Each object has its own Diffuse BSDF material (an
image bake writes into the active Image Texture node of each material) and a hand-laid `RadiosityUV`
map: the floor over the whole square, the box's faces in a 3 x 2 grid of cells, inset a texel.
Images start at -1: Cycles bakes the texels whose centres lie in a face and, with no margin,
leaves the rest, so -1 marks a texel no face covers.

Writes lightmaps/lightmap_box.npz: "<object>" (H, W, 3) float32 rows from the bottom, as Blender stores
pixels; "samples", "seconds", "blender_version". Settings as DESIGN.md section 4 (cycles_settings.py).
"""
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cycles_settings  # noqa: E402

# In a folder of its own: the .npz files beside this script are the sample scenes' corner references.
PATH = os.path.join(HERE, "lightmaps", "lightmap_box.npz")
SIZES = {"Floor": (64, 64), "Box": (48, 32)}   # (width, height) of each object's image
LAMP = ((-0.9, -0.6, 1.8), 400.0)              # location, watts


def _diffuse(ob, rho):
    mat = bpy.data.materials.new(ob.name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (rho, rho, rho, 1.0)
    mat.node_tree.links.new(bsdf.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
    ob.data.materials.append(mat)
    return mat


def _uv_map(me, face_cells, cells, width, height):
    """RadiosityUV: face f's corners (in loop order, counter-clockwise) on the corners of cell
    face_cells[f] of a cells = (columns, rows) grid, inset by one texel."""
    layer = me.uv_layers.new(name="RadiosityUV")
    sizes = np.empty(len(me.polygons), np.int32)
    me.polygons.foreach_get("loop_total", sizes)
    assert np.all(sizes == 4)
    cols, rows = cells
    inset = np.array([1.0 / width, 1.0 / height])
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    uv = []
    for f in range(len(me.polygons)):
        c, r = face_cells[f] % cols, face_cells[f] // cols
        lo = np.array([c / cols, r / rows]) + inset
        hi = np.array([(c + 1) / cols, (r + 1) / rows]) - inset
        uv.append(lo + square * (hi - lo))
    layer.data.foreach_set("uv", np.concatenate(uv).astype(np.float32).ravel())
    return layer


def build():
    """The scene, from factory settings. Returns {object name: object}."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.world = None
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    floor = bpy.context.object
    floor.name = "Floor"
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.5, 0.4, 0.4), rotation=(0, 0, 0.35))
    box = bpy.context.object
    box.name = "Box"
    for ob, rho in ((floor, 0.6), (box, 0.5)):
        _diffuse(ob, rho)
        for layer in list(ob.data.uv_layers):
            ob.data.uv_layers.remove(layer)
    _uv_map(floor.data, [0], (1, 1), *SIZES["Floor"])
    _uv_map(box.data, list(range(6)), (3, 2), *SIZES["Box"])
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    lamp.location, lamp.data.energy = LAMP
    lamp.data.shadow_soft_size = 0.0
    scene.collection.objects.link(lamp)
    return {"Floor": floor, "Box": box}


def bake(objects, samples):
    """Cycles' bake of each object into a fresh -1 image of SIZES. Returns ({name: (H, W, 3)}, seconds)."""
    scene = bpy.context.scene
    cycles_settings.unbiased(scene, samples, 64, 0)
    for name, ob in objects.items():
        width, height = SIZES[name]
        image = bpy.data.images.new(name + "_Cycles", width, height, float_buffer=True)
        image.pixels.foreach_set(np.full(width * height * 4, -1.0, np.float32))
        tree = ob.data.materials[0].node_tree
        node = tree.nodes.new("ShaderNodeTexImage")
        node.image = image
        tree.nodes.active = node
        ob.select_set(True)
    bpy.context.view_layer.objects.active = objects["Floor"]
    start = time.perf_counter()
    bpy.ops.object.bake(type='COMBINED', target='IMAGE_TEXTURES', uv_layer="RadiosityUV", margin=0,
                        use_clear=False)
    seconds = time.perf_counter() - start
    out = {}
    for name in objects:
        image = bpy.data.images[name + "_Cycles"]
        px = np.empty(len(image.pixels), np.float32)
        image.pixels.foreach_get(px)
        out[name] = px.reshape(image.size[1], image.size[0], 4)[..., :3]
    return out, seconds


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    samples = int(argv[argv.index("--samples") + 1]) if "--samples" in argv else 4096
    images, seconds = bake(build(), samples)
    np.savez_compressed(PATH, samples=samples, seconds=seconds, blender_version=bpy.app.version_string, **images)
    print(f"wrote {PATH}: {samples} spp in {seconds:.1f} s")


if __name__ == "__main__":
    main()

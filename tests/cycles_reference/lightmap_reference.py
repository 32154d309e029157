"""Cycles' COMBINED image bakes: the references test_lightmaps.py compares the add-on's lightmaps with.

    blender -b --factory-startup --python tests/cycles_reference/lightmap_reference.py [-- --samples N]
        [--only NAME] [--seed S]

NAME is "box" (below) or a sample scene; without --only, all of them. Settings as DESIGN.md section 4
(cycles_settings.py). Images start at -1: Cycles bakes the texels whose centres lie in a face and,
with no margin, leaves the rest, so -1 marks a texel no face covers.

"box" (build()): a 4 m grey floor of one quad, a grey 0.8 m box standing on it, a point lamp without
radius off to one side, no world light. Each object has its own Diffuse BSDF material (an image bake
writes into the active Image Texture node of each material) and a hand-laid `RadiosityUV` map: the
floor over the whole square, the box's faces in a 3 x 2 grid of cells, inset a texel. Writes
lightmaps/lightmap_box.npz: "<object>" (H, W, 3) float32 rows from the bottom, as Blender stores
pixels; "samples", "seconds", "blender_version".

The sample scenes (SAMPLE_SCENES; the animated room at its first frame; made with --samples 8192):
every mesh object that renders and has a face that does not emit (the Cornell box's emitter has
none) gets its own copies of its materials, a `RadiosityUV` map made by Lightmap Pack
(addon/uv_charts.py, as the add-on makes one) and a square image (image_side()). A Subdivision
Surface object bakes its subdivided mesh, in the UVs Blender subdivides from its cage's. Writes
lightmaps/<scene>[_fNNN].npz: "<object>" (H, W, 3) float16 (as above), "<object>:uv" (L, 2) float32
the cage's RadiosityUV per face corner, the map to give the object to bake the same texels, and for
an object with modifiers "<object>:eval_uv" (T, 3, 2) float32, its evaluated mesh's loop triangles
in that map, the UVs Cycles baked; "samples", "seconds", "frame", "blender_version".
With --seed S the file is <scene>[_fNNN]_seedS.npz, for noise estimates.
"""
import importlib.util
import math
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import cycles_settings  # noqa: E402
import make_references  # noqa: E402  (emitting_corners)


def _addon_module(name):
    """A module of addon/ that imports none of the others, without the add-on (and without putting
    addon/ on sys.path, where its module names would shadow others)."""
    spec = importlib.util.spec_from_file_location("lightmap_reference_" + name, os.path.join(ROOT, "addon", name + ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


uv_charts = _addon_module("uv_charts")   # the add-on's Lightmap Pack call: the map it would make

# In a folder of its own: the .npz files beside this script are the sample scenes' corner references.
PATH = os.path.join(HERE, "lightmaps", "lightmap_box.npz")
SIZES = {"Floor": (64, 64), "Box": (48, 32)}   # (width, height) of each object's image
LAMP = ((-0.9, -0.6, 1.8), 400.0)              # location, watts
SAMPLE_SCENES = {"cornell_box": None, "animated_room": 1, "subsurf_room": None, "interior_room": None}
DENSITY = 10.0                                 # texels a metre across the square root of an object's area
FACE_TEXELS = 16                               # ... and at least this many times the square root of its faces
SIDE = (48, 96)                                # bounds of a sample object's image's width and height


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


def bake(objects, sizes, samples, seed=0):
    """Cycles' bake of each object into a fresh -1 image of sizes[name] = (width, height), each
    object with its own copies of its materials. Returns ({name: (H, W, 3)}, seconds)."""
    scene = bpy.context.scene
    cycles_settings.unbiased(scene, samples, 64, seed)
    bpy.ops.object.select_all(action='DESELECT')
    for name, ob in objects.items():
        width, height = sizes[name]
        image = bpy.data.images.new(name + "_Cycles", width, height, float_buffer=True)
        image.pixels.foreach_set(np.full(width * height * 4, -1.0, np.float32))
        # objects that share a material would bake into one image
        for slot in ob.material_slots:
            slot.material = slot.material.copy()
            tree = slot.material.node_tree
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = image
            tree.nodes.active = node
        ob.select_set(True)
    bpy.context.view_layer.objects.active = next(iter(objects.values()))
    start = time.perf_counter()
    bpy.ops.object.bake(type='COMBINED', target='IMAGE_TEXTURES', uv_layer=uv_charts.UV_MAP, margin=0,
                        use_clear=False)
    seconds = time.perf_counter() - start
    out = {}
    for name in objects:
        image = bpy.data.images[name + "_Cycles"]
        px = np.empty(len(image.pixels), np.float32)
        image.pixels.foreach_get(px)
        out[name] = px.reshape(image.size[1], image.size[0], 4)[..., :3]
    return out, seconds


def sample_path(scene, frame=None, seed=0):
    return os.path.join(HERE, "lightmaps", scene + (f"_f{frame:03d}" if frame is not None else "")
                        + (f"_seed{seed}" if seed else "") + ".npz")


def image_side(ob):
    """The side of ob's image: DENSITY texels a metre across the square root of its (cage's) area,
    at least FACE_TEXELS times the square root of its face count (Lightmap Pack gives each face a
    chart and a margin round it: furniture of many small faces needs the room), a multiple of 8
    within SIDE."""
    me = ob.data
    areas = np.empty(len(me.polygons))
    me.polygons.foreach_get("area", areas)
    scale = abs(np.linalg.det(np.array(ob.matrix_world)[:3, :3])) ** (2.0 / 3.0)
    side = max(math.sqrt(areas.sum() * scale) * DENSITY, FACE_TEXELS * math.sqrt(len(areas)))
    return int(min(max(8 * math.ceil(side / 8), SIDE[0]), SIDE[1]))


def loop_uv(me):
    uv = np.empty(2 * len(me.loops), np.float32)
    me.uv_layers[uv_charts.UV_MAP].data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)


def evaluated_uv(ob):
    """(T, 3, 2) ob's evaluated mesh's loop triangles in RadiosityUV."""
    me = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    try:
        me.calc_loop_triangles()
        loops = np.empty(3 * len(me.loop_triangles), np.int32)
        me.loop_triangles.foreach_get("loops", loops)
        return loop_uv(me)[loops].reshape(-1, 3, 2)
    finally:
        ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh_clear()


def bake_sample(scene_name, frame, samples, seed):
    """The sample's lightmap reference into sample_path(...); returns the path."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(make_references.SAMPLES_DIR, scene_name + ".blend"))
    scene = bpy.context.scene
    if frame is not None:
        scene.frame_set(frame)
    objects = {ob.name: ob for ob in sorted(scene.objects, key=lambda o: o.name)
               if ob.type == 'MESH' and not ob.hide_render and not make_references.emitting_corners(ob).all()}
    sizes, data = {}, {}
    for name, ob in objects.items():
        side = image_side(ob)
        sizes[name] = (side, side)
        assert uv_charts.ensure_uv_map(ob.data, side) is not None, name
        data[name + ":uv"] = loop_uv(ob.data)
        if ob.modifiers:
            data[name + ":eval_uv"] = evaluated_uv(ob)
    images, seconds = bake(objects, sizes, samples, seed)
    data.update({name: image.astype(np.float16) for name, image in images.items()})
    path = sample_path(scene_name, frame, seed)
    np.savez_compressed(path, samples=samples, seconds=seconds, frame=scene.frame_current,
                        blender_version=bpy.app.version_string, **data)
    texels = sum(int((image[..., 0] >= 0).sum()) for image in images.values())
    print(f"wrote {path}: {texels} texels at {samples} spp in {seconds:.1f} s, "
          f"{os.path.getsize(path) / 1024:.0f} KiB", flush=True)
    return path


def open_with_reference(scene_name, frame=None):
    """Opens a sample scene (at its reference's frame) and gives each object of its lightmap
    reference the reference's RadiosityUV and an empty float image of the reference's size under
    the add-on's name for it, `<object>_Radiosity`: the add-on then bakes the texels Cycles baked.
    Returns the reference ({key: array})."""
    with np.load(sample_path(scene_name, frame)) as z:
        ref = {k: z[k] for k in z.files}
    bpy.ops.wm.open_mainfile(filepath=os.path.join(make_references.SAMPLES_DIR, scene_name + ".blend"))
    if frame is not None:
        bpy.context.scene.frame_set(frame)
    for name in objects_of(ref):
        layer = bpy.data.objects[name].data.uv_layers.new(name=uv_charts.UV_MAP)
        layer.data.foreach_set("uv", ref[name + ":uv"].ravel())
        height, width = ref[name].shape[:2]
        bpy.data.images.new(name + "_Radiosity", width, height, float_buffer=True)
    return ref


def objects_of(ref):
    """The names of the objects whose images a lightmap reference holds."""
    return sorted(k for k in ref if ":" not in k and np.ndim(ref[k]) == 3)


def texel_pairs(ref):
    """{object: (its image `<object>_Radiosity`'s RGB, Cycles' RGB)}, (n, 3) float64 each, over the
    texels Cycles baked."""
    out = {}
    for name in objects_of(ref):
        cycles = ref[name].astype(np.float64)
        baked = cycles[..., 0] >= 0
        image = bpy.data.images[name + "_Radiosity"]
        assert tuple(image.size) == cycles.shape[1::-1], f"{name}: image {tuple(image.size)}"
        px = np.empty(len(image.pixels), np.float32)
        image.pixels.foreach_get(px)
        out[name] = (px.reshape(cycles.shape[0], cycles.shape[1], 4)[..., :3][baked].astype(np.float64), cycles[baked])
    return out


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []

    def value(flag, default, kind=int):
        return kind(argv[argv.index(flag) + 1]) if flag in argv else default
    samples, only, seed = value("--samples", 4096), value("--only", None, str), value("--seed", 0)
    if only in (None, "box"):
        objects = build()
        images, seconds = bake(objects, SIZES, samples, seed)
        np.savez_compressed(PATH, samples=samples, seconds=seconds, blender_version=bpy.app.version_string,
                            **images)
        print(f"wrote {PATH}: {samples} spp in {seconds:.1f} s")
    for name, frame in SAMPLE_SCENES.items():
        if only in (None, name):
            bake_sample(name, frame, samples, seed)


if __name__ == "__main__":
    main()

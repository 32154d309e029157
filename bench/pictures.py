"""Pictures of what the add-on bakes, beside Cycles' render of the same camera: the README's figure.

    blender -b --factory-startup --python bench/pictures.py [-- OUT.png [SPP]]

For each sample scene (the animated room at its first frame, baked, and at its last, where Live
Update took it incrementally), four pictures from the scene camera, Standard view transform:
- the default preset's `Radiosity` attribute as Workbench shows it (flat: the colours as stored).
  It holds a value per corner of the user's mesh, as Cycles' vertex bake does, and Blender
  interpolates it across each face: a room of six quads shows its corners' light only;
- the solver's own patches (Solver.refined), what the attribute would show on a mesh that fine;
- the default preset's lightmaps (docs/lightmaps.md), each mesh an Emission shader (strength 1)
  reading its `<object>_Radiosity` image in `RadiosityUV`, rendered by Cycles with the lamps
  hidden and the world black: the texels' shadows and hot spots inside the faces;
- Cycles' path-traced render (SPP samples, DESIGN.md section 4 settings): per pixel, noisy.
Writes bench/results/pictures.png.
"""
import os
import sys
import tempfile

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
from plot_png import Canvas  # noqa: E402
from conftest import load_package  # noqa: E402
import cycles_settings  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
OUT = args[0] if args else os.path.join(HERE, "results", "pictures.png")
SPP = int(args[1]) if len(args) > 1 else 1024
SIZE = 200
SHOTS = [("cornell_box", None), ("subsurf_room", None), ("interior_room", None), ("animated_room", 1),
         ("animated_room", 24)]


def rendered(scene, engine):
    """(SIZE, SIZE, 3) uint8 picture from the scene camera."""
    scene.render.engine = engine
    scene.view_settings.view_transform = 'Standard'
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    path = os.path.join(tempfile.mkdtemp(), "shot.png")
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.empty(SIZE * SIZE * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    rgb = px.reshape(SIZE, SIZE, 4)[::-1, :, :3]   # Blender's rows run bottom to top
    return np.clip(rgb * 255 + 0.5, 0, 255).astype(np.uint8)


def ours(scene):
    """Workbench showing the baked attribute as stored."""
    for ob in scene.objects:
        if ob.type == 'MESH' and "Radiosity" in ob.data.color_attributes:
            ob.data.color_attributes.active_color = ob.data.color_attributes["Radiosity"]
    shading = scene.display.shading
    shading.light = 'FLAT'
    shading.color_type = 'VERTEX'
    return rendered(scene, 'BLENDER_WORKBENCH')


def patches(scene):
    """Workbench showing the live solver's patches, coloured as solved, in place of the meshes."""
    job = load_package().live_update.live_jobs[scene.name]
    shown = [ob for ob in scene.objects if ob.type == 'MESH' and not ob.hide_render]
    made = []
    live = scene.radiosity.live_update
    scene.radiosity.live_update = False   # else it would light these meshes, their originals hidden
    for ob in shown:
        pos, rad = job.solver.refined(job.ids[ob.name])
        me = bpy.data.meshes.new(ob.name + " patches")
        me.vertices.add(len(pos))
        me.vertices.foreach_set("co", np.asarray(pos, np.float32).ravel())
        me.loops.add(len(pos))
        me.loops.foreach_set("vertex_index", np.arange(len(pos), dtype=np.int32))
        me.polygons.add(len(pos) // 4)
        me.polygons.foreach_set("loop_start", np.arange(0, len(pos), 4, dtype=np.int32))
        me.polygons.foreach_set("loop_total", np.full(len(pos) // 4, 4, np.int32))
        me.update()
        colour = me.color_attributes.new("Solved", 'FLOAT_COLOR', 'CORNER')
        rgba = np.ones((len(pos), 4), np.float32)
        rgba[:, :3] = rad
        colour.data.foreach_set("color", rgba.ravel())
        me.color_attributes.active_color = colour
        made.append(bpy.data.objects.new(me.name, me))
        scene.collection.objects.link(made[-1])
        ob.hide_render = True
    try:
        return ours(scene)
    finally:
        for ob in shown:
            ob.hide_render = False
        for ob in made:
            bpy.data.meshes.remove(ob.data)
        scene.radiosity.live_update = live


def lightmaps(scene):
    """Cycles showing each mesh's lightmap as an emitter: the texels are all the light there is."""
    lightmap = load_package().lightmap
    live = scene.radiosity.live_update
    scene.radiosity.live_update = False   # else it would solve the scene these emitters make
    meshes = [ob for ob in scene.objects if ob.type == 'MESH']
    kept = {ob.name: (list(ob.data.materials), ob.hide_render) for ob in meshes}
    lamps = [ob for ob in scene.objects if ob.type == 'LIGHT' and not ob.hide_render]
    world = scene.world
    made = []
    try:
        scene.world = bpy.data.worlds.new("black")
        scene.world.color = (0, 0, 0)
        for ob in lamps:
            ob.hide_render = True
        for ob in meshes:
            image = bpy.data.images.get(lightmap.image_name(ob.name))
            if image is None:             # not lit, no lightmap: not shown
                ob.hide_render = True
                continue
            mat = bpy.data.materials.new(ob.name + " lightmap")
            made.append(mat)
            mat.use_nodes = True
            nodes, links = mat.node_tree.nodes, mat.node_tree.links
            nodes.clear()
            uv = nodes.new('ShaderNodeUVMap')
            uv.uv_map = "RadiosityUV"
            tex = nodes.new('ShaderNodeTexImage')
            tex.image = image
            emit = nodes.new('ShaderNodeEmission')
            emit.inputs["Strength"].default_value = 1.0
            out = nodes.new('ShaderNodeOutputMaterial')
            links.new(uv.outputs["UV"], tex.inputs["Vector"])
            links.new(tex.outputs["Color"], emit.inputs["Color"])
            links.new(emit.outputs["Emission"], out.inputs["Surface"])
            slots = ob.data.materials      # each slot replaced in place: the faces' indices stay
            if len(slots) == 0:
                slots.append(mat)
            for i in range(len(slots)):
                slots[i] = mat
        cycles_settings.unbiased(scene, 16, 0, 1)   # emission seen directly: nothing to bounce
        return rendered(scene, 'CYCLES')
    finally:
        for ob in meshes:
            materials, hidden = kept[ob.name]
            slots = ob.data.materials
            if len(materials) == 0 and len(slots) == 1:
                slots.pop()
            for i, m in enumerate(materials):
                slots[i] = m
            ob.hide_render = hidden
        for ob in lamps:
            ob.hide_render = False
        black, scene.world = scene.world, world
        bpy.data.worlds.remove(black)
        for mat in made:
            bpy.data.materials.remove(mat)
        scene.radiosity.live_update = live


def cycles(scene):
    cycles_settings.unbiased(scene, SPP, 64, 1)   # seed 1, as the accuracy bench's Cycles rows
    return rendered(scene, 'CYCLES')


def main():
    load_package().register()   # the add-on from this source tree, its engine from build/engine
    tiles = []
    baked = None
    for name, frame in SHOTS:
        if baked != name:
            bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", name + ".blend"))
            scene = bpy.context.scene
            scene.radiosity.preset = 'DEFAULT'
            scene.radiosity.lightmaps = True
            scene.radiosity.display_offered = True   # else the bake turns Show Bake on: Cycles would show it
            if frame is not None:
                scene.frame_set(frame)
            assert bpy.ops.radiosity.bake() == {'FINISHED'}
            scene.radiosity.live_update = True
            baked = name
        else:                       # live update: an incremental update of the solver from the bake
            scene.frame_set(frame)
            assert load_package().live_update.last_sync[scene.name]["mode"] == "incremental"
        label = name.replace("_", " ") + (f", frame {frame}" if frame is not None else "")
        tiles.append((label, [(ours(scene), "ours: the attribute"), (patches(scene), "ours: the patches"),
                              (lightmaps(scene), "ours: the lightmap"), (cycles(scene), f"Cycles, {SPP} spp")]))
        print(label, "done", flush=True)
    pad, top = 12, 34
    c = Canvas(4 * SIZE + 5 * pad, len(tiles) * (SIZE + top + pad) + pad)
    for i, (label, pictures) in enumerate(tiles):
        y = pad + i * (SIZE + top + pad)
        c.text(pad, y, label, (0, 0, 0), 2)
        for j, (img, caption) in enumerate(pictures):
            x = pad + j * (SIZE + pad)
            c.img[y + top - 6:y + top - 6 + SIZE, x:x + SIZE] = img
            c.text(x, y + 18, caption, (70, 70, 70), 1)
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    c.save(OUT)
    print("wrote", OUT)


main()

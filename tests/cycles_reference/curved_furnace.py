"""Cycles inside a closed Catmull-Clark cube: every face emits 1 and reflects rho (0.8).

    blender -b --factory-startup --python tests/cycles_reference/curved_furnace.py [-- --samples N]

Writes curved_furnace.json: per level 0-3, the mean over all face corners of (1 - rho) B from a
COMBINED vertex bake of Blender's subdivided cube (limit surface, smooth shaded; level 0: the cube
itself, flat faces shaded smooth), settings as in cycles_settings.py. Energy balance would give 1;
Cycles gives less, because a smooth-shaded corner drops the directions under its facet, most at low
levels. test_module.py compares the engine's
solve of the same cube with it.
"""
import json
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import cycles_settings  # noqa: E402

RHO = 0.8


def cube(level):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add(size=2)
    ob = bpy.context.object
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode='OBJECT')
    if level > 0:   # at 0 the modifier would still move the corners onto the limit surface
        md = ob.modifiers.new("subsurf", 'SUBSURF')
        md.levels = md.render_levels = level
        md.use_limit_surface = True
        bpy.ops.object.modifier_apply(modifier=md.name)
    bpy.ops.object.shade_smooth()
    mat = bpy.data.materials.new("furnace")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (RHO, RHO, RHO, 1)
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    add = nodes.new("ShaderNodeAddShader")
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(diffuse.outputs[0], add.inputs[0])
    links.new(emission.outputs[0], add.inputs[1])
    links.new(add.outputs[0], out.inputs["Surface"])
    ob.data.materials.append(mat)
    return ob


def bake(level, samples):
    ob = cube(level)
    sc = bpy.context.scene
    sc.world = bpy.data.worlds.new("dark")
    sc.world.use_nodes = True
    sc.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    cycles_settings.unbiased(sc, samples, 64, seed=0)
    sc.render.bake.target = 'VERTEX_COLORS'
    attribute = ob.data.color_attributes.new("Cycles", 'FLOAT_COLOR', 'CORNER')
    ob.data.color_attributes.active_color = attribute
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob
    t = time.perf_counter()
    bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')
    seconds = time.perf_counter() - t
    values = np.empty(len(attribute.data) * 4, np.float32)
    attribute.data.foreach_get("color", values)
    balance = values.reshape(-1, 4)[:, :3].mean(1) * (1 - RHO)
    return {"mean": float(balance.mean()), "min": float(balance.min()), "max": float(balance.max()),
            "corners": len(balance), "seconds": round(seconds, 1)}


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    samples = int(argv[argv.index("--samples") + 1]) if "--samples" in argv else 4096
    result = {"rho": RHO, "samples": samples, "blender_version": bpy.app.version_string, "levels": {}}
    for level in (0, 1, 2, 3):
        result["levels"][str(level)] = bake(level, samples)
        print(level, result["levels"][str(level)], flush=True)
    with open(os.path.join(os.path.dirname(__file__), "curved_furnace.json"), "w") as f:
        json.dump(result, f, indent=1)


main()

"""The main job: bake a sample scene with the add-on, save the baked .blend, print what it cost and
render a picture of the baked colours from the scene camera.

    blender -b --addons dynamic_radiosity sample_blends/cornell_box.blend --python tools/main_job.py -- OUT_DIR
"""
import os
import sys

import bpy

out_dir = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "out"
os.makedirs(out_dir, exist_ok=True)
name = os.path.splitext(os.path.basename(bpy.data.filepath))[0]
scene = bpy.context.scene

if bpy.ops.radiosity.bake() != {'FINISHED'}:
    raise SystemExit("bake failed")
r = scene.radiosity
print(f"{name}: baked in {r.last_seconds:.2f} s, residual {r.last_residual:.1e}, "
      f"{r.last_patches} patches, {r.last_points} vertices, {r.last_rays:.0f} rays; effects: {r.last_effects}")

baked = os.path.abspath(os.path.join(out_dir, name + "_baked.blend"))
bpy.ops.wm.save_as_mainfile(filepath=baked, copy=True)
print("saved", baked)

# Workbench shows the active colour attribute as it is: a picture of exactly what was baked.
for obj in scene.objects:
    if obj.type == 'MESH' and "Radiosity" in obj.data.color_attributes:
        obj.data.color_attributes.active_color = obj.data.color_attributes["Radiosity"]
scene.render.engine = 'BLENDER_WORKBENCH'
shading = scene.display.shading
shading.light = 'FLAT'
shading.color_type = 'VERTEX'
scene.view_settings.view_transform = 'Standard'
scene.render.resolution_x, scene.render.resolution_y = 640, 640
scene.render.filepath = os.path.abspath(os.path.join(out_dir, name + "_baked.png"))
bpy.ops.render.render(write_still=True)
print("picture", scene.render.filepath)

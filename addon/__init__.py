"""Dynamic Radiosity: diffuse global illumination baked into a colour attribute by a native engine."""

bl_info = {
    "name": "Dynamic Radiosity",
    "author": "Dynamic Radiosity team",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Radiosity; 3D View > Sidebar > Radiosity",
    "description": "Bakes diffuse global illumination (Cycles units) into the 'Radiosity' colour attribute",
    "category": "Lighting",
}

if "bpy" in locals():                       # F8 / reload: re-import the submodules
    import importlib
    for _m in ("errors", "engine", "settings", "writeback", "texture", "world", "export", "checks", "effects",
               "scene_diff", "preferences", "estimate", "job", "live_progress", "live_update", "bake_stats", "farm_cache", "farm",
               "texel_raster", "texel_filter", "texel_padding", "uv_charts", "lightmap", "display", "properties",
               "operators", "panels"):
        if _m in locals():
            importlib.reload(locals()[_m])

import bpy  # noqa: E402

from . import (errors, engine, settings, writeback, texture, world, export, checks, effects,  # noqa: E402,F401
               scene_diff, preferences, estimate, job, live_progress, live_update, bake_stats, farm_cache, farm, texel_raster,
               texel_filter, texel_padding, uv_charts, lightmap, display, properties, operators, panels)

# One list, registered in order and unregistered in reverse (like Blender's glTF add-on).
classes = (
    *preferences.classes,
    *properties.classes,
    *operators.classes,
    *live_progress.classes,
    *panels.classes,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    properties.register_props()
    live_update.register_handlers()
    live_progress.register_keymap()


def unregister():
    live_progress.unregister_keymap()
    live_update.unregister_handlers()
    properties.unregister_props()
    for c in reversed(classes):
        bpy.utils.unregister_class(c)


if __name__ == "__main__":
    register()

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
    # Each after the modules it imports, so that the names it takes from them are the new ones. The
    # two rings (export -> display -> lightmap -> export; live_update <-> live_progress) take whole
    # modules, which a reload updates in place, so any order within them is right.
    for _m in ("errors", "engine", "settings", "preferences", "writeback", "texture", "world", "checks", "effects",
               "uv_charts", "texel_raster", "texel_filter", "texel_padding", "shadow_reach", "export", "lightmap",
               "lightmap_updates", "lightmap_sequence", "lightmap_still", "display", "scene_diff", "estimate", "job",
               "live_update", "live_progress", "bake_stats", "farm_cache", "farm", "properties", "operators", "panels"):
        if _m in locals():
            importlib.reload(locals()[_m])

import bpy  # noqa: E402

from . import (errors, engine, settings, preferences, writeback, texture, world, checks, effects,  # noqa: E402,F401
               uv_charts, texel_raster, texel_filter, texel_padding, shadow_reach, export, lightmap,
               lightmap_updates, lightmap_sequence, lightmap_still, display, scene_diff, estimate, job,
               live_update, live_progress, bake_stats, farm_cache, farm, properties, operators, panels)

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

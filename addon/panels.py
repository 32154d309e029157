"""Render properties panel and 3D view sidebar panel (tab "Radiosity")."""
import bpy

from . import estimate, farm, live_update


def _human(n):
    n = float(n)
    for unit in ("", "k", "M", "G", "T"):
        if abs(n) < 1000:
            return f"{n:.0f}{unit}" if unit == "" else f"{n:.1f}{unit}"
        n /= 1000
    return f"{n:.1f}P"


def _seconds(s):
    if s < 60:
        return f"{s:.1f} s"
    if s < 3600:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"


def draw_main(layout, context):
    scene = context.scene
    props = scene.radiosity
    layout.use_property_split = True
    layout.use_property_decorate = False
    layout.prop(props, "preset")
    try:
        points, rays, secs = estimate.cost(props, scene)
        col = layout.column(align=True)
        col.label(text=f"Estimate: ~{_human(points)} vertices, ~{_human(rays)} rays", icon='INFO')
        col.label(text=f"Estimate: ~{_seconds(secs)} a frame (rough)")
    except Exception:   # noqa: BLE001 -- never break drawing
        pass
    col = layout.column(align=True)
    col.operator("radiosity.bake", icon='LIGHT')
    col.operator("radiosity.bake_animation", icon='RENDER_ANIMATION')
    col.operator("radiosity.clear", icon='X')
    layout.prop(props, "show_bake")
    if props.show_bake:
        layout.prop(props, "display_exposure")
    layout.prop(props, "live_update")
    layout.prop(props, "store_frames")
    layout.prop(props, "lightmaps")
    if props.lightmaps:
        col = layout.column(align=True)
        col.prop(props, "texel_density")
        col.prop(props, "lightmap_min_size")
        col.prop(props, "lightmap_max_size")
        col.operator("radiosity.save_lightmaps", icon='EXPORT')
    layout.prop(props, "farm_scheduler")
    running = farm.progress.get(scene.name)
    if running is not None:
        layout.label(text=f"Farm: {running[0]} of {running[1]} frames baked", icon='NETWORK_DRIVE')
    info = live_update.last_sync.get(scene.name)
    if props.live_update and info:
        layout.label(text=live_status(info), icon='TIME')


def live_status(info):
    """One line on the last live update."""
    mode = info.get("mode")
    if mode in ("incremental", "full"):
        text = f"Live: {mode} {info.get('seconds_total', 0.0) * 1000:.0f} ms"
        pts, touched = info.get("points") or 0, info.get("touched_points")
        if mode == "incremental" and pts and touched is not None:
            text += f", {100.0 * touched / pts:.0f}% of vertices touched"
        if info.get("restart"):
            text += f", solved afresh: {info['restart']}"
        elif info.get("budgeted"):
            text += f", playing at residual {100.0 * info['residual']:.1f}%"
        elif mode == "incremental":
            text += ", settled" if info.get("settled") else f", settling (residual {100.0 * info['residual']:.2f}%)"
        return text
    if mode == "unchanged":
        return "Live: up to date"
    return f"Live: {mode}" + (f" ({info['reason']})" if info.get("reason") else "")


def draw_settings(layout, context):
    props = context.scene.radiosity
    layout.use_property_split = True
    layout.use_property_decorate = False
    col = layout.column(align=True)
    col.prop(props, "samples_direct")
    col.prop(props, "samples_indirect")
    col = layout.column(align=True)
    col.prop(props, "patch_size_relative")
    col.prop(props, "threshold")
    col.prop(props, "auto_relaxation")
    row = col.row()
    row.active = not props.auto_relaxation
    row.prop(props, "relaxation")
    layout.prop(props, "exact_near_direct")
    row = layout.row()
    row.active = props.exact_near_direct
    row.prop(props, "exact_near_reflected")
    layout.prop(props, "db_cache_mb")
    layout.prop(props, "max_patches")


def draw_results(layout, context):
    props = context.scene.radiosity
    if not props.has_results:
        layout.label(text="No bake yet")
        return
    col = layout.column(align=True)
    frames = f" ({props.last_frames} frames)" if props.last_frames > 1 else ""
    col.label(text=f"Time: {_seconds(props.last_seconds)}{frames}")
    col.label(text=f"Residual: {props.last_residual:.2e}")
    col.label(text=f"Patches: {props.last_patches:,}   Vertices: {props.last_points:,}")
    col.label(text=f"Rays: {_human(props.last_rays)}   Shots: {props.last_shots:,}")
    col.label(text=f"Relaxation: {props.last_relaxation:.2f}")
    box = layout.box()
    box.label(text="Effects simulated:")
    for part in _wrap(props.last_effects, 36):
        box.label(text=part)
    if props.last_warnings:
        box = layout.box()
        for w in props.last_warnings.split("\n")[:6]:
            box.label(text=w, icon='ERROR')


def _wrap(text, width):
    lines, cur = [], ""
    for word in text.split(", "):
        nxt = f"{cur}, {word}" if cur else word
        if len(nxt) > width and cur:
            lines.append(cur + ",")
            cur = word
        else:
            cur = nxt
    if cur:
        lines.append(cur)
    return lines


class _Render:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"


class _Sidebar:
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Radiosity"


def _panels(place, name, closed):
    """The Radiosity panel and its Settings and Last Bake sub-panels for one place in the UI: the
    same three panels in Render properties and in the 3D view's sidebar."""
    main = f"RADIOSITY_PT_{name}"

    def panel(idname, label, draw, parent=None, options=()):
        attrs = {"bl_idname": idname, "bl_label": label, "bl_options": set(options),
                 "draw": lambda self, context: draw(self.layout, context)}
        if parent:
            attrs["bl_parent_id"] = parent
        return type(idname, (place, bpy.types.Panel), attrs)

    return (panel(main, "Radiosity", draw_main, options={'DEFAULT_CLOSED'} if closed else ()),
            panel(main + "_settings", "Settings", draw_settings, main, {'DEFAULT_CLOSED'}),
            panel(main + "_results", "Last Bake", draw_results, main))


classes = _panels(_Render, "render", closed=True) + _panels(_Sidebar, "sidebar", closed=False)

"""Render properties panel and 3D view sidebar panel (tab "Radiosity"), with sub-panels by purpose:
Settings, Live Update, Bake Animation, Output, Last Bake, Statistics.

Every text fits a default-width sidebar at the default UI scale (tests/addon/test_panel_fit.py):
long texts are wrapped to WRAP pixels, details go to tooltips and the Info log.
"""
import json

import blf
import bpy
from bpy.props import StringProperty

from . import effects, estimate, farm, live_update

WRAP = 140   # px of 11-point text: what a default-width sidebar leaves a label beside an icon


def human(n):
    """A count in three digits or fewer: 950, 7.2k, 3.1M."""
    n = float(n)
    for unit in ("", "k", "M", "G", "T"):
        if abs(n) < 1000:
            return f"{n:.0f}{unit}" if unit == "" or n >= 10 else f"{n:.1f}{unit}"
        n /= 1000
    return f"{n:.0f}P"


def seconds(s):
    """A duration as an artist reads it: milliseconds below one second, then seconds, minutes, hours."""
    if s < 1:
        return f"{s * 1000:.0f} ms"
    if s < 60:
        return f"{s:.1f} s" if s < 10 else f"{s:.0f} s"
    if s < 3600:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"


def time_range(low, high):
    """'0.2-0.5 s', '3-6 s', '40 s-2.1 min': one unit when both ends share it."""
    if high < 10:
        digits = 1 if low < 1 else 0
        return f"{low:.{digits}f}-{high:.{digits}f} s"
    a, b = seconds(low), seconds(high)
    if a.split()[-1] == b.split()[-1]:
        return a if a == b else f"{a.split()[0]}-{b}"
    return f"{a}-{b}"


def light_left(fraction):
    """The residual as a share of the light, in plain words."""
    pct = 100.0 * fraction
    return f"{pct:.2g}%" if pct >= 0.01 else "<0.01%"


def wrap(text, width=WRAP):
    """Lines of `text`, split at spaces, each at most `width` px wide in the UI font."""
    blf.size(0, 11)
    lines, cur = [], ""
    for word in text.split():
        nxt = f"{cur} {word}" if cur else word
        if cur and blf.dimensions(0, nxt)[0] > width:
            lines.append(cur)
            cur = word
        else:
            cur = nxt
    return lines + ([cur] if cur else [])


def _labels(layout, text, icon='NONE'):
    """`text` wrapped into labels, the icon on the first, the rest indented to match."""
    col = layout.column(align=True)
    for i, line in enumerate(wrap(text)):
        col.label(text=line, icon=icon if i == 0 else 'BLANK1' if icon != 'NONE' else 'NONE')


class RADIOSITY_MT_quality(bpy.types.Menu):
    """The Quality presets, each with the time it would take on this scene."""
    bl_idname = "RADIOSITY_MT_quality"
    bl_label = "Quality"

    def draw(self, context):
        props = context.scene.radiosity
        try:
            times = estimate.preset_times(context.scene)
        except Exception:   # noqa: BLE001 -- the menu without times rather than none (no engine)
            times = {}
        for item in props.bl_rna.properties["preset"].enum_items:
            low, high = times.get(item.identifier, (0.0, 0.0))
            text = f"{item.name}   {time_range(low, high)}" if high > 0 else item.name
            self.layout.prop_enum(props, "preset", item.identifier, text=text)


class RADIOSITY_OT_effect(bpy.types.Operator):
    """One line of Last Bake's lists: its tooltip, and a click, give the details"""
    bl_idname = "radiosity.effect"
    bl_label = "What the Bake Did"
    bl_options = {'INTERNAL'}

    detail: StringProperty(options={'SKIP_SAVE', 'HIDDEN'})

    @classmethod
    def description(cls, _context, properties):
        return properties.detail

    def execute(self, _context):
        self.report({'INFO'}, f"Radiosity: {self.detail}")
        return {'FINISHED'}


def draw_main(layout, context):
    scene = context.scene
    props = scene.radiosity
    split = layout.split(factor=0.4, align=True)
    split.alignment = 'RIGHT'
    split.label(text="Quality")
    split.menu(RADIOSITY_MT_quality.bl_idname, text=props.bl_rna.properties["preset"].enum_items[props.preset].name)
    try:
        points, _rays, (low, high) = estimate.cost(props, scene)
        if points:
            layout.label(text=f"~{human(points)} vertices · {time_range(low, high)}", icon='TIME')
    except Exception:   # noqa: BLE001 -- never break drawing
        pass
    col = layout.column(align=True)
    col.operator("radiosity.bake", icon='LIGHT')
    col.operator("radiosity.clear", icon='X')


def draw_settings(layout, context):
    props = context.scene.radiosity
    col = layout.column(align=True)
    col.prop(props, "samples_direct")
    col.prop(props, "samples_indirect")
    col = layout.column(align=True)
    col.prop(props, "patch_size_relative")
    col.prop(props, "threshold")
    col = layout.column(align=True)
    col.prop(props, "auto_relaxation")
    row = col.row()
    row.active = not props.auto_relaxation
    row.prop(props, "relaxation")
    col = layout.column(align=True)
    col.prop(props, "exact_near_direct")
    row = col.row()
    row.active = props.exact_near_direct
    row.prop(props, "exact_near_reflected")
    layout.prop(props, "max_patches")


def draw_live_header(layout, context):
    layout.prop(context.scene.radiosity, "live_update", text="")


def draw_live(layout, context):
    scene = context.scene
    props = scene.radiosity
    layout.active = props.live_update
    info = live_update.last_sync.get(scene.name)
    if info:
        for i, line in enumerate(live_status(info)):
            layout.label(text=line, icon='TIME' if i == 0 else 'BLANK1')
    layout.prop(props, "db_cache_mb")


def live_status(info):
    """Lines on the last live update: what it did and how long it took, then how far it got."""
    mode = info.get("mode")
    if mode in ("incremental", "full"):
        took = seconds(info.get("seconds_total", 0.0))
        lines = [f"Updated in {took}" if mode == "incremental" else f"Solved afresh in {took}"]
        pts, touched = info.get("points") or 0, info.get("touched_points")
        if mode == "incremental" and pts and touched is not None and touched < pts:
            lines.append(f"{100.0 * touched / pts:.0f}% of vertices changed")
        if info.get("restart"):
            lines += wrap(f"Solved afresh: {info['restart']}")
        elif mode == "full" and info.get("reason"):
            lines += wrap(info["reason"][:1].upper() + info["reason"][1:])
        if info.get("budgeted"):
            lines.append(f"Playing, {light_left(info.get('residual', 0.0))} light left")
        elif mode == "incremental":
            lines.append("Settled" if info.get("settled")
                         else f"Settling, {light_left(info.get('residual', 0.0))} left")
        return lines
    if mode == "unchanged":
        return ["Up to date"]
    head = "Update failed" if mode == "error" else "Not updated"
    return [head] + (wrap(str(info["reason"])) if info.get("reason") else [])


def draw_animation(layout, context):
    scene = context.scene
    props = scene.radiosity
    layout.operator("radiosity.bake_animation", icon='RENDER_ANIMATION')
    layout.prop(props, "store_frames")
    split = layout.split(factor=0.4, align=True)
    split.alignment = 'RIGHT'
    split.label(text=props.bl_rna.properties["farm_scheduler"].name)
    split.prop(props, "farm_scheduler", text="")
    running = farm.progress.get(scene.name)
    if running is not None:
        layout.label(text=f"Farm: {running[0]} of {running[1]} frames", icon='NETWORK_DRIVE')


def draw_output(layout, context):
    props = context.scene.radiosity
    layout.label(text="Colour attribute: Radiosity")
    col = layout.column(align=True)
    col.prop(props, "show_bake")
    if props.show_bake:
        col.prop(props, "display_exposure")
        if props.display_note:
            _labels(layout, props.display_note, icon='INFO')
    layout.prop(props, "lightmaps")
    if props.lightmaps:
        col = layout.column(align=True)
        col.prop(props, "texel_density")
        col.prop(props, "lightmap_min_size")
        col.prop(props, "lightmap_max_size")
        layout.operator("radiosity.save_lightmaps", icon='EXPORT')


def draw_results(layout, context):
    scene = context.scene
    props = scene.radiosity
    info = live_update.last_sync.get(scene.name)
    live = bool(info) and info.get("mode") in ("incremental", "full")
    if live:   # a live update since the bake: the light shown is its
        layout.label(text=f"Live update, {seconds(info.get('seconds_total', 0.0))}", icon='TIME')
        layout.label(text=f"Playing ({light_left(info.get('residual', 0.0))} light left)" if info.get("budgeted")
                     else status(info.get("converged", True), info.get("residual", 0.0)))
    if not props.has_results:
        if not live:
            layout.label(text="No bake yet")
        return
    col = layout.column(align=True)
    if not live:
        col.label(text=status(props.last_converged, props.last_residual))
    what = f"{props.last_frames} frames" if props.last_frames > 1 else f"{human(props.last_points)} vertices"
    col.label(text=f"Baked in {seconds(props.last_seconds)} · {what}")
    try:
        listed = json.loads(props.last_effect_items)
    except ValueError:
        listed = []
    for kind, title, icon in ((effects.SIMULATED, "Simulated", 'CHECKMARK'),
                              (effects.APPROXIMATED, "Approximated", 'DOT'), (effects.LEFT_OUT, "Left out", 'REMOVE')):
        part = [(row[1], effects.described(row)) for row in listed if row[0] == kind]
        if not part:
            continue
        col = layout.column(align=True)
        col.label(text=f"{title}:")
        for short, detail in part:
            row = col.row(align=True)
            row.alignment = 'LEFT'            # a button without emboss centres its text otherwise
            row.operator(RADIOSITY_OT_effect.bl_idname, text=short, icon=icon, emboss=False).detail = detail
    if props.last_warnings:
        box = layout.box()
        for w in props.last_warnings.split("\n")[:6]:
            _labels(box, w[:1].upper() + w[1:], icon='ERROR')


def status(converged, residual):
    """'Converged (0.1% light left)': the residual in plain words."""
    return f"{'Converged' if converged else 'Stopped early'} ({light_left(residual)} light left)"


def draw_statistics(layout, context):
    props = context.scene.radiosity
    if not props.has_results:
        layout.label(text="No bake yet")
        return
    col = layout.column(align=True)
    col.label(text=f"Light left: {props.last_residual:.2e}")
    col.label(text=f"Patches: {props.last_patches:,}")
    col.label(text=f"Vertices: {props.last_points:,}")
    col.label(text=f"Rays: {human(props.last_rays)}")
    col.label(text=f"Shots: {props.last_shots:,}")
    col.label(text=f"Speed-up: {props.last_relaxation:.2f}")
    col.label(text=f"Time: {props.last_seconds:.2f} s")


class _Render:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"


class _Sidebar:
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Radiosity"


def _panels(place, name, closed):
    """The Radiosity panel and its sub-panels for one place in the UI: the same panels in Render
    properties and in the 3D view's sidebar."""
    main = f"RADIOSITY_PT_{name}"

    def panel(suffix, label, draw, options=(), header=None):
        idname = main + suffix
        attrs = {"bl_idname": idname, "bl_label": label, "bl_options": set(options),
                 "draw": lambda self, context: draw(self.layout, context)}
        if suffix:
            attrs["bl_parent_id"] = main
        if header:
            attrs["draw_header"] = lambda self, context: header(self.layout, context)
        return type(idname, (place, bpy.types.Panel), attrs)

    return (panel("", "Radiosity", draw_main, {'DEFAULT_CLOSED'} if closed else ()),
            panel("_settings", "Settings", draw_settings, {'DEFAULT_CLOSED'}),
            panel("_live", "Live Update", draw_live, {'DEFAULT_CLOSED'}, header=draw_live_header),
            panel("_animation", "Bake Animation", draw_animation, {'DEFAULT_CLOSED'}),
            panel("_output", "Output", draw_output),
            panel("_results", "Last Bake", draw_results),
            panel("_statistics", "Statistics", draw_statistics, {'DEFAULT_CLOSED'}))


classes = ((RADIOSITY_MT_quality, RADIOSITY_OT_effect)
           + _panels(_Render, "render", closed=True) + _panels(_Sidebar, "sidebar", closed=False))

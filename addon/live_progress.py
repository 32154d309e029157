"""What the user sees of a live update running in the worker (live_update.play()): its progress in
the status bar once it has run longer than a moment, and Esc to stop it.

Esc is an item of the Window key map (radiosity.live_cancel), not a modal operator: the operator's
poll lets the key on to the rest of Blender unless a live update runs, and a modal tool that runs
(an object being dragged) sees Esc before any key map does, so the key is never taken from it. A
modal handler added while a tool runs would sit above the tool's and see its events first. While
the animation plays, Esc stops playback as always, and the progress is not shown (the updates
follow the frames).
"""
import bpy

from . import live_update

DELAY = 0.3       # seconds an update runs before its progress shows: shorter ones would only flicker
INTERVAL = 0.1    # seconds between refreshes of the status text

_shown = {"text": None}   # what the status bar shows from here (None: Blender's own)
_keymaps = []             # (key map, item) registered


def status(scene):
    """The status bar's text for the live update of `scene` running in the worker, or None."""
    p = live_update.progress(scene)
    if p is None or p["seconds"] < DELAY or live_update.playing():
        return None
    if p["cancelling"]:
        return f"Radiosity: stopping the live update of frame {p['frame']}"
    what = "settling" if p["settle"] else "live update of"
    # Nothing is reported before the first shot (the change's gathers, the bulk of a move's cost).
    shooting = f"{100 * p['fraction']:.0f}%, residual {p['residual']:.2e}, " if p["fraction"] > 0 else ""
    return f"Radiosity: {what} frame {p['frame']}: {shooting}{p['seconds']:.1f} s  (Esc to cancel)"


def _set_text(text):
    wm = bpy.context.window_manager
    for window in wm.windows if wm is not None else ():
        if window.workspace is not None:
            with bpy.context.temp_override(window=window):
                window.workspace.status_text_set(text)
    _shown["text"] = text


def follow_timer():
    """Timer: the status text while an update runs; Blender's own again once none does."""
    scene = bpy.context.scene
    text = status(scene) if scene is not None else None
    if text != _shown["text"]:
        _set_text(text)
    return INTERVAL if scene is not None and live_update.running(scene) is not None else None


def follow():
    """Show the progress of the update live_update.play() has started (an interactive Blender)."""
    if not bpy.app.timers.is_registered(follow_timer):
        bpy.app.timers.register(follow_timer, first_interval=DELAY)


class RADIOSITY_OT_live_cancel(bpy.types.Operator):
    """Stop the running live update: the colours stay the last complete update's"""
    bl_idname = "radiosity.live_cancel"
    bl_label = "Cancel Live Update"

    @classmethod
    def poll(cls, context):
        scene = context.scene
        return scene is not None and not live_update.playing() and live_update.running(scene) is not None

    def execute(self, context):
        live_update.cancel(context.scene)
        self.report({'INFO'}, "Radiosity: live update cancelled; the colours stay the last complete update's")
        return {'FINISHED'}


def register_keymap():
    kc = bpy.context.window_manager.keyconfigs.addon
    if kc is None:                        # background mode: no key maps
        return
    km = kc.keymaps.new(name="Window", space_type='EMPTY', region_type='WINDOW')
    _keymaps.append((km, km.keymap_items.new(RADIOSITY_OT_live_cancel.bl_idname, 'ESC', 'PRESS')))


def unregister_keymap():
    for km, kmi in _keymaps:
        km.keymap_items.remove(kmi)
    _keymaps.clear()
    if _shown["text"] is not None:
        _set_text(None)


classes = (RADIOSITY_OT_live_cancel,)

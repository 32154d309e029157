"""The add-on's preferences: how fast this machine bakes, learnt from its own bakes (estimate.record),
kept with Blender's preferences so that the panel's estimate knows the machine from the first draw."""
from types import SimpleNamespace

import bpy
from bpy.props import FloatProperty, StringProperty

# The sample scenes' bakes on a 2-core machine trace 19-32 M rays/s; each vertex costs about 50 us of
# refinement, direct light and write-back besides its rays. A machine starts from these.
SECONDS_PER_POINT = 5.0e-5
SECONDS_PER_RAY = 4.3e-8


class RADIOSITY_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    seconds_per_point: FloatProperty(
        name="Time per Vertex", default=SECONDS_PER_POINT, min=0.0, precision=8,
        description="What a vertex costs a bake on this computer besides its rays, in seconds: learnt "
                    "from its last bakes")
    seconds_per_ray: FloatProperty(
        name="Time per Ray", default=SECONDS_PER_RAY, min=0.0, precision=12,
        description="What a ray costs a bake on this computer, in seconds: learnt from its last bakes")
    ratios: StringProperty(
        name="Last Bakes", default="",
        description="Each of the last bakes' time over what the starting rates give for its vertices "
                    "and rays; their median scales the rates")

    def draw(self, _context):
        col = self.layout.column(align=True)
        n = len(self.ratios.split())
        col.label(text=f"Estimates learnt from {n} bake{'s' if n != 1 else ''} on this computer:")
        col.label(text=f"{self.seconds_per_ray * 1e9:.1f} ns a ray, {self.seconds_per_point * 1e6:.0f} us a vertex")


# The add-on loaded without being enabled (tests, benches, a script that imports it) has no entry in
# the preferences: it learns in memory only.
_unsaved = SimpleNamespace(seconds_per_point=SECONDS_PER_POINT, seconds_per_ray=SECONDS_PER_RAY, ratios="")


def machine():
    """This machine's rates: the add-on's preferences, or the in-memory stand-in."""
    addon = bpy.context.preferences.addons.get(__package__)
    prefs = getattr(addon, "preferences", None) if addon is not None else None
    return prefs if prefs is not None else _unsaved


classes = (RADIOSITY_AP_preferences,)

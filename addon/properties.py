"""scene.radiosity: quality preset, the knobs behind it, live_update, and the last bake's results."""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from . import display
from .settings import preset_values


def _fill(self, _context):
    for k, v in preset_values(self.preset).items():
        setattr(self, k, v)


class RADIOSITY_PG_settings(bpy.types.PropertyGroup):
    # Names are short enough for a default-width sidebar (tests/addon/test_panel_fit.py); what each
    # knob means to the engine is in docs/settings.md.
    preset: EnumProperty(
        name="Quality",
        items=[('DRAFT', "Draft", "A quick preview while you set up lights and materials"),
               ('DEFAULT', "Default", "Good everyday quality in seconds on small scenes"),
               ('HIGH', "High", "Closest to Cycles: for the final bake"),
               ('REFERENCE', "Reference", "Very slow: for comparisons, not for use")],
        default='DEFAULT', update=_fill,
        description="How fine and how long the bake is; choosing one fills the Settings")
    samples_direct: IntProperty(
        name="Light Samples", default=64, min=1, soft_max=4096,
        description="Rays each patch sends toward every lamp and glowing surface. More: smoother soft "
                    "shadows, longer bakes")
    samples_indirect: IntProperty(
        name="Bounce Samples", default=16, min=1, soft_max=1024,
        description="Rays each patch sends for light bounced off other surfaces. More: less blotchy "
                    "bounce light, longer bakes")
    patch_size_relative: FloatProperty(
        name="Patch Size", default=1 / 32, min=1e-4, max=1.0, precision=4, step=0.1,
        description="Size of the patches the light is worked out on, as a share of the scene's size. "
                    "Smaller: sharper shadows and more detail, longer bakes")
    threshold: FloatProperty(
        name="Light Left", default=1e-3, min=1e-8, max=1.0, precision=5, step=0.01,
        description="The bake stops when this share of the light is still to bounce. Smaller: darker "
                    "corners come out right, longer bakes")
    auto_relaxation: BoolProperty(
        name="Auto Speed-Up", default=True,
        description="Pick the speed-up from how much light the first bounces bring back: more in a "
                    "closed bright room, none in an open scene")
    relaxation: FloatProperty(
        name="Speed-Up", default=1.3, min=1.0, max=1.95, precision=2,
        description="Bounce a little more light each time than is there, so that bright rooms finish "
                    "sooner (1: none). The result is the same")
    exact_near_direct: BoolProperty(
        name="Exact Contact Light", default=True,
        description="Work out the direct light exactly where objects touch (a box's foot, where its "
                    "shadow starts) instead of blending it across a patch. Off at Draft: it costs time "
                    "on every live update")
    exact_near_reflected: BoolProperty(
        name="Exact Contact Bounce", default=False,
        description="With Exact Contact Light, the bounced light too: feet of objects and room corners "
                    "come closer to Cycles, for up to a bake's time again in busy scenes (on at High "
                    "and Reference)")
    db_cache_mb: FloatProperty(
        name="Move Memory (MB)", default=256.0, min=0.0, soft_max=4096.0, precision=0,
        description="Memory Live Update keeps of what a moving object changed, so that moving it back "
                    "or on is quicker; the result is the same. 0: none. Presets leave it as it is")
    max_patches: IntProperty(
        name="Patch Limit", default=2000000, min=1000, soft_max=20000000,
        description="A scene that would need more patches is refused before baking, with the object "
                    "that needs the most named (about 2.3 KB of memory a patch). Presets leave it as it is")
    live_update: BoolProperty(
        name="Live Update", default=False,
        description="Update the lighting as you edit and when the frame changes: only what changed is "
                    "worked out again (frames baked by Bake Animation show their own light)")
    store_frames: BoolProperty(
        name="Keep Frames in File", default=True,
        description="Save the frames Bake Animation bakes in the .blend, so that the animation renders "
                    "with its light after reopening the file")
    farm_scheduler: StringProperty(
        name="Farm", default="",
        description="Address of a render farm's Dask scheduler (tcp://host:8786): its machines bake "
                    "Bake Animation's frames from the saved .blend (docs/farm.md). Empty: this computer "
                    "alone")
    lightmaps: BoolProperty(
        name="Lightmaps", default=False, update=display.on_lightmaps,
        description="Bake also an image '<object>_Radiosity' per lit mesh, in the UV map 'RadiosityUV' "
                    "(made if missing): shadows finer than the patches, packed into the .blend")
    texel_density: FloatProperty(
        name="Texels per Metre", default=32.0, min=0.01, soft_max=1024.0, precision=1,
        description="Sharpness of a new lightmap: texels per metre of surface (an existing image "
                    "keeps its size)")
    lightmap_min_size: IntProperty(
        name="Minimum Size", default=64, min=4, max=16384,
        description="Smallest side of a new lightmap, in texels")
    lightmap_max_size: IntProperty(
        name="Maximum Size", default=2048, min=4, max=16384,
        description="Largest side of a new lightmap, in texels")

    # results of the last bake (written by the operators)
    last_seconds: FloatProperty(name="Time", default=0.0, precision=2, unit='TIME_ABSOLUTE')
    last_residual: FloatProperty(name="Light Left", default=0.0, precision=6)
    last_patches: IntProperty(name="Patches", default=0)
    last_points: IntProperty(name="Vertices", default=0)
    last_rays: FloatProperty(name="Rays", default=0.0, precision=0)   # may exceed 2^31
    last_shots: IntProperty(name="Shots", default=0)
    last_relaxation: FloatProperty(name="Speed-Up", default=0.0, precision=2)  # what the solve chose
    last_effects: StringProperty(name="Effects", default="")          # effects.sentence, as reported
    last_effect_items: StringProperty(name="Effect List", default="[]")  # effects.items as JSON
    last_converged: BoolProperty(name="Converged", default=True)
    last_frames: IntProperty(name="Frames", default=0)
    last_warnings: StringProperty(name="Warnings", default="")
    has_results: BoolProperty(default=False)
    # this scene's points and rays over what its bounds gave, and its time over what the starting
    # rates give for them, at its last bake (estimate.record); 0: not baked here
    estimate_points_scale: FloatProperty(default=0.0)
    estimate_rays_scale: FloatProperty(default=0.0)
    estimate_seconds_scale: FloatProperty(default=0.0)

    show_bake: BoolProperty(
        name="Show Bake", default=False, update=display.on_toggle,
        description="Show the baked light in the viewport and in renders: the lit meshes' materials "
                    "glow with it (their lightmaps, with Lightmaps on) in place of their surface "
                    "(turned off, they are as they were)")
    display_exposure: FloatProperty(
        name="Exposure", default=0.0, soft_min=-10.0, soft_max=10.0, precision=2, update=display.on_exposure,
        description="Brightness of the shown bake, in stops")
    display_offered: BoolProperty(default=False)   # the first bake turns Show Bake on, later ones do not
    display_note: StringProperty(default="")   # display.note: materials that show the attribute in place of a lightmap


classes = (RADIOSITY_PG_settings,)


def register_props():
    bpy.types.Scene.radiosity = PointerProperty(type=RADIOSITY_PG_settings)


def unregister_props():
    del bpy.types.Scene.radiosity

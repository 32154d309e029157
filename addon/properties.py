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
    preset: EnumProperty(
        name="Quality",
        items=[('DRAFT', "Draft", "Fast preview: coarse patches, few samples"),
               ('DEFAULT', "Default", "Balanced quality and time"),
               ('HIGH', "High", "Fine patches, many samples"),
               ('REFERENCE', "Reference", "Very slow; for comparisons")],
        default='DEFAULT', update=_fill,
        description="Quality preset; choosing one fills the settings below")
    samples_direct: IntProperty(
        name="Direct Samples", default=64, min=1, soft_max=4096,
        description="Visibility rays per patch for light from lamps and emitters")
    samples_indirect: IntProperty(
        name="Indirect Samples", default=16, min=1, soft_max=1024,
        description="Visibility rays per patch for each shot of reflected light")
    patch_size_relative: FloatProperty(
        name="Patch Size", default=1 / 32, min=1e-4, max=1.0, precision=4, step=0.1,
        description="Patch size as a fraction of the scene's diagonal (smaller = finer shadows)")
    threshold: FloatProperty(
        name="Threshold", default=1e-3, min=1e-8, max=1.0, precision=5, step=0.01,
        description="Stop when the unshot light falls below this fraction of the emitted light")
    auto_relaxation: BoolProperty(
        name="Automatic Relaxation", default=True,
        description="Over-relax reflected light shots by what the first shots see come back: more "
                    "in a closed bright room, none in an open scene (faster than any one fixed value)")
    relaxation: FloatProperty(
        name="Relaxation", default=1.3, min=1.0, max=1.95, precision=2,
        description="Over-relaxation of reflected light shots when not automatic (1 = plain "
                    "progressive refinement)")
    exact_near_direct: BoolProperty(
        name="Exact Contact Light", default=True,
        description="Each corner evaluates the direct light of the surfaces right beside it where it "
                    "lands instead of interpolating it: right at the foot of an object, where its "
                    "shadow edge starts (off at Draft: it costs time on every update)")
    exact_near_reflected: BoolProperty(
        name="Exact Reflected Contact Light", default=False,
        description="With Exact Contact Light, the reflected light of those surfaces too: a box's foot on "
                    "a floor and a room's corners come closer to Cycles, for about 30 ms a corner beside "
                    "surfaces whose light varies (on at High and Reference; worked out anew after every update)")
    db_cache_mb: FloatProperty(
        name="dB Cache (MB)", default=256.0, min=0.0, soft_max=4096.0, precision=0,
        description="Memory an update may keep of what the scene around a moving object does to the "
                    "rays its moves change, so that moving it back or on traces them no more; past "
                    "it they are traced again (same result). 0: no cache. Presets leave it as it is")
    max_patches: IntProperty(
        name="Patch Limit", default=2000000, min=1000, soft_max=20000000,
        description="A scene that would refine to more patches is refused with a message (naming the "
                    "object that makes the most) before anything is refined: a solve holds about "
                    "2.3 KB a patch. Presets leave it as it is")
    live_update: BoolProperty(
        name="Live Update", default=False,
        description="Update the lighting on frame change and while editing: only what changed is "
                    "re-shot on the engine's solver kept in memory (frames baked by Bake Animation "
                    "show their baked lighting)")
    store_frames: BoolProperty(
        name="Keep Frames in File", default=True,
        description="Save the frames of Bake Animation in the .blend, so that the animation renders "
                    "with its lighting after reopening (e.g. blender -b file.blend -a)")
    farm_scheduler: StringProperty(
        name="Farm Scheduler", default="",
        description="Address of a Dask scheduler (tcp://host:8786) whose workers bake Bake Animation's "
                    "frames in chunks, on the saved .blend, into a cache folder beside it (docs/farm.md). "
                    "Empty: this machine alone")
    lightmaps: BoolProperty(
        name="Lightmaps", default=False,
        description="Bake also writes an image '<object>_Radiosity' per lit mesh, in its UV map "
                    "'RadiosityUV' (made with Lightmap Pack if missing): each texel the light at its own "
                    "surface point, with shadows finer than the patches (packed into the .blend)")
    texel_density: FloatProperty(
        name="Texel Density", default=32.0, min=0.01, soft_max=1024.0, precision=1,
        description="Texels per metre of a new lightmap's side, across the square root of the mesh's "
                    "area (an existing image is written at its own size)")
    lightmap_min_size: IntProperty(
        name="Minimum Size", default=64, min=4, max=16384,
        description="Smallest side of a new lightmap, in texels")
    lightmap_max_size: IntProperty(
        name="Maximum Size", default=2048, min=4, max=16384,
        description="Largest side of a new lightmap, in texels")

    # results of the last bake (written by the operators)
    last_seconds: FloatProperty(name="Time", default=0.0, precision=2, unit='TIME_ABSOLUTE')
    last_residual: FloatProperty(name="Residual", default=0.0, precision=6)
    last_patches: IntProperty(name="Patches", default=0)
    last_points: IntProperty(name="Vertices", default=0)
    last_rays: FloatProperty(name="Rays", default=0.0, precision=0)   # may exceed 2^31
    last_shots: IntProperty(name="Shots", default=0)
    last_relaxation: FloatProperty(name="Relaxation", default=0.0, precision=2)  # what the solve chose
    last_effects: StringProperty(name="Effects", default="")
    last_frames: IntProperty(name="Frames", default=0)
    last_warnings: StringProperty(name="Warnings", default="")
    has_results: BoolProperty(default=False)

    show_bake: BoolProperty(
        name="Show Bake", default=False, update=display.on_toggle,
        description="Show the baked light in the viewport and in renders: the lit meshes' materials "
                    "emit it in place of their surface (turned off, they are as they were)")
    display_exposure: FloatProperty(
        name="Exposure", default=0.0, soft_min=-10.0, soft_max=10.0, precision=2, update=display.on_exposure,
        description="Brightness of the shown bake, in stops")
    display_offered: BoolProperty(default=False)   # the first bake turns Show Bake on, later ones do not


classes = (RADIOSITY_PG_settings,)


def register_props():
    bpy.types.Scene.radiosity = PointerProperty(type=RADIOSITY_PG_settings)


def unregister_props():
    del bpy.types.Scene.radiosity

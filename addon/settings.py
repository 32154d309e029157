"""scene.radiosity's knobs and the engine's Settings, each way: the engine's presets fill the knobs,
the knobs make the Settings of a solve."""
from .engine import load_engine

KNOBS = ("samples_direct", "samples_indirect", "patch_size_relative", "threshold", "relaxation", "exact_near_direct",
         "exact_near_reflected")


def preset_values(name):
    """Knob values of a preset: the engine's Settings are their one source (its relaxation 0 is
    the Auto Speed-Up box)."""
    s = load_engine().Settings.preset(name.lower())
    values = {k: getattr(s, k) for k in KNOBS if k != "relaxation"}
    values["auto_relaxation"] = s.relaxation == 0
    if s.relaxation:
        values["relaxation"] = s.relaxation
    return values


def engine_settings(props, engine=None):
    """engine.Settings from scene.radiosity: the preset's values, overridden by the knobs. The
    preset's refinement driven by the light (light_refinement, light_contrast) has no knob: it
    comes as the preset sets it."""
    engine = engine or load_engine()
    s = engine.Settings.preset(props.preset.lower())
    s.samples_direct = int(props.samples_direct)
    s.samples_indirect = int(props.samples_indirect)
    s.patch_size_relative = float(props.patch_size_relative)
    s.threshold = float(props.threshold)
    s.relaxation = 0.0 if props.auto_relaxation else float(props.relaxation)   # the engine's 0: automatic
    s.exact_near_direct = bool(props.exact_near_direct)
    s.exact_near_reflected = bool(props.exact_near_reflected)
    s.db_cache_mb = float(props.db_cache_mb)
    s.max_patches = int(props.max_patches)
    return s


def settings_key(settings):
    """What must match for an engine Solver to be reused (the dB cache's cap and the patch limit are
    fixed in it too)."""
    return tuple(getattr(settings, k) for k in KNOBS + ("light_refinement", "light_contrast", "db_cache_mb",
                                                         "max_patches"))

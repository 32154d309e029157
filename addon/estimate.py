"""The panel's estimate of what a quality costs on the scene: vertices and rays from the object bounds,
seconds from this machine's rates (preferences.machine), learnt from its last bakes.

    points  ~ POINTS_PER_PATCH_AREA * surface area / patch_size^2
    rays    ~ points * (samples_indirect + SAMPLES_FLOOR) * ln(1 / threshold) * RAYS_FACTOR: reflected
              shots, which go on until the threshold, trace most rays (dim shots sample distant
              receivers less, but not below a floor: Solver::Impl::far_samples)
    seconds ~ seconds_per_point * points + seconds_per_ray * rays

A bake of the scene corrects the first two for it (its points and rays over what the bounds gave:
props.estimate_points_scale, props.estimate_rays_scale) and the rates (its time over what they give:
props.estimate_seconds_scale), and every bake on the machine tells it the rates. What the estimate
is worth against actual bakes: bench/estimate.py.
"""
import functools
import math

import numpy as np

from . import export as exporter
from . import preferences
from .settings import preset_values

# Fitted to the sample scenes' bakes at draft, default and high: per point and e-fold of the threshold
# they trace 29-112 rays (a scene's own figure holds within 15% across presets) per indirect sample
# and 1.5 more; RAYS_FACTOR is their geometric middle, for a scene not yet baked.
POINTS_PER_PATCH_AREA = 3.0
SAMPLES_FLOOR = 1.5
RAYS_FACTOR = 70.0
KEEP = 9                      # bakes the rates are the median of: one slow bake moves them little
SPREAD = 1.4                  # the range shown: estimate / SPREAD .. estimate * SPREAD, when the scene
UNSEEN = 1.5                  # has been baked on this machine; wider by UNSEEN when either is new


def scene_measure(scene):
    """(approximate total surface area, scene diagonal, light count) from object bounding boxes:
    cheap enough for a panel's draw(), which runs at every redraw, because every object's values
    come at once through foreach_get."""
    obs = scene.objects
    n = len(obs)
    kinds = np.array([ob.type for ob in obs], dtype="U16")
    hidden = np.zeros(n, bool)
    obs.foreach_get("hide_render", hidden)
    lights = int(np.count_nonzero((kinds == 'LIGHT') & ~hidden))
    solid = np.isin(kinds, exporter.GEOMETRY) & ~hidden
    if not solid.any():
        return 0.0, 0.0, lights
    def each(name, size):
        out = np.empty(n * size, np.float32)
        obs.foreach_get(name, out)
        return out.reshape(n, -1)[solid].astype(np.float64)
    M = each("matrix_world", 16).reshape(-1, 4, 4).transpose(0, 2, 1)   # stored by columns
    bb = np.einsum("oij,okj->oki", M[:, :3, :3], each("bound_box", 24).reshape(-1, 8, 3)) + M[:, None, :3, 3]
    diag = float(np.linalg.norm(bb.max((0, 1)) - bb.min((0, 1))))
    d = np.abs(each("dimensions", 3))
    boxes = 2.0 * (d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 0] * d[:, 2])
    area = float(np.where(d.min(1) > 1e-9, boxes, d.max(1) ** 2).sum())
    return area, diag, lights


def model_counts(scene, patch_size_relative, samples_indirect, threshold):
    """(points, rays) the bounds give for these knobs, before the scene's own correction."""
    area, diag, _lights = scene_measure(scene)
    if diag <= 0 or patch_size_relative <= 0:
        return 0.0, 0.0
    patch = patch_size_relative * diag
    points = POINTS_PER_PATCH_AREA * area / (patch * patch)
    return points, points * (samples_indirect + SAMPLES_FLOOR) * math.log(1.0 / min(threshold, 0.5)) * RAYS_FACTOR


def _ratios(rates):
    return [float(r) for r in rates.ratios.split()]


def _seconds(props, points, rays):
    """(low, high) seconds for these counts on this machine. A scene baked here before also brings
    its own time against the rates (its rays may cost more than most, the machine may be busier now):
    half-way between the two, in ratio, so that a one-off slow bake counts half."""
    rates = preferences.machine()
    mid = rates.seconds_per_point * points + rates.seconds_per_ray * rays
    if props.estimate_seconds_scale > 0 and rates.seconds_per_ray > 0:
        mid *= math.sqrt(props.estimate_seconds_scale * preferences.SECONDS_PER_RAY / rates.seconds_per_ray)
    spread = SPREAD * (1.0 if props.estimate_points_scale > 0 else UNSEEN) \
        * (1.0 if len(_ratios(rates)) >= 3 else UNSEEN)
    return mid / spread, mid * spread


def _corrected(props, points, rays):
    if props.estimate_points_scale > 0:
        return points * props.estimate_points_scale, rays * props.estimate_rays_scale
    return points, rays


def cost(props, scene):
    """(points, rays, (low, high) seconds): what the knobs of `props` cost on this scene."""
    points, rays = _corrected(props, *model_counts(scene, props.patch_size_relative, props.samples_indirect,
                                                    props.threshold))
    return int(points), int(rays), _seconds(props, points, rays)


@functools.lru_cache(maxsize=None)
def _preset(name):
    return preset_values(name)


def preset_times(scene):
    """{preset identifier: (low, high) seconds} on this scene, for the Quality menu."""
    props = scene.radiosity
    out = {}
    for item in props.bl_rna.properties["preset"].enum_items:
        k = _preset(item.identifier)
        points, rays = _corrected(props, *model_counts(scene, k["patch_size_relative"], k["samples_indirect"],
                                                       k["threshold"]))
        out[item.identifier] = _seconds(props, points, rays)
    return out


def record(scene, stats):
    """Learn from a finished single-frame bake (bake_stats `stats`, made with scene.radiosity's knobs):
    the scene's counts against the bounds' model, the machine's rates against its time."""
    props = scene.radiosity
    points, rays, secs = float(stats["points"]), float(stats["rays"]), float(stats["seconds"])
    model_points, model_rays = model_counts(scene, props.patch_size_relative, props.samples_indirect, props.threshold)
    if min(points, rays, secs, model_points, model_rays) <= 0:
        return
    props.estimate_points_scale = points / model_points
    props.estimate_rays_scale = rays / model_rays
    rates = preferences.machine()
    base = preferences.SECONDS_PER_POINT * points + preferences.SECONDS_PER_RAY * rays
    props.estimate_seconds_scale = secs / base
    ratios = (_ratios(rates) + [secs / base])[-KEEP:]
    k = float(np.median(ratios))
    rates.seconds_per_point = preferences.SECONDS_PER_POINT * k
    rates.seconds_per_ray = preferences.SECONDS_PER_RAY * k
    rates.ratios = " ".join(f"{r:.4g}" for r in ratios)

"""The panel's rough estimate of what the chosen quality costs on the scene, from object bounding boxes."""
import math

import numpy as np

from . import export as exporter

# A rough model, fitted to bakes of the sample scenes at draft, default and high on 2 cores: its
# points, rays and seconds land within 0.66-2.2x of theirs (over for the Cornell box, under for the
# animated room).
#   points  ~ POINTS_PER_PATCH_AREA * surface area / patch_size^2
#   rays    ~ points * samples_indirect * ln(1 / threshold) * RAYS_FACTOR: reflected shots, which go on
#             until the threshold, trace most rays (dim shots sample distant receivers less,
#             Solver::Impl::far_samples)
#   seconds ~ SECONDS_PER_POINT * points + SECONDS_PER_RAY * rays
POINTS_PER_PATCH_AREA = 3.0
RAYS_FACTOR = 80.0            # the bakes trace 50-90 rays a point per indirect sample and e-fold
SECONDS_PER_POINT = 5.0e-5
SECONDS_PER_RAY = 4.3e-8      # they trace 19-32 M rays/s


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


def cost(props, scene):
    """(points, rays, seconds): a rough estimate of what the chosen quality costs on this scene."""
    area, diag, lights = scene_measure(scene)
    if diag <= 0 or props.patch_size_relative <= 0:
        return 0, 0, 0.0
    patch = props.patch_size_relative * diag
    points = POINTS_PER_PATCH_AREA * area / (patch * patch)
    rays = points * props.samples_indirect * math.log(1.0 / min(props.threshold, 0.5)) * RAYS_FACTOR
    return int(points), int(rays), SECONDS_PER_POINT * points + SECONDS_PER_RAY * rays

"""A texel's light over its footprint, as Cycles' image bake takes it.

Cycles does not take a texel's light at its centre alone: every sample but the first moves the point
uniformly within the middle half of the texel (its barycentric coordinates by the differentials
Blender hands it, half a texel's, times an offset in [-1/2, 1/2] along x and along y), mirrored
back into the triangle where it leaves it. A texel on a shadow edge or at an object's foot so holds
a blend of both sides. Where the light is
smooth, the centre's value is that mean to a fraction of a percent; so only texels whose
neighbours' light differs are averaged, over a grid of offsets.
"""
import numpy as np

# Texels averaged where the light bends across them by more than this part of the brightest of
# the three (a second difference along a row, column or diagonal): a shadow edge or an object's
# foot. The mean of a light linear across the footprint is its centre's value; a bend of CONTRAST
# moves the mean by about CONTRAST / 100 (the footprint's variance, a 48th of a texel squared, per
# axis), so a lamp's falloff across a texel is left at its centre.
CONTRAST = 0.02
SAMPLES = 8   # offsets per axis: a step across the footprint lands within 1 / (2 SAMPLES) of its mean
FOOTPRINT = 0.5  # the side of the square the samples cover, in texels


def offsets(samples=SAMPLES):
    """(samples^2, 2) offsets in texels, a grid over the footprint whose mean of any light is the
    footprint's mean to the grid's resolution."""
    axis = ((np.arange(samples) + 0.5) / samples - 0.5) * FOOTPRINT
    return np.stack(np.meshgrid(axis, axis, indexing="xy"), axis=-1).reshape(-1, 2)


def edges(rgb, covered):
    """(H, W) bool: covered texels where the light (channel sum) bends by more than CONTRAST of the
    brightest of the three along some line of three covered texels centred on them."""
    h, w = covered.shape
    light = np.pad(np.where(covered, rgb.sum(axis=2), 0.0), 1)
    inside = np.pad(covered, 1)
    centre = light[1:h + 1, 1:w + 1]
    out = np.zeros((h, w), bool)
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = light[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        b = light[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        both = inside[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] & inside[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        top = np.maximum(np.maximum(a, b), centre)
        out |= both & (top > 0) & (np.abs(a + b - 2 * centre) > CONTRAST * top)
    return covered & out


def barycentric_steps(px):
    """(T, 2, 3): how each triangle's barycentric coordinates change per texel along x and y;
    px (T, 3, 2) its corners in texel units. Zero for a triangle of no area in UV."""
    e1, e2 = px[:, 1] - px[:, 0], px[:, 2] - px[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    safe = np.where(det != 0, det, 1.0)
    # (w1, w2) = M^-1 (p - p0) with M = [e1 e2]: their steps along x and y are M^-1's columns.
    inv = np.stack([np.stack([e2[:, 1], -e1[:, 1]], 1), np.stack([-e2[:, 0], e1[:, 0]], 1)], 1) / safe[:, None, None]
    inv[det == 0] = 0.0
    steps = np.zeros((len(px), 2, 3))
    steps[:, :, 1:] = inv
    steps[:, :, 0] = -inv.sum(axis=2)
    return steps


def _mirror(x, top):
    """x reflected into [0, top] at its ends, over and over (OpenGL's mirrored repeat)."""
    top = np.maximum(top, 1e-12)
    n = np.floor(x / top)
    x = x - n * top
    return np.where(n.astype(np.int64) % 2 == 1, top - x, x)


def into_triangle(bary):
    """(..., 3) barycentric coordinates mirrored back into their triangle, the first in [0, 1],
    the second in [0, 1 - first], as Cycles' bake mirrors its samples."""
    u = _mirror(bary[..., 0], 1.0)
    v = _mirror(bary[..., 1], 1.0 - u)
    return np.stack([u, v, 1.0 - u - v], axis=-1)


def footprint(bary, steps):
    """(n, S, 3): each texel's (bary (n, 3), its triangle's steps (n, 2, 3)) sample points."""
    o = offsets()
    moved = bary[:, None, :] + o[None, :, :1] * steps[:, None, 0] + o[None, :, 1:] * steps[:, None, 1]
    return into_triangle(moved)

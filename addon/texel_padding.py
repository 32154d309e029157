"""Padding: texels outside a lightmap's charts take their light from the covered texels near them,
so that filtering and mipmaps, which mix texels across a chart's border, do not mix in black."""
import numpy as np

# Rings grown one texel at a time, each texel the mean of its covered neighbours: what bilinear
# filtering and the first mip levels read beside a chart. Farther texels come from the coarser
# levels of a pull-push pyramid, which reaches any distance in log2(size) steps.
RINGS = 8

_NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def _grow_ring(rgb, covered):
    """One ring: each uncovered texel with a covered neighbour (of 8) becomes their mean."""
    h, w = covered.shape
    total = np.zeros_like(rgb)
    count = np.zeros(covered.shape, np.int32)
    padded_rgb = np.pad(rgb, ((1, 1), (1, 1), (0, 0)))
    padded_cov = np.pad(covered, 1)
    for dy, dx in _NEIGHBOURS:
        c = padded_cov[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        total += np.where(c[..., None], padded_rgb[1 + dy:1 + dy + h, 1 + dx:1 + dx + w], 0.0)
        count += c
    ring = ~covered & (count > 0)
    rgb[ring] = total[ring] / count[ring][:, None]
    covered |= ring
    return ring.any()


def _pull_push(rgb, covered):
    """Fills every uncovered texel from the coverage-weighted means of ever coarser 2x2 blocks."""
    h, w = covered.shape
    if covered.all() or not covered.any() or (h == 1 and w == 1):
        return
    H, W = h + h % 2, w + w % 2
    weight = np.zeros((H, W), np.float64)
    weight[:h, :w] = covered
    value = np.zeros((H, W, rgb.shape[2]), np.float64)
    value[:h, :w] = rgb * covered[..., None]
    block_weight = weight.reshape(H // 2, 2, W // 2, 2).sum(axis=(1, 3))
    block_value = value.reshape(H // 2, 2, W // 2, 2, -1).sum(axis=(1, 3))
    coarse_covered = block_weight > 0
    coarse = np.zeros_like(block_value)
    coarse[coarse_covered] = block_value[coarse_covered] / block_weight[coarse_covered][:, None]
    _pull_push(coarse, coarse_covered)
    up = np.repeat(np.repeat(coarse, 2, axis=0), 2, axis=1)[:h, :w]
    rgb[~covered] = up[~covered]


def pad(rgb, covered):
    """rgb (H, W, C) float, covered (H, W) bool: fills the uncovered texels in place (all of them,
    where any texel is covered)."""
    covered = covered.copy()
    for _ in range(RINGS):
        if not _grow_ring(rgb, covered):
            break
    _pull_push(rgb, covered)
    return rgb

"""Which surface point each texel centre of a lightmap shows: triangles in UV space rasterised with numpy.

A texel (column i, row j, rows from the bottom as Blender stores pixels) has its centre at UV
((i + 0.5) / width, (j + 0.5) / height). A texel whose centre lies in a triangle takes the point of
that triangle with the same barycentric coordinates; one in no triangle is left to padding.
"""
import numpy as np

# Candidate texels (bounding boxes of triangles) handled at once: bounds the memory a large image takes.
CHUNK = 1 << 22


def rasterise(uv, width, height):
    """uv: (T, 3, 2) triangle corners in UV. Returns (texel, triangle, barycentric): flat texel
    indices (row * width + column) of the covered texels, the triangle each lies in and its (n, 3)
    barycentric coordinates. A texel on an edge shared by two triangles is taken by one of them."""
    px = np.asarray(uv, np.float64) * (width, height) - 0.5     # texel centres at whole numbers
    lo = np.clip(np.ceil(px.min(axis=1)), 0, (width - 1, height - 1)).astype(np.int64)
    hi = np.clip(np.floor(px.max(axis=1)), -1, (width - 1, height - 1)).astype(np.int64)
    span = np.maximum(hi - lo + 1, 0)
    count = span[:, 0] * span[:, 1]
    texels, triangles, weights = [], [], []
    start = 0
    while start < len(px):
        total = np.cumsum(count[start:])
        stop = start + max(1, int(np.searchsorted(total, CHUNK, side="right")))
        t = np.repeat(np.arange(start, stop), count[start:stop])
        first = np.repeat(np.cumsum(count[start:stop]) - count[start:stop], count[start:stop])
        k = np.arange(len(t)) - first
        x = lo[t, 0] + k % span[t, 0]
        y = lo[t, 1] + k // span[t, 0]
        a, b, c = px[t, 0], px[t, 1], px[t, 2]
        # Barycentric coordinates from the signed areas (edge functions) of the sub-triangles.
        area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        w1 = ((x - a[:, 0]) * (c[:, 1] - a[:, 1]) - (y - a[:, 1]) * (c[:, 0] - a[:, 0]))
        w2 = ((b[:, 0] - a[:, 0]) * (y - a[:, 1]) - (b[:, 1] - a[:, 1]) * (x - a[:, 0]))
        with np.errstate(divide="ignore", invalid="ignore"):
            w1, w2 = w1 / area, w2 / area
        w0 = 1.0 - w1 - w2
        tolerance = -1e-9   # a centre exactly on an edge belongs to the triangles on both sides
        inside = (area != 0) & (w0 >= tolerance) & (w1 >= tolerance) & (w2 >= tolerance)
        texels.append((y * width + x)[inside])
        triangles.append(t[inside])
        weights.append(np.clip(np.stack([w0, w1, w2], axis=1)[inside], 0.0, 1.0))
        start = stop
    if not texels:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3))
    texel, triangle, bary = np.concatenate(texels), np.concatenate(triangles), np.concatenate(weights)
    bary /= bary.sum(axis=1, keepdims=True)
    # One triangle a texel: the last to cover it, as a later draw over an earlier one.
    last = len(texel) - 1 - np.unique(texel[::-1], return_index=True)[1]
    return texel[last], triangle[last], bary[last]

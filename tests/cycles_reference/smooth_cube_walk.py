"""Random walks inside the smooth-shaded cube of curved_furnace.json's level 0, under Cycles' model
of a smooth-shaded diffuse surface, without Cycles: what a corner should hold.

    /usr/bin/python3.11 tests/cycles_reference/smooth_cube_walk.py [paths]

The cube [-1, 1]^3 faces inward; every face emits 1 and reflects rho = 0.8. A point's shading normal
is its triangle's corner normals (along the diagonals) interpolated barycentrically, as Cycles
interpolates them (a bilinear interpolation gives the same); the walk samples a cosine lobe about it
and drops the directions under the facet (Cycles' bsdf_diffuse_sample), and a ray that meets
another face at the corner it leaves meets it there. Prints the mean (1 - rho) B at a corner and its
standard error: 0.6310 +- 0.0005 with 400,000 paths (2 s). Cycles' own bake of that
cube's corners gives 0.615 (curved_furnace.json), the engine 0.634 (test_module.py).
"""
import sys

import numpy as np

RHO = 0.8


def shading_normals(p, axis):
    """Unit shading normals at points p on the faces x[axis] = +-1."""
    b, c = (axis + 1) % 3, (axis + 2) % 3
    u, v = (p[:, b] + 1) / 2, (p[:, c] + 1) / 2

    def corner(ub, vc):   # the inward corner normal -(vertex) / sqrt(3)
        n = np.zeros((len(p), 3))
        n[:, axis], n[:, b], n[:, c] = -np.sign(p[:, axis]), 1 - 2 * ub, 1 - 2 * vc
        return n / np.sqrt(3)
    upper = (u > v)[:, None]
    n = np.where(upper, (1 - u)[:, None] * corner(0, 0) + (u - v)[:, None] * corner(1, 0) + v[:, None] * corner(1, 1),
                 (1 - v)[:, None] * corner(0, 0) + (v - u)[:, None] * corner(0, 1) + u[:, None] * corner(1, 1))
    return n / np.linalg.norm(n, axis=1)[:, None]


def cosine_about(n, rng):
    phi, r = 2 * np.pi * rng.random(len(n)), rng.random(len(n))
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(n, helper)
    t /= np.linalg.norm(t, axis=1)[:, None]
    s = np.sqrt(r)
    return (np.cos(phi) * s)[:, None] * t + (np.sin(phi) * s)[:, None] * np.cross(n, t) + np.sqrt(1 - r)[:, None] * n


def corner_value(paths, seed=1):
    rng = np.random.default_rng(seed)
    p = np.tile([1.0, 1.0, 1.0], (paths, 1))   # a corner, on the face z = 1
    axis = np.full(paths, 2)
    total, weight = np.ones(paths), np.ones(paths)
    alive = np.arange(paths)
    while len(alive) and weight[alive].max() > 1e-7:
        pa, ax = p[alive], axis[alive]
        ns, ng = np.empty((len(alive), 3)), np.zeros((len(alive), 3))
        for a in range(3):
            on = ax == a
            ns[on] = shading_normals(pa[on], a)
            ng[on, a] = -np.sign(pa[on, a])
        w = cosine_about(ns, rng)
        up = (w * ng).sum(1) > 0                 # under the facet: dropped
        alive, pa, w = alive[up], pa[up], w[up]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(w != 0, (np.sign(w) - pa) / w, np.inf)
        t[t < 0] = np.inf
        hit = np.argmin(t, axis=1)
        q = pa + t[np.arange(len(alive)), hit][:, None] * w
        q[np.arange(len(alive)), hit] = np.sign(w[np.arange(len(alive)), hit])
        weight[alive] *= RHO
        total[alive] += weight[alive]
        p[alive], axis[alive] = np.clip(q, -1, 1), hit
    b = (1 - RHO) * total
    return b.mean(), b.std() / np.sqrt(paths)


if __name__ == "__main__":
    mean, error = corner_value(int(sys.argv[1]) if len(sys.argv) > 1 else 400_000)
    print(f"(1 - rho) B at a corner: {mean:.4f} +- {error:.4f}")

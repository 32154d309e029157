"""Which objects' direct light a move may change: those where the moved object, where it was or
where it is, reaches into the region between the object and a direct source (a lamp, an emitting
mesh, the sun). Elsewhere it blocks no ray from a source to the object, so the object's direct
light is what it was.

Bounds are spheres round the world-space vertices. The region between an object's sphere and a
source's is their convex hull, the union of the spheres whose centre and radius run linearly from
one to the other. The sun is a source far along its rays, as wide there as its disc. World light
comes from every direction: with it, a move may change every object's direct light.

No bpy here: export data in (numpy), object indices out.
"""
import numpy as np

# Ternary-search steps for the hull's nearest sphere: (2/3)^40 of the segment, far below a texel.
STEPS = 40


def sphere(m):
    """(centre (3,), radius) round MeshExport m's vertices in world space."""
    t = np.asarray(m.transform, np.float64)
    world = np.asarray(m.positions, np.float64) @ t[:3, :3].T + t[:3, 3]
    if len(world) == 0:
        return np.zeros(3), 0.0
    centre = 0.5 * (world.min(axis=0) + world.max(axis=0))
    return centre, float(np.sqrt(((world - centre) ** 2).sum(axis=1).max()))


def emits(m, materials):
    """Whether mesh export m emits light (a face's material, or texture colours, of its emission)."""
    if m.corner_emission is not None and np.any(np.asarray(m.corner_emission) > 0):
        return True
    return any(np.any(np.asarray(materials[i].emission) > 0) for i in np.unique(m.face_materials))


def world_lit(sx):
    return bool(np.any(np.asarray(sx.world) > 0)) or (sx.world_map is not None and bool(np.any(sx.world_map > 0)))


def _lamps(sx):
    """(centres (L,3), radii (L,)) of the lit point, spot and area lamps; (suns: directions (S,3),
    half angles (S,))."""
    centres, radii, suns, halves = [], [], [], []
    for l in sx.lights:
        power = next((p for p in (l.intensity, l.irradiance, l.radiance) if p is not None), None)
        if not l.visible or power is None or not np.any(np.asarray(power) > 0):
            continue
        if l.kind == "sun":
            suns.append(np.asarray(l.direction, np.float64))
            halves.append(0.5 * l.angle)
        elif l.kind == "area":
            centres.append(l.position)
            radii.append(np.linalg.norm(l.u_half_axis) + np.linalg.norm(l.v_half_axis))
        else:
            centres.append(l.position)
            radii.append(l.radius)
    return ((np.array(centres, np.float64).reshape(-1, 3), np.array(radii, np.float64)),
            (np.array(suns, np.float64).reshape(-1, 3), np.array(halves, np.float64)))


def _hull_distance(a, ra, b, rb, x):
    """Per row: the distance from point x to the convex hull of spheres (a, ra) and (b, rb)
    (negative inside): min over t in [0, 1] of |x - c(t)| - r(t), a convex function of t."""
    def f(t):
        c = a + t[:, None] * (b - a)
        return np.linalg.norm(x - c, axis=1) - (ra + t * (rb - ra))
    lo, hi = np.zeros(len(a)), np.ones(len(a))
    for _ in range(STEPS):
        m1, m2 = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        left = f(m1) < f(m2)
        hi = np.where(left, m2, hi)
        lo = np.where(left, lo, m1)
    return np.minimum(np.minimum(f(lo), f(np.zeros(len(a)))), f(np.ones(len(a))))


def reached(before, after, moved, targets):
    """The indices among `targets` (mesh indices of `after`) whose direct light the meshes `moved`
    (indices of both exports, laid out alike) may have changed, each as it was in `before` and as
    it is in `after`: all of them where a mover emits or the world lights the scene."""
    targets = list(targets)
    places = []   # the movers' spheres, old and new, where visible
    for i in moved:
        for sx in (before, after):
            if i < len(sx.meshes) and sx.meshes[i].visible:
                if emits(sx.meshes[i], sx.materials):
                    return set(targets)
                places.append(sphere(sx.meshes[i]))
    if not places or not targets:
        return set()
    if world_lit(before) or world_lit(after):
        return set(targets)
    spheres = [sphere(after.meshes[i]) for i in targets]
    (lamp_c, lamp_r), (sun_d, sun_h) = _lamps(after)
    emitters = [sphere(m) for i, m in enumerate(after.meshes)
                if m.visible and i not in moved and emits(m, after.materials)]
    src_c = np.concatenate([lamp_c, np.array([c for c, _ in emitters]).reshape(-1, 3)])
    src_r = np.concatenate([lamp_r, np.array([r for _, r in emitters], np.float64)])
    # The sun as a source beyond the scene: farther than any object and mover lie apart.
    all_c = np.array([c for c, _ in spheres + places])
    far = 4.0 * (np.ptp(all_c, axis=0).max() + max(r for _, r in spheres + places) + 1.0)
    out = set()
    for k, (c, r) in zip(targets, spheres):
        sc = np.concatenate([src_c, c - far * sun_d])
        sr = np.concatenate([src_r, r + far * np.tan(sun_h)])
        if len(sc) == 0:
            continue
        for x, rx in places:
            n = len(sc)
            d = _hull_distance(np.repeat(c[None], n, 0), np.full(n, r), sc, sr, np.repeat(x[None], n, 0))
            if np.any(d <= rx):
                out.add(k)
                break
    return out

"""A path tracer in plain numpy for the corners of a sample scene: an independent check of both
Cycles' corner values and ours where they disagree.

    blender -b --factory-startup --python tests/cycles_reference/trace_corner.py -- SCENE OBJECT LOOP
        [--up H] [--inset F] [--paths N] [--frame F]

The scene is what the add-on exports at that frame (its meshes' cages, materials and emission, its
point lamps of radius 0, rectangular area lamps and suns, and its world as one uniform colour, in
the engine's units). Panes pass light on straight (Tracer). A smooth mirror (a specular colour at roughness 0.05 or less over no
diffuse part, as mirror_room's Glossy BSDF) reflects along the mirrored direction, times its colour,
on both sides; light reaches a point by way of it only along such a path (a path leaving the mirror
collects the lamps and emitters it meets), and lamps do not block rays (Cycles' lamps are not
occluders). The point is the corner of loop LOOP of OBJECT, raised H along +z or
moved F of the way to its face's centroid; it prints the radiance leaving it along its face's
normal (the `Radiosity` contract), with its standard error, beside Cycles' cached corner value.
Diffuse, both sides of every face reflect, emission two-sided, next-event estimation to the
emitting faces and lamps, up to 64 bounces (a closed furnace at rho 0.8 within its noise of
rho E / (1 - rho)), paths ending where they carry under 1e-6. LOOP `all` traces every
non-emitting corner of OBJECT and adds them to SCENE[_fNNN]_traced.npz (optics/mirror_room_traced.npz
for the optics samples, whose Cycles corners are in optics/) ("<object>:corner_traced"
and "<object>:corner_traced_error", (K,3) in loop order, NaN at emitting corners; "traced_inset",
"traced_paths"): the reference at junctions, where Cycles' own corner value is ill-posed
(reference.py: limit_reference). LOOP `junctions` does so for the corners on a junction only
(reference.junction_faces), the only ones limit_reference takes, leaving the rest NaN.

On cornell_box, 100,000 paths a corner (4-19 s each), where Cycles' corner is well-posed: Ceiling
loop 5 0.2662 +- 0.0012 (Cycles 0.2663), ShortBox loop 7 1 mm down 0.0424 +- 0.0003 (0.0424),
TallBox loop 2 1.1774 +- 0.0011 (1.1692: +0.7%, not explained; its direct light alone, 0.9453 +-
0.0004, is the engine's within 0.1%: 0.9463 at default, 0.9457 at high). ShortBox loop 4, the -y
foot, where the box's shadow edge on the floor starts: 0.0712 +- 0.0004 at Cycles' inset point
(--inset 0.005; Cycles there 0.0715, ours at the corner 0.0719), 0.1016 +- 0.0005 on the box's
vertical edge 1 cm up (0.099 at 0.01 mm, with 16 bounces); Cycles' corner 0.0532. The corner's value
depends on the way one comes to it. A room's concave corner, Room loop 4: 0.2278 +- 0.0003 at
--inset 1e-4 (0.28 mm in; 0.2293 / 0.2277 at 1e-3 / 1e-5 with 16 bounces), ours 0.23, Cycles' corner
0.2196. At the corner itself the trace is no use: rays to the walls meeting there start on them.
"""
import fcntl
import os
import sys
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "addon"))
from conftest import load_package  # noqa: E402
import make_references  # noqa: E402
import optics_references  # noqa: E402
import reference  # noqa: E402
from smooth_cube_walk import cosine_about  # noqa: E402


MIRROR_ROUGHNESS = 0.05      # the engine's: a specular lobe this smooth is a mirror (docs/method.md)


def triangles(sx):
    """(T,3,3) world triangles of the visible meshes, and their (T,3) diffuse reflectance, emission
    and mirror colour (0 where the face is no mirror)."""
    tris, rho, emission, mirror, _ = faces_of(sx)
    return tris, rho, emission, mirror


def panes(sx):
    """The triangles' (T,3) straight-through colour (Transparent BSDF), (T,3) glass colour and (T,)
    index of refraction, as triangles() lists them."""
    return faces_of(sx)[4]


def faces_of(sx):
    tris, rho, emission, mirror, passing = [], [], [], [], []
    for m in sx.visible_meshes:
        world = m.positions @ m.transform[:3, :3].T + m.transform[:3, 3]
        starts = np.concatenate(([0], np.cumsum(m.face_sizes)[:-1]))
        for f, (start, size) in enumerate(zip(starts, m.face_sizes)):
            ring = m.face_vertices[start:start + size]
            material = sx.materials[m.face_materials[f]]
            specular = np.asarray(material.specular, float)
            smooth = specular.max() > 0 and material.roughness <= MIRROR_ROUGHNESS
            if smooth and np.max(material.reflectance) > 0:
                raise SystemExit(f"trace_corner traces pure mirrors only ({m.name}: a diffuse part too)")
            straight, glass = np.asarray(material.transmittance, float), np.asarray(material.glass, float)
            if straight.max() + glass.max() > 0 and (np.max(material.reflectance) > 0 or min(straight.max(),
                                                                                            glass.max()) > 0):
                raise SystemExit(f"trace_corner traces panes of one lobe only ({m.name})")
            for j in range(1, size - 1):
                tris.append(world[[ring[0], ring[j], ring[j + 1]]])
                rho.append(material.reflectance)
                emission.append(material.emission)
                mirror.append(specular if smooth else np.zeros(3))
                passing.append((straight, glass, material.ior))
    straight, glass, ior = (np.array([f[i] for f in passing], float) for i in range(3))
    return (np.array(tris), np.array(rho, float), np.array(emission, float), np.array(mirror, float),
            (straight.reshape(-1, 3), glass.reshape(-1, 3), ior))


def lamps(sx):
    """The scene's lamps: point lamps of radius 0 as ((L,3) positions, (L,3) intensities, W/sr), and
    rectangular area lamps as ((A,3) centres, (A,3) half axes u and v, (A,3) unit directions the light
    travels, (A,3) radiances)."""
    visible = [l for l in sx.lights if l.visible and l.kind != "sun"]
    if any(not (l.kind == "point" and l.radius == 0 or l.kind == "area" and l.shape == "rect") for l in visible):
        raise SystemExit("trace_corner traces point lamps of radius 0, rectangular area lamps and suns only")
    points = [l for l in visible if l.kind == "point"]
    areas = [l for l in visible if l.kind == "area"]

    def rows(lights, key):
        return np.array([getattr(l, key) for l in lights], float).reshape(-1, 3)
    return ((rows(points, "position"), rows(points, "intensity")),
            (rows(areas, "position"), rows(areas, "u_half_axis"), rows(areas, "v_half_axis"),
             rows(areas, "direction"), rows(areas, "radiance")))


def suns(sx):
    """The scene's suns: (S,3) directions their light travels, (S,) angular diameters, (S,3)
    irradiances."""
    suns = [l for l in sx.lights if l.visible and l.kind == "sun"]
    return (np.array([l.direction for l in suns], float).reshape(-1, 3), np.array([l.angle for l in suns], float),
            np.array([l.irradiance for l in suns], float).reshape(-1, 3))


def fresnel(cos_i, n):
    """Unpolarised Fresnel reflectance of a dielectric of index n, light arriving at cosine cos_i."""
    cos_i = np.clip(np.abs(cos_i), 0.0, 1.0)
    cos_t = np.sqrt(np.maximum(0.0, 1 - (1 - cos_i ** 2) / n ** 2))
    rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)) ** 2
    rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)) ** 2
    return 0.5 * (rs + rp)


class Tracer:
    """Panes (panes(): a Transparent BSDF's colour, or glass) let light through straight: a
    transparent one times its colour, glass times its colour and (1 - F) at each face (a slab's
    faces are parallel: the light leaves as it came, a few millimetres aside), and glass reflects F
    of it as a mirror of its colour. Shadow rays pass them so. The world (uniform, `world`) lights
    what paths escape to; suns (suns()) are sampled over their discs."""

    def __init__(self, tris, rho, emission, mirror, lamps, seed=7, panes=None, suns=None, world=None):
        self.v0, self.e1, self.e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
        n = np.cross(self.e1, self.e2)
        area = 0.5 * np.linalg.norm(n, axis=1)
        self.normal = n / np.linalg.norm(n, axis=1)[:, None]
        self.rho, self.emission, self.mirror = rho, emission, mirror
        self.is_mirror = mirror.max(1) > 0
        self.lights = np.nonzero(emission.sum(1) > 0)[0]
        self.light_area = area[self.lights].sum()
        self.light_p = area[self.lights] / self.light_area
        (self.lamp_position, self.lamp_intensity), (self.area_centre, self.area_u, self.area_v,
                                                      self.area_direction, self.area_radiance) = lamps
        self.area_size = 4 * np.linalg.norm(np.cross(self.area_u, self.area_v), axis=1)
        none = np.zeros((len(tris), 3))
        self.straight, self.glass, self.ior = panes if panes is not None else (none, none, np.ones(len(tris)))
        self.is_pane = (self.straight.max(1) > 0) | (self.glass.max(1) > 0)
        self.sun_direction, self.sun_angle, self.sun_irradiance = (
            suns if suns is not None else (np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3))))
        self.world = np.zeros(3) if world is None else np.asarray(world, float)
        self.rng = np.random.default_rng(seed)

    def passing(self, k, w):
        """(N,3) what pane triangles k pass of rays along w, at their angle."""
        cos_i = (self.normal[k] * w).sum(1)
        return self.straight[k] + self.glass[k] * (1 - fresnel(cos_i, self.ior[k]))[:, None]

    def through(self, o, w, tmax):
        """(N,3) what reaches o + tmax w from o along w (tmax may be inf): 0 past an opaque face,
        else the product of what the panes on the way pass."""
        factor = np.ones((len(o), 3))
        o, tmax = o.copy(), np.asarray(tmax, float).copy()
        active = np.arange(len(o))
        for _ in range(16):
            t, k = self.hit(o[active], w[active], 1e-7, tmax[active])
            met = np.isfinite(t)
            active, t, k = active[met], t[met], k[met]
            pane = self.is_pane[k]
            factor[active[~pane]] = 0.0
            active, t, k = active[pane], t[pane], k[pane]
            if not len(active):
                break
            factor[active] *= self.passing(k, w[active])
            o[active] += t[:, None] * w[active]
            tmax[active] -= t
        return factor

    def hit(self, o, w, tmin, tmax=None, skip=None):
        """Nearest hit (t, triangle) of rays o + t w, t in (tmin, tmax); Moller-Trumbore, all at once."""
        p = np.cross(w[:, None, :], self.e2[None])
        det = (self.e1[None] * p).sum(2)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o[:, None, :] - self.v0[None]
        u = (s * p).sum(2) * inv
        q = np.cross(s, self.e1[None])
        v = (w[:, None, :] * q).sum(2) * inv
        t = (self.e2[None] * q).sum(2) * inv
        inside = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > tmin)
        if tmax is not None:
            inside &= t < tmax[:, None]
        if skip is not None:
            inside &= ~skip[None]
        t = np.where(inside, t, np.inf)
        k = np.argmin(t, axis=1)
        return t[np.arange(len(o)), k], k

    def direct(self, p, n, rho):
        """Light from the emitting faces and point lamps reflected at points p (normals n on the side lit)."""
        out = np.zeros((len(p), 3))
        for position, intensity in zip(self.lamp_position, self.lamp_intensity):
            d = position - p
            dist = np.linalg.norm(d, axis=1)
            w = d / dist[:, None]
            cos_p = (n * w).sum(1)
            seen = self.through(p, w, dist * (1 - 1e-7)) * (cos_p > 0)[:, None]
            out += seen * rho / np.pi * intensity * (cos_p / dist ** 2)[:, None]
        for c, u, v, direction, radiance, size in zip(self.area_centre, self.area_u, self.area_v,
                                                      self.area_direction, self.area_radiance, self.area_size):
            a, b = 2 * self.rng.random(len(p)) - 1, 2 * self.rng.random(len(p)) - 1
            d = c + a[:, None] * u + b[:, None] * v - p
            dist = np.linalg.norm(d, axis=1)
            w = d / dist[:, None]
            cos_p, cos_y = (n * w).sum(1), -(w @ direction)
            seen = self.through(p, w, dist * (1 - 1e-7)) * ((cos_p > 0) & (cos_y > 0))[:, None]
            out += seen * rho / np.pi * radiance * (cos_p * cos_y / dist ** 2 * size)[:, None]
        for direction, angle, irradiance in zip(self.sun_direction, self.sun_angle, self.sun_irradiance):
            # uniform over the sun's disc of directions
            cos_max = np.cos(0.5 * angle)
            cos_t = 1 - self.rng.random(len(p)) * (1 - cos_max)
            phi = 2 * np.pi * self.rng.random(len(p))
            axis = -np.asarray(direction, float) / np.linalg.norm(direction)
            a = np.cross(axis, (1.0, 0.0, 0.0) if abs(axis[0]) < 0.9 else (0.0, 1.0, 0.0))
            a /= np.linalg.norm(a)
            b = np.cross(axis, a)
            sin_t = np.sqrt(np.maximum(0.0, 1 - cos_t ** 2))
            w = (cos_t[:, None] * axis + (sin_t * np.cos(phi))[:, None] * a + (sin_t * np.sin(phi))[:, None] * b)
            cos_p = (n * w).sum(1)
            seen = self.through(p, w, np.full(len(p), np.inf)) * (cos_p > 0)[:, None]
            out += seen * rho / np.pi * irradiance * cos_p[:, None]
        if not len(self.lights):
            return out
        k = self.lights[self.rng.choice(len(self.lights), len(p), p=self.light_p)]
        a, b = np.sqrt(self.rng.random(len(p))), self.rng.random(len(p))
        y = self.v0[k] + (a * (1 - b))[:, None] * self.e1[k] + (a * b)[:, None] * self.e2[k]
        d = y - p
        dist = np.linalg.norm(d, axis=1)
        w = d / dist[:, None]
        cos_p, cos_y = (n * w).sum(1), np.abs((self.normal[k] * w).sum(1))
        seen = self.through(p, w, dist * (1 - 1e-7)) * (cos_p > 0)[:, None]
        return out + seen * rho / np.pi * self.emission[k] * (cos_p * cos_y / dist ** 2)[:, None] * self.light_area

    def met(self, o, w, t):
        """Light that rays o + s w, s < t, meet on area lamps facing them and emitting faces they
        end on (t, the hits' triangles): what a path brings back after a mirror, where no lamp can
        be sampled."""
        out = np.zeros((len(o), 3))
        for c, u, v, direction, radiance in zip(self.area_centre, self.area_u, self.area_v, self.area_direction,
                                                self.area_radiance):
            facing = (w @ direction) < 0
            s = ((c - o) @ direction) / np.where(facing, w @ direction, -1.0)
            q = o + s[:, None] * w - c
            inside = ((np.abs(q @ u) <= u @ u) & (np.abs(q @ v) <= v @ v))
            out += np.where((facing & (s > 0) & (s < t) & inside)[:, None], radiance, 0.0)
        return out

    def radiance(self, x, n, paths, batch=20000):
        """Mean and standard error (RGB) of the radiance leaving point x (normal n) of a non-emitting face."""
        own = (np.abs(((x - self.v0) * self.normal).sum(1)) < 1e-6) & ((self.normal @ n) > 0.999)
        rho0 = self.rho[own][0]
        values = []
        for start in range(0, paths, batch):
            count = min(batch, paths - start)
            p, nn = np.tile(x, (count, 1)), np.tile(n, (count, 1))
            weight = np.tile(rho0, (count, 1))
            out = self.direct(p, nn, weight)
            alive = np.arange(count)
            specular = np.zeros(count, bool)      # the path's last bounce was off a mirror (or glass)
            straight = np.zeros(count, bool)      # it went on through a pane: its direction stays
            w = np.zeros((count, 3))
            for bounce in range(64):
                diffuse = alive[~specular[alive] & ~straight[alive]]
                w[diffuse] = cosine_about(nn[diffuse], self.rng)
                t, k = self.hit(p[alive], w[alive], 1e-9 if bounce == 0 else 1e-7, skip=own if bounce == 0 else None)
                after_mirror = specular[alive]
                out[alive[after_mirror]] += weight[alive[after_mirror]] * (
                    self.met(p[alive[after_mirror]], w[alive[after_mirror]], t[after_mirror])
                    + np.where(np.isfinite(t[after_mirror])[:, None], self.emission[k[after_mirror]], 0.0))
                found = np.isfinite(t)
                out[alive[~found]] += weight[alive[~found]] * self.world  # the world is not sampled directly
                alive, t, k = alive[found], t[found], k[found]
                q = p[alive] + t[:, None] * w[alive]
                facing = self.normal[k] * np.where((self.normal[k] * w[alive]).sum(1) < 0, 1.0, -1.0)[:, None]
                # A pane passes the path on or, glass, reflects it (F of the time): as a mirror, then.
                pane = self.is_pane[k]
                reflects = pane & (self.rng.random(len(k)) < self.glass[k].max(1) / np.maximum(
                    self.glass[k].max(1), 1e-30) * fresnel((self.normal[k] * w[alive]).sum(1), self.ior[k]))
                passes = pane & ~reflects
                mirror = self.is_mirror[k] | reflects
                lit = alive[~mirror & ~pane]
                out[lit] += weight[lit] * self.direct(q[~mirror & ~pane], facing[~mirror & ~pane],
                                                      self.rho[k[~mirror & ~pane]])
                factor = np.where(mirror[:, None], np.where(reflects[:, None], self.glass[k], self.mirror[k]),
                                  self.rho[k])
                factor[passes] = self.straight[k[passes]] + self.glass[k[passes]]
                weight[alive] *= factor
                reflected = w[alive] - 2 * (w[alive] * facing).sum(1)[:, None] * facing
                w[alive[mirror]] = reflected[mirror]
                specular[alive[~passes]] = mirror[~passes]
                straight[alive] = passes
                p[alive], nn[alive] = q, facing
                alive = alive[weight[alive].max(1) > 1e-6]
                if not len(alive):
                    break
            values.append(out)
        values = np.concatenate(values)
        return values.mean(0), values.std(0) / np.sqrt(len(values))


def optics(scene):
    """Whether `scene` is an optics sample, whose references optics_references.py makes."""
    return scene in optics_references.OPTIC


def cycles_path(scene, frame):
    """The scene's Cycles corners: make_references' file, or optics_references' for the optics samples."""
    return optics_references.path_of(scene) if optics(scene) else reference.path_of(scene, frame)


def save(scene, frame, name, values, errors, inset, paths):
    """Adds one object's traced corners to the scene's _traced.npz beside its Cycles corners (a lock:
    objects run side by side)."""
    path = optics_references.traced_path_of(scene) if optics(scene) else reference.traced_path_of(scene, frame)
    with open(path + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        data = reference.read_npz(path) if os.path.exists(path) else {}
        data.update({name + ":corner_traced": values.astype(np.float32),
                     name + ":corner_traced_error": errors.astype(np.float32),
                     "traced_inset": np.float64(inset), "traced_paths": np.int64(paths)})
        np.savez_compressed(path, **data)
    os.remove(path + ".lock")


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    scene, name = argv[0], argv[1]
    up = float(argv[argv.index("--up") + 1]) if "--up" in argv else 0.0
    inset = float(argv[argv.index("--inset") + 1]) if "--inset" in argv else 0.0
    paths = int(argv[argv.index("--paths") + 1]) if "--paths" in argv else 200_000
    frame = int(argv[argv.index("--frame") + 1]) if "--frame" in argv else None
    bpy.ops.wm.open_mainfile(filepath=os.path.join(HERE, "..", "..", "sample_blends", scene + ".blend"))
    if frame is not None:
        bpy.context.scene.frame_set(frame)
    sx = load_package().export.export_scene()
    tracer = Tracer(*triangles(sx), lamps(sx), panes=panes(sx), suns=suns(sx), world=sx.world)
    ob = bpy.data.objects[name]
    co, normals, faces = make_references.world_faces(ob)
    everything = argv[2] in ("all", "junctions")
    wanted = ~make_references.emitting_corners(ob)
    if argv[2] == "junctions":
        scene_faces = [f for o in bpy.context.scene.objects if o.type == 'MESH' and not o.hide_render
                       for f in make_references.world_faces(o)[2]]
        wanted &= reference.junction_faces(co, normals, scene_faces).any(1)
    loops = np.nonzero(wanted)[0] if everything else [int(argv[2])]
    cycles = reference.corner_reference(reference.read_npz(cycles_path(scene, frame)), name).mean(1)
    values, errors = np.full((len(co), 3), np.nan), np.full((len(co), 3), np.nan)
    face_ends = np.cumsum([len(f) for f in faces])
    for loop in loops:
        face = faces[np.searchsorted(face_ends, loop, side="right")]
        x = co[loop] + np.array([0.0, 0.0, up]) + inset * (face.mean(0) - co[loop])
        t = time.perf_counter()
        values[loop], errors[loop] = tracer.radiance(x, normals[loop], paths)
        print(f"{name} loop {loop} at {np.round(x, 5)}: {values[loop].mean():.4f} +- {errors[loop].mean():.4f} "
              f"(Cycles' corner {cycles[loop]:.4f}); {time.perf_counter() - t:.0f} s", flush=True)
    if everything:
        save(scene, frame, name, values, errors, inset, paths)


if __name__ == "__main__":
    main()

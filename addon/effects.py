"""What light a bake simulates, approximates and leaves out: the panel's lists and the bake report's sentence."""
import numpy as np

from . import export as exporter
from . import texture


def _both_sides(m):
    """Whether the engine solves both sides of mesh `m`: all but closed ones, where each directed edge of
    the faces comes once and its reverse once (ObjectPatches::enclosed_side), whose inside it skips."""
    fv = m.face_vertices.astype(np.int64)
    starts = np.concatenate(([0], np.cumsum(m.face_sizes)[:-1]))
    nxt = np.arange(len(fv)) + 1
    nxt[starts + m.face_sizes - 1] = starts
    a, b = fv, fv[nxt]
    n = len(m.positions) + 1
    edges = np.sort(a * n + b)
    return bool((a == b).any() or (edges[1:] == edges[:-1]).any() or not np.array_equal(edges, np.sort(b * n + a)))


SIMULATED, APPROXIMATED, LEFT_OUT = "simulated", "approximated", "left out"
# As the engine (mirror.h): a specular lobe at most this rough is a mirror, rougher ones reflect
# diffusely; an object whose mirror faces lie in more planes than MOST_PLANES is curved (no mirror
# planes: its sharp lobe reflects diffusely too).
MIRROR_ROUGHNESS = 0.05
MOST_PLANES = 6


def _sharp(material):
    return max(material.specular) > 0 and material.roughness <= MIRROR_ROUGHNESS


def _mirror_planes(m, sharp):
    """How many planes the faces of mesh `m` whose materials `sharp` marks (a bool per material) lie
    in, each face's by Newell's normal and its mean corner (object space: a transform keeps planes
    planes); planes a Catmull-Clark surface bends count as many."""
    faces = sharp[m.face_materials]
    if not faces.any():
        return 0
    starts = np.concatenate(([0], np.cumsum(m.face_sizes)[:-1]))
    nxt = np.arange(len(m.face_vertices)) + 1
    nxt[starts + m.face_sizes - 1] = starts
    p, q = m.positions[m.face_vertices], m.positions[m.face_vertices[nxt]]
    normal = np.add.reduceat(np.cross(p, q), starts)
    length = np.linalg.norm(normal, axis=1)
    kept = faces & (length > 0)
    if not kept.any():
        return 0
    normal = normal[kept] / length[kept, None]
    centre = (np.add.reduceat(p, starts) / m.face_sizes[:, None])[kept]
    size = max(float(np.ptp(m.positions, axis=0).max()), 1e-12)
    planes = len(np.unique(np.round(np.c_[normal * 1e3, (normal * centre).sum(1) / size * 1e5]), axis=0))
    return MOST_PLANES + 1 if m.refine == "catmull_clark" and m.level > 0 and planes > 1 else planes


def _mirrors(sx, meshes):
    """{material index: objects} for the sharp specular materials on planar objects and on curved
    ones, and the number of mirror planes."""
    sharp = np.array([_sharp(mat) for mat in sx.materials], bool)
    planes = [_mirror_planes(m, sharp) for m in meshes]

    def sharp_users(keep):
        return _users([m for m, n in zip(meshes, planes) if keep(n)], lambda m: m.face_materials[sharp[m.face_materials]])
    return (sharp_users(lambda n: 0 < n <= MOST_PLANES), sharp_users(lambda n: n > MOST_PLANES),
            sum(n for n in planes if n <= MOST_PLANES))


def _users(meshes, materials_of=lambda m: m.face_materials):
    """{material index: names of the objects in `meshes` whose faces (those `materials_of` gives the
    materials of) use it}, objects once each."""
    users = {}
    for m in meshes:
        for i in np.unique(materials_of(m)):
            names = users.setdefault(int(i), [])
            if m.object_name not in names:
                names.append(m.object_name)
    return users


def _named(sx, users, calls_for):
    """'Pane on Window, Door; ...' for the materials in `users` that `calls_for` (a MaterialExport
    test) picks, or "" if none does."""
    def objects(names):
        return ", ".join(names[:5]) + (" ..." if len(names) > 5 else "")
    picked = [f"{sx.materials[i].name} on {objects(names)}" for i, names in sorted(users.items())
              if calls_for(sx.materials[i])]
    return "; ".join(picked[:5]) + (" ..." if len(picked) > 5 else "")


def _optics(sx, users, meshes):
    """The rows for light that materials pass on without diffusing it (export.Lobes): each with the
    materials that call for it and the objects that use them; none where no material does."""
    def some(lobe):
        return lambda m: max(getattr(m, lobe)) > 0

    def noted(note):
        return lambda m: note in m.notes
    rows = [
        (SIMULATED, "Transmission", "light through transparent and glass surfaces, filtered by their colour",
         lambda m: max(m.transmittance) > 0 or max(m.glass) > 0),
        (APPROXIMATED, "Refraction (direction kept)", "glass passing light on straight, not bent", some("glass")),
        (APPROXIMATED, "Frosted glass", "rough glass passing light on as clear glass does",
         noted(exporter.FROSTED)),
        (SIMULATED, "Alpha cut-outs", "light through the clear parts of an image's alpha (a Mix with a "
         "Transparent BSDF, a Principled Alpha), ray by ray", _users([m for m in meshes if m.corner_uv is not None]),
         lambda m: m.coverage is not None),
        (APPROXIMATED, "Mix factors as means",
         "a Mix factor or Alpha that varies over a mesh (a procedural texture, a mix of images) taken as its mean",
         noted(exporter.MEAN_FACTOR)),
        (APPROXIMATED, "Alpha without UVs", "an image's alpha on a mesh without its UV map taken as its mean",
         _users([m for m in meshes if m.corner_uv is None]), lambda m: m.coverage is not None),
        (APPROXIMATED, "Rough reflection as diffuse", "rough metal and glossy reflection spread as diffuse light",
         lambda m: max(m.specular) > 0 and not _sharp(m)),
        (LEFT_OUT, "Glass reflections", "the light glass reflects off its faces", some("glass")),
        (LEFT_OUT, "Principled specular", "the specular layer of Principled BSDFs (their Specular input)",
         noted(exporter.SPECULAR_LAYER)),
    ]
    planar, curved, planes = _mirrors(sx, meshes)
    sky = np.max(np.asarray(sx.world, np.float64)) > 0
    rows[1:1] = [(SIMULATED, f"Mirrors ({planes} plane{'s' if planes > 1 else ''})",
                  "planar mirrors and smooth metal passing on the light that reaches them", planar, _sharp)]
    rows += [(APPROXIMATED, "Curved mirrors", "smooth reflection off curved surfaces spread as diffuse light",
              curved, _sharp),
             (LEFT_OUT, "Mirror to mirror", "light between mirrors past one mirror bounce",
              planar if planes > 1 else {}, _sharp),
             (APPROXIMATED, "World in mirrors", "world light by way of mirrors, sampled as the world is (noisy in "
              "small mirrors)", planar if sky else {}, _sharp)]
    out = []
    for kind, short, detail, *by, calls_for in rows:
        who = _named(sx, by[0] if by else users, calls_for)
        if who:
            out.append([kind, short, f"{detail} ({who})"])
    return out


def items(sx):
    """What light the bake simulates, approximates and leaves out, each as [kind, short, detail]: the
    panel lists the short words (one line each, the detail in its tooltip), the report the details."""
    lamps = {}
    for l in sx.lights:
        if l.visible:
            lamps[l.kind] = lamps.get(l.kind, 0) + 1
    out = []
    for kind, n in sorted(lamps.items()):
        text = f"{n} {kind} lamp{'s' if n > 1 else ''}"
        out.append([SIMULATED, text[:1].upper() + text[1:], text])
    if np.max(np.asarray(sx.world, np.float64)) > 0:
        out.append([SIMULATED, "World light", "world light (its background is not black)"])
    meshes = sx.visible_meshes
    used = {int(i) for m in meshes for i in np.unique(m.face_materials)}
    if any(max(sx.materials[i].emission) > 0 for i in used):
        if any(m.corner_emission is not None for m in meshes):
            out.append([APPROXIMATED, "Emission, at corners", "emission from materials, varying over meshes"])
        else:
            out.append([SIMULATED, "Emissive materials", "emission from emissive materials"])
    sources = {type(leaf) for m in meshes for i in np.unique(m.face_materials)
               for source in (sx.materials[i].texture if m.corner_reflectance is not None else None,
                              sx.materials[i].emission_texture if m.corner_emission is not None else None)
               for leaf in texture.leaves(source)}
    if texture.TextureRef in sources:
        out.append([APPROXIMATED, "Textures, at corners", "colour textures (sampled at face corners)"])
    if texture.AttributeRef in sources:
        out.append([SIMULATED, "Colour attributes", "colour attributes"])
    if any(m.refine == "catmull_clark" for m in meshes):
        out.append([SIMULATED, "Subdivision surfaces",
                    "Catmull-Clark objects (Subdivision Surface, refined by the engine from the cage)"])
    if any(m.object_type != 'MESH' for m in meshes):
        out.append([APPROXIMATED, "Curves, text: no colours",
                    "curve, text, surface and metaball objects (in the light, with no colours to hold)"])
    if meshes:
        out.append([SIMULATED, "Every bounce", "diffuse interreflection, every bounce down to the threshold"])
    # Information, not a warning: Cycles lights both sides of them too (every floor plane is one); they
    # cost the engine the inside it skips on closed meshes. Once per object: instances share its faces.
    sources = {m.object_name: m for m in meshes}
    both = [name for name, m in sources.items() if _both_sides(m)]
    if both:
        out.append([SIMULATED, f"Both sides of {len(both)} mesh{'es' if len(both) > 1 else ''}",
                    "both sides of open meshes or ones with flipped faces ("
                    + ", ".join(both[:5]) + (" ..." if len(both) > 5 else "") + ")"])
    users = _users(meshes)
    out += _optics(sx, users, meshes)
    # Never simulated, named with the materials that have them; the attribute holds diffuse light.
    who = _named(sx, users, lambda m: exporter.VOLUME in m.notes or exporter.SUBSURFACE in m.notes)
    out.append([LEFT_OUT, "Volumes, subsurface",
                f"volumes and subsurface scattering ({who + '; ' if who else ''}a diffuse bake)"])
    return out


def _transmission_cost(stats):
    """What light through panes cost the solve, as its stats count it: hits on panes that rays went
    on through, and the share of its rays that crossed one. The seconds are not separable from the
    rest of the tracing (bench/effects_cost.py measures them, scene by scene)."""
    crossings, crossed, rays = (int(stats.get(k, 0)) for k in ("pane_crossings", "rays_through_panes", "rays"))
    if not rays:
        return ""
    return f"{_many(crossings)} pane crossings, {_share(crossed, rays)} of the rays" if crossed else "no ray crossed a pane"


def _many(n):
    return f"{n / 1e6:.1f} M" if n >= 100_000 else f"{n:,}"


def _share(part, whole):
    share = 100 * part / whole
    return f"{share:.0f}%" if share >= 10 else f"{share:.2g}%"  # a window's few rays: 0.043%, not 0%


def _mirror_cost(stats):
    """What light by way of mirrors cost the solve: the legs of its paths through a mirror (two a
    path: to the mirror and on from it) and their share of its rays."""
    legs, rays = int(stats.get("mirror_rays", 0)), int(stats.get("rays", 0))
    return f"{_many(legs)} rays by way of mirrors, {_share(legs, rays)} of the rays" if rays else ""


# The rows whose cost a solve's stats give, by their short words without what follows in brackets
# ("Mirrors (2 planes)"): the cost's text from the stats.
_COSTS = {"Transmission": _transmission_cost, "Mirrors": _mirror_cost}


def costed(listed, stats):
    """items() after a solve: each row [kind, short, detail, cost], cost the text of what `stats` (the
    engine's solve stats) count of it, "" where they count nothing for it."""
    def cost(short):
        of = _COSTS.get(short.split(" (")[0])
        return of(stats) if of else ""
    return [list(row[:3]) + [cost(row[1])] for row in listed]


def described(row):
    """A row's detail with its cost, if it has one: the report's words and the panel's tooltip."""
    kind, short, detail, *cost = row
    return f"{detail} [cost: {cost[0]}]" if cost and cost[0] else detail


def sentence(listed):
    """The report's sentence of items() (or costed()): what is simulated or approximated, then what is
    left out."""
    return ", ".join([described(row) for row in listed if row[0] != LEFT_OUT]
                     + ["left out: " + ", ".join(described(row) for row in listed if row[0] == LEFT_OUT)])

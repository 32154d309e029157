"""What light a bake simulates, approximates and leaves out: the panel's lists and the bake report's sentence."""
import numpy as np

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
# DESIGN.md: the attribute holds what Cycles' bake of a diffuse scene holds; a material's metal or
# glass is reported where it is met.
LEFT_OUT_TEXT = "left out: glossy reflection, transmission, volumes and subsurface scattering (a diffuse bake)"


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
    out += [[LEFT_OUT, "Glossy reflection", LEFT_OUT_TEXT], [LEFT_OUT, "Transmission", LEFT_OUT_TEXT],
            [LEFT_OUT, "Volumes, subsurface", LEFT_OUT_TEXT]]
    return out


def sentence(listed):
    """The report's sentence of items(): what is simulated or approximated, then what is left out."""
    return ", ".join([detail for kind, _, detail in listed if kind != LEFT_OUT] + [LEFT_OUT_TEXT])

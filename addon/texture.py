"""What varies a diffuse or Principled BSDF's colour across a mesh, found in the node tree and taken
at the face corners with numpy over all of them at once: a colour attribute, read there; a colour
texture, sampled at their UVs as Cycles samples it (texel centres at (i + 0.5) / size, Linear or
Closest, the node's extension; an 8-bit sRGB image interpolated as stored and then made linear, as
Cycles keeps such images compressed), the UVs from a UV Map node, a Texture Coordinate node's UV or
the default map, through a Mapping node if there is one; Mix and colour-correction nodes of those
and plain colours, a Color Ramp on one of them, and a Mix's factor taken from one (as Cycles takes a
colour for a number: its luminance) or from an image's alpha, which also changes its colour as
Cycles 3.4 takes it (`alpha_handling`). And `Images`, what exports read from images (world.py reads
environments).

Cycles reads the texture wherever it shades; the engine gets it at the mesh's face corners and
interpolates it across each face, as a colour sampled per vertex is: detail finer than the mesh's
faces is averaged out."""
from dataclasses import dataclass

import numpy as np

from .writeback import ATTRIBUTE as OUTPUT_ATTRIBUTE

__all__ = ["TextureRef", "AttributeRef", "MixRef", "AdjustRef", "RampRef", "GrayRef", "Images", "colour_source",
           "image_texture", "corner_colours", "attribute_colours", "blended", "adjusted", "ramped", "gray", "leaves",
           "varies", "mean_of", "mean_colour", "mapping_of", "mapped_uv", "encoded_srgb", "srgb_to_linear", "input_number",
           "factor_texels", "MAX_FACTOR_SIDE"]


@dataclass
class TextureRef:
    image: object                 # bpy.types.Image
    uv_map: str                   # "" = the mesh's active render UV map (the node's default)
    interpolation: str            # the node's: 'Linear', 'Closest', 'Cubic', 'Smart'
    extension: str                # 'REPEAT', 'EXTEND', 'CLIP', 'MIRROR'
    factor: np.ndarray            # (3,) what the BSDF multiplies the colour by (Principled: metal, transmission)
    mapping: np.ndarray = None    # (3, 4): a Mapping node's affine map of (u, v, 0, 1), or None
    output: str = "Color"         # the node's output read: "Alpha" gives (alpha, alpha, alpha)
    # What Cycles makes of the image's alpha (`alpha_handling`): an 8-bit image's colour multiplied
    # by it on load, where Blender keeps it straight; divided by it again at the texel read, where
    # the node's Alpha output is used.
    premultiply: bool = False
    unassociate: bool = False


@dataclass
class AttributeRef:
    name: str                     # "" = the mesh's default colour attribute (the node's default)
    factor: np.ndarray            # as TextureRef.factor


@dataclass
class GrayRef:
    """A colour source where a number is asked for: its luminance, as Cycles converts a colour
    socket linked into a number one (linear_rgb_to_gray)."""
    colour: object


# Rec. 709 luminance: the luma of Blender's default OpenColorIO configuration, which Cycles reads.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass
class MixRef:
    """A Mix node's colour (or a legacy MixRGB's): `blend` of a and b by `fac`, each side a (3,)
    colour or a reference that varies over the mesh; `fac` a number or a GrayRef."""
    blend: str
    fac: object
    a: object
    b: object
    clamp: bool                   # the result to [0, 1]
    factor: np.ndarray            # as TextureRef.factor
    clamp_factor: bool = True     # fac to [0, 1] (a MixRGB's always; a Mix node's as it says)


@dataclass
class RampRef:
    """A Color Ramp's colour: the table Cycles bakes from the ramp, looked up at `fac`, a number or
    a GrayRef."""
    table: np.ndarray             # (RAMP_TABLE_SIZE, 3): the ramp at i / (size - 1)
    interpolate: bool             # between the table's entries (the ramp is not Constant)
    fac: object
    factor: np.ndarray            # as TextureRef.factor


RAMP_TABLE_SIZE = 256             # Cycles' (svm_ramp)


# Cycles' svm_mix, on colours (K, 3) or (3,); t the factor.
BLENDS = {
    'MIX': lambda a, b, t: (1 - t) * a + t * b,
    'ADD': lambda a, b, t: a + t * b,
    'MULTIPLY': lambda a, b, t: a * ((1 - t) + t * b),
    'SUBTRACT': lambda a, b, t: a - t * b,
    'SCREEN': lambda a, b, t: 1 - ((1 - t) + t * (1 - b)) * (1 - a),
    'DIFFERENCE': lambda a, b, t: (1 - t) * a + t * np.abs(a - b),
    'DARKEN': lambda a, b, t: (1 - t) * a + t * np.minimum(a, b),
    'LIGHTEN': lambda a, b, t: (1 - t) * a + t * np.maximum(a, b),
}


@dataclass
class AdjustRef:
    """A colour node of one colour in (Invert, Gamma, Bright/Contrast, Hue/Saturation/Value): `kind`
    with its unlinked `values`, applied to `colour`, a (3,) colour or a reference."""
    kind: str
    values: dict
    colour: object
    factor: np.ndarray            # as TextureRef.factor


# Each node: its colour input's name and the other inputs it takes (unlinked) by name.
ADJUSTS = {'INVERT': ("Color", ("Fac",)), 'GAMMA': ("Color", ("Gamma",)),
           'BRIGHTCONTRAST': ("Color", ("Bright", "Contrast")),
           'HUE_SAT': ("Color", ("Hue", "Saturation", "Value", "Fac"))}


def colour_source(socket, warnings, depth=0):
    """TextureRef, AttributeRef, MixRef or AdjustRef for what `socket`'s colour comes from, else None
    (unlinked, or a node not followed). One of colours that do not vary over the mesh does not
    either (`varies`): mean_of gives it."""
    if depth > 16:
        return None
    return image_texture(socket, warnings) or colour_attribute(socket, warnings) or \
        colour_mix(socket, warnings, depth) or colour_adjust(socket, warnings, depth) or \
        colour_ramp(socket, warnings, depth)


def leaves(source):
    """The TextureRefs and AttributeRefs a source reads."""
    if isinstance(source, MixRef):
        return leaves(source.fac) + leaves(source.a) + leaves(source.b)
    if isinstance(source, (AdjustRef, GrayRef)):
        return leaves(source.colour)
    if isinstance(source, RampRef):
        return leaves(source.fac)
    return [source] if isinstance(source, (TextureRef, AttributeRef)) else []


def varies(source):
    return bool(leaves(source))


def colour_mix(socket, warnings, depth=0):
    """MixRef for a Mix node of colours (or a MixRGB) linked straight into `socket`, else None."""
    if socket is None or not socket.is_linked or depth > 16:
        return None
    node = socket.links[0].from_node
    if node.type == 'MIX_RGB':
        fac, a, b, clamp = node.inputs["Fac"], node.inputs["Color1"], node.inputs["Color2"], node.use_clamp
    elif node.type == 'MIX' and node.data_type == 'RGBA':
        sockets = {s.identifier: s for s in node.inputs}
        fac, a, b, clamp = sockets["Factor_Float"], sockets["A_Color"], sockets["B_Color"], node.clamp_result
    else:
        return None
    if node.blend_type not in BLENDS:
        warnings.append(f"{node.name}: a {node.blend_type.title()} mix is not followed; its first colour is used")
        return None
    return MixRef(node.blend_type, input_number(node, fac, warnings, depth), _input_colour(node, a, warnings, depth),
                  _input_colour(node, b, warnings, depth), clamp, np.ones(3), node.type == 'MIX_RGB' or node.clamp_factor)


def colour_ramp(socket, warnings, depth=0):
    """RampRef for a Color Ramp's colour linked straight into `socket`, else None."""
    if socket is None or not socket.is_linked:
        return None
    link = socket.links[0]
    node = link.from_node
    if node.type != 'VALTORGB' or link.from_socket.identifier != 'Color':
        return None
    ramp = node.color_ramp
    table = np.array([ramp.evaluate(i / (RAMP_TABLE_SIZE - 1))[:3] for i in range(RAMP_TABLE_SIZE)], np.float64)
    return RampRef(table, ramp.interpolation != 'CONSTANT', input_number(node, node.inputs["Fac"], warnings, depth),
                   np.ones(3))


def input_number(node, socket, warnings, depth):
    """What a node's number input holds: the luminance of a colour source linked into it (GrayRef),
    or its unlinked value."""
    if not socket.is_linked:
        return float(socket.default_value)
    link = socket.links[0]
    if link.from_node.type == 'TEX_IMAGE' and link.from_socket.identifier == 'Alpha':   # its (a, a, a)'s gray is a
        source = image_texture(socket, warnings)
    else:
        source = colour_source(socket, warnings, depth + 1) if link.from_socket.type == 'RGBA' else None
    if source is None:
        warnings.append(f"{node.name}.{socket.name} is linked to a node or output not followed; its unlinked value "
                        "is used")
        return float(socket.default_value)
    return GrayRef(source)


def _input_colour(node, socket, warnings, depth):
    """What a colour node's colour input holds: its colour source, or its unlinked colour."""
    if not socket.is_linked:
        return np.array(socket.default_value[:3], np.float64)
    source = colour_source(socket, warnings, depth + 1)
    if source is None:
        warnings.append(f"{node.name}.{socket.name} is linked to a node not followed; its unlinked value is used")
        return np.array(socket.default_value[:3], np.float64)
    return source


def colour_adjust(socket, warnings, depth=0):
    """AdjustRef for an Invert, Gamma, Bright/Contrast or Hue/Saturation/Value node linked straight
    into `socket`, else None."""
    if socket is None or not socket.is_linked:
        return None
    node = socket.links[0].from_node
    if node.type not in ADJUSTS:
        return None
    colour, names = ADJUSTS[node.type]
    for name in names:
        if node.inputs[name].is_linked:
            warnings.append(f"{node.name}.{name} is linked; its unlinked value is used")
    values = {name: float(node.inputs[name].default_value) for name in names}
    return AdjustRef(node.type, values, _input_colour(node, node.inputs[colour], warnings, depth), np.ones(3))


def _rgb_to_hsv(c):
    """(..., 3) RGB to HSV as Blender's rgb_to_hsv (h, s in [0, 1))."""
    r, g, b = c[..., 0], c[..., 1], c[..., 2]
    v = np.maximum(np.maximum(r, g), b)
    delta = v - np.minimum(np.minimum(r, g), b)
    s = np.where(v != 0, delta / np.where(v != 0, v, 1), 0.0)
    safe = np.where(delta != 0, delta, 1)
    h = np.where(r == v, (g - b) / safe, np.where(g == v, 2 + (b - r) / safe, 4 + (r - g) / safe)) / 6
    h = np.where(s != 0, np.where(h < 0, h + 1, h), 0.0)
    return np.stack([h, s, v], -1)


def _hsv_to_rgb(c):
    """(..., 3) HSV to RGB as Blender's hsv_to_rgb."""
    h, s, v = c[..., 0], c[..., 1], c[..., 2]
    h = np.where(h == 1, 0.0, h) * 6
    i = np.floor(h)
    f = h - i
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    i = i.astype(int) % 6
    pick = lambda *xs: np.choose(i, xs)   # noqa: E731
    rgb = np.stack([pick(v, q, p, p, t, v), pick(t, v, v, q, p, p), pick(p, p, t, v, v, q)], -1)
    return np.where((s == 0)[..., None], v[..., None], rgb)


def adjusted(ref, colour):
    """ref's node (Cycles' svm) applied to colours (K, 3) or (3,), times ref.factor."""
    k, x = ref.kind, ref.values
    if k == 'INVERT':
        out = (1 - x["Fac"]) * colour + x["Fac"] * (1 - colour)
    elif k == 'GAMMA':
        out = np.where(colour > 0, np.power(np.maximum(colour, 0), x["Gamma"]), colour)
    elif k == 'BRIGHTCONTRAST':
        a, b = 1 + x["Contrast"], x["Bright"] - 0.5 * x["Contrast"]
        out = np.maximum(a * colour + b, 0)
    else:   # HUE_SAT
        hsv = _rgb_to_hsv(np.asarray(colour, np.float64))
        h = hsv[..., 0] + x["Hue"] - 0.5
        hsv = np.stack([h - np.floor(h), np.clip(hsv[..., 1] * x["Saturation"], 0, 1), hsv[..., 2] * x["Value"]], -1)
        out = np.maximum(x["Fac"] * _hsv_to_rgb(hsv) + (1 - x["Fac"]) * colour, 0)
    return out * ref.factor


def blended(ref, a, b, t):
    """ref's colour from its sides' values a and b (colours (K, 3) or (3,)) and its factor's t (a
    number, or (K,)), times ref.factor."""
    t = np.asarray(t, np.float64)
    if ref.clamp_factor:
        t = np.clip(t, 0.0, 1.0)
    out = BLENDS[ref.blend](a, b, t[..., None] if t.ndim else t)
    return (np.clip(out, 0.0, 1.0) if ref.clamp else out) * ref.factor


def gray(colour):
    """Luminance, (K,) or a number, of colours (K, 3) or (3,)."""
    return np.asarray(colour, np.float64) @ LUMINANCE


def ramped(ref, fac):
    """ref's colour at fac (a number, or (K,)), times ref.factor: Cycles' rgb_ramp_lookup, held at
    the ramp's ends."""
    f = np.clip(np.nan_to_num(np.asarray(fac, np.float64)), 0.0, 1.0) * (RAMP_TABLE_SIZE - 1)
    i = np.minimum(f.astype(np.int64), RAMP_TABLE_SIZE - 1)
    t = (f - i)[..., None]
    out = ref.table[i]
    if ref.interpolate:
        out = np.where(t > 0, (1 - t) * out + t * ref.table[np.minimum(i + 1, RAMP_TABLE_SIZE - 1)], out)
    return out * ref.factor


def colour_attribute(socket, warnings):
    """AttributeRef for a Color Attribute node, or an Attribute node's Color, linked straight into
    `socket`, else None."""
    if socket is None or not socket.is_linked:
        return None
    link = socket.links[0]
    node = link.from_node
    if node.type == 'VERTEX_COLOR':
        name = node.layer_name
    elif node.type == 'ATTRIBUTE' and node.attribute_type == 'GEOMETRY' and link.from_socket.identifier == 'Color':
        name = node.attribute_name
    else:
        return None
    if name == OUTPUT_ATTRIBUTE:   # it would take the last bake's light for its colour
        warnings.append(f"{node.name} reads {OUTPUT_ATTRIBUTE}, the bake's own output: its unlinked colour is used")
        return None
    return AttributeRef(name, np.ones(3))


def attribute_colours(ref, me, loops, label, warnings):
    """(K, 3) linear RGB of `ref`'s colour attribute at the exported corners (`loops`: their mesh
    loops, None: all), times ref.factor; None (said why) if the mesh has no such colour attribute."""
    attrs = me.color_attributes
    attr = attrs.get(ref.name) if ref.name else (
        attrs[attrs.render_color_index] if 0 <= attrs.render_color_index < len(attrs) else None)
    if attr is None or attr.domain not in ('POINT', 'CORNER'):
        warnings.append(f"{label}: no colour attribute {ref.name or '(the default)'} on points or corners; "
                        "black, as Cycles takes it")
        return None
    values = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", values)   # linear, bytes included
    values = values.reshape(-1, 4)[:, :3].astype(np.float64)
    if attr.domain == 'POINT':
        corner_vertex = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", corner_vertex)
        values = values[corner_vertex]
    return (values if loops is None else values[loops]) * ref.factor


def image_texture(socket, warnings):
    """TextureRef for an Image Texture node (with an image) linked straight into `socket`, else None."""
    if socket is None or not socket.is_linked:
        return None
    node = socket.links[0].from_node
    if node.type != 'TEX_IMAGE' or node.image is None:
        return None
    uv_map, mapping = "", None
    vector = node.inputs.get("Vector")
    link = vector.links[0] if vector is not None and vector.is_linked else None
    if link is not None and link.from_node.type == 'MAPPING':
        mapping = mapping_of(link.from_node, warnings)
        inner = link.from_node.inputs["Vector"]
        link = inner.links[0] if inner.is_linked else None
        if mapping is not None and link is None:   # Cycles maps the point (0, 0, 0): one texel everywhere
            warnings.append(f"{node.name}: a Mapping node with nothing in its Vector is not followed; "
                            "the default UV map is used")
            mapping = None
    if link is not None:
        source = link.from_node
        if source.type == 'UVMAP':
            uv_map = source.uv_map
        elif not (source.type == 'TEX_COORD' and link.from_socket.identifier == 'UV'):
            what = (f"Texture Coordinate's {link.from_socket.name}" if source.type == 'TEX_COORD'
                    else f"{source.type} node")
            warnings.append(f"{node.name}: texture coordinates from a {what} are not followed; "
                            "the default UV map is used")
            mapping = None
    premultiply, unassociate = alpha_handling(node)
    return TextureRef(node.image, uv_map, node.interpolation, node.extension, np.ones(3), mapping,
                      socket.links[0].from_socket.identifier, premultiply, unassociate)


def alpha_handling(node):
    """(premultiply, unassociate) for an Image Texture node, as Cycles 3.4 takes its image's alpha
    (ImageTextureNode and BlenderImageLoader): a colour image (not Non-Color, alpha mode neither
    Channel Packed nor None) is associated with its alpha on load, the 8-bit ones by Cycles, the
    float ones already by Blender; and divided by it at the read when the node's Alpha output
    feeds a node (Cycles drops nodes whose outputs lead nowhere). Left unassociated, an 8-bit sRGB
    image bakes many times too bright where it is transparent."""
    image = node.image
    associated = image.colorspace_settings.name != 'Non-Color' and image.alpha_mode not in ('CHANNEL_PACKED', 'NONE')
    used = any(link.to_node.type == 'OUTPUT_MATERIAL' or any(out.is_linked for out in link.to_node.outputs)
               for link in node.outputs["Alpha"].links)
    return associated and not image.is_float, associated and used


def _rotation(euler):
    """Blender's XYZ Euler rotation: about x first, then y, then z."""
    (cx, cy, cz), (sx, sy, sz) = np.cos(euler), np.sin(euler)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def mapping_of(node, warnings):
    """(3, 4) affine map of a Mapping node (Point, Texture or Vector type), or None (said why)."""
    kind = node.vector_type
    names = ("Location", "Rotation", "Scale") if kind != 'VECTOR' else ("Rotation", "Scale")
    if kind == 'NORMAL' or any(node.inputs[n].is_linked for n in names):
        warnings.append(f"{node.name}: a {kind.title()} Mapping node" +
                        (" with linked inputs" if kind != 'NORMAL' else "") + " is not followed")
        return None
    location = np.array(node.inputs["Location"].default_value, np.float64)
    rotation = _rotation(np.array(node.inputs["Rotation"].default_value, np.float64))
    scale = np.array(node.inputs["Scale"].default_value, np.float64)
    if kind == 'TEXTURE':   # the inverse of Point, a zero scale giving zero (Cycles' safe divide)
        inverse = np.divide(1.0, scale, out=np.zeros(3), where=scale != 0)
        linear = inverse[:, None] * rotation.T
        return np.hstack([linear, (-linear @ location)[:, None]])
    linear = rotation * scale[None, :]
    return np.hstack([linear, (location if kind == 'POINT' else np.zeros(3))[:, None]])


def mapped_uv(ref, uv):
    """(K, 2) texture coordinates of UVs (K, 2) through ref's Mapping node, if any."""
    if ref.mapping is None:
        return uv
    return uv @ ref.mapping[:2, :2].T + ref.mapping[:2, 3]


def encoded_srgb(image):
    """Whether the pixels hold sRGB's encoding: an 8-bit image in sRGB (float images are linear)."""
    return not image.is_float and image.colorspace_settings.name == 'sRGB'


def srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _read(image):
    """(H, W, 4) float32 pixels as stored (8-bit images in their colour space's encoding)."""
    w, h = image.size
    px = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(px)
    return px.reshape(h, w, 4)


def _wrap(i, n, extension):
    if extension in ('EXTEND', 'CLIP'):
        return np.clip(i, 0, n - 1)
    if extension == 'MIRROR':
        i = np.mod(i, 2 * n)
        return np.where(i < n, i, 2 * n - 1 - i)
    return np.mod(i, n)


class Images:
    """What exports read from images. Pixels are kept for one export only (`end_export`): a 4k image
    is 256 MB of floats. What was sampled from them (the mean colour, the colours at a mesh's UVs)
    outlives it, for later exports whose images are known not to have changed, the frames of an
    animation: reading a 4k image again would cost each frame's export tens of milliseconds. A new Images for exports
    that may follow an edit of the pixels (Blender 3.4 gives no cheap sign of one)."""

    # Sources whose pixels follow the frame: sampled anew each export.
    PER_FRAME = {'SEQUENCE', 'MOVIE', 'VIEWER'}

    def __init__(self):
        # Keyed by name_full: images linked from two libraries may share a name.
        self._pixels = {}    # image -> (H, W, 4) float32, this export's
        self._sampled = {}   # (image, what) -> (stamp, inputs, result)
        self._used = set()

    @staticmethod
    def _stamp(image):
        # Catches what a frame can change without an edit: a reload, a resize, the first stroke of paint.
        return (image.source, image.filepath_raw, tuple(image.size), image.is_dirty,
                image.colorspace_settings.name)

    def pixels(self, image):
        if image.name_full not in self._pixels:
            self._pixels[image.name_full] = _read(image)
        return self._pixels[image.name_full]

    def sampled(self, image, what, inputs, work):
        """work(), or its result from an earlier export of the same image, `what` and `inputs`."""
        if image.source in self.PER_FRAME:
            return work()
        key = (image.name_full, what)
        stamp = self._stamp(image)
        kept = self._sampled.get(key)
        self._used.add(key)
        if kept is not None and kept[0] == stamp and (inputs is None or np.array_equal(kept[1], inputs)):
            return kept[2]
        result = work()
        self._sampled[key] = (stamp, None if inputs is None else inputs.copy(), result)
        return result

    def end_export(self):
        """Drops the pixels, and what the export just ended did not sample."""
        self._pixels.clear()
        self._sampled = {k: v for k, v in self._sampled.items() if k in self._used}
        self._used.clear()


def mean_of(source, images):
    """(3,) the colour a source stands for where it cannot be read at the corners: an image's mean,
    black for an attribute (as Cycles takes a mesh without it), a Mix or adjustment of those; times
    its factor."""
    if isinstance(source, (np.ndarray, float)):
        return source
    if isinstance(source, MixRef):
        return blended(source, mean_of(source.a, images), mean_of(source.b, images), mean_of(source.fac, images))
    if isinstance(source, AdjustRef):
        return adjusted(source, mean_of(source.colour, images))
    if isinstance(source, GrayRef):
        return float(gray(mean_of(source.colour, images)))
    if isinstance(source, RampRef):
        return ramped(source, mean_of(source.fac, images))
    base = mean_colour(source, images) if isinstance(source, TextureRef) else np.zeros(3)
    return base * source.factor


def mean_colour(ref, images):
    """(3,) mean linear RGB of `ref`'s image as its node reads it (zeros if it has no pixels), over
    about 256 x 256 of its texels: it only stands in where a mesh has no UVs, and making a whole 2k
    sRGB image linear costs an export 0.2 s."""
    def work():
        px = images.pixels(ref.image)
        step = max(1, max(px.shape[:2]) // 256)
        px = _stored(ref, px[::step, ::step].reshape(-1, 4))
        if not px.size:
            return np.zeros(3)
        return _read_out(ref, px).mean(0, dtype=np.float64)
    return images.sampled(ref.image, ("mean", ref.output, ref.premultiply, ref.unassociate), None, work)


# The longest side of an image factor the engine reads per ray (factor_texels). A 4k leaf atlas would
# hold 64 MB of floats per material; at 1024 a texel of a 2 m card is 2 mm, finer than the patches
# that receive its shadow resolve, and a box filter keeps the coverage's mean.
MAX_FACTOR_SIDE = 1024


def factor_texels(ref, images):
    """(H, W) float32 in [0, 1], rows from the bottom: what `ref`'s image gives a number input per
    texel (its alpha, or its colour's luminance, as a GrayRef reads it), box-filtered down by whole
    factors to at most MAX_FACTOR_SIDE a side."""
    def work():
        px = images.pixels(ref.image)
        h, w = px.shape[:2]
        if not h or not w:
            return np.zeros((1, 1), np.float32)
        sy, sx = -(-h // MAX_FACTOR_SIDE), -(-w // MAX_FACTOR_SIDE)
        # The texels past the last whole block of a side (fewer than a step) are left off.
        h2, w2 = h // sy, w // sx
        px = px[:h2 * sy, :w2 * sx]
        if ref.output == "Alpha":
            factor = px[..., 3]
        else:   # a band of rows at a time: a 4k image's colours in float64 would take 400 MB
            band = max(1, 256 // sy) * sy
            factor = np.concatenate([gray(_read_out(ref, _stored(ref, px[r:r + band].reshape(-1, 4))))
                                     .reshape(-1, w2 * sx) for r in range(0, h2 * sy, band)])
        factor = factor.reshape(h2, sy, w2, sx).mean((1, 3), dtype=np.float64)
        return np.clip(factor, 0.0, 1.0).astype(np.float32)
    return images.sampled(ref.image, ("factor", ref.output, ref.premultiply, ref.unassociate), None, work)


def corner_colours(ref, uv, images, user=""):
    """(K, 3) linear RGB of `ref`'s image at UVs (K, 2), times ref.factor, through `images` (`user`:
    who asks, a mesh and material, so that each keeps its own). Cycles bakes a corner as a point of
    its face: a UV on a texel's edge reads the texel on the face's side, so pass UVs a hair inside
    their faces."""
    uv = mapped_uv(ref, uv)
    key = ("corners", user, ref.interpolation, ref.extension, ref.output, ref.premultiply, ref.unassociate)
    colour = images.sampled(ref.image, key, uv, lambda: _texels_at(ref, uv, images))
    return colour * ref.factor


def _stored(ref, px):
    """Texels (..., 4) as Cycles holds them: an 8-bit image's colour associated with its alpha as
    Cycles does it, on the bytes ((c * a) / 255 in integers)."""
    if not ref.premultiply:
        return px
    byte = np.rint(px * 255.0)
    return np.concatenate([np.floor(byte[..., :3] * byte[..., 3:] / 255.0) / 255.0, px[..., 3:]], -1)


def _read_out(ref, px):
    """(K, 3) linear RGB of the node's output from texels (K, 4) as interpolated: the colour divided
    by its alpha where Cycles unassociates it (alpha neither 0 nor 1) and made linear, or the alpha."""
    if ref.output == "Alpha":
        return np.repeat(px[:, 3:], 3, 1).astype(np.float64)
    colour = px[:, :3].astype(np.float64)
    if ref.unassociate:
        a = px[:, 3:].astype(np.float64)
        colour = np.where((a != 0) & (a != 1), colour / np.where(a != 0, a, 1.0), colour)
    return srgb_to_linear(colour) if encoded_srgb(ref.image) else colour


def _texels_at(ref, uv, images):
    px = images.pixels(ref.image)   # float32: only the texels read are widened
    h, w = px.shape[:2]
    if w == 0 or h == 0:
        return np.zeros((len(uv), 3))
    x = uv[:, 0] * w - 0.5
    y = uv[:, 1] * h - 0.5
    if ref.interpolation == 'Closest':
        texel = _stored(ref, px[_wrap(np.floor(y + 0.5).astype(np.int64), h, ref.extension),
                                _wrap(np.floor(x + 0.5).astype(np.int64), w, ref.extension)].astype(np.float64))
    else:   # Linear; Cubic and Smart taken as Linear
        x0, y0 = np.floor(x), np.floor(y)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
        xs = [_wrap(x0, w, ref.extension), _wrap(x0 + 1, w, ref.extension)]
        ys = [_wrap(y0, h, ref.extension), _wrap(y0 + 1, h, ref.extension)]
        at = lambda j, i: _stored(ref, px[ys[j], xs[i]])
        texel = (1 - fx) * (1 - fy) * at(0, 0) + fx * (1 - fy) * at(0, 1) + (1 - fx) * fy * at(1, 0) + fx * fy * at(1, 1)
    colour = _read_out(ref, texel)
    if ref.extension == 'CLIP':
        outside = (uv < 0).any(1) | (uv > 1).any(1)
        colour = np.where(outside[:, None], 0.0, colour)
    return colour

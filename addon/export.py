"""Blender depsgraph -> flat numpy arrays for the radiosity engine.

No per-vertex Python loops: every per-element array comes from ``foreach_get`` into numpy.
Lamp conversions follow Cycles 3.4.1 as measured in ``CYCLES_UNITS.md``:

    point / spot  intensity  I = colour * P / (4 pi)            [W/sr]   (irradiance I cos / r^2)
    spot cone     a(phi) = cos(phi) * smoothstep((cos(phi) - c0) / ((1 - c0) * blend)), c0 = cos(size/2)
    sun           irradiance E = colour * S                      [W/m^2]  (on a perpendicular plane)
    area          radiance   L = colour * P / (4 * A_world)      one-sided, towards the lamp's local -Z
    world         radiance   colour * strength
    emission      radiance   colour * strength, two-sided

The engine's unknown is outgoing radiance B = E + rho * irradiance / pi.

Entry point: ``export_scene(depsgraph) -> SceneExport``.
"""
from dataclasses import dataclass, field, replace
import math

import bpy
import numpy as np

from . import display
from . import texture as colour_texture
from . import world as world_light

__all__ = ["SceneExport", "MeshExport", "MaterialExport", "LightExport", "Lobes", "FROSTED", "SPECULAR_LAYER",
           "MEAN_FACTOR", "SUBSURFACE", "VOLUME", "export_scene", "to_engine",
           "export_materials_of", "material_values", "world_radiance", "light_values", "dark",
           "POINT_INTENSITY_PER_WATT", "AREA_RADIANCE_FACTOR", "DEFAULT_REFLECTANCE"]

POINT_INTENSITY_PER_WATT = 1.0 / (4.0 * math.pi)   # W/sr per W, point and spot
AREA_RADIANCE_FACTOR = 0.25                        # L = AREA_RADIANCE_FACTOR * P / A_world
DEFAULT_REFLECTANCE = (0.8, 0.8, 0.8)             # Cycles' shader for faces without a material
INSIDE = 1e-4                                      # of the way to a face's UV middle, where a corner's texel is read
MAX_REFLECTANCE = 0.99                             # the engine takes reflectance below one (_below_one)


# ----------------------------------------------------------------------------- data classes
@dataclass
class MaterialExport:
    name: str
    reflectance: tuple            # rho, linear RGB: the diffuse lobe
    emission: tuple               # emitted radiance, linear RGB, two-sided
    warnings: list = field(default_factory=list)
    # What varies the BSDF's colour over a mesh (texture.TextureRef, AttributeRef, MixRef or AdjustRef):
    # reflectance per face corner (MeshExport.corner_reflectance); `reflectance` is what texture.mean_of
    # gives where it cannot be read there (an image's mean; black for an attribute, as in Cycles).
    texture: object = None
    emission_texture: object = None   # the same for the emission colour (MeshExport.corner_emission)
    # The lobes that pass light on without diffusing it (Lobes); per channel, reflectance +
    # transmittance + glass + specular is at most one.
    transmittance: tuple = (0.0, 0.0, 0.0)
    glass: tuple = (0.0, 0.0, 0.0)
    ior: float = 1.45
    specular: tuple = (0.0, 0.0, 0.0)
    roughness: float = 0.5
    notes: frozenset = frozenset()    # what the lobes stand in for approximately or leave out (FROSTED...)
    # Where the surface is, by place (Coverage): `transmittance` passes where it is not; the
    # meshes that use the material give the UVs (MeshExport.corner_uv). None: everywhere alike.
    coverage: object = None

    def lobes(self):
        """Scene.add_material's keywords after the reflectance, in the order Solver.set_material takes them
        after its index and reflectance."""
        return dict(emission=self.emission, transmittance=self.transmittance, glass=self.glass, ior=self.ior,
                    specular=self.specular, roughness=self.roughness, alpha=self.coverage)


@dataclass
class MeshExport:
    name: str                     # object name (instances: "name[i]")
    positions: np.ndarray         # (N,3) float64, object space
    face_sizes: np.ndarray        # (F,) int32
    face_vertices: np.ndarray     # (K,) int32, K = face_sizes.sum()
    face_materials: np.ndarray    # (F,) int32 into SceneExport.materials
    transform: np.ndarray         # (4,4) float64, object -> world
    refine: str = "bilinear"      # "none" | "bilinear" | "catmull_clark"; plain meshes are "bilinear"
    level: int = 0                # Catmull-Clark level (subdivision modifier); 0 with "bilinear":
                                  # the engine picks the bilinear level from its patch size
    loop_indices: np.ndarray = None   # (K,) int32 original mesh loop of each exported corner (None =
                                      # identity; -1: a copy a modifier made)
    matches_original: bool = True     # every original loop is an exported corner (write-back ok)
    animated: bool = False
    object_name: str = ""
    visible: bool = True          # False: hidden from render; the engine keeps it out of the lighting
    smooth: np.ndarray = None     # (F,) bool, Shade Smooth per face (Cycles bakes with interpolated normals)
    corner_reflectance: np.ndarray = None  # (K,3) per exported corner where a material has a texture
    corner_emission: np.ndarray = None     # (K,3) the same where a material's emission has one
    corner_uv: np.ndarray = None  # (K,2) where a material's coverage is read (MaterialExport.coverage), or None
    object_type: str = 'MESH'     # the Blender object's: the others light the scene but hold no colours
    deforms: bool = False         # modifiers or shape keys may bend it (the engine keeps its flat faces' points apart)


@dataclass
class LightExport:
    name: str
    kind: str                     # "point" | "spot" | "sun" | "area"
    position: np.ndarray = None   # (3,) world
    direction: np.ndarray = None  # (3,) unit, direction the light travels (spot axis, sun rays, area normal)
    intensity: np.ndarray = None  # (3,) W/sr, point and spot
    radius: float = 0.0           # point/spot soft radius
    spot_size: float = 0.0        # full cone angle, radians
    spot_blend: float = 0.0
    irradiance: np.ndarray = None # (3,) sun, W/m^2 on a perpendicular plane
    angle: float = 0.0            # sun angular diameter, radians
    radiance: np.ndarray = None   # (3,) area lamp emitted radiance
    u_half_axis: np.ndarray = None    # (3,) world, half extent along the lamp's local X
    v_half_axis: np.ndarray = None    # (3,) world, half extent along the lamp's local Y
                                      # (the lamp emits along -(u x v); swapped for mirrored lamps)
    shape: str = ""               # "rect" | "disc" (engine names; a disc's axes may differ: ellipse)
    area: float = 0.0             # world area of the area lamp
    visible: bool = True          # False: hidden from render, exported dark (see dark())
    warnings: list = field(default_factory=list)


@dataclass
class SceneExport:
    meshes: list
    materials: list
    lights: list
    world: np.ndarray             # (3,) background radiance (a world map's mean)
    frame: int = 0
    warnings: list = field(default_factory=list)
    world_map: np.ndarray = None  # (H, W, 3) the world's radiance by direction (Solver.set_world_map), or None

    def material_index(self, name):
        return [m.name for m in self.materials].index(name)

    @property
    def visible_meshes(self):
        """The meshes that take part in the lighting (and get colours)."""
        return [m for m in self.meshes if m.visible]

    def mesh(self, name):
        for m in self.meshes:
            if m.name == name:
                return m
        raise KeyError(name)

    def light(self, name):
        for l in self.lights:
            if l.name == name:
                return l
        raise KeyError(name)


@dataclass
class _Gathered:
    """What an export gathers over its objects: each material once, the images it read, the warnings."""
    registry: dict                # {original material name, None for the default: index into materials}
    materials: list               # MaterialExport, in scene-wide index order
    images: object                # texture.Images of this export
    warnings: list


@dataclass
class _Corners:
    """The exported corners of one mesh, where _corner_values reads colours."""
    me: object                    # the bpy Mesh exported
    loops: np.ndarray             # (K,) its loop at each exported corner, or None: the identity
    sizes: np.ndarray             # (F,) face sizes
    face_materials: np.ndarray    # (F,) scene-wide material index of each face
    label: str                    # the object's name in warnings
    uvs: dict = field(default_factory=dict)   # {UV map name: the corners' UVs}: read once for reflectance,
                                              # emission and coverage (several materials may share one)


# ----------------------------------------------------------------------------- materials
def _rgb(v):
    return tuple(float(x) for x in tuple(v)[:3])


def _input_value(node, name, warnings):
    sock = node.inputs.get(name)
    if sock is None:
        return None
    if sock.is_linked:
        warnings.append(f"{node.name}.{name} is linked to a node; using its unlinked value")
    v = sock.default_value
    try:
        return tuple(v)
    except TypeError:
        return float(v)


def _below_one(rho, label, warnings):
    """rho clipped to [0, MAX_REFLECTANCE]. Cycles renders a white surface with a bounded number of
    bounces; the engine solves for all of them, and a surface that reflected all it gets would
    hold its light forever in a closed room."""
    rho = np.asarray(rho, np.float64)
    if (rho > MAX_REFLECTANCE).any():
        warnings.append(f"{label} reflect up to {rho.max():.3g} of the light; taken as {MAX_REFLECTANCE} "
                        "(a surface cannot reflect all the light it gets)")
    return np.clip(rho, 0.0, MAX_REFLECTANCE)


def _colour(node, name, warnings, textures):
    """A BSDF's colour input: (3,) array; ones when what varies it across a mesh (an image texture, a
    colour attribute, a Mix with one of those) goes to `textures`."""
    source = colour_texture.colour_source(node.inputs[name], warnings) if textures is not None else None
    if source is None:
        return np.array(_input_value(node, name, warnings)[:3])
    if not colour_texture.varies(source):   # a Mix of plain colours
        return colour_texture.mean_of(source, None)
    textures.append(source)
    return np.ones(3)


# MaterialExport.notes: what a material's lobes stand in for approximately, or leave out.
FROSTED = "frosted glass"                 # rough refraction, passed on as if clear
SPECULAR_LAYER = "specular layer"         # a Principled BSDF's dielectric reflection over its diffuse part
MEAN_FACTOR = "mean factor"               # a Mix's factor or an Alpha that varies over the mesh, as its mean
SUBSURFACE = "subsurface"
VOLUME = "volume"
FROSTED_ROUGHNESS = 0.1                   # glass rougher than this scatters its light visibly


def _zero():
    return np.zeros(3)


@dataclass
class Lobes:
    """What a shader does with the light it gets, per RGB channel: the diffuse reflectance, emitted
    radiance, and the lobes that pass light on undiffused, as the engine's Material takes them."""
    reflectance: np.ndarray = field(default_factory=_zero)
    emission: np.ndarray = field(default_factory=_zero)
    transmittance: np.ndarray = field(default_factory=_zero)   # straight through (Transparent BSDF, alpha)
    glass: np.ndarray = field(default_factory=_zero)           # refracting interface's colour
    ior: float = 1.45
    specular: np.ndarray = field(default_factory=_zero)        # mirror colour (Glossy BSDF, metal)
    roughness: float = 0.5                                     # of the specular lobe
    notes: frozenset = frozenset()
    # Where the surface is (Coverage): `transmittance` then passes where it is not, the other lobes
    # hold on average. None: transmittance everywhere.
    coverage: object = None

    COLOURS = ("reflectance", "emission", "transmittance", "glass", "specular")

    def scaled(self, f):
        """Every colour times f (a number); what a zero weight leaves has no notes."""
        return replace(self, notes=self.notes if f > 0 else frozenset(),
                       coverage=self.coverage if f > 0 else None, **{k: getattr(self, k) * f for k in self.COLOURS})

    def averaged(self):
        """The same with its transmittance as its mean over its coverage's places."""
        if self.coverage is None:
            return self
        return replace(self, transmittance=self.transmittance * (1 - self.coverage.mean), coverage=None,
                       notes=self.notes | {MEAN_FACTOR})

    def plus(self, other):
        """The sum of two shaders (an Add shader, the two sides of a Mix once weighted): colours add,
        the index of refraction and the roughness average by the glass and specular lobes they
        belong to. A coverage stays where the other shader passes no light straight through; else
        both go as their means."""
        if (self.coverage is not None and other.transmittance.any()) or \
                (other.coverage is not None and self.transmittance.any()):
            self, other = self.averaged(), other.averaged()

        def by(weight, key):
            wa, wb = float(np.mean(getattr(self, weight))), float(np.mean(getattr(other, weight)))
            a, b = getattr(self, key), getattr(other, key)
            return (wa * a + wb * b) / (wa + wb) if wa + wb > 0 else a
        return Lobes(**{k: getattr(self, k) + getattr(other, k) for k in self.COLOURS},
                     ior=by("glass", "ior"), roughness=by("specular", "roughness"), notes=self.notes | other.notes,
                     coverage=self.coverage if self.coverage is not None else other.coverage)


def _tint(node, name, warnings, images):
    """(3,) a colour input of a lobe that passes light on: its mean over the mesh where it varies."""
    source = colour_texture.colour_source(node.inputs[name], warnings)
    if source is None:
        return np.array(_input_value(node, name, warnings)[:3])
    return np.asarray(colour_texture.mean_of(source, images), np.float64)


def _factor(node, name, warnings, images):
    """(value, source) of a number input: an image's alpha or a colour's luminance linked into it
    (source: its texture.GrayRef) taken as its mean over the image, else its unlinked value (None)."""
    socket = node.inputs[name]
    value = colour_texture.input_number(node, socket, warnings, 0)
    if isinstance(value, float):
        return value, None
    return float(colour_texture.mean_of(value, images)), value


@dataclass(eq=False)
class Coverage:
    """Where a material's surface is, by place: what an Image Texture gives a factor (its alpha, or its
    colour's luminance), or one minus it where the factor weighs the transparent side. The engine
    reads it at each ray's crossing (its Material.alpha): an array to it (__array__), and equal to
    another of the same texels, which is what a change of material compares."""
    texture: object               # texture.TextureRef: its UV map and Mapping say where a mesh reads it
    texels: np.ndarray            # (H, W) float32 in [0, 1], rows from the bottom (texture.factor_texels)
    mean: float                   # of the texels, as the engine takes it

    def __array__(self, dtype=None, copy=None):
        return self.texels if dtype is None else self.texels.astype(dtype)

    def __eq__(self, other):
        return isinstance(other, Coverage) and np.array_equal(self.texels, other.texels)


def _coverage(source, images, inverted=False):
    """Coverage of a factor's source (_factor), or None where the engine cannot read it per place:
    anything but an image texture straight into the factor, or one that does not repeat (Repeat,
    the node's default, is what the engine reads)."""
    ref = source.colour if isinstance(source, colour_texture.GrayRef) else None
    if not isinstance(ref, colour_texture.TextureRef) or ref.extension != 'REPEAT':
        return None
    texels = colour_texture.factor_texels(ref, images)
    if inverted:
        texels = (1 - texels).astype(np.float32)
    return Coverage(ref, texels, float(texels.mean(dtype=np.float64)))


def _first(node, names):
    """The first of an input's names (Blender 3.x's, then 4.x's) the node has, or None."""
    return next((n for n in names if node.inputs.get(n) is not None), None)


def _number(node, names, warnings, default=0.0):
    name = _first(node, names)
    return default if name is None else float(_input_value(node, name, warnings))


def _principled(node, warnings, textures, emissions, images):
    """Lobes of a Principled BSDF (Blender 3.4's): Cycles' diffuse base times (1 - metallic)(1 -
    transmission), a metal mirror of the base colour times metallic, glass of it times transmission
    (1 - metallic), emission; Alpha a mixes all of it with a Transparent BSDF (every lobe times a,
    transmittance 1 - a), as Cycles expands the node."""
    before = len(textures) if textures is not None else 0
    base = _colour(node, "Base Color", warnings, textures)
    # a base colour that varies over the mesh: the diffuse lobe has it per corner, the others its mean
    tint = base if textures is None or len(textures) == before else \
        np.asarray(colour_texture.mean_of(textures[-1], images), np.float64)
    metal = _number(node, ("Metallic",), warnings)
    trans = _number(node, ("Transmission", "Transmission Weight"), warnings)
    roughness = _number(node, ("Roughness",), warnings, 0.5)
    ecol = _colour(node, _first(node, ("Emission", "Emission Color")), warnings, emissions)
    estr = _input_value(node, "Emission Strength", warnings)
    notes = set()
    dielectric = (1 - metal) * (1 - trans)
    if dielectric > 0 and _number(node, ("Specular", "Specular IOR Level"), warnings) > 0:
        notes.add(SPECULAR_LAYER)
    if _number(node, ("Subsurface", "Subsurface Weight"), warnings) > 0:
        notes.add(SUBSURFACE)
    glass_roughness = 1 - (1 - roughness) * (1 - _number(node, ("Transmission Roughness",), warnings))
    if trans * (1 - metal) > 0 and glass_roughness > FROSTED_ROUGHNESS:
        notes.add(FROSTED)
    alpha, source = _factor(node, "Alpha", warnings, images)
    coverage = _coverage(source, images)
    if coverage is not None:
        alpha = coverage.mean
    elif source is not None:
        notes.add(MEAN_FACTOR)
    lobes = Lobes(reflectance=base * dielectric, emission=ecol * (1.0 if estr is None else float(estr)),
                  glass=tint * trans * (1 - metal), ior=_number(node, ("IOR",), warnings, 1.45),
                  specular=tint * metal, roughness=roughness, notes=frozenset(notes))
    if alpha >= 1:
        return lobes
    if coverage is not None:   # white where the surface is not
        return lobes.scaled(alpha).plus(Lobes(transmittance=np.ones(3), coverage=coverage))
    return lobes.scaled(max(alpha, 0.0)).plus(Lobes(transmittance=np.full(3, 1 - max(alpha, 0.0))))


def _shader(node, warnings, depth=0, textures=None, emissions=None, images=None):
    """Lobes of a shader node. With `textures` (a list), what varies the node's own colour over a mesh
    is collected there and the colour taken as one; with `emissions`, the same for its emission
    colour. `images`: the export's texture.Images, for the means of colours that vary."""
    if node is None or depth > 16:
        return Lobes()
    t = node.type
    if t == 'BSDF_DIFFUSE':
        return Lobes(reflectance=_colour(node, "Color", warnings, textures))
    if t == 'EMISSION':
        c = _colour(node, "Color", warnings, emissions)
        return Lobes(emission=c * float(_input_value(node, "Strength", warnings)))
    if t == 'BSDF_PRINCIPLED':
        return _principled(node, warnings, textures, emissions, images)
    if t == 'BSDF_TRANSPARENT':
        return Lobes(transmittance=_tint(node, "Color", warnings, images))
    if t == 'BSDF_GLASS':
        frosted = float(_input_value(node, "Roughness", warnings)) > FROSTED_ROUGHNESS
        return Lobes(glass=_tint(node, "Color", warnings, images), ior=float(_input_value(node, "IOR", warnings)),
                     notes=frozenset({FROSTED}) if frosted else frozenset())
    if t in ('BSDF_GLOSSY', 'BSDF_ANISOTROPIC'):
        return Lobes(specular=_tint(node, "Color", warnings, images),
                     roughness=float(_input_value(node, "Roughness", warnings)))
    if t == 'ADD_SHADER':
        return _shader(_linked(node.inputs[0]), warnings, depth + 1, images=images).plus(
            _shader(_linked(node.inputs[1]), warnings, depth + 1, images=images))
    if t == 'MIX_SHADER':
        f, source = _factor(node, "Fac", warnings, images)
        f = min(max(f, 0.0), 1.0)
        a = _shader(_linked(node.inputs[1]), warnings, depth + 1, images=images)
        b = _shader(_linked(node.inputs[2]), warnings, depth + 1, images=images)
        # One side passes light straight through (a Transparent BSDF): the factor says, by place,
        # how much of the other is there, read by the engine per ray (leaves, curtains).
        clear = [x.transmittance.any() and x.coverage is None for x in (a, b)]
        coverage = None
        if source is not None and clear[0] != clear[1] and a.coverage is None and b.coverage is None:
            coverage = _coverage(source, images, inverted=clear[1])
        if coverage is not None:
            f = 1 - coverage.mean if clear[1] else coverage.mean
        mixed = a.scaled(1 - f).plus(b.scaled(f))
        if coverage is not None:
            return replace(mixed, transmittance=(b if clear[1] else a).transmittance, coverage=coverage)
        return replace(mixed, notes=mixed.notes | {MEAN_FACTOR}) if source is not None else mixed
    if t == 'GROUP' or t == 'REROUTE':
        warnings.append(f"{node.name}: {t} node not followed; treated as black")
        return Lobes()
    warnings.append(f"{node.name}: unsupported shader {t}; treated as black")
    return Lobes()


def _linked(socket):
    if socket is None or not socket.is_linked:
        return None
    return socket.links[0].from_node




def _material(name, lobes, warnings, texture=None, emission_texture=None):
    """MaterialExport of Lobes, each lobe brought into what the engine takes (reported where it was
    not): the diffuse one below one, each in [0, 1], together at most one per channel, the index of
    refraction in [1, 10], the roughness in [0, 1]."""
    rho = _below_one(lobes.reflectance, "its colours", warnings)
    tau, glass, spec = (np.clip(np.asarray(c, np.float64), 0.0, 1.0)
                        for c in (lobes.transmittance, lobes.glass, lobes.specular))
    # With a coverage, the transmittance passes where the surface is not: on average 1 - its mean.
    total = rho + tau * (1 - lobes.coverage.mean if lobes.coverage is not None else 1.0) + glass + spec
    if (total > 1).any():
        warnings.append(f"its lobes pass on up to {total.max():.3g} of the light; scaled down to one "
                        "(a surface cannot give out more light than it gets)")
        rho, tau, glass, spec = (c / np.maximum(total, 1.0) for c in (rho, tau, glass, spec))
    ior = float(np.clip(lobes.ior, 1.0, 10.0))
    if ior != lobes.ior and glass.any():
        warnings.append(f"index of refraction {lobes.ior:.3g} taken as {ior:.3g}")
    return MaterialExport(name, _rgb(rho), _rgb(np.maximum(lobes.emission, 0.0)), list(dict.fromkeys(warnings)),
                          texture, emission_texture, _rgb(tau), _rgb(glass), ior, _rgb(spec),
                          float(np.clip(lobes.roughness, 0.0, 1.0)), lobes.notes, lobes.coverage)


def material_values(mat, images=None):
    """MaterialExport for a bpy Material (or None: Cycles' default grey diffuse). `images`: the
    export's texture.Images."""
    images = colour_texture.Images() if images is None else images
    if mat is None:
        return MaterialExport("<default>", DEFAULT_REFLECTANCE, (0.0, 0.0, 0.0))
    warnings = []
    if mat.use_nodes and mat.node_tree is not None:
        out = display.user_output(mat.node_tree)
        if out is None:
            return MaterialExport(mat.name, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ["no material output"])
        textures, emissions = [], []
        lobes = _shader(_linked(out.inputs["Surface"]), warnings, textures=textures, emissions=emissions,
                        images=images)
        if out.inputs["Volume"].is_linked:
            lobes = replace(lobes, notes=lobes.notes | {VOLUME})
        # Where they cannot be read at the corners (no UVs...): texture.mean_of.
        source = textures[0] if textures else None
        if source is not None:
            source.factor = lobes.reflectance
            lobes = replace(lobes, reflectance=colour_texture.mean_of(source, images))
        emission_source = emissions[0] if emissions else None
        if emission_source is not None:
            emission_source.factor = lobes.emission
            lobes = replace(lobes, emission=colour_texture.mean_of(emission_source, images))
        return _material(mat.name, lobes, warnings, source, emission_source)
    return _material(mat.name, Lobes(reflectance=np.array(mat.diffuse_color[:3])), warnings)


def world_radiance(world, warnings=None, images=None):
    """(background radiance (3,), world map (H, W, 3) or None, [LightExport suns]) of a World: its
    Background node's colour times strength. An Environment Texture there gives what its image sends
    as the engine can take it (world.sky_lights): its suns as sun lamps, the rest as a map."""
    warnings = [] if warnings is None else warnings
    if world is None:
        return np.zeros(3), None, []
    if world.use_nodes and world.node_tree is not None:
        out = display.user_output(world.node_tree, ('OUTPUT_WORLD',))
        node = _linked(out.inputs["Surface"]) if out is not None else None
        if node is None:
            return np.zeros(3), None, []
        if node.type == 'BACKGROUND':
            c = node.inputs["Color"]
            strength = float(_input_value(node, "Strength", warnings))
            if not c.is_linked:
                return np.array(c.default_value[:3]) * strength, None, []
            source = c.links[0].from_node
            if source.type == 'TEX_ENVIRONMENT' and source.image is not None:
                images = colour_texture.Images() if images is None else images
                sky, rest, found = world_light.sky_lights(source, images)
                turn = world_light.environment_turn(source, warnings)
                suns = [LightExport(f"{world.name} sun {k}", "sun", direction=-_unit(turn @ towards),
                                    irradiance=irradiance * strength, angle=float(angle))
                        for k, (towards, irradiance, angle) in enumerate(found)]
                if rest is not None and not np.allclose(turn, np.eye(3)):
                    rest = world_light.turned_about_z(rest, turn)
                    if rest is None:
                        warnings.append(f"world: {source.image.name} turned by a Mapping node other than about "
                                        "z: its suns turn, its sky goes as a uniform sky of its mean")
                warnings.append(f"world: {source.image.name} as {len(suns)} sun lamp(s) and " +
                                (f"a {rest.shape[1]} x {rest.shape[0]} map of the rest" if rest is not None
                                 else "a uniform sky of the rest"))
                return sky * strength, None if rest is None else rest * strength, suns
            warnings.append(f"world: a {source.type} node on the Background's colour is not followed; "
                            "the world's viewport colour is used")
            return np.array(world.color[:3]) * strength, None, []
        warnings.append(f"world: a {node.type} node is not followed; the world is black")
        return np.zeros(3), None, []
    return np.array(world.color[:3], dtype=np.float64), None, []


def export_materials_of(ob, registry, materials, images=None):
    """Slot -> scene-wide material index lookup table (int32 array, at least one entry)."""
    lut = []
    for slot in ob.material_slots:
        m = slot.material
        key = m.original.name if m is not None else None
        if key not in registry:
            registry[key] = len(materials)
            materials.append(material_values(m.original if m is not None else None, images))
        lut.append(registry[key])
    if not lut:
        if None not in registry:
            registry[None] = len(materials)
            materials.append(material_values(None))
        lut.append(registry[None])
    return np.asarray(lut, np.int32)


# ----------------------------------------------------------------------------- meshes
def _last_subsurf(ob):
    mods = [m for m in ob.modifiers if m.show_render]
    if mods and mods[-1].type == 'SUBSURF':
        return mods[-1]
    return None


def face_materials(me):
    """Mesh `me`'s faces' material indices (int32), read as the attribute they are, over ten times
    faster than through the faces. No attribute: every face has the first."""
    mi = np.zeros(len(me.polygons), np.int32)
    attribute = me.attributes.get("material_index")
    if attribute is not None and attribute.domain == 'FACE':
        attribute.data.foreach_get("value", mi)
    return mi


def mesh_arrays(me):
    """(positions f64 (N,3), face_sizes i32, face_vertices i32, material_index i32, loop_indices or None)."""
    nv, nf, nl = len(me.vertices), len(me.polygons), len(me.loops)
    co = np.empty(nv * 3, np.float32)           # matches the property type: the fast path
    me.vertices.foreach_get("co", co)
    sizes = np.empty(nf, np.int32)
    me.polygons.foreach_get("loop_total", sizes)
    starts = np.empty(nf, np.int32)
    me.polygons.foreach_get("loop_start", starts)
    lv = np.empty(nl, np.int32)
    me.loops.foreach_get("vertex_index", lv)
    mi = face_materials(me)
    contiguous = np.zeros(nf, np.int64)
    if nf:
        contiguous[1:] = np.cumsum(sizes[:-1], dtype=np.int64)
    loops = None
    if nf and (not np.array_equal(contiguous, starts) or sizes.sum() != nl):
        loops = (np.repeat(starts - contiguous, sizes) + np.arange(int(sizes.sum()))).astype(np.int32)
        lv = lv[loops]
    return co.reshape(-1, 3).astype(np.float64), sizes, lv, mi, loops


def _deforming(ob):
    """What Blender's evaluation makes of mesh object ob's data besides its last Subdivision Surface
    (which goes to the engine as cage and level): "modifier <name>" for its others Cycles applies,
    and "shape keys". (Modifiers compare with ==: each access makes a new Python object.)"""
    sub = _last_subsurf(ob)
    return [f"modifier {m.name}" for m in ob.modifiers if m.show_render and m != sub] + \
        (["shape keys"] if ob.data.shape_keys is not None else [])


def _needs_reevaluation(ob):
    """True when the mesh ob sends is not what the viewport's evaluation gives: its cage when
    something besides its last Subdivision Surface changes ob.data; else its render evaluation, where
    a modifier is shown in one of viewport and render only, or subdivides to another level there."""
    sub = _last_subsurf(ob)
    if sub is not None:
        return bool(_deforming(ob))
    return any(_evaluated_otherwise(m) for m in ob.modifiers)


def _evaluated_otherwise(m):
    """Whether modifier m does something else in the viewport than in renders."""
    return m.show_viewport != m.show_render or \
        (m.show_render and hasattr(m, "render_levels") and m.levels != m.render_levels)


def _render_meshes(objects, depsgraph, subdivided=False):
    """{name: Mesh copy} of `objects` (originals) as Cycles renders them (a bake evaluates for render,
    the viewport's depsgraph for the viewport): each modifier shown as in renders and at its render
    level, but the last Subdivision Surface off, as it goes to the engine as cage and level (on with
    `subdivided`: the mesh Cycles itself renders). One depsgraph update for all of them, then restore."""
    if not objects:
        return {}
    saved = []          # (modifier, show_viewport, levels or None)
    for ob in objects:
        sub = _last_subsurf(ob)
        for m in ob.modifiers:
            levels = m.levels if hasattr(m, "render_levels") else None
            saved.append((m, m.show_viewport, levels))
            m.show_viewport = m.show_render and (subdivided or m != sub)
            if levels is not None:
                m.levels = m.render_levels
    try:
        depsgraph.update()
        return {ob.name: bpy.data.meshes.new_from_object(ob.evaluated_get(depsgraph)) for ob in objects}
    finally:
        for m, shown, levels in saved:
            m.show_viewport = shown
            if levels is not None:
                m.levels = levels
        depsgraph.update()


def _keyed(idb):
    """Whether an action, drivers or NLA tracks drive the ID `idb` (None: no)."""
    ad = getattr(idb, "animation_data", None)
    return ad is not None and bool(ad.action is not None or len(ad.drivers) or len(ad.nla_tracks))


def _is_animated(ob):
    o = ob
    while o is not None:
        if _keyed(o):
            return True
        o = o.parent
    return False


def _corner_values(corners, gathered, emission=False):
    """(K,3) reflectance (emission) per exported corner, where a face's material's colour (emission
    colour) varies over the mesh: a texture sampled at the corners' UVs, a colour attribute read
    there, nodes of those; None when none does."""
    me, loops, sizes, face_materials, label = (corners.me, corners.loops, corners.sizes, corners.face_materials,
                                               corners.label)
    materials, images, warnings = gathered.materials, gathered.images, gathered.warnings
    source_of = (lambda m: m.emission_texture) if emission else (lambda m: m.texture)
    textured = {int(i) for i in np.unique(face_materials) if source_of(materials[i]) is not None}
    if not textured:
        return None
    per_material = np.array([m.emission if emission else m.reflectance for m in materials], np.float64).reshape(-1, 3)
    rho = np.repeat(per_material[face_materials], sizes, axis=0)
    corner_material = np.repeat(face_materials, sizes)

    def values(source, at, material):
        """(n, 3) of `source` at the corners `at`, or (3,) where it does not vary; (n,) or a number
        for a GrayRef or a number."""
        if isinstance(source, colour_texture.MixRef):
            return colour_texture.blended(source, values(source.a, at, material), values(source.b, at, material),
                                          values(source.fac, at, material))
        if isinstance(source, colour_texture.AdjustRef):
            return colour_texture.adjusted(source, values(source.colour, at, material))
        if isinstance(source, colour_texture.GrayRef):
            return colour_texture.gray(values(source.colour, at, material))
        if isinstance(source, colour_texture.RampRef):
            return colour_texture.ramped(source, values(source.fac, at, material))
        if isinstance(source, colour_texture.AttributeRef):
            colours = colour_texture.attribute_colours(source, me, loops, label, warnings)
            return colours[at] if colours is not None else colour_texture.mean_of(source, images)
        if isinstance(source, colour_texture.TextureRef):
            uv = _uv_map(corners, source.uv_map)
            if uv is None:
                warnings.append(f"{label}: no UV map{' ' + source.uv_map if source.uv_map else ''} for the "
                                f"texture of {material}; its mean colour is used")
                return colour_texture.mean_of(source, images)
            return colour_texture.corner_colours(source, uv[at], images, (label, material))
        return source

    for i in sorted(textured):
        at = corner_material == i
        rho[at] = values(source_of(materials[i]), at, materials[i].name)
    return np.maximum(rho, 0.0) if emission else _below_one(rho, f"{label}'s texture colours", warnings)


def _uv_map(corners, name):
    """The exported corners' UVs (K, 2) of a UV map ("": the active render one), or None."""
    me, loops, sizes = corners.me, corners.loops, corners.sizes
    layer = me.uv_layers.get(name) if name else next((l for l in me.uv_layers if l.active_render),
                                                     me.uv_layers.active)
    if layer is not None and layer.name not in corners.uvs:
        uv = np.empty(len(me.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2).astype(np.float64)
        if loops is not None:
            uv = uv[loops]
        # A hair towards each face's middle, where Cycles reads a corner (texture.corner_colours).
        starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
        middle = np.repeat(np.add.reduceat(uv, starts) / sizes[:, None], sizes, axis=0)
        corners.uvs[layer.name] = uv + INSIDE * (middle - uv)
    return None if layer is None else corners.uvs[layer.name]


def _coverage_uvs(corners, gathered):
    """(K, 2) where each exported corner reads its face's material's coverage (MaterialExport.coverage:
    its texture's UV map through its Mapping node), zero at the faces of other materials; None where
    no face's material has one, or where the mesh lacks a map one of them reads: the engine takes
    UVs for a whole mesh, so all its materials then pass their means (said)."""
    materials = gathered.materials
    covered = [int(i) for i in np.unique(corners.face_materials) if materials[i].coverage is not None]
    if not covered:
        return None
    corner_material = np.repeat(corners.face_materials, corners.sizes)
    out = np.zeros((len(corner_material), 2))
    for i in covered:
        ref = materials[i].coverage.texture
        uv = _uv_map(corners, ref.uv_map)
        if uv is None:
            gathered.warnings.append(f"{corners.label}: no UV map{' ' + ref.uv_map if ref.uv_map else ''} for "
                                     f"the alpha of {materials[i].name}; the alpha of its materials goes as "
                                     "their means")
            return None
        at = corner_material == i
        out[at] = colour_texture.mapped_uv(ref, uv[at])
    return out


def _corner_keys(co, sizes, fv):
    """(K, 6) int64: each corner's position and its face's centre, bit for bit."""
    starts = np.concatenate(([0], np.cumsum(sizes)[:-1])).astype(np.int64)
    centre = np.add.reduceat(co[fv], starts, axis=0) / sizes[:, None] if len(sizes) else np.zeros((0, 3))
    return np.ascontiguousarray(np.hstack([co[fv], np.repeat(centre, sizes, axis=0)])).view(np.int64)


def _original_loops(orig_me, co, sizes, fv):
    """(K,) int32: the original mesh's loop at each exported corner, -1 at copies modifiers made
    (Mirror, Array, Solidify keep the original faces where they were, bit for bit); None unless
    every original loop is found (modifiers that move faces, or deform the mesh). Corners are
    looked up by a hash of their keys, then compared whole: np.unique over the rows is far slower
    on large meshes."""
    oco, osizes, ofv, _, oloops = mesh_arrays(orig_me)
    ko = _corner_keys(oco, osizes, ofv)
    ke = _corner_keys(co, sizes, fv)
    if not len(ko):
        return np.full(len(ke), -1, np.int32)

    def mixed(x):   # splitmix64's finaliser: every input bit moves every output bit
        with np.errstate(over='ignore'):
            x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return x ^ (x >> np.uint64(31))

    def hashed(k):
        h = np.zeros(len(k), np.uint64)
        for column in k.view(np.uint64).T:
            h = mixed(h ^ mixed(column))
        return h
    ho = hashed(ko)
    order = np.argsort(ho, kind='stable')
    at = order[np.minimum(np.searchsorted(ho[order], hashed(ke)), len(ko) - 1)]
    found = (ko[at] == ke).all(1)
    covered = np.zeros(len(ko), bool)
    covered[at[found]] = True
    if not covered.all():
        return None
    original = at if oloops is None else oloops[at]
    return np.where(found, original, -1).astype(np.int32)


def export_mesh(ob_eval, matrix, gathered, name=None, rendered=None):
    """MeshExport of one evaluated object; its materials and what the export cannot reproduce go to
    `gathered` (_Gathered). `rendered`: its mesh as renders evaluate it, where that is not the
    viewport's (_render_meshes)."""
    warnings = gathered.warnings
    lut = export_materials_of(ob_eval, gathered.registry, gathered.materials, gathered.images)
    orig = ob_eval.original
    sub = _last_subsurf(orig) if orig.type == 'MESH' else None   # a curve's is Blender's to apply
    refine, level = "bilinear", 0
    if sub is not None:
        level = int(sub.render_levels)
        if sub.subdivision_type == 'CATMULL_CLARK' and level > 0:
            refine = "catmull_clark"
        else:                   # Simple subdivision keeps flat faces flat: the engine's own bilinear
            level = 0
    if rendered is not None or sub is not None:
        me = rendered if rendered is not None else orig.data
        cleanup = lambda: None
    else:
        me = ob_eval.to_mesh()
        cleanup = ob_eval.to_mesh_clear
    matches = orig.type == 'MESH' and len(me.loops) == len(orig.data.loops) and \
        len(me.polygons) == len(orig.data.polygons)
    try:
        co, sizes, fv, mi, loops = mesh_arrays(me)
        original = loops
        if not matches and orig.type == 'MESH' and (name or orig.name) == orig.name:
            # colours for the faces the modifiers kept (an instance's are not written)
            original = _original_loops(orig.data, co, sizes, fv)
            matches = original is not None
        fm = lut[np.clip(mi, 0, len(lut) - 1)]
        corners = _Corners(me, loops, sizes, fm, name or ob_eval.name)
        rho = _corner_values(corners, gathered)
        emitted = _corner_values(corners, gathered, emission=True)
        uv = _coverage_uvs(corners, gathered)
        smooth = np.empty(len(me.polygons), bool)
        me.polygons.foreach_get("use_smooth", smooth)
        if me.use_auto_smooth and smooth.any():
            warnings.append(f"{name or ob_eval.name}: Auto Smooth's sharp edges are not split "
                            "(smooth faces shade with vertex normals)")
    finally:
        cleanup()
    return MeshExport(name or ob_eval.name, co, sizes, fv, fm.astype(np.int32),
                      np.array(matrix, np.float64), refine, level, original, matches,
                      _is_animated(orig), orig.name, smooth=smooth, corner_reflectance=rho, object_type=orig.type,
                      corner_emission=emitted, deforms=orig.type == 'MESH' and bool(_deforming(orig)),
                      corner_uv=uv)


# ----------------------------------------------------------------------------- lights
def _unit(v):
    v = np.asarray(v, np.float64)
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


def light_values(ob_eval, matrix, name=None):
    L = ob_eval.data
    M = np.array(matrix, np.float64)
    color = np.array(L.color[:3], np.float64)
    pos = M[:3, 3].copy()
    down = _unit(-M[:3, 2])                          # lamps point along their local -Z
    le = LightExport(name or ob_eval.name, L.type.lower(), position=pos, direction=down)
    if L.type in ('POINT', 'SPOT'):
        le.intensity = color * L.energy * POINT_INTENSITY_PER_WATT
        le.radius = float(L.shadow_soft_size)
        if L.type == 'SPOT':
            le.spot_size = float(L.spot_size)
            le.spot_blend = float(L.spot_blend)
    elif L.type == 'SUN':
        le.irradiance = color * L.energy
        le.angle = float(L.angle)
        le.position = None
    elif L.type == 'AREA':
        sx = float(L.size)
        sy = float(L.size_y) if L.shape in ('RECTANGLE', 'ELLIPSE') else sx
        u = M[:3, 0] * (sx / 2)
        v = M[:3, 1] * (sy / 2)
        if np.linalg.det(M[:3, :3]) < 0:               # mirrored: keep -(u x v) = the lamp's -Z
            u, v = v, u
        ellipse = L.shape in ('DISK', 'ELLIPSE')
        le.shape = "disc" if ellipse else "rect"
        lu, lv = np.linalg.norm(u), np.linalg.norm(v)
        le.area = float(math.pi * lu * lv if ellipse else 4.0 * lu * lv)
        le.u_half_axis, le.v_half_axis = u, v
        le.radiance = color * L.energy * AREA_RADIANCE_FACTOR / le.area if le.area > 0 else np.zeros(3)
        if ellipse and abs(lu - lv) > 1e-6 * max(lu, lv):
            le.warnings.append(f"{le.name}: elliptic area lamp ({2*lu:.3g} x {2*lv:.3g}); "
                               "radiance is exact, the engine's disc uses radius |u|")
        spread = getattr(L, "spread", math.pi)
        if spread < math.pi - 1e-6:
            le.warnings.append(f"{le.name}: spread {math.degrees(spread):.0f} deg ignored (treated as 180)")
    return le


def dark(l):
    """LightExport `l` hidden: the same lamp, with no power. A Solver keeps the lamps it was built with
    by index, so hiding or showing a lamp is a change of its power, not a new Solver."""
    def zero(v):
        return None if v is None else np.zeros(3)
    return replace(l, visible=False, intensity=zero(l.intensity), irradiance=zero(l.irradiance),
                   radiance=zero(l.radiance))


# ----------------------------------------------------------------------------- scene
def _shown_collections(scene, hidden):
    """The scene's collections (as_pointer()s) reached from the scene's own collection without passing
    through one whose flag `hidden` is set: "hide_render", those whose objects Cycles renders;
    "hide_viewport", those whose objects the viewport's depsgraph holds (not disabled in viewports)."""
    shown, stack = set(), [scene.collection]
    while stack:
        c = stack.pop()
        if c.as_pointer() in shown or getattr(c, hidden):
            continue
        shown.add(c.as_pointer())
        stack.extend(c.children)
    return shown


def _in(ob, collections, hidden):
    """`ob` is shown in one of `collections` (_shown_collections(scene, hidden)) and not itself hidden."""
    return not getattr(ob, hidden) and any(c.as_pointer() in collections for c in ob.users_collection)


def _stored_matrix(ob, depsgraph, enabled):
    """(object -> world matrix, None) of `ob`, an object the viewport's depsgraph does not evaluate
    (disabled in viewports), from what is stored in it; or (None, why not). Stored, its location,
    rotation and scale (deltas too: matrix_basis) are the user's, but its matrix_world is the one of
    its last evaluation, stale once its parent moved. What animation, drivers, constraints or physics
    make of it only an evaluation knows. In float32, multiplied as Blender does: an object disabled
    in viewports goes with the bits it had shown (live update sees no move). `enabled`:
    _shown_collections(scene, "hide_viewport")."""
    if _keyed(ob) or ob.rigid_body is not None or any(not c.mute for c in ob.constraints):
        return None, f"the animation, constraints or physics of {ob.name}"
    basis = np.array(ob.matrix_basis, np.float32)
    p = ob.parent
    if p is None:
        return basis, None
    if ob.parent_type != 'OBJECT' or getattr(p.data, "use_path", False):   # a bone, vertices, a path
        return None, f"its parenting to {p.name} ({ob.parent_type.lower()})"
    ev = p.evaluated_get(depsgraph)
    if ev.is_evaluated and _in(p, enabled, "hide_viewport"):
        parent = np.array(ev.matrix_world, np.float32)
    else:
        parent, why = _stored_matrix(p, depsgraph, enabled)
        if parent is None:
            return None, why
    return parent @ np.array(ob.matrix_parent_inverse, np.float32) @ basis, None


def _from_data(ob, depsgraph, enabled):
    """(matrix, None) when what Cycles renders of `ob`, disabled in viewports, is its own data (a mesh
    with no modifier but a last Subdivision Surface, which goes as cage and level anyway; a lamp)
    placed by _stored_matrix; else (None, what only Blender's evaluation applies)."""
    if ob.type not in ('MESH', 'LIGHT'):
        return None, f"turning its {ob.type.lower()} data into faces"
    applied = _deforming(ob) if ob.type == 'MESH' else []
    if applied:
        return None, f"its {applied[0]}"
    if _keyed(ob.data):
        return None, f"the animation of its {ob.type.lower()} data"
    return _stored_matrix(ob, depsgraph, enabled)


# Object types whose evaluated geometry Cycles renders as surfaces (hair curves and point clouds it
# does not draw as faces). Curves, text, surfaces and metaballs light the scene but hold no colours.
GEOMETRY = ('MESH', 'CURVE', 'FONT', 'SURFACE', 'META')


def _hidden_in_viewports(depsgraph, listed, rendered, warnings):
    """export_scene's items for the objects Cycles renders but the viewport hides, which the depsgraph's
    object_instances leaves out (`listed`: the names it gave; `rendered`: _shown_collections(scene,
    "hide_render")). Hidden with H (or a collection's eye), an object is evaluated all the same and
    goes as if shown. Disabled in viewports (its own or a collection's monitor icon), it is not
    evaluated: it goes as its own data (_from_data), or, where Cycles renders more than that, stays
    out of the lighting with a warning saying why and what to do."""
    view_layer = depsgraph.view_layer
    enabled = _shown_collections(depsgraph.scene, "hide_viewport")
    items = []
    for ob in view_layer.objects:
        # An object the iterator left out but visible is an instancer not shown as itself.
        if (ob.type not in GEOMETRY and ob.type != 'LIGHT') or ob.name in listed \
                or ob.visible_get(view_layer=view_layer) or not _in(ob, rendered, "hide_render"):
            continue
        ev = ob.evaluated_get(depsgraph)
        if ev.is_evaluated and _in(ob, enabled, "hide_viewport"):
            items.append((ob, ob.type, np.array(ev.matrix_world, np.float64), ob.name, True, True))
            continue
        M, why = _from_data(ob, depsgraph, enabled)
        if M is None:
            warnings.append(f"'{ob.name}' is disabled in viewports but renders; it is left out of the lighting: "
                            f"{why}, which only Blender's evaluation applies, and a disabled object gets "
                            "none. Enable it in viewports (hidden with H it is still lit) or disable it in "
                            "renders")
        else:
            items.append((ob, ob.type, M, ob.name, True, False))
    return items


def export_scene(depsgraph=None, images=None):
    """Export the evaluated scene. Meshes and lamps hidden from render are exported too (meshes with
    visible=False, lamps dark()): a Solver built from the export can show them later without a rebuild.
    Those hidden in the viewport but rendered light the scene as Cycles renders them
    (_hidden_in_viewports). Instanced meshes light it too, and are named "name[i]".
    `images`: a texture.Images that earlier exports of the same images used (other frames of the
    same scene, no edit between); None: every image read anew."""
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    scene = depsgraph.scene_eval
    registry, materials, meshes, lights, warnings = {}, [], [], [], []
    images = colour_texture.Images() if images is None else images
    gathered = _Gathered(registry, materials, images, warnings)
    # Collect first: _render_meshes re-evaluates the depsgraph, invalidating the iterator.
    items = []          # (original object, type, matrix, name, visible, evaluated: read from the depsgraph)
    listed = set()      # the objects the iterator gave as themselves
    counts = {}
    instancers = {}     # {instancer: names of the meshes it instances}
    rendered = _shown_collections(scene.original, "hide_render")
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type not in GEOMETRY and ob.type != 'LIGHT':
            continue
        if inst.is_instance and ob.type == 'MESH' and ob.original.type != 'MESH':
            continue   # a curve's (text's...) evaluated mesh: listed beside the curve, exported as it
        # An instance's source collection is often hidden from render on purpose: only the object's own
        # flag counts there.
        visible = (inst.is_instance and not ob.original.hide_render) or _in(ob.original, rendered, "hide_render")
        if inst.is_instance:
            counts[ob.name] = counts.get(ob.name, 0) + 1
            name = f"{ob.name}[{counts[ob.name] - 1}]"
            if visible and ob.type == 'MESH':
                instancers.setdefault(inst.parent.original.name, set()).add(ob.original.name)
        else:
            name = ob.name
            listed.add(name)
        items.append((ob.original, ob.type, np.array(inst.matrix_world, np.float64), name, visible, True))
    items += _hidden_in_viewports(depsgraph, listed, rendered, warnings)
    if instancers:
        # BakeJob.colours() writes none: an instance has no mesh of its own to hold them.
        held = [f"{k} ({', '.join(sorted(v))})" for k, v in sorted(instancers.items())]
        warnings.append("instanced meshes light the scene but get no colours (a mesh holds one set, which every "
                        "instance of it shows): " + "; ".join(held[:5]) + (" ..." if len(held) > 5 else "")
                        + "; Object > Apply > Make Instances Real (then Make Local, for linked ones) gives "
                        "each its own")
    todo = {o.name: o for o, kind, *_ in items if kind == 'MESH' and _needs_reevaluation(o)}
    rendered_meshes = _render_meshes(list(todo.values()), depsgraph)
    try:
        for orig, kind, M, name, visible, evaluated in items:
            ev = orig.evaluated_get(depsgraph) if evaluated else orig
            if kind in GEOMETRY:
                m = export_mesh(ev, M, gathered, name, rendered_meshes.get(orig.name))
                m.visible = visible
                if len(m.face_sizes):
                    meshes.append(m)
            elif visible:
                le = light_values(ev, M, name)
                warnings += le.warnings
                lights.append(le)
            else:
                lights.append(dark(light_values(ev, M, name)))
        world, world_map, suns = world_radiance(scene.world, warnings, images)
        lights += suns
    finally:
        images.end_export()
        for me in rendered_meshes.values():
            bpy.data.meshes.remove(me)
    for m in materials:
        warnings += [f"material {m.name}: {w}" for w in m.warnings]
    return SceneExport(meshes, materials, lights, world, scene.frame_current, warnings, world_map)


# ----------------------------------------------------------------------------- engine feed
def lamp_args(l):
    """What the engine takes of LightExport `l`: the arguments of Scene.add_{kind}_light, and of
    Solver.set_{kind}_light after the lamp's index."""
    if l.kind == "point":
        return l.position, l.intensity, l.radius
    if l.kind == "spot":
        return l.position, l.direction, l.intensity, l.radius, l.spot_size, l.spot_blend
    if l.kind == "sun":
        return l.direction, l.irradiance, l.angle
    return l.position, l.u_half_axis, l.v_half_axis, l.radiance, l.shape


def to_engine(sx, engine, patch_size=0.0, dynamic=None, after=None):
    """Build an engine Scene from a SceneExport. `engine` is the radiosity_engine module (passed in,
    so this file imports without it). `dynamic`: None = animated objects, or a set of mesh names.
    `after`: a SceneExport that `sx` extends (scene_diff.align_export): only the materials, meshes and
    lamps past after's, as Solver.add takes them (material indices count after's materials).
    Returns (scene, {mesh name: engine object id})."""
    first = (len(after.materials), len(after.meshes), len(after.lights)) if after else (0, 0, 0)
    s = engine.Scene()
    for m in sx.materials[first[0]:]:
        s.add_material(m.reflectance, **m.lobes())
    ids = {}
    for m in sx.meshes[first[1]:]:
        dyn = m.animated if dynamic is None else (m.name in dynamic)
        ids[m.name] = first[1] + s.add_mesh(
            m.positions, m.face_sizes, m.face_vertices, np.asarray(m.face_materials, np.int32), m.transform,
            refine=m.refine, level=m.level, patch_size=patch_size, dynamic=bool(dyn), name=m.name,
            visible=m.visible, smooth=m.smooth, corner_reflectance=m.corner_reflectance,
            corner_emission=m.corner_emission, deforms=m.deforms, corner_uv=m.corner_uv)
    for l in sx.lights[first[2]:]:
        getattr(s, f"add_{l.kind}_light")(*lamp_args(l))
    if sx.world_map is not None:
        s.set_world_map(np.asarray(sx.world_map, np.float64))
    else:
        s.set_world(np.asarray(sx.world, np.float64))
    return s, ids

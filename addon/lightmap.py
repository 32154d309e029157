"""Lightmaps: per lit mesh a float image `<object name>_Radiosity` laid out in its RadiosityUV map,
each texel the light at the surface point it shows (Solver.surface_radiance: its own direct light,
the solution's reflected light), in the units of the Radiosity attribute, what Cycles' COMBINED
bake writes into an image texture.

This module lays texels out and evaluates them; a still bake (lightmap_still.py), live update
(lightmap_updates.py) and Bake Animation (lightmap_sequence.py) decide when. Written images are
packed into the .blend.
"""
import math
import os

import bpy
import numpy as np

from . import export, texel_filter, texel_padding, texel_raster, uv_charts

IMAGE_SUFFIX = "_Radiosity"
AVERAGED_AT_ONCE = 65536   # texels averaged in one engine call: bounds the memory of their samples


def image_name(object_name):
    return object_name + IMAGE_SUFFIX


def surface_area(ob):
    """ob's mesh area in world units: object-space face areas scaled by the transform (exact for a
    uniform scale, the mean for another)."""
    me = ob.data
    areas = np.empty(len(me.polygons), np.float64)
    me.polygons.foreach_get("area", areas)
    scale = abs(np.linalg.det(np.array(ob.matrix_world, np.float64)[:3, :3])) ** (2.0 / 3.0)
    return float(areas.sum()) * scale


def image_size(ob, props):
    """The side of a new square image for ob: texel_density texels per metre across the square
    root of its area, within the minimum and maximum sizes. Lightmap Pack leaves part of the square
    between charts, so the texels on the surface are somewhat fewer."""
    side = math.ceil(math.sqrt(surface_area(ob)) * props.texel_density)
    return int(min(max(side, props.lightmap_min_size), props.lightmap_max_size))


def _triangles(me, layer):
    """(uv (T, 3, 2), face (T,), vertices (T, 3)) of me's loop triangles in UV layer `layer`."""
    me.calc_loop_triangles()
    t = len(me.loop_triangles)
    loops = np.empty(3 * t, np.int32)
    me.loop_triangles.foreach_get("loops", loops)
    vertices = np.empty(3 * t, np.int32)
    me.loop_triangles.foreach_get("vertices", vertices)
    faces = np.empty(t, np.int32)
    me.loop_triangles.foreach_get("polygon_index", faces)
    uv = np.empty(2 * len(me.loops), np.float32)
    layer.data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)[loops].reshape(t, 3, 2), faces, vertices.reshape(t, 3)


class Raster:
    """What a lightmap's texels show of a mesh, which its light does not change: each covered
    texel's triangle and barycentric point (texel_raster.py), each triangle's engine face and
    vertices, and how its barycentric coordinates step per texel (the footprint, texel_filter.py).
    `engine_face` and `positions` where me is not the engine's input mesh but a Subdivision
    Surface's subdivided mesh: per face of me the input face it lies on (the engine takes its points
    onto the limit surface it refines that face to), and me's vertices, object space."""

    def __init__(self, me, layer, width, height, engine_face=None, positions=None):
        uv, faces, self.vertices = _triangles(me, layer)
        self.faces = faces if engine_face is None else engine_face[faces]
        self.positions = positions
        self.width, self.height = width, height
        self.texel, self.triangle, self.bary = texel_raster.rasterise(uv, width, height)
        self.steps = texel_filter.barycentric_steps(uv * (width, height))


def texels(solver, index, positions, raster):
    """(height, width, 4) float32 RGBA: each covered texel of `raster` lit from `solver` (object
    `index`, whose input mesh has `positions`, object space), averaged over its footprint as
    Cycles' bake does where the light changes (texel_filter.py), the rest padded, alpha 1.
    Alpha is 1 on padding too: images are stored with colour premultiplied by alpha, so a padded
    texel of alpha 0 would lose its colour when packed or saved."""
    width, height = raster.width, raster.height
    texel, triangle, bary = raster.texel, raster.triangle, raster.bary
    corners = (positions if raster.positions is None else raster.positions)[raster.vertices]

    def light(triangle, bary):
        at = np.einsum("nk,nkj->nj", bary, corners[triangle])
        return solver.surface_radiance(index, raster.faces[triangle].astype(np.int32), np.ascontiguousarray(at))

    rgb = np.zeros((height * width, 3), np.float32)
    rgb[texel] = light(triangle, bary)
    covered = np.zeros(height * width, bool)
    covered[texel] = True
    edge = texel_filter.edges(rgb.reshape(height, width, 3), covered.reshape(height, width)).ravel()[texel]
    if edge.any():
        for part in np.array_split(np.flatnonzero(edge), max(1, int(edge.sum()) // AVERAGED_AT_ONCE)):
            points = texel_filter.footprint(bary[part], raster.steps[triangle[part]])
            values = light(np.repeat(triangle[part], points.shape[1]), points.reshape(-1, 3))
            rgb[texel[part]] = values.reshape(points.shape[0], points.shape[1], 3).mean(axis=1)
    rgb = texel_padding.pad(rgb.reshape(height, width, 3), covered.reshape(height, width))
    return np.concatenate([rgb, np.ones((height, width, 1), np.float32)], axis=2)


def targets(job):
    """(object, MeshExport) of every mesh object of `job` that gets a lightmap, and why others do not.
    The engine's faces must be the object's own mesh's, in order."""
    out, skipped = [], []
    for m in job.export.visible_meshes:
        ob = bpy.data.objects.get(m.object_name)
        if m.object_type != 'MESH' or m.name != m.object_name or ob is None or ob.type != 'MESH':
            continue
        me = ob.data
        if ob.library is not None or me.library is not None:
            skipped.append(f"'{ob.name}' uses linked library data: no lightmap")
        elif not m.matches_original or len(m.face_sizes) != len(me.polygons) or len(m.positions) != len(me.vertices):
            skipped.append(f"'{ob.name}': modifiers change its faces: no lightmap")
        elif not me.polygons:
            continue
        else:
            out.append((ob, m))
    return out, skipped


def layout(ob, props):
    """(width, height, RadiosityUV layer) of ob's lightmap: an existing image's size, else
    image_size(); the map made if missing. None when the mesh has no room for another UV map."""
    image = bpy.data.images.get(image_name(ob.name))
    size = None if image is None else size_of(image)
    if size is not None and size[0] > 0 and size[1] > 0:
        width, height = size
    else:
        width = height = image_size(ob, props)
    layer = uv_charts.ensure_uv_map(ob.data, max(width, height))
    return None if layer is None else (width, height, layer)


def size_of(image):
    """(width, height) of an image; of a sequence (Bake Animation's), its first file's: Blender
    reports a sequence's size only through an image user."""
    if image.source != 'SEQUENCE':
        return tuple(image.size)
    path = bpy.path.abspath(image.filepath, library=image.library)
    if not os.path.isfile(path):
        return None
    first = bpy.data.images.load(path, check_existing=False)
    try:
        return tuple(first.size)
    finally:
        bpy.data.images.remove(first)


def no_room(ob):
    return f"'{ob.name}' has no room for a UV map '{uv_charts.UV_MAP}': no lightmap"


def subdivided(ob, face_sizes, level):
    """(mesh, engine_face): ob's mesh as Cycles renders and bakes it, its Subdivision Surface on at
    its render level `level`, with the cage's UV maps subdivided as Blender subdivides them; and per
    face of it the cage face it comes from, None if the count is not Blender's. The caller removes
    the mesh. Blender's subdivided mesh holds each cage face's faces together, in the cage's order:
    an n-gon's n quads split into 4^(level - 1) each (a quad's 4^level)."""
    ob.data.update()       # a RadiosityUV map just made is subdivided too
    me = export._render_meshes([ob], bpy.context.evaluated_depsgraph_get(), subdivided=True)[ob.name]
    children = np.asarray(face_sizes, np.int64) * 4 ** (level - 1)
    if children.sum() != len(me.polygons):
        return me, None
    return me, np.repeat(np.arange(len(children), dtype=np.int32), children)


def raster(ob, m, layer, width, height):
    """(Raster of ob's lightmap, None), or (None, why it gets none). A Subdivision Surface object's
    texels follow the subdivided mesh Cycles renders and bakes, and its UVs."""
    if m.refine != "catmull_clark":
        return Raster(ob.data, layer, width, height), None
    me, engine_face = subdivided(ob, m.face_sizes, m.level)
    try:
        if engine_face is None:
            return None, f"'{ob.name}': its subdivided mesh's faces are not in Blender's order: no lightmap"
        co = np.empty(3 * len(me.vertices), np.float64)
        me.vertices.foreach_get("co", co)
        return Raster(me, me.uv_layers[uv_charts.UV_MAP], width, height, engine_face, co.reshape(-1, 3)), None
    finally:
        bpy.data.meshes.remove(me)


def write_image(name, width, height, rgba):
    """Writes (height, width, 4) pixels into image `name`, made float if missing, and packs it.
    A sequence (Bake Animation's) becomes a single image again."""
    image = bpy.data.images.get(name)
    if image is not None and image.source == 'SEQUENCE':
        image.source = 'GENERATED'
        image.generated_width, image.generated_height, image.use_generated_float = width, height, True
    if image is None or tuple(image.size) != (width, height):
        if image is not None:      # an empty image (no pixels to write into) is made anew
            bpy.data.images.remove(image)
        image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    image.use_fake_user = True     # kept in the .blend while no material uses it yet
    image.pixels.foreach_set(np.ascontiguousarray(rgba, np.float32).ravel())
    image.file_format = 'OPEN_EXR'
    image.pack()
    image.update()
    return image


def images_of(scene):
    """The lightmap images of the scene's mesh objects that exist."""
    return [image for ob in scene.objects if ob.type == 'MESH'
            for image in [bpy.data.images.get(image_name(ob.name))] if image is not None]


def save_exr(images, folder):
    """Writes each image as `<folder>/<image name>.exr` (float, as the pixels are); returns the paths.
    The images keep their own file paths."""
    folder = bpy.path.abspath(folder)
    os.makedirs(folder, exist_ok=True)
    paths = []
    for image in images:
        path = os.path.join(folder, bpy.path.clean_name(image.name) + ".exr")
        kept = image.filepath_raw, image.file_format
        image.filepath_raw, image.file_format = path, 'OPEN_EXR'
        try:
            image.save()
        finally:
            image.filepath_raw, image.file_format = kept
        paths.append(path)
    return paths

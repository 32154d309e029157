"""Smooth and flat shading as Cycles bakes it: Shade Smooth faces take interpolated vertex normals
(a Subdivision Surface object's limit normals), flat ones their face's. Checked on direct light,
where Cycles' vertex bake is exact at a few samples (a point lamp without radius, no bounces), so
the comparison is tight and fast: a corner's direct light follows the cosine of its shading normal
to the lamp, and a wrong normal shows at once.

The flat Subdivision Surface cube keeps 7%: its level-2 quads are not planar, and Cycles shades a
flat quad by the two triangles it cuts it into, each with its own normal, where a patch has one
(the mean). Shaded the other way (a smooth sphere as flat, a flat cube as smooth), each is 36-38% off.
"""
import os
import sys

import bpy
import numpy as np
import pytest

from conftest import ROOT, load_engine

engine = load_engine()
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
import cycles_settings  # noqa: E402
import reference  # noqa: E402


def lit_object(kind, smooth):
    """An empty scene holding one object (a 16 x 8 UV sphere, or a cube under a level-2 Subdivision
    Surface) shaded smooth or flat, lit by a point lamp above and to the side."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cycles_settings.unbiased(scene, 4, 0, 0)  # direct light only: exact at any sample count
    scene.render.bake.target = 'VERTEX_COLORS'
    if kind == "sphere":
        bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=1.0)
    else:
        bpy.ops.mesh.primitive_cube_add(size=1.5)
        sub = bpy.context.object.modifiers.new("Subdivision", 'SUBSURF')
        sub.levels = sub.render_levels = 2
    ob = bpy.context.object
    ob.data.polygons.foreach_set("use_smooth", [smooth] * len(ob.data.polygons))
    ob.data.update()
    diffuse(ob).inputs["Color"].default_value = (0.7, 0.7, 0.7, 1)
    point_lamp(scene, 500.0, (2.0, -1.0, 3.0))
    return ob


def diffuse(ob):
    """A Diffuse BSDF material on ob (Principled's specular layer would add a highlight): its node."""
    mat = bpy.data.materials.new(ob.name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    mat.node_tree.links.new(bsdf.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
    ob.data.materials.append(mat)
    return bsdf


def point_lamp(scene, watts, location):
    """A point lamp without radius: its direct light at a corner is exact at any sample count."""
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'POINT'))
    lamp.data.energy = watts
    lamp.data.shadow_soft_size = 0.0
    lamp.location = location
    scene.collection.objects.link(lamp)


def direct_light(export, ob):
    """Our corner values of ob in the scene as exported: the lamps' light, gathered, nothing
    reflected (and no near-field bounce: not in a bake without bounces)."""
    scene, ids = export.to_engine(export.export_scene(), engine)
    settings = engine.Settings.preset("draft")
    settings.max_shots = 0
    settings.exact_near_direct = False
    solver = engine.Solver(scene, settings)
    solver.solve()
    return solver.corner_radiance(ids[ob.name])


def direct_light_grid(subdivisions, size, samples=4, keep=False):
    """(scene, grid): an empty scene (`keep`: the scene as it is) that Cycles bakes with direct light
    only (exact at any sample count for lamps without a size), and a grid in it."""
    if not keep:
        bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    cycles_settings.unbiased(scene, samples, 0, 0)
    scene.render.bake.target = 'VERTEX_COLORS'
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=subdivisions, y_subdivisions=subdivisions, size=size)
    return scene, bpy.context.object


def cycles_corners(ob):
    a = ob.data.color_attributes.new("CyclesRef", 'FLOAT_COLOR', 'CORNER')
    ob.data.color_attributes.active_color = a
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)
    bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')
    c = np.empty(len(a.data) * 4, np.float32)
    a.data.foreach_get("color", c)
    return c.reshape(-1, 4)[:, :3]


# (object, smooth) -> bound: the measured relative RMS over the corners against Cycles, with a margin
BOUNDS = {("sphere", True): 0.003,           # 0.063%
          ("sphere", False): 0.003,          # 0.087%
          ("subsurf_cube", True): 0.003,     # 0.029%
          ("subsurf_cube", False): 0.09}     # 7.06%


@pytest.mark.parametrize("kind, smooth", BOUNDS, ids=[f"{k}-{'smooth' if s else 'flat'}" for k, s in BOUNDS])
def test_direct_light_follows_the_shading(export, kind, smooth):
    ob = lit_object(kind, smooth)
    ref = cycles_corners(ob)
    err = reference.relative_rms(direct_light(export, ob), ref)
    print(f"\n  {kind} {'smooth' if smooth else 'flat'}: {100 * err:.3f}% RMS against Cycles", end="")
    assert err < BOUNDS[kind, smooth]


def test_curve_and_text_objects_cast_their_shadows_as_in_cycles(export):
    """Curves, text, surfaces and metaballs are surfaces to Cycles: they block and reflect light,
    though they hold no colour attribute. The export takes text and curves as the objects they are,
    not as the instances of objects with no loops their evaluated meshes come as, and metaballs too."""
    scene, floor = direct_light_grid(24, 4.0)
    diffuse(floor)
    bpy.ops.object.text_add(location=(-1.3, -0.7, 0.9))
    text = bpy.context.object
    text.data.body, text.data.size, text.data.extrude = "HI", 1.4, 0.05
    bpy.ops.curve.primitive_bezier_circle_add(radius=0.5, location=(0.9, 0.8, 0.6))
    bpy.context.object.data.bevel_depth = 0.08
    bpy.ops.object.metaball_add(type='BALL', radius=0.4, location=(0.9, -1.0, 0.7))
    point_lamp(scene, 500.0, (0.2, -0.1, 3.0))
    bpy.ops.object.select_all(action='DESELECT')   # Cycles bakes what is selected
    ref = cycles_corners(floor)
    dark = ref.max(1) < 0.05 * ref.max()
    assert dark.sum() >= 30, dark.sum()   # the three cast shadows over many corners
    err = reference.relative_rms(direct_light(export, floor), ref)
    print(f"\n  floor under text, a bevelled curve and a metaball: {100 * err:.3f}% RMS against Cycles", end="")
    assert err < 0.005
    sx = export.export_scene()   # each once (the depsgraph also lists their meshes as instances)
    assert sorted(m.object_type for m in sx.meshes) == ['CURVE', 'FONT', 'MESH', 'META']


@pytest.mark.parametrize("turn", [0.0, 40.0])
def test_an_hdri_sun_lights_and_shadows_as_in_cycles(export, turn):
    """A world image with a small, very bright sun: Cycles samples it where it is; the export sends
    it as a sun lamp there and the rest as the engine's world map, turned as a Mapping node turns
    the image (`turn` degrees about z). Direct light on a floor round a box, and on the box."""
    import test_export
    scene, floor = direct_light_grid(24, 4.0, samples=256)   # the sky's light is sampled
    diffuse(floor)
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.0, 0.0, 0.4))
    box = bpy.context.object
    test_export.sky_world(scene, turn=turn)
    bpy.ops.object.select_all(action='DESELECT')
    ref = cycles_corners(floor)
    shade = ref.max(1) < 0.3 * ref.max()
    assert 100 <= shade.sum() <= 400, shade.sum()   # the box's shadow (and footprint)
    err = reference.relative_rms(direct_light(export, floor), ref)
    print(f"\n  floor round a box under an HDRI's sun and sky: {100 * err:.3f}% RMS against Cycles", end="")
    # 1.1%. With the sky of the rest uniform, 2.4% (the floor sees only its upper half in Cycles); with
    # the sun spread over it too (no sun lamp), 64%: the lit floor at 0.40 of Cycles, the shadow 3-8 times.
    assert err < 0.015   # 0.72-1.14%
    # The box's sides face different parts of the sky (a quarter of it bluer, round +y), each lit by
    # the ground and the sun or not.
    # Not its bottom, on the floor: Cycles' rays from there hit the floor, ours, set off below it, the
    # ground's part of the sky (1.2 against 0, any world; a face no one sees).
    ref = cycles_corners(box)
    normal_z = np.repeat([p.normal.z for p in box.data.polygons], [p.loop_total for p in box.data.polygons])
    seen = normal_z > -0.5
    err = reference.relative_rms(direct_light(export, box)[seen], ref[seen])
    print(f"; the box: {100 * err:.3f}%", end="")
    assert err < 0.012   # 0.59-0.72% (Cycles' seed is fixed); a map turned the wrong way gives 2.0%

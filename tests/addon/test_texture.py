"""A colour texture or a colour attribute on the BSDF's colour, taken at the face corners as Cycles
takes it. Checked on direct light (a point lamp without radius, no bounces), where Cycles' vertex
bake is exact at a few samples: each corner's value is the lamp's light times the colour there, so a
wrong texel convention, colour space, wrap, mapping or attribute domain shows at once."""
import os
import sys

import bpy
import numpy as np
import pytest

from conftest import ROOT, load_engine

load_engine()   # when collected: a missing or broken engine fails the run (conftest.load_engine)
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
import reference  # noqa: E402
from test_shading import cycles_corners, diffuse, direct_light, direct_light_grid, point_lamp  # noqa: E402

# 4 x 4 texels, each its own colour, none near white (the engine's limit is below one)
TEXELS = np.random.default_rng(7).uniform(0.05, 0.9, (4, 4, 3))


def textured_grid(interpolation, colorspace, uv_scale, mapping=None, subdivisions=6):
    """A 2 m grid (5 x 5 quads: `subdivisions` vertices a side) whose Diffuse BSDF takes its colour
    from the 4 x 4 image, under a lamp.
    `mapping`: (vector type, location, rotation, scale) of a Mapping node between a Texture
    Coordinate node's UV and the image."""
    scene, ob = direct_light_grid(subdivisions, 2.0)
    uv = np.empty(len(ob.data.loops) * 2, np.float32)
    ob.data.uv_layers.active.data.foreach_get("uv", uv)
    ob.data.uv_layers.active.data.foreach_set("uv", uv * uv_scale)   # past 1: the image repeats
    image = bpy.data.images.new("Texels", 4, 4, alpha=False)
    image.colorspace_settings.name = colorspace
    image.pixels.foreach_set(np.concatenate([TEXELS, np.ones((4, 4, 1))], 2).astype(np.float32).ravel())
    bsdf = diffuse(ob)
    tex = bsdf.id_data.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = interpolation
    bsdf.id_data.links.new(tex.outputs["Color"], bsdf.inputs["Color"])
    if mapping is not None:
        tree = bsdf.id_data
        node = tree.nodes.new("ShaderNodeMapping")
        node.vector_type, location, rotation, scale = mapping
        node.inputs["Location"].default_value = location
        node.inputs["Rotation"].default_value = rotation
        node.inputs["Scale"].default_value = scale
        coords = tree.nodes.new("ShaderNodeTexCoord")
        tree.links.new(coords.outputs["UV"], node.inputs["Vector"])
        tree.links.new(node.outputs["Vector"], tex.inputs["Vector"])
    point_lamp(scene, 300.0, (0.5, -0.3, 2.0))
    return ob


# Mappings: shifted, turned about each axis (a turn about x or y folds the plane of the UVs) and
# stretched unevenly, as a point and as a texture (its inverse), and one without a location.
TURN = (0.3, -0.2, 0.5)
MAPPINGS = {"point": ('POINT', (0.1, 0.25, 0.0), TURN, (1.3, 0.8, 1.0)),
            "texture": ('TEXTURE', (0.1, 0.25, 0.0), TURN, (1.3, 0.8, 1.0)),
            "vector": ('VECTOR', (0.0, 0.0, 0.0), TURN, (0.7, 1.6, 1.0))}
CASES = [("Linear", "sRGB", 1.0, None), ("Closest", "sRGB", 1.0, None), ("Linear", "Non-Color", 1.0, None),
         ("Linear", "sRGB", 1.7, None)] + [("Linear", "sRGB", 1.0, m) for m in MAPPINGS]


@pytest.mark.parametrize("interpolation, colorspace, uv_scale, mapping", CASES,
                         ids=[f"{i}-{c}-uv{s}" + (f"-{m}" if m else "") for i, c, s, m in CASES])
def test_texture_colours_reach_the_corners_as_cycles_bakes_them(addon, interpolation, colorspace, uv_scale, mapping):
    ob = textured_grid(interpolation, colorspace, uv_scale, MAPPINGS.get(mapping))
    corners_as_cycles_bakes_them(addon, ob, f"{interpolation} {colorspace} uv x{uv_scale} {mapping or ''}")


def corners_as_cycles_bakes_them(addon, ob, label):
    """Checks ob's corners' direct light against Cycles' vertex bake; returns the export."""
    ref = cycles_corners(ob)
    sx = addon.export.export_scene()
    assert sx.meshes[0].corner_reflectance is not None and not sx.warnings, sx.warnings
    err = reference.relative_rms(direct_light(addon.export, ob), ref)
    print(f"\n  {label}: {100 * err:.3f}% RMS against Cycles", end="")
    # the colours vary 18-fold from corner to corner: a wrong texel or colour space is tens of percent
    assert err < 0.003
    return sx


def test_texture_coordinates_not_followed_are_reported(addon):
    ob = textured_grid("Linear", "sRGB", 1.0, ('NORMAL', (0, 0, 0), TURN, (1, 1, 1)))
    assert any("Normal Mapping node is not followed" in w for w in addon.export.export_scene().warnings)
    tree = ob.active_material.node_tree
    tree.links.new(tree.nodes["Texture Coordinate"].outputs["Generated"], tree.nodes["Mapping"].inputs["Vector"])
    tree.nodes["Mapping"].vector_type = 'POINT'
    assert any("Texture Coordinate's Generated are not followed" in w for w in addon.export.export_scene().warnings)


def test_a_textured_bake_reports_the_texture_and_a_texture_change_re_adds_the_object(addon):
    ob = textured_grid("Linear", "sRGB", 1.0)
    scene = bpy.context.scene
    scene.radiosity.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    assert "colour textures" in scene.radiosity.last_effects
    before = addon.export.export_scene()
    image = bpy.data.images["Texels"]
    image.pixels.foreach_set(np.full(4 * 4 * 4, 0.5, np.float32))
    after = addon.export.export_scene()
    state = addon.scene_diff.align_export(before, after)
    retired = state.meshes[[m.name for m in before.meshes].index(ob.name)]
    assert not retired.visible and addon.scene_diff.RETIRED in retired.name   # re-added with the new colours
    assert state.meshes[-1].name == ob.name and not np.array_equal(
        state.meshes[-1].corner_reflectance, before.mesh(ob.name).corner_reflectance)


def test_white_is_taken_just_below_one_and_said_so(addon):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = bpy.data.materials.new("Snow")
    mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (1, 1, 1, 1)
    m = addon.export.material_values(mat)
    assert max(m.reflectance) == addon.export.MAX_REFLECTANCE < 1
    assert any("cannot reflect all" in w for w in m.warnings)


def test_frames_reuse_what_was_sampled_and_an_edit_reads_the_image_again(addon, monkeypatch):
    """Live update on frame changes reuses what earlier frames sampled from an image (reading a 4k image
    costs every frame's export tens of milliseconds); an edit reads it anew, so new pixels reach the colours."""
    live = addon.live_update
    ob = textured_grid("Linear", "sRGB", 1.0)
    scene = bpy.context.scene
    scene.radiosity.preset = 'DRAFT'
    ob.keyframe_insert("location", frame=1)
    ob.location.z += 0.2
    ob.keyframe_insert("location", frame=3)
    reads = []
    read = addon.texture._read
    monkeypatch.setattr(addon.texture, "_read", lambda image: reads.append(image.name) or read(image))

    def reflectance():
        return live.live_jobs[scene.name].exported.mesh(ob.name).corner_reflectance

    scene.frame_set(1)
    scene.radiosity.live_update = True
    scene.frame_set(1)
    assert live.last_sync[scene.name]["mode"] == "full" and reads == ["Texels"]
    first = reflectance()
    for f in (2, 3):
        scene.frame_set(f)
        assert live.last_sync[scene.name]["mode"] == "incremental"
    assert reads == ["Texels"]                        # the frames read no pixels
    assert np.array_equal(reflectance(), first)
    assert np.array_equal(addon.export.export_scene().mesh(ob.name).corner_reflectance, first)  # reads

    grey = 0.5
    opaque_grey = np.tile(np.float32([grey, grey, grey, 1.0]), 4 * 4)   # alpha 1: nothing premultiplied
    bpy.data.images["Texels"].pixels.foreach_set(opaque_grey)
    ob.location.x += 0.01                             # an edit: the depsgraph handler exports anew
    bpy.context.view_layer.update()
    assert live.last_sync[scene.name]["mode"] == "incremental" and reads == ["Texels"] * 3
    stored = round(grey * 255) / 255                  # an 8-bit image
    linear = ((stored + 0.055) / 1.055) ** 2.4
    assert np.allclose(reflectance(), linear, rtol=1e-6), reflectance()[:3]


ATTRIBUTES = [("FLOAT_COLOR", 'CORNER', "VERTEX_COLOR"), ("BYTE_COLOR", 'POINT', "ATTRIBUTE"),
              ("BYTE_COLOR", 'CORNER', "DEFAULT")]


@pytest.mark.parametrize("kind, domain, node", ATTRIBUTES, ids=[f"{k}-{d}-{n}" for k, d, n in ATTRIBUTES])
def test_colour_attribute_colours_reach_the_corners_as_cycles_bakes_them(addon, kind, domain, node):
    """A Color Attribute node (named, or the default: the render colour attribute) or an Attribute
    node's Color on the Diffuse BSDF: each corner takes the attribute's colour there."""
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    tree.nodes.remove(tree.nodes["Image Texture"])
    me = ob.data
    decoy = me.color_attributes.new("Decoy", 'FLOAT_COLOR', 'CORNER')   # not the one asked for
    decoy.data.foreach_set("color", np.ones(len(decoy.data) * 4, np.float32))
    attr = me.color_attributes.new("Paint", kind, domain)
    colours = np.random.default_rng(3).uniform(0.05, 0.9, (len(attr.data), 4)).astype(np.float32)
    attr.data.foreach_set("color", colours.ravel())
    if node == "ATTRIBUTE":
        source = tree.nodes.new("ShaderNodeAttribute")
        source.attribute_name = "Paint"
    else:
        source = tree.nodes.new("ShaderNodeVertexColor")
        source.layer_name = "Paint" if node == "VERTEX_COLOR" else ""
        me.color_attributes.render_color_index = me.color_attributes.find("Paint")
    tree.links.new(source.outputs["Color"], tree.nodes["Diffuse BSDF"].inputs["Color"])
    sx = corners_as_cycles_bakes_them(addon, ob, f"{kind} on {domain}, {node}")
    assert "colour attributes" in addon.effects.sentence(addon.effects.items(sx))


def test_a_colour_attribute_missing_or_the_bakes_own_output_is_reported(addon):
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    tree.nodes.remove(tree.nodes["Image Texture"])
    source = tree.nodes.new("ShaderNodeVertexColor")
    source.layer_name = "Paint"
    tree.links.new(source.outputs["Color"], tree.nodes["Diffuse BSDF"].inputs["Color"])
    sx = addon.export.export_scene()
    assert any("no colour attribute Paint" in w for w in sx.warnings), sx.warnings
    assert max(sx.materials[0].reflectance) == 0                 # black, as Cycles takes it:
    assert np.abs(cycles_corners(ob)).max() < 1e-6
    source.layer_name = addon.writeback.ATTRIBUTE
    sx = addon.export.export_scene()
    assert any("the bake's own output" in w for w in sx.warnings), sx.warnings
    assert sx.materials[0].texture is None and min(sx.materials[0].reflectance) > 0.5   # the unlinked grey


# (node, blend, factor, clamp, what A and B are): the texture, a colour attribute or a plain colour
MIXES = [("ShaderNodeMix", 'MULTIPLY', 0.8, False, ("image", (0.9, 0.5, 0.2))),
         ("ShaderNodeMixRGB", 'MIX', 0.3, False, ("image", "attribute")),
         ("ShaderNodeMix", 'SCREEN', 0.6, True, ((0.3, 0.6, 0.1), "image")),
         ("ShaderNodeMix", 'DIFFERENCE', 1.0, False, ("attribute", "image")),
         ("ShaderNodeMixRGB", 'LIGHTEN', 0.7, True, ("image", (0.5, 0.5, 0.5)))]


@pytest.mark.parametrize("kind, blend, fac, clamp, sides", MIXES, ids=[f"{k[10:]}-{b}" for k, b, *_ in MIXES])
def test_mixed_colours_reach_the_corners_as_cycles_bakes_them(addon, kind, blend, fac, clamp, sides):
    """A Mix node (or a legacy MixRGB) between the texture, a colour attribute and plain colours:
    each corner takes the blend of what its sides give there."""
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    image = tree.nodes["Image Texture"]
    paint = ob.data.color_attributes.new("Paint", 'FLOAT_COLOR', 'CORNER')
    paint.data.foreach_set("color", np.random.default_rng(5).uniform(0.05, 0.9, len(paint.data) * 4)
                           .astype(np.float32))
    attribute = tree.nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "Paint"
    mix = tree.nodes.new(kind)
    mix.blend_type = blend
    if kind == "ShaderNodeMix":
        mix.data_type, mix.clamp_result = 'RGBA', clamp
        fac_socket, a_socket, b_socket = (next(s for s in mix.inputs if s.identifier == i)
                                          for i in ("Factor_Float", "A_Color", "B_Color"))
        out = next(s for s in mix.outputs if s.identifier == "Result_Color")
    else:
        mix.use_clamp = clamp
        fac_socket, a_socket, b_socket, out = mix.inputs["Fac"], mix.inputs["Color1"], mix.inputs["Color2"], mix.outputs[0]
    fac_socket.default_value = fac
    for socket, what in zip((a_socket, b_socket), sides):
        if what == "image":
            tree.links.new(image.outputs["Color"], socket)
        elif what == "attribute":
            tree.links.new(attribute.outputs["Color"], socket)
        else:
            socket.default_value = (*what, 1.0)
    tree.links.new(out, tree.nodes["Diffuse BSDF"].inputs["Color"])
    corners_as_cycles_bakes_them(addon, ob, f"{kind[10:]} {blend}")


RAMPS = [('LINEAR', 'RGB'), ('CONSTANT', 'RGB'), ('EASE', 'RGB'), ('B_SPLINE', 'HSV')]


@pytest.mark.parametrize("interpolation, mode", RAMPS, ids=[f"{i}-{m}" for i, m in RAMPS])
def test_a_colour_ramp_on_the_texture_reaches_the_corners_as_cycles_bakes_it(addon, interpolation, mode):
    """A Color Ramp of three colours whose factor is the texture's colour (its luminance, as Cycles
    takes a colour for a number): each corner takes the ramp there, as Cycles' table of it gives."""
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    node = tree.nodes.new("ShaderNodeValToRGB")
    ramp = node.color_ramp
    ramp.interpolation, ramp.color_mode = interpolation, mode
    ramp.elements[0].position, ramp.elements[0].color = 0.1, (0.8, 0.1, 0.1, 1.0)
    ramp.elements[1].position, ramp.elements[1].color = 0.7, (0.1, 0.2, 0.8, 1.0)
    ramp.elements.new(0.35).color = (0.2, 0.7, 0.3, 1.0)
    tree.links.new(tree.nodes["Image Texture"].outputs["Color"], node.inputs["Fac"])
    tree.links.new(node.outputs["Color"], tree.nodes["Diffuse BSDF"].inputs["Color"])
    corners_as_cycles_bakes_them(addon, ob, f"ramp {interpolation} {mode}")


@pytest.mark.parametrize("kind", ["ShaderNodeMix", "ShaderNodeMixRGB"])
def test_a_mix_factor_from_a_texture_or_attribute_reaches_the_corners_as_cycles_bakes_it(addon, kind):
    """A Mix of the texture and a plain colour whose factor is a colour attribute's luminance (a Mix
    node), or the texture's own (a MixRGB), pushed past 0 and 1 by a Bright/Contrast and so clamped."""
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    image = tree.nodes["Image Texture"]
    mix = tree.nodes.new(kind)
    if kind == "ShaderNodeMix":
        mix.data_type = 'RGBA'
        fac, a, b = (next(s for s in mix.inputs if s.identifier == i) for i in ("Factor_Float", "A_Color", "B_Color"))
        out = next(s for s in mix.outputs if s.identifier == "Result_Color")
        paint = ob.data.color_attributes.new("Paint", 'FLOAT_COLOR', 'POINT')
        paint.data.foreach_set("color", np.random.default_rng(3).uniform(0.0, 1.0, len(paint.data) * 4)
                               .astype(np.float32))
        source = tree.nodes.new("ShaderNodeVertexColor")
        source.layer_name = "Paint"
        tree.links.new(source.outputs["Color"], fac)
    else:
        fac, a, b, out = mix.inputs["Fac"], mix.inputs["Color1"], mix.inputs["Color2"], mix.outputs[0]
        lift = tree.nodes.new("ShaderNodeBrightContrast")
        lift.inputs["Bright"].default_value, lift.inputs["Contrast"].default_value = 0.5, 1.5
        tree.links.new(image.outputs["Color"], lift.inputs["Color"])
        tree.links.new(lift.outputs["Color"], fac)
    fac.default_value = 0.0   # what a factor not followed would give
    tree.links.new(image.outputs["Color"], a)
    b.default_value = (0.9, 0.6, 0.1, 1.0)
    tree.links.new(out, tree.nodes["Diffuse BSDF"].inputs["Color"])
    corners_as_cycles_bakes_them(addon, ob, f"{kind[10:]} factor")


def test_a_number_from_an_output_not_followed_is_reported(addon):
    """A Noise Texture's Fac into a Color Ramp's factor: the factor's unlinked value, and a warning."""
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    node = tree.nodes.new("ShaderNodeValToRGB")
    node.inputs["Fac"].default_value = 0.25
    tree.links.new(tree.nodes.new("ShaderNodeTexNoise").outputs["Fac"], node.inputs["Fac"])
    tree.links.new(node.outputs["Color"], tree.nodes["Diffuse BSDF"].inputs["Color"])
    sx = addon.export.export_scene()
    assert any("Fac is linked to a node or output not followed" in w for w in sx.warnings), sx.warnings
    np.testing.assert_allclose(sx.materials[0].reflectance, node.color_ramp.evaluate(0.25)[:3], atol=0.01)


# An image with transparency (alpha 0.1-1 per texel) in each of Cycles' ways of taking it: the 8-bit
# image's colour is associated with its alpha on load (multiplied, on the bytes); where the node's
# Alpha output feeds a node it is divided by it again; a Channel Packed image's is left alone; a
# float image's pixels are associated already. "mix": the alpha as a Mix factor of the texture's
# colour over a plain one; "alpha": the Alpha output straight into the BSDF's colour, as a gray.
ALPHA_CASES = [("STRAIGHT", False, "colour"), ("STRAIGHT", False, "mix"), ("PREMUL", False, "alpha"),
               ("CHANNEL_PACKED", False, "colour"), ("STRAIGHT", True, "colour")]


@pytest.mark.parametrize("mode, is_float, use", ALPHA_CASES,
                         ids=[f"{m}-{'float' if f else 'byte'}-{u}" for m, f, u in ALPHA_CASES])
def test_an_images_alpha_reaches_the_corners_as_cycles_bakes_it(addon, mode, is_float, use):
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    tex, bsdf = tree.nodes["Image Texture"], tree.nodes["Diffuse BSDF"]
    if is_float:
        tex.image = bpy.data.images.new("Float", 4, 4, alpha=True, float_buffer=True)
    tex.image.alpha_mode = mode
    alpha = np.random.default_rng(5).uniform(0.1, 1.0, (4, 4, 1))
    tex.image.pixels.foreach_set(np.concatenate([TEXELS, alpha], 2).astype(np.float32).ravel())
    if use == "mix":
        mix = tree.nodes.new("ShaderNodeMixRGB")
        mix.inputs["Color1"].default_value = (0.9, 0.5, 0.1, 1.0)
        tree.links.new(tex.outputs["Alpha"], mix.inputs["Fac"])
        tree.links.new(tex.outputs["Color"], mix.inputs["Color2"])
        tree.links.new(mix.outputs[0], bsdf.inputs["Color"])
    elif use == "alpha":
        tree.links.new(tex.outputs["Alpha"], bsdf.inputs["Color"])
    corners_as_cycles_bakes_them(addon, ob, f"{mode} {'float' if is_float else '8-bit'} {use}")


ADJUSTS = [("ShaderNodeInvert", {"Fac": 0.7}), ("ShaderNodeGamma", {"Gamma": 2.2}),
           ("ShaderNodeGamma", {"Gamma": 0.5}), ("ShaderNodeBrightContrast", {"Bright": 0.05, "Contrast": -0.2}),
           ("ShaderNodeHueSaturation", {"Hue": 0.3, "Saturation": 1.4, "Value": 0.9, "Fac": 0.8})]


@pytest.mark.parametrize("kind, values", ADJUSTS, ids=[f"{k[10:]}-{list(v.values())[0]}" for k, v in ADJUSTS])
def test_adjusted_colours_reach_the_corners_as_cycles_bakes_them(addon, kind, values):
    """Invert, Gamma, Bright/Contrast and Hue/Saturation/Value between the texture and the BSDF."""
    ob = textured_grid("Linear", "sRGB", 1.0)
    tree = ob.active_material.node_tree
    node = tree.nodes.new(kind)
    for name, value in values.items():
        node.inputs[name].default_value = value
    tree.links.new(tree.nodes["Image Texture"].outputs["Color"], node.inputs["Color"])
    tree.links.new(node.outputs["Color"], tree.nodes["Diffuse BSDF"].inputs["Color"])
    corners_as_cycles_bakes_them(addon, ob, f"{kind[10:]} {values}")


@pytest.mark.parametrize("shader", ["ShaderNodeEmission", "ShaderNodeBsdfPrincipled"])
def test_an_emission_texture_glows_and_lights_as_cycles_bakes_it(addon, shader):
    """The texture on an emission colour (an Emission shader's, a Principled BSDF's): the glowing
    grid shows it at its corners, and a floor just below takes its pattern. The grid is finer than
    the texels: what a face shows is its corners' colours interpolated (with the 5 x 5-quad grid of
    the tests above, faces wider than texels, the floor is 9% RMS off)."""
    ob = textured_grid("Linear", "sRGB", 1.0, subdivisions=24)
    bpy.data.objects.remove(bpy.data.objects["Lamp"])
    tree = ob.active_material.node_tree
    glow = tree.nodes.new(shader)
    if shader == "ShaderNodeEmission":
        glow.inputs["Strength"].default_value = 3.0
        colour = glow.inputs["Color"]
    else:
        glow.inputs["Base Color"].default_value = (0, 0, 0, 1)
        glow.inputs["Emission Strength"].default_value = 3.0
        colour = glow.inputs["Emission"]
    tree.links.new(tree.nodes["Image Texture"].outputs["Color"], colour)
    tree.links.new(glow.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    ob.rotation_euler = (np.pi, 0, 0)   # facing down
    ob.location.z = 0.3
    scene, floor = direct_light_grid(12, 3.0, samples=1024, keep=True)
    diffuse(floor)
    sx = addon.export.export_scene()
    assert sx.mesh(ob.name).corner_emission is not None
    bpy.ops.object.select_all(action='DESELECT')   # Cycles bakes what is selected
    glowing = reference.relative_rms(direct_light(addon.export, ob), cycles_corners(ob))
    ob.select_set(False)
    lit = reference.relative_rms(direct_light(addon.export, floor), cycles_corners(floor))
    print(f"\n  {shader[10:]}: the grid {100 * glowing:.3f}%, the floor {100 * lit:.2f}% RMS against Cycles", end="")
    assert glowing < 0.003 and lit < 0.015   # 0.86%

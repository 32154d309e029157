"""Alpha cut-outs (leaf cards, curtains): an image's alpha on a Principled BSDF, or a Mix with a
Transparent BSDF by it, goes to the engine as the image (Material.alpha) and the UVs its node reads
(MeshExport.corner_uv), and a bake puts the image's shadow under the card."""
import math

import bpy
import numpy as np
import pytest

SIZE = 8


def checkers(size=SIZE, squares=4):
    """Alpha 1 on the square at the image's bottom left, rows from the bottom."""
    i = np.arange(size) * squares // size
    return ((i[:, None] + i[None, :]) % 2 == 0).astype(np.float32)


def alpha_image(alpha, name="Leaf"):
    """A float image of white with `alpha` (H, W), rows from the bottom."""
    h, w = alpha.shape
    image = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    px = np.ones((h, w, 4), np.float32)
    px[..., 3] = alpha
    image.pixels.foreach_set(px.ravel())
    return image


def card_material(kind, image, uv_map=""):
    """A material whose alpha comes from `image` through an Image Texture node (its UV Map node
    naming `uv_map`, if given): "principled" (its Alpha), "mix" (Mix(Transparent, Diffuse) by the
    alpha), "mix swapped" (Mix(Diffuse, Transparent)), "mix luminance" (by the colour, as a gray)."""
    m = bpy.data.materials.new(kind)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = image
    if uv_map:
        uv = nt.nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_map
        nt.links.new(uv.outputs["UV"], tex.inputs["Vector"])
    if kind == "principled":
        bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.inputs["Base Color"].default_value = (0.2, 0.6, 0.1, 1)
        nt.links.new(tex.outputs["Alpha"], bsdf.inputs["Alpha"])
        nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
        return m
    mix = nt.nodes.new("ShaderNodeMixShader")
    clear, leaf = nt.nodes.new("ShaderNodeBsdfTransparent"), nt.nodes.new("ShaderNodeBsdfDiffuse")
    clear.inputs["Color"].default_value = (1.0, 0.9, 0.8, 1)
    leaf.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1)
    sides = (leaf, clear) if kind == "mix swapped" else (clear, leaf)
    nt.links.new(sides[0].outputs[0], mix.inputs[1])
    nt.links.new(sides[1].outputs[0], mix.inputs[2])
    nt.links.new(tex.outputs["Color" if kind == "mix luminance" else "Alpha"], mix.inputs["Fac"])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    return m


def card(material, z=1.0, size=4.0, name="Card"):
    """A square card `size` wide at height z facing up, its UV map the unit square (u along x), and
    a second map "Turned" of it turned a quarter and shifted."""
    me = bpy.data.meshes.new(name)
    h = size / 2
    me.from_pydata([(-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)], [], [(0, 1, 2, 3)])
    plain = me.uv_layers.new(name="UVMap")
    plain.data.foreach_set("uv", np.array([(0, 0), (1, 0), (1, 1), (0, 1)], np.float32).ravel())
    turned = me.uv_layers.new(name="Turned")
    turned.data.foreach_set("uv", np.array([(0.25, 1), (0.25, 0), (1.25, 0), (1.25, 1)], np.float32).ravel())
    me.uv_layers.active = plain
    me.materials.append(material)
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


@pytest.fixture
def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def exported(export, material):
    s = export.export_scene()
    return s, s.materials[s.material_index(material.name)]


@pytest.mark.parametrize("kind", ["principled", "mix", "mix swapped", "mix luminance"])
def test_an_image_alpha_goes_as_the_image_and_its_uvs(export, empty_scene, kind):
    alpha = checkers()
    image = alpha_image(alpha)
    if kind == "mix luminance":   # the colour carries the pattern, its alpha is 1
        px = np.ones((SIZE, SIZE, 4), np.float32)
        px[..., :3] = alpha[..., None]
        image.pixels.foreach_set(px.ravel())
    material = card_material(kind, image, uv_map="Turned")
    card(material)
    s, m = exported(export, material)
    assert m.coverage is not None and export.MEAN_FACTOR not in m.notes
    # Where the surface is: the alpha, or one minus it where the factor weighs the transparent side.
    want = 1 - alpha if kind == "mix swapped" else alpha
    np.testing.assert_allclose(np.asarray(m.coverage), want, atol=1e-6)
    clear = (1.0, 1.0, 1.0) if kind == "principled" else (1.0, 0.9, 0.8)
    np.testing.assert_allclose(m.transmittance, clear, rtol=1e-6)
    if kind == "principled":   # the base colour's diffuse lobe where the card is, on average half of it
        np.testing.assert_allclose(m.reflectance, np.array((0.2, 0.6, 0.1)) * 0.5, rtol=1e-6)
    mesh = s.mesh("Card")
    # The UV Map node's map, a hair towards the face's middle (where Cycles reads a corner).
    np.testing.assert_allclose(mesh.corner_uv, [(0.25, 1), (0.25, 0), (1.25, 0), (1.25, 1)], atol=1e-3)


def test_a_large_image_goes_box_filtered_to_at_most_1024_a_side(export, empty_scene):
    alpha = np.zeros((4, 2048), np.float32)
    alpha[:, 1::2] = 1.0        # every other column: half, once two columns are one texel
    alpha[:, :1024] = 0.0       # the left half clear
    material = card_material("mix", alpha_image(alpha))
    card(material)
    _, m = exported(export, material)
    texels = np.asarray(m.coverage)
    assert texels.shape == (4, 1024)
    np.testing.assert_allclose(texels[:, :512], 0.0)
    np.testing.assert_allclose(texels[:, 512:], 0.5)
    assert m.coverage.mean == pytest.approx(0.25)


def test_what_the_engine_cannot_read_by_place_goes_as_its_mean(export, empty_scene):
    """A texture that does not repeat, and a card without the UV map its node names."""
    image = alpha_image(checkers())
    extended = card_material("mix", image)
    extended.node_tree.nodes["Image Texture"].extension = 'CLIP'
    card(extended)
    s, m = exported(export, extended)
    assert m.coverage is None and export.MEAN_FACTOR in m.notes
    np.testing.assert_allclose(m.transmittance, np.array((1.0, 0.9, 0.8)) * 0.5, rtol=1e-6)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    missing = card_material("mix", alpha_image(checkers()), uv_map="Nowhere")
    ob = card(missing)
    s, m = exported(export, missing)
    assert s.mesh("Card").corner_uv is None
    assert any("no UV map Nowhere for the alpha" in w for w in s.warnings)
    # Beside a material the mesh has the map of, both go as their means: UVs go a whole mesh.
    ob.data.materials.append(card_material("principled", alpha_image(checkers())))
    bpy.ops.object.select_all(action='DESELECT')
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.mesh.subdivide()
    bpy.ops.object.mode_set(mode='OBJECT')
    ob.data.polygons.foreach_set("material_index", np.arange(len(ob.data.polygons)) % 2)
    ob.data.update()
    s = export.export_scene()
    assert len(np.unique(s.mesh("Card").face_materials)) == 2 and s.mesh("Card").corner_uv is None


def test_effects_name_alpha_cut_outs_as_simulated_and_those_without_uvs_as_means(addon, empty_scene):
    """The rows name the material and the objects; a card without the UV map goes as the mean. Both
    rows' short words fit the sidebar uncut (test_panel_fit)."""
    import test_panel_fit as panel
    material = card_material("mix", alpha_image(checkers()))
    card(material)
    rows = {short: (kind, detail) for kind, short, detail in addon.effects.items(addon.export.export_scene())}
    assert rows["Alpha cut-outs"][0] == addon.effects.SIMULATED and rows["Alpha cut-outs"][1].endswith("(mix on Card)")
    assert "Mix factors as means" not in rows and "Alpha without UVs" not in rows
    bare = card(material, z=2.0, name="Bare")
    bare.data.uv_layers.remove(bare.data.uv_layers["Turned"])
    bare.data.uv_layers.remove(bare.data.uv_layers["UVMap"])
    rows = {short: (kind, detail) for kind, short, detail in addon.effects.items(addon.export.export_scene())}
    assert rows["Alpha cut-outs"][1].endswith("(mix on Card)")
    assert rows["Alpha without UVs"] == (addon.effects.APPROXIMATED, "an image's alpha on a mesh without "
                                                  "its UV map taken as its mean (mix on Bare)")
    cut = []
    for short in ("Alpha cut-outs", "Alpha without UVs"):
        panel.fits(short, panel.WIDTHS["sidebar"] - panel.PAD - panel.CLIP - panel.ICON, "effects", cut)
    assert not cut, cut


RHO, SUN = 0.5, 3.0


def test_a_bake_puts_the_image_s_shadow_under_a_leaf_card(addon, empty_scene):
    """A sun straight down through a card whose alpha is a checkerboard of 1 m squares (its
    visible part black, so nothing bounces back): the floor's corners under clear squares get the
    sun's light times the card's clear colour, under opaque ones none. A uniform dimming by the
    mean, as before, would give every corner half."""
    scene = empty_scene
    alpha = checkers(64, 4)
    card(card_material("mix", alpha_image(alpha)))
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=33, y_subdivisions=33, size=4.0)
    floor = bpy.context.object
    floor.name = "Floor"
    white = bpy.data.materials.new("Floor")
    white.diffuse_color = (RHO, RHO, RHO, 1)
    floor.data.materials.append(white)
    sun = bpy.data.lights.new("Sun", 'SUN')
    sun.energy = SUN
    sun.angle = 0.0
    scene.collection.objects.link(bpy.data.objects.new("Sun", sun))
    scene.radiosity.preset = 'DRAFT'
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    me = floor.data
    colours = np.empty(len(me.loops) * 4, np.float32)
    me.color_attributes["Radiosity"].data.foreach_get("color", colours)
    colours = colours.reshape(-1, 4)[:, :3]
    vertex = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", vertex)
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    xy = co.reshape(-1, 3)[vertex, :2]
    # Where the sun's ray from each corner crosses the card's image, and the squares round it.
    x, y = (xy[:, 0] + 2) / 4 * 64, (xy[:, 1] + 2) / 4 * 64
    col, row = np.floor(x).astype(int) % 64, np.floor(y).astype(int) % 64
    a = alpha[row, col]
    clean = np.ones(len(a), bool)
    for dc in (-1, 0, 1):
        for dr in (-1, 0, 1):
            clean &= alpha[(row + dr) % 64, (col + dc) % 64] == a
    assert clean.sum() > 1000 and (a[clean] == 0).any() and (a[clean] == 1).any()
    want = (1 - a[clean])[:, None] * RHO * SUN / math.pi * np.array((1.0, 0.9, 0.8))
    np.testing.assert_allclose(colours[clean], want, rtol=1e-3, atol=1e-4)


def sunlit_card(material, scene):
    """A card of `material` over a floor ("Grid") under a sun: the card."""
    leaf = card(material)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=9, y_subdivisions=9, size=4.0)
    sun = bpy.data.lights.new("Sun", 'SUN')
    sun.energy = SUN
    scene.collection.objects.link(bpy.data.objects.new("Sun", sun))
    return leaf


def floor_before_updated_and_fresh(addon, before, after, calls):
    """The floor's light in a solve of `before`, once that solver has taken `calls` and settled, and in
    a fresh solve of `after`."""
    export, engine = addon.export, addon.engine.load_engine()
    scene, ids = export.to_engine(before, engine)
    solver = engine.Solver(scene, engine.Settings.preset("draft"))
    solver.solve()
    was = solver.refined(ids["Grid"])[1]
    addon.scene_diff.apply_calls(solver, calls)
    solver.update()
    solver.solve()
    fresh = engine.Solver(export.to_engine(after, engine)[0], engine.Settings.preset("draft"))
    fresh.solve()
    return was, solver.refined(ids["Grid"])[1], fresh.refined(ids["Grid"])[1]


def test_a_new_image_on_the_card_is_a_material_change_the_solver_follows(addon, empty_scene):
    """Live update: the card's image painted over goes as Solver.set_material with the new image;
    the updated solver agrees with a fresh solve of the new scene (the floor under the card)."""
    export, engine = addon.export, addon.engine.load_engine()
    material = card_material("mix", alpha_image(checkers()))
    sunlit_card(material, empty_scene)
    before = export.export_scene()
    material.node_tree.nodes["Image Texture"].image = alpha_image(1 - checkers(), "Painted")
    after = export.export_scene()
    calls = addon.scene_diff.diff_exports(before, after, engine)
    assert [name for name, _ in calls] == ["set_material"]
    _, got, want = floor_before_updated_and_fresh(addon, before, after, calls)
    assert want.max() > 0.1
    np.testing.assert_allclose(got, want, atol=1e-3 * want.max())


def test_new_uvs_on_the_card_reach_the_solver(addon, empty_scene):
    """Live update: the card's UVs moved a square along u turn its clear squares opaque and back;
    the engine takes UVs with the mesh, so the card goes anew, and the updated solver agrees with a
    fresh solve of the new scene (the floor under the card)."""
    export, engine = addon.export, addon.engine.load_engine()
    leaf = sunlit_card(card_material("mix", alpha_image(checkers())), empty_scene)
    before = export.export_scene()
    uv = np.empty(len(leaf.data.loops) * 2, np.float32)
    leaf.data.uv_layers.active.data.foreach_get("uv", uv)
    leaf.data.uv_layers.active.data.foreach_set("uv", uv + np.tile(np.float32([0.25, 0.0]), len(uv) // 2))
    leaf.data.update()
    after = addon.scene_diff.align_export(before, export.export_scene())
    calls = addon.scene_diff.diff_exports(before, after, engine)
    assert calls
    was, got, want = floor_before_updated_and_fresh(addon, before, after, calls)
    assert want.max() > 0.1 and np.abs(want - was).max() > 0.1 * want.max()
    np.testing.assert_allclose(got, want, atol=1e-3 * want.max())


def blocks(size=64, squares=4, seed=3):
    """Random squares of alpha 0 or 1, the same under no turn or mirroring of the image."""
    pattern = np.random.default_rng(seed).integers(0, 2, (squares, squares)).astype(np.float32)
    return np.kron(pattern, np.ones((size // squares, size // squares), np.float32))


def test_blocks_tell_a_turn_and_a_mirror():
    b = blocks()
    assert all(not np.array_equal(b, t) and not np.array_equal(b, 1 - t)
               for t in (b.T, b[::-1], b[:, ::-1], np.rot90(b), np.rot90(b, 2), np.rot90(b, 3)))


@pytest.mark.parametrize("uv_map", ["", "Turned"])
def test_the_floor_under_a_leaf_card_agrees_with_cycles(export, uv_map):
    """Direct light from a point lamp (no radius: exact in Cycles at any sample count) through a
    card of random blocks, read through its UV map or one turned and shifted: the dappled floor as
    Cycles bakes it, with transparent shadows."""
    import test_shading as shading
    scene, floor = shading.direct_light_grid(32, 4.0)
    scene.cycles.transparent_max_bounces = 8   # Cycles' shadow rays go on through the card's clear parts
    shading.diffuse(floor)
    card(card_material("mix", alpha_image(blocks()), uv_map=uv_map))
    shading.point_lamp(scene, 500.0, (0.2, -0.1, 3.0))
    bpy.ops.object.select_all(action='DESELECT')
    ref = shading.cycles_corners(floor)
    dark = ref.max(1) < 0.05 * ref.max()
    assert 200 <= dark.sum() <= len(ref) - 200, dark.sum()   # both clear and opaque squares over the floor
    err = shading.reference.relative_rms(shading.direct_light(export, floor), ref)
    print(f"\n  floor under a card of blocks ({uv_map or 'UVMap'}): {100 * err:.3f}% RMS against Cycles", end="")
    assert err < 0.01


def test_a_mapping_node_maps_the_uvs_the_engine_reads(export, empty_scene):
    """UV Map -> Mapping (Point: scale, then location) -> Image Texture: the corners' UVs as mapped."""
    material = card_material("principled", alpha_image(blocks()), uv_map="UVMap")
    nt = material.node_tree
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (2.0, 3.0, 1.0)
    mapping.inputs["Location"].default_value = (0.1, -0.2, 0.0)
    nt.links.new(nt.nodes["UV Map"].outputs["UV"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], nt.nodes["Image Texture"].inputs["Vector"])
    card(material)
    s, m = exported(export, material)
    assert m.coverage is not None
    uv = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], float)
    np.testing.assert_allclose(s.mesh("Card").corner_uv, uv * (2.0, 3.0) + (0.1, -0.2), atol=1e-3)

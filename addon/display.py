"""Showing the bake: in each lit mesh's materials a node group fed with the baked light, and a
material output of its own made the active output, so that Eevee's viewport, F12 and Cycles show
the baked light itself.

The group emits its Light input times 2^exposure: a baked surface's outgoing radiance is what a
renderer would show of it, so emission is the bake seen as it is. The light is the object's
lightmap (an Image Texture reading `<object>_Radiosity` through a UV Map node set to `RadiosityUV`)
when it has one and Lightmaps is on, its texels being finer than the attribute's corners; else an
Attribute node reading `Radiosity`. A material holds one image for every object using it, so a
material that several lit objects use shows the attribute, and the panel names it when one of
them has a lightmap.

The material's own nodes and links are not touched (exports read them through `user_output`);
turning the display off removes the nodes it added and makes the output that was active active
again: the material is as it was.
"""
import bpy

from . import lightmap, lightmap_sequence
from .uv_charts import UV_MAP
from .writeback import ATTRIBUTE

GROUP = "Radiosity Display"
NODE = "Radiosity Display"                 # the group node in each material
OUTPUT = "Radiosity Display Output"        # the material output it feeds, active while shown
LIGHT = "Radiosity Display Light"          # what feeds the group: the lightmap's Image Texture, or an Attribute
UV = "Radiosity Display UV"                # the UV Map node (RadiosityUV) under the lightmap's Image Texture
ADDED = (NODE, OUTPUT, LIGHT, UV)
KEPT = "radiosity_active_output"           # on OUTPUT: the output that was active, made active again on hide


def _group():
    """The shared node group: Light -> Emission (strength 2^Exposure) -> Shader."""
    group = bpy.data.node_groups.get(GROUP)
    if group is not None and group.inputs.get("Light") is not None:
        return group
    if group is not None:       # an older add-on's group, read from a saved file: its nodes are made anew
        bpy.data.node_groups.remove(group)
    group = bpy.data.node_groups.new(GROUP, 'ShaderNodeTree')
    group.inputs.new('NodeSocketColor', "Light")
    group.inputs.new('NodeSocketFloat', "Exposure")
    group.outputs.new('NodeSocketShader', "Shader")
    nodes, links = group.nodes, group.links
    inputs, outputs = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    power = nodes.new('ShaderNodeMath')
    power.operation = 'POWER'
    power.inputs[0].default_value = 2.0
    emission = nodes.new('ShaderNodeEmission')
    links.new(inputs.outputs["Exposure"], power.inputs[1])
    links.new(inputs.outputs["Light"], emission.inputs["Color"])
    links.new(power.outputs[0], emission.inputs["Strength"])
    links.new(emission.outputs[0], outputs.inputs["Shader"])
    return group


def _lightmap(ob, props):
    """ob's lightmap image, if Lightmaps is on and ob has one and its RadiosityUV map; else None."""
    if not props.lightmaps or ob.data.uv_layers.get(UV_MAP) is None:
        return None
    return bpy.data.images.get(lightmap.image_name(ob.name))


def plan(scene):
    """({material: the lightmap image it shows, None for the attribute}, for the node materials of
    the scene's lit meshes; the names of those that show the attribute because several lit objects,
    one at least with a lightmap, use them)."""
    users = {}
    for ob in scene.objects:
        if ob.type != 'MESH' or ob.data.color_attributes.get(ATTRIBUTE) is None:
            continue
        for slot in ob.material_slots:
            m = slot.material
            if m is not None and m.use_nodes and m.library is None:
                objects = users.setdefault(m, [])
                if ob not in objects:
                    objects.append(ob)
    shown, shared = {}, []
    for m, objects in users.items():
        images = [_lightmap(ob, scene.radiosity) for ob in objects]
        shown[m] = images[0] if len(objects) == 1 else None
        if len(objects) > 1 and any(image is not None for image in images):
            shared.append(m.name)
    return shown, shared


def note(shared):
    """What the panel says of the materials that show the attribute in place of a lightmap."""
    if not shared:
        return ""
    names = ", ".join(f"'{n}'" for n in sorted(shared)[:3]) + (f" and {len(shared) - 3} more" if len(shared) > 3 else "")
    return (f"{names} show{'s' if len(shared) == 1 else ''} the attribute: a material shows one image, "
            "and several lit objects use it (give each its own copy to see their lightmaps)")


def user_output(tree, types=('OUTPUT_MATERIAL',)):
    """The output node the material renders with when the bake is not shown: the active one, or while
    shown the one that was active. Exports read the material through it."""
    display = tree.nodes.get(OUTPUT)
    kept = display.get(KEPT, "") if display is not None else None
    outs = [n for n in tree.nodes if n.type in types and n.name != OUTPUT
            and getattr(n, "target", 'ALL') in ('ALL', 'CYCLES')]
    for n in outs:
        if (n.name == kept) if kept is not None else n.is_active_output:
            return n
    return outs[0] if outs else None


def _shows(tree, image):
    """Whether the tree shows the display with this light already."""
    light = tree.nodes.get(LIGHT)
    if tree.nodes.get(OUTPUT) is None or light is None:
        return False
    if image is None:
        return light.bl_idname == 'ShaderNodeAttribute'
    return light.bl_idname == 'ShaderNodeTexImage' and light.image == image


def _light(tree, image):
    """The node that feeds the group: an Attribute node reading the attribute, or with an image an
    Image Texture reading it through RadiosityUV, playing it if it is Bake Animation's sequence."""
    if image is None:
        light = tree.nodes.new('ShaderNodeAttribute')
        light.attribute_name = ATTRIBUTE
    else:
        uv = tree.nodes.new('ShaderNodeUVMap')
        uv.name = uv.label = UV
        uv.uv_map = UV_MAP
        light = tree.nodes.new('ShaderNodeTexImage')
        light.image = image
        light.extension = 'EXTEND'     # a texel at the image's edge is not the opposite edge's neighbour
        tree.links.new(uv.outputs["UV"], light.inputs["Vector"])
        if image.source == 'SEQUENCE':
            lightmap_sequence.play(image)
    light.name = light.label = LIGHT
    return light


def _put_in(tree, group, image, exposure):
    active = user_output(tree)
    node = tree.nodes.new('ShaderNodeGroup')
    node.node_tree = group
    node.name = node.label = NODE
    node.inputs["Exposure"].default_value = exposure
    light = _light(tree, image)
    output = tree.nodes.new('ShaderNodeOutputMaterial')
    output.name = output.label = OUTPUT
    output[KEPT] = active.name if active is not None else ""
    if active is not None:       # a row below the active output
        x, y = active.location.x, active.location.y - 300
        for dx, name in ((-700, UV), (-450, LIGHT), (-200, NODE), (0, OUTPUT)):
            if name in tree.nodes:
                tree.nodes[name].location = (x + dx, y)
    tree.links.new(light.outputs["Color"], node.inputs["Light"])
    tree.links.new(node.outputs["Shader"], output.inputs["Surface"])
    output.is_active_output = True


def _take_out(tree):
    """Removes the nodes the display added and makes the output that was active active again."""
    output = tree.nodes.get(OUTPUT)
    if output is None:
        return
    kept = tree.nodes.get(output.get(KEPT, ""))
    for name in ADDED:
        node = tree.nodes.get(name)
        if node is not None:
            tree.nodes.remove(node)
    if kept is not None:
        kept.is_active_output = True


def show(scene):
    """Puts the display in every lit mesh's materials, or brings it up to date where the light it
    should show changed (a lightmap made or gone, Lightmaps turned on or off). The material's own
    nodes and links stay as they are."""
    shown, shared = plan(scene)
    group = _group()
    for m, image in shown.items():
        if not _shows(m.node_tree, image):
            _take_out(m.node_tree)
            _put_in(m.node_tree, group, image, scene.radiosity.display_exposure)
    scene.radiosity.display_note = note(shared)


def hide(scene):
    """Takes the display out of every material that has it."""
    for m in bpy.data.materials:
        if m.use_nodes and m.node_tree is not None:
            _take_out(m.node_tree)
    group = bpy.data.node_groups.get(GROUP)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)
    scene.radiosity.display_note = ""


def set_exposure(scene):
    for m in bpy.data.materials:
        node = m.node_tree.nodes.get(NODE) if m.use_nodes else None
        if node is not None:
            node.inputs["Exposure"].default_value = scene.radiosity.display_exposure


def after_bake(scene):
    """The first bake of a scene turns the display on (later ones leave the user's choice); a shown
    display takes in meshes lit for the first time and lightmaps made by the bake."""
    props = scene.radiosity
    if not props.display_offered:
        props.display_offered = True
        props.show_bake = True          # its update shows
    elif props.show_bake:
        show(scene)


def on_toggle(props, _context):
    (show if props.show_bake else hide)(props.id_data)     # the scene the settings belong to


def on_lightmaps(props, _context):
    if props.show_bake:
        show(props.id_data)


def on_exposure(props, _context):
    set_exposure(props.id_data)

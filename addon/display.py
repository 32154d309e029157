"""Showing the bake: a node group and a material output of its own, made the active output, in each
lit mesh's materials, so that Eevee's viewport, F12 and Cycles show the baked light itself.

The group emits the `Radiosity` attribute times 2^exposure: a baked surface's outgoing radiance is
what a renderer would show of it, so emission is the bake seen as it is. The material's own nodes
and links are not touched (exports read them through `user_output`); turning the display off
removes the two nodes and makes the output that was active active again: the material is as it was.
"""
import bpy

from .writeback import ATTRIBUTE

GROUP = "Radiosity Display"
NODE = "Radiosity Display"                 # the group node in each material
OUTPUT = "Radiosity Display Output"        # the material output it feeds, active while shown
KEPT = "radiosity_active_output"           # on OUTPUT: the output that was active, made active again on hide


def _group():
    """The shared node group: Attribute -> Emission (strength 2^Exposure) -> Shader."""
    group = bpy.data.node_groups.get(GROUP)
    if group is not None:
        return group
    group = bpy.data.node_groups.new(GROUP, 'ShaderNodeTree')
    group.inputs.new('NodeSocketFloat', "Exposure")
    group.outputs.new('NodeSocketShader', "Shader")
    nodes, links = group.nodes, group.links
    inputs, outputs = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    attribute = nodes.new('ShaderNodeAttribute')
    attribute.attribute_name = ATTRIBUTE
    power = nodes.new('ShaderNodeMath')
    power.operation = 'POWER'
    power.inputs[0].default_value = 2.0
    emission = nodes.new('ShaderNodeEmission')
    links.new(inputs.outputs["Exposure"], power.inputs[1])
    links.new(attribute.outputs["Color"], emission.inputs["Color"])
    links.new(power.outputs[0], emission.inputs["Strength"])
    links.new(emission.outputs[0], outputs.inputs["Shader"])
    return group


def _materials(scene):
    """The node materials of the scene's lit meshes."""
    seen = []
    for ob in scene.objects:
        if ob.type != 'MESH' or ob.data.color_attributes.get(ATTRIBUTE) is None:
            continue
        for slot in ob.material_slots:
            m = slot.material
            if m is not None and m.use_nodes and m.library is None and m not in seen:
                seen.append(m)
    return seen


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


def show(scene):
    """Puts the display group, and an output of its own made active, in every lit mesh's materials
    (those not showing it yet). The material's own nodes and links stay as they are."""
    group = _group()
    for m in _materials(scene):
        tree = m.node_tree
        if tree.nodes.get(OUTPUT) is not None:
            continue
        active = user_output(tree)
        node = tree.nodes.new('ShaderNodeGroup')
        node.node_tree = group
        node.name = node.label = NODE
        node.inputs["Exposure"].default_value = scene.radiosity.display_exposure
        output = tree.nodes.new('ShaderNodeOutputMaterial')
        output.name = output.label = OUTPUT
        output[KEPT] = active.name if active is not None else ""
        if active is not None:
            node.location = (active.location.x, active.location.y - 200)
            output.location = (active.location.x + 200, active.location.y - 200)
        tree.links.new(node.outputs["Shader"], output.inputs["Surface"])
        output.is_active_output = True


def hide(scene):
    """Takes the display out of every material that has it, and makes active again the output that was."""
    for m in bpy.data.materials:
        tree = m.node_tree if m.use_nodes else None
        output = tree.nodes.get(OUTPUT) if tree is not None else None
        if output is None:
            continue
        kept = tree.nodes.get(output.get(KEPT, ""))
        tree.nodes.remove(output)
        node = tree.nodes.get(NODE)
        if node is not None:
            tree.nodes.remove(node)
        if kept is not None:
            kept.is_active_output = True
    group = bpy.data.node_groups.get(GROUP)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)


def set_exposure(scene):
    for m in bpy.data.materials:
        node = m.node_tree.nodes.get(NODE) if m.use_nodes else None
        if node is not None:
            node.inputs["Exposure"].default_value = scene.radiosity.display_exposure


def after_bake(scene):
    """The first bake of a scene turns the display on (later ones leave the user's choice); a shown
    display takes in meshes lit for the first time."""
    props = scene.radiosity
    if not props.display_offered:
        props.display_offered = True
        props.show_bake = True          # its update shows
    elif props.show_bake:
        show(scene)


def on_toggle(props, _context):
    (show if props.show_bake else hide)(props.id_data)     # the scene the settings belong to


def on_exposure(props, _context):
    set_exposure(props.id_data)

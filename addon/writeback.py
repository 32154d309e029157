"""Engine results -> the `Radiosity` colour attribute (FLOAT_COLOR, CORNER), one foreach_set a mesh.

Values are outgoing radiance in scene-linear units, what Cycles' COMBINED vertex-colour bake writes
(addon/CYCLES_UNITS.md); alpha is 1.
"""
import bpy
import numpy as np

ATTRIBUTE = "Radiosity"


def can_write(ob):
    """(ok, reason) for writing ob's mesh."""
    if ob is None or ob.type != 'MESH':
        return False, "not a mesh"
    if ob.library is not None or ob.data.library is not None:
        return False, f"'{ob.name}' uses linked library data; not written"
    if getattr(ob.data, "override_library", None) is not None and ob.data.override_library is not None:
        return False, f"'{ob.name}' mesh is a library override; not written"
    if ob.mode == 'EDIT' or ob.data.is_editmode:
        return False, f"'{ob.name}' is in Edit Mode; not written"
    if ob.hide_render:
        return False, None
    return True, None


def ensure_attribute(me):
    a = me.color_attributes.get(ATTRIBUTE)
    if a is not None and (a.data_type != 'FLOAT_COLOR' or a.domain != 'CORNER'):
        me.color_attributes.remove(a)
        a = None
    if a is None:
        a = me.color_attributes.new(ATTRIBUTE, 'FLOAT_COLOR', 'CORNER')
    return a


def write_mesh(me, rgba):
    """Write (loops, 4) float32 RGBA into me's Radiosity attribute."""
    rgba = np.ascontiguousarray(rgba, np.float32)
    if rgba.shape != (len(me.loops), 4):
        raise ValueError(f"{me.name}: {rgba.shape[0]} colours for {len(me.loops)} face corners")
    a = ensure_attribute(me)
    a.data.foreach_set("color", rgba.ravel())
    try:
        me.color_attributes.active_color = a
    except (AttributeError, TypeError):
        pass
    me.update()
    return a


def write_all(colours, scene=None):
    """Write {object name: rgba} for the objects of bpy.data. Returns (written, messages).
    Nothing is written for linked / edit-mode / render-hidden objects; each shared mesh only once."""
    written, messages, done = [], [], {}
    for name, rgba in colours.items():
        ob = bpy.data.objects.get(name)
        ok, why = can_write(ob)
        if not ok:
            if why:
                messages.append(why)
            continue
        me = ob.data
        if me.name in done:
            if done[me.name] != name:
                messages.append(f"'{name}' shares its mesh with '{done[me.name]}': shows that object's lighting")
            continue
        if len(me.loops) != len(rgba):
            messages.append(f"'{name}' changed since the bake; not written")
            continue
        write_mesh(me, rgba)
        done[me.name] = name
        written.append(name)
    return written, messages


def read_mesh(me):
    """(loops, 4) float32 copy of the Radiosity attribute, or None."""
    a = me.color_attributes.get(ATTRIBUTE)
    if a is None:
        return None
    out = np.empty(len(a.data) * 4, np.float32)
    a.data.foreach_get("color", out)
    return out.reshape(-1, 4)


def clear(objects):
    """Remove the attribute from these objects' meshes. Returns the count removed."""
    n = 0
    for ob in objects:
        if ob.type != 'MESH' or ob.data.library is not None:
            continue
        a = ob.data.color_attributes.get(ATTRIBUTE)
        if a is not None:
            ob.data.color_attributes.remove(a)
            ob.data.update()
            n += 1
    return n

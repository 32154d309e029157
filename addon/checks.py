"""The checks that stop a bake before the engine sees the scene, each with a BakeError that says
why and names the object."""
import numpy as np

from .errors import BakeError

# How far from the world origin a vertex may lie (metres, Blender units). Blender holds coordinates
# and transforms in float32, whose steps at 1e15 m are 2^26 m (67,000 km): nothing modelled lies
# there; a vertex that far is a stray one, a script's inf (Blender stores FLT_MAX) or a runaway scale.
# The engine would take it (it works in double about the scene's centre; Embree, in float32, drops
# faces only past 1.8e18), but its tolerances follow the scene's size: patches under 1e-7 of the
# diagonal are dropped as degenerate and rays leave surfaces 1e-5 of it off, so every other surface
# would vanish and the bake come out black, blamed on the lamps.
FAR = 1e15


def check_scene(scene):
    """Before the export: no mesh is in Edit Mode, whose edits the export would not see."""
    edit = [ob.name for ob in scene.objects
            if ob.type == 'MESH' and (ob.mode == 'EDIT' or getattr(ob.data, "is_editmode", False))]
    if edit:
        raise BakeError(f"object '{edit[0]}' is in Edit Mode: switch to Object Mode before baking")


def check_export(sx):
    """After the export `sx`: something to bake, and no vertex too far out for the solver's tolerances."""
    if not sx.visible_meshes:
        raise BakeError("nothing to bake: the scene has no visible mesh objects")
    _check_extent(sx)


def _check_extent(sx):
    """BakeError naming the first mesh of `sx` (hidden ones too: they set the engine's scene size as
    well) with a vertex past FAR from the world origin. NaN passes: the engine names it."""
    # A bound first, as every live edit exports: the largest object-space coordinate through each
    # transform's rows; world positions only where it is past.
    reach = np.array([np.maximum(m.positions.max(initial=0.0), -m.positions.min(initial=0.0)) for m in sx.meshes])
    T = np.abs(np.array([m.transform[:3] for m in sx.meshes]))
    for i in np.flatnonzero(T[:, :, 3].max(1) + T[:, :, :3].sum(2).max(1) * reach > FAR):
        m = sx.meshes[i]
        far = np.abs(m.positions @ m.transform[:3, :3].T + m.transform[:3, 3]).max()
        if far > FAR:
            raise BakeError(f"object '{m.name}': a vertex lies {far:.3g} m from the world origin, past {FAR:.0e} m "
                            "(a stray vertex, an infinite value set by a script, a huge scale?); beside it every "
                            "other surface would be too small for the solver to light: move or delete it")

"""Lightmaps kept current across a Solver's updates (live update, Bake Animation's frames): after
each update only the lightmaps whose light may have changed are evaluated again, and what does
not change from frame to frame, each object's rasterised texels (lightmap.Raster), is kept.

A texel holds its point's own direct light and the solution's reflected light, interpolated
between its patch's corners (lightmap.py). So an object's lightmap is the one of its last
evaluation, and is not evaluated again, when on the same Solver
- nothing but meshes moved, deformed, vanished or appeared (a lamp, material or the world changed:
  every lightmap is evaluated again), and the object is not among them;
- none of them, where it was or where it is, reaches between the object and a direct source
  (shadow_reach.py);
- no corner of its patches (Solver.refined) moved by more than CHANGED of their mean light since.

prepare() reads Blender (main thread), evaluate() only the engine and numpy (any thread: a live
update's worker), and the caller writes what it returns.
"""
import numpy as np

from . import lightmap, shadow_reach

# A patch corner whose light moved by more than this part of the object's mean corner light since
# its lightmap's last evaluation has it evaluated again: the texels' reflected light is within it.
CHANGED = 1e-3

# Solver calls that change nothing but where meshes are and whether they show.
_PLACE_CALLS = {"set_transform", "set_positions", "set_visible"}


def _raster_key(me, m, layer, width, height):
    """What an object's Raster depends on: its faces, its RadiosityUV map and the image's size;
    under a Subdivision Surface also its cage's shape, which places the subdivided mesh's points."""
    uv = np.empty(2 * len(me.loops), np.float32)
    layer.data.foreach_get("uv", uv)
    sizes = np.empty(len(me.polygons), np.int32)
    me.polygons.foreach_get("loop_total", sizes)
    cage = hash(np.ascontiguousarray(m.positions).tobytes()) if m.refine == "catmull_clark" else None
    return width, height, hash(uv.tobytes()), hash(sizes.tobytes()), cage


def changed(reference, corners):
    """Whether patch-corner light `corners` differs from `reference` by more than CHANGED of its
    mean (a corner count that differs: the object was refined anew)."""
    if reference is None or reference.shape != corners.shape:
        return True
    scale = float(reference.mean()) if len(reference) else 0.0
    return bool(np.any(np.abs(corners - reference) > CHANGED * max(scale, 1e-30)))


class Lightmaps:
    """One scene's lightmaps as its Solver last had them evaluated."""

    def __init__(self):
        self.solver = None     # the Solver the references are of
        self.rasters = {}      # {object name: (key, lightmap.Raster)}
        self.references = {}   # {object name: (P, 3) patch-corner light at the last evaluation}
        self.evaluated = []    # object names evaluated by the last evaluate() (tests, reports)

    def prepare(self, job, props):
        """Main thread: ({object name: Raster} of job's lightmap targets, messages for the others).
        A raster is made again where the object's faces, RadiosityUV map or image size changed."""
        found, messages = lightmap.targets(job)
        plan = {}
        for ob, m in found:
            laid = lightmap.layout(ob, props)
            if laid is None:
                messages.append(lightmap.no_room(ob))
                continue
            width, height, layer = laid
            key = _raster_key(ob.data, m, layer, width, height)
            kept = self.rasters.get(ob.name)
            if kept is None or kept[0] != key:
                laid_out, why = lightmap.raster(ob, m, layer, width, height)
                if laid_out is None:
                    messages.append(why)
                    continue
                kept = self.rasters[ob.name] = (key, laid_out)
                self.references.pop(ob.name, None)
            plan[ob.name] = kept[1]
        return plan, messages

    def evaluate(self, job, plan):
        """Any thread, after job solved: {object name: (height, width, 4) rgba} of the lightmaps of
        `plan` (prepare()) whose light may have changed since their last evaluation."""
        self.evaluated = []
        if not job.succeeded:
            return {}
        meshes = {m.name: (i, m) for i, m in enumerate(job.export.meshes)}
        current = {name: meshes[name] for name in plan if name in meshes}
        moved, everything = set(), self.solver is not job.solver or not job.incremental
        for name, args in job.calls or ():
            if name in _PLACE_CALLS:
                moved.add(args[0])
            else:
                everything = True
        reached = set()
        if moved and not everything:
            reached = shadow_reach.reached(job.base.export, job.export, moved,
                                           [i for i, _m in current.values()])
        out = {}
        for name, (i, m) in current.items():
            index = job.ids[m.name]
            corners = np.asarray(job.solver.refined(index)[1])
            if everything or i in moved or i in reached or changed(self.references.get(name), corners):
                out[name] = lightmap.texels(job.solver, index, m.positions, plan[name])
                self.references[name] = corners
                self.evaluated.append(name)
        self.solver = job.solver
        return out

    def forget(self):
        """The next evaluation evaluates every lightmap (a bake wrote them all, or a new Solver)."""
        self.solver = None
        self.references.clear()

"""Bake pipeline shared by the operators: export (main thread) -> solve (any thread) -> colours.

    job = BakeJob(context.scene, depsgraph, settings)   # main thread: export + checks
    job.solve(progress)                                  # may run in a worker thread (GIL released)
    colours = job.colours()                              # {object name: (loops, 4) float32}

    later = BakeJob(scene, depsgraph, settings, base=job)  # incremental: the same engine Solver,
    later.solve(progress)                                   # only what changed since `job` is sent
                                                            # (budget=0.04: 40 ms of shooting; the
                                                            # next job shoots on from there)

Nothing here writes to Blender data; see writeback.py.
"""
from dataclasses import replace
import math
import os
import sys
import time

import numpy as np

from . import export as exporter
from . import texture

ENGINE_PRESETS = ("draft", "default", "high", "reference")


class BakeError(Exception):
    """A user-facing error: the bake cannot start (message says why and which object)."""


def load_engine():
    """The radiosity_engine module: bundled next to the add-on, else the source tree's build/engine."""
    try:
        from . import radiosity_engine
        return radiosity_engine
    except ImportError:
        pass
    if "radiosity_engine" in sys.modules:
        return sys.modules["radiosity_engine"]
    here = os.path.dirname(os.path.abspath(__file__))
    build = os.path.join(os.path.dirname(here), "build", "engine")
    if os.path.isdir(build) and build not in sys.path:
        sys.path.append(build)
    try:
        import radiosity_engine
    except ImportError as e:
        raise BakeError("the radiosity engine module is missing (re-install the add-on)") from e
    return radiosity_engine


def engine_settings(props, engine=None):
    """engine.Settings from scene.radiosity: the preset's values, overridden by the knobs."""
    engine = engine or load_engine()
    s = engine.Settings.preset(props.preset.lower())
    s.samples_direct = int(props.samples_direct)
    s.samples_indirect = int(props.samples_indirect)
    s.patch_size_relative = float(props.patch_size_relative)
    s.threshold = float(props.threshold)
    s.relaxation = 0.0 if props.auto_relaxation else float(props.relaxation)   # the engine's 0: automatic
    s.exact_near_direct = bool(props.exact_near_direct)
    s.exact_near_reflected = bool(props.exact_near_reflected)
    s.db_cache_mb = float(props.db_cache_mb)
    s.max_patches = int(props.max_patches)
    return s


# ----------------------------------------------------------------------------- checks
def _edit_mode_objects(scene):
    return [ob.name for ob in scene.objects
            if ob.type == 'MESH' and (ob.mode == 'EDIT' or getattr(ob.data, "is_editmode", False))]


# How far from the world origin a vertex may lie (metres, Blender units). Blender holds coordinates
# and transforms in float32, whose steps at 1e15 m are 2^26 m (67,000 km): nothing modelled lies
# there; a vertex that far is a stray one, a script's inf (Blender stores FLT_MAX) or a runaway scale.
# The engine would take it (it works in double about the scene's centre; Embree, in float32, drops
# faces only past 1.8e18), but its tolerances follow the scene's size: patches under 1e-7 of the
# diagonal are dropped as degenerate and rays leave surfaces 1e-5 of it off, so every other surface
# would vanish and the bake come out black, blamed on the lamps.
FAR = 1e15


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


def _open(m):
    """Whether the engine solves both sides of mesh `m`: all but closed ones, where each directed edge of
    the faces comes once and its reverse once (ObjectPatches::enclosed_side), whose inside it skips."""
    fv = m.face_vertices.astype(np.int64)
    starts = np.concatenate(([0], np.cumsum(m.face_sizes)[:-1]))
    nxt = np.arange(len(fv)) + 1
    nxt[starts + m.face_sizes - 1] = starts
    a, b = fv, fv[nxt]
    n = len(m.positions) + 1
    edges = np.sort(a * n + b)
    return bool((a == b).any() or (edges[1:] == edges[:-1]).any() or not np.array_equal(edges, np.sort(b * n + a)))


def effects_of(sx):
    """What light the bake simulates, each with what in the scene calls for it, then what it leaves
    out: the panel and the bake's report show it."""
    lamps = {}
    for l in sx.lights:
        if l.visible:
            lamps[l.kind] = lamps.get(l.kind, 0) + 1
    out = [f"{n} {kind} lamp{'s' if n > 1 else ''}" for kind, n in sorted(lamps.items())]
    if np.max(np.asarray(sx.world, np.float64)) > 0:
        out.append("world light (its background is not black)")
    meshes = sx.visible_meshes
    used = {int(i) for m in meshes for i in np.unique(m.face_materials)}
    if any(max(sx.materials[i].emission) > 0 for i in used):
        out.append("emission from "
                   + ("materials, varying over meshes" if any(m.corner_emission is not None for m in meshes)
                      else "emissive materials"))
    sources = {type(leaf) for m in meshes for i in np.unique(m.face_materials)
               for source in (sx.materials[i].texture if m.corner_reflectance is not None else None,
                              sx.materials[i].emission_texture if m.corner_emission is not None else None)
               for leaf in texture.leaves(source)}
    if texture.TextureRef in sources:
        out.append("colour textures (sampled at face corners)")
    if texture.AttributeRef in sources:
        out.append("colour attributes")
    if any(m.refine == "catmull_clark" for m in meshes):
        out.append("Catmull-Clark objects (Subdivision Surface, refined by the engine from the cage)")
    if any(m.object_type != 'MESH' for m in meshes):
        out.append("curve, text, surface and metaball objects (in the light, with no colours to hold)")
    if meshes:
        out.append("diffuse interreflection, every bounce down to the threshold")
    # Information, not a warning: Cycles lights both sides of them too (every floor plane is one); they
    # cost the engine the inside it skips on closed meshes. Once per object: instances share its faces.
    sources = {m.object_name: m for m in meshes}
    both = [name for name, m in sources.items() if _open(m)]
    if both:
        out.append("both sides of open meshes or ones with flipped faces ("
                   + ", ".join(both[:5]) + (" ..." if len(both) > 5 else "") + ")")
    # DESIGN.md: the attribute holds what Cycles' bake of a diffuse scene holds; a material's metal or
    # glass is reported where it is met.
    out.append("left out: glossy reflection, transmission, volumes and subsurface scattering "
               "(a diffuse bake)")
    return ", ".join(out)



# ----------------------------------------------------------------------------- incremental updates
def settings_key(settings):
    """What must match for an engine Solver to be reused (the dB cache's cap and the patch limit are
    fixed in it too)."""
    from .properties import KNOBS
    return tuple(getattr(settings, k) for k in KNOBS + ("db_cache_mb", "max_patches"))


def _same(a, b):
    if a is None or b is None:
        return a is None and b is None
    return np.array_equal(np.asarray(a), np.asarray(b))


def _lamp_call(index, l):
    """The Solver.set_*_light call (name, args) that sets lamp `index` to LightExport `l`."""
    return f"set_{l.kind}_light", (index, *exporter.lamp_args(l))


# For the messages that report a rebuild.
REBUILD_NOTE = ("the engine takes every change of the scene incrementally, objects, lamps and materials "
                "added included, but for new quality settings, an object added beyond the scene's size, a "
                "deformation that opens a crease, or deleted and replaced objects outweighing the scene")

# Appended (with its index) to the name of a mesh or lamp the Solver keeps but the scene no longer
# has as it was (align_export): no Blender name holds a NUL.
RETIRED = "\0retired"


def _same_layout(a, b):
    """Whether the engine can take mesh `b` in place of `a`: the same patches, points, shading and colours."""
    return (a.refine == b.refine and a.level == b.level and a.deforms == b.deforms
            and a.positions.shape == b.positions.shape
            and np.array_equal(a.face_sizes, b.face_sizes) and np.array_equal(a.face_vertices, b.face_vertices)
            and np.array_equal(a.face_materials, b.face_materials)
            and _same(a.smooth, b.smooth) and _same(a.corner_reflectance, b.corner_reflectance)
            and _same(a.corner_emission, b.corner_emission))


def _as_held(a, b, bent):
    """Mesh export `b` as the Solver that holds `a` should take it: deforming (MeshDesc::deforms, each
    flat face keeping its own point at the vertices it shares) once `a` is, or with `bent` where its
    own vertices moved with no modifier or shape key behind them (a script's edit, Edit Mode's once
    left)."""
    flat = b.refine != "catmull_clark" and (b.smooth is None or not np.all(b.smooth))
    moved = a.positions.shape == b.positions.shape and not np.array_equal(a.positions, b.positions)
    return replace(b, deforms=True) if not b.deforms and (a.deforms or (bent and flat and moved)) else b


def align_export(old, new, bent=False):
    """`new` laid out as the Solver that holds `old` will hold it: old's meshes, lamps and materials
    first, by index in old's order, then what `new` adds (diff_exports sends those with Solver.add).

    A mesh or lamp hidden from render, or missing from `new` (deleted, its collection excluded), is
    old's, hidden (lamps dark): the engine keeps what it had, only its visibility changes, and it can
    come back later (undo of a delete). A visible mesh is new's, its material indices mapped to the
    result's list. A mesh the engine cannot change in place (its topology, material assignment,
    smooth / flat shading, texture colours or whether it deforms changed) or a lamp of another type or area shape keeps
    old's entry, renamed RETIRED and hidden or dark, and comes again after, as new's. `bent`: the
    engine refused `new` as a change of `old` (flat faces bent apart at a vertex they share); flat
    meshes whose own vertices moved go as deforming from then on (_as_held)."""
    materials = list(old.materials)    # a material no object of `new` uses keeps old's values
    mat_index = {m.name: i for i, m in enumerate(materials)}
    for m in new.materials:
        if m.name not in mat_index:
            mat_index[m.name] = len(materials)
            materials.append(m)
        materials[mat_index[m.name]] = m
    to_state = np.array([mat_index[m.name] for m in new.materials] or [0], np.int32)
    fresh = {m.name: replace(m, face_materials=to_state[m.face_materials]) for m in new.meshes}
    meshes, added = [], []
    for i, a in enumerate(old.meshes):
        b = fresh.pop(a.name, None)
        if b is None or not b.visible:
            meshes.append(replace(a, visible=False))
            continue
        b = _as_held(a, b, bent)
        if _same_layout(a, b):
            meshes.append(b)
        else:
            meshes.append(replace(a, name=f"{a.name}{RETIRED}{i}", visible=False))
            added.append(b)
    fresh_lights = {l.name: l if l.visible else exporter.dark(l) for l in new.lights}
    lights, added_lights = [], []
    for i, a in enumerate(old.lights):
        b = fresh_lights.pop(a.name, None)
        if b is None or not b.visible:
            lights.append(exporter.dark(a))
        elif (a.kind, a.shape) != (b.kind, b.shape):
            lights.append(exporter.dark(replace(a, name=f"{a.name}{RETIRED}{i}")))
            added_lights.append(b)
        else:
            lights.append(b)
    return replace(new, meshes=meshes + added + list(fresh.values()), materials=materials,
                   lights=lights + added_lights + list(fresh_lights.values()))


def outgrown(aligned, sx):
    """Why the Solver holding `aligned` (align_export's layout of the scene `sx`) should be dropped for
    a new one, or None. It keeps every object deleted or replaced by another topology, hidden, for its
    life: an edit session that keeps replacing a large object would grow it without end. Once those
    hold more faces than the scene itself (faces stand for the patches they refine to), one full
    solve of the scene as it is costs less than carrying them."""
    names = {m.name for m in sx.meshes}
    dead = [m for m in aligned.meshes if m.name not in names]
    dead_faces = sum(len(m.face_sizes) for m in dead)
    live_faces = sum(len(m.face_sizes) for m in sx.meshes)
    if dead_faces <= live_faces:
        return None
    return (f"{len(dead)} objects deleted or replaced since the last full solve hold more faces than the "
            f"scene ({dead_faces} against {live_faces})")


def diff_exports(old, new, engine):
    """The engine calls [(Solver method name, args)] that turn the scene `old` (a SceneExport as a
    Solver holds it, mesh i its object i) into `new`, laid out alike (align_export): set_* for what
    both hold, one `add` (an engine Scene from the `engine` module) for what `new` holds past old.

    Everything is compared with numpy (whole arrays, no per-vertex loops); equal data sends nothing."""
    calls = []
    for i, (a, b) in enumerate(zip(old.meshes, new.meshes)):
        if a.visible != b.visible:
            calls.append(("set_visible", (i, b.visible)))
        if not np.array_equal(a.transform, b.transform):
            calls.append(("set_transform", (i, b.transform)))
        if not np.array_equal(a.positions, b.positions):
            calls.append(("set_positions", (i, b.positions)))
    for i, (a, b) in enumerate(zip(old.materials, new.materials)):
        if not (_same(a.reflectance, b.reflectance) and _same(a.emission, b.emission)):
            calls.append(("set_material", (i, b.reflectance, b.emission)))
    for i, (a, b) in enumerate(zip(old.lights, new.lights)):
        ca, cb = _lamp_call(i, a), _lamp_call(i, b)
        if not all(_same(x, y) if isinstance(x, np.ndarray) or isinstance(y, np.ndarray) else x == y
                   for x, y in zip(ca[1], cb[1])):
            calls.append(cb)
    if not (_same(old.world, new.world) and _same(old.world_map, new.world_map)):
        calls.append(("set_world_map", (np.asarray(new.world_map, np.float64),)) if new.world_map is not None
                     else ("set_world", (np.asarray(new.world, np.float64),)))
    if (len(new.meshes), len(new.materials), len(new.lights)) != (len(old.meshes), len(old.materials),
                                                                   len(old.lights)):
        calls.append(("add", (exporter.to_engine(new, engine, after=old)[0],)))
    return calls


def apply_calls(solver, calls):
    for name, args in calls:
        getattr(solver, name)(*args)

# ----------------------------------------------------------------------------- job
class BakeJob:
    """One frame's bake. Construct on the main thread; solve() anywhere; colours() after.

    With `base` (an earlier, succeeded BakeJob of the same scene and settings) the job is incremental:
    it reuses base's engine Solver and sends only what changed since base's export (diff_exports),
    then calls Solver.update(); its `export` is then the scene as that Solver holds it (align_export:
    deleted objects stay in it, hidden, and what was added comes after). When the engine refuses the
    change (an object added beyond the scene's size), or what base's Solver keeps of deleted and
    replaced objects outweighs the scene (outgrown), it builds a new Solver and solves the whole scene
    (`rebuild_reason` says why). `base` must not be used afterwards: its Solver now holds this job's
    scene. `images`: the texture.Images of an earlier job whose images this frame shares (a frame
    change with no edit between: what was sampled from them is not read again); None: read anew."""

    def __init__(self, scene, depsgraph, props=None, preset=None, engine=None, base=None, images=None):
        self.engine = engine or load_engine()
        self.warnings = []
        self.frame = scene.frame_current
        self.cancel_requested = False
        self.fraction = 0.0
        self.residual = 1.0
        self.stats = None
        self.error = None
        self.done = False
        self.rays = 0
        self.shots = 0
        self.budget = None           # seconds of shooting (solve()); None: to the threshold
        self.out_of_budget = False   # the budget stopped the shooting: the residual is above the threshold
        self._shoot_until = None
        self.calls = None            # incremental: the Solver calls to send
        self.rebuild_reason = None   # incremental asked for, full solve needed: why
        self.scene = None
        edit = _edit_mode_objects(scene)
        if edit:
            raise BakeError(f"object '{edit[0]}' is in Edit Mode: switch to Object Mode before baking")
        self.images = texture.Images() if images is None else images
        sx = exporter.export_scene(depsgraph, images=self.images)
        self.export = self.exported = sx
        if not sx.visible_meshes:
            raise BakeError("nothing to bake: the scene has no visible mesh objects")
        _check_extent(sx)
        self.warnings += sx.warnings
        if props is not None:
            self.settings = engine_settings(props, self.engine)
        else:
            self.settings = self.engine.Settings.preset(preset or "default")
        self.solver = None
        self.base = None
        if base is not None:
            if base.solver is None or not base.succeeded:
                self.rebuild_reason = "no solved scene to update"
            elif settings_key(base.settings) != settings_key(self.settings):
                self.rebuild_reason = "the quality settings changed"
            else:
                aligned = align_export(base.export, sx)   # as the Solver will hold it
                self.rebuild_reason = outgrown(aligned, sx)
                if self.rebuild_reason is None:
                    self.export = aligned
                    self.calls = diff_exports(base.export, aligned, self.engine)
        if self.calls is not None:
            self.base = base
            self.solver = base.solver
            self.ids = {m.name: i for i, m in enumerate(self.export.meshes)}
        else:
            self._build_scene()
        self._effects = None
        self.seconds = 0.0

    def _build_scene(self):
        try:
            self.scene, self.ids = exporter.to_engine(self.export, self.engine)
        except ValueError as e:
            raise BakeError(str(e)) from e

    @property
    def effects(self):
        """effects_of the scene exported, worked out when first read (a bake's report), not for every
        live edit: it sorts every mesh's edges."""
        if self._effects is None:
            self._effects = effects_of(self.exported)
        return self._effects

    @property
    def incremental(self):
        return self.calls is not None

    @property
    def unchanged(self):
        """Incremental, nothing differs from base and base shot to the threshold: solve() does nothing."""
        return self.calls is not None and not self.calls and not self.base.out_of_budget

    # -- any thread
    def cancel(self):
        self.cancel_requested = True
        s = self.solver
        if s is not None:
            s.cancel()

    def _progress(self, fraction, residual):
        self.fraction = float(fraction)
        self.residual = float(residual)
        if self.user_progress is not None and self.user_progress(fraction, residual) is False:
            self.cancel_requested = True
        if self.budget is not None and not self.cancel_requested:
            # The engine reports before its first shot: the budget is for shooting, whatever the
            # change itself cost. Stopping leaves a consistent state that shoots on from there.
            now = time.perf_counter()
            if self._shoot_until is None:
                self._shoot_until = now + self.budget
            if now >= self._shoot_until:
                self.out_of_budget = True
                return False
        return not self.cancel_requested

    def _full(self):
        if self.scene is None:
            self._build_scene()
        try:
            self.solver = self.engine.Solver(self.scene, self.settings)
        except ValueError as e:
            raise BakeError(str(e)) from e
        if self.cancel_requested:
            return None
        return dict(self.solver.solve(progress=self._progress))

    def _update(self):
        base = dict(self.base.stats)
        if self.unchanged:
            return dict(base, touched_points=0, seconds=0.0, shots_before=base.get("shots", 0),
                        rays_before=base.get("rays", 0), warnings=list(base.get("warnings", [])))
        try:
            apply_calls(self.solver, self.calls)
            st = dict(self.solver.update(progress=self._progress))
        except ValueError as e:           # e.g. a scaled object refines to another patch count
            if self._send_bent_as_deforming():
                return self._update()
            self.rebuild_reason = f"the engine refused the change ({e})"
            self.calls = None
            self.base = None
            self.export = self.exported  # without what only base's Solver kept (hidden, retired)
            return self._full()
        st["shots_before"] = base.get("shots", 0)
        st["rays_before"] = base.get("rays", 0)
        return st

    def _send_bent_as_deforming(self):
        """After the engine refused the change: whether flat meshes whose own vertices moved can go
        once more, as deforming, so that the change is still an update. Each such edit used to be a
        new Solver and a full solve. A refused update leaves the Solver as it was, but an `add` among
        the calls took effect when made: sent again, its objects would come twice."""
        if any(name == "add" for name, _ in self.calls):
            return False
        aligned = align_export(self.base.export, self.exported, bent=True)
        if sum(m.deforms for m in aligned.meshes) == sum(m.deforms for m in self.export.meshes):
            return False
        self.export = aligned
        self.calls = diff_exports(self.base.export, aligned, self.engine)
        self.ids = {m.name: i for i, m in enumerate(aligned.meshes)}
        return True

    def solve(self, progress=None, budget=None):
        """Run the solver; with `budget`, stop shooting after that many seconds of it (the job
        succeeds, out_of_budget and not converged). Errors are kept in self.error (also raised when
        not in a thread)."""
        self.user_progress = progress
        self.budget = budget
        t = time.perf_counter()
        try:
            if self.cancel_requested:
                return None
            st = self._update() if self.incremental else self._full()
            if st is None:
                return None
            self.stats = st
            if st.get("diverged"):   # its colours would be garbage: keep the old ones
                raise BakeError(str(st["warnings"][-1]))
            # Shots, rays and warnings add up over a Solver's life: keep this job's share.
            before = self.base.stats if self.incremental else {}
            self.rays = max(0, int(st.get("rays", 0)) - int(st.pop("rays_before", 0)))
            self.shots = max(0, int(st.get("shots", 0)) - int(st.pop("shots_before", 0)))
            old = len(before.get("warnings", [])) if before else 0
            self.warnings += [str(w) for w in st.get("warnings", [])[old:]]
            if st.get("cancelled") and not self.out_of_budget:
                self.cancel_requested = True
            return st
        except Exception as e:   # noqa: BLE001 -- reported by the caller
            self.error = e
            raise
        finally:
            self.seconds = time.perf_counter() - t
            self.done = True

    @property
    def succeeded(self):
        return self.done and self.error is None and not self.cancel_requested and self.stats is not None

    def colours(self, exact_near_direct=True):
        """{object name: (loops, 4) float32 RGBA in the original mesh's loop order} for every
        visible, non-instanced mesh whose corners match its original mesh (a hidden object keeps the
        colours it has). exact_near_direct=False: the near direct light interpolated, whatever the
        settings (Solver.corner_radiance)."""
        out = {}
        for m in self.export.visible_meshes:
            if m.object_type != 'MESH':   # no colour attribute to hold them: in effects_of
                continue
            if not m.matches_original or m.name != m.object_name:
                if m.name == m.object_name:
                    self.warnings.append(f"{m.name}: modifiers move or deform the faces it has; not written")
                continue
            rad = np.asarray(self.solver.corner_radiance(self.ids[m.name], exact_near_direct), np.float32)
            n = len(rad) if m.loop_indices is None else int(m.loop_indices.max()) + 1
            rgba = np.ones((n, 4), np.float32)
            if m.loop_indices is None:
                rgba[:, :3] = rad
            else:
                kept = m.loop_indices >= 0   # not the copies of its faces that modifiers made
                rgba[m.loop_indices[kept], :3] = rad[kept]
            out[m.object_name] = rgba
        return out


# ----------------------------------------------------------------------------- estimate
# Calibrated on the sample scenes (2026-12-02, 2 cores, the bench alone; points / rays / seconds
# measured): Cornell box draft 1,871 / 3 M / 0.17 s, default 6,863 / 43 M / 1.9 s, high 26,255 /
# 341 M / 13.9 s; subsurf room default 7,037 / 96 M / 3.0 s, high 26,893 / 838 M / 22.8 s; animated
# room default 6,939 / 85 M / 3.8 s, high 26,795 / 770 M / 32.5 s. The estimates land within
# 0.66-2.2x of these (Cornell box over, animated room under).
#   points  ~ POINTS_PER_PATCH_AREA * surface area / patch_size^2
#   rays    ~ points * samples_indirect * ln(1 / threshold) * RAYS_FACTOR: reflected shots, which go on
#             until the threshold, trace most rays (about 50-90 per point, indirect sample and e-fold:
#             dim shots sample distant receivers less, Solver::Impl::far_samples)
#   seconds ~ SECONDS_PER_POINT * points + SECONDS_PER_RAY * rays (19-32 M rays/s)
POINTS_PER_PATCH_AREA = 3.0
RAYS_FACTOR = 80.0
SECONDS_PER_POINT = 5.0e-5
SECONDS_PER_RAY = 4.3e-8


def scene_measure(scene):
    """(approximate total surface area, scene diagonal, light count) from object bounding boxes:
    cheap enough for a panel's draw() (every object at once through foreach_get: one at a time,
    5,000 objects took 115 ms a redraw)."""
    obs = scene.objects
    n = len(obs)
    kinds = np.array([ob.type for ob in obs], dtype="U16")
    hidden = np.zeros(n, bool)
    obs.foreach_get("hide_render", hidden)
    lights = int(np.count_nonzero((kinds == 'LIGHT') & ~hidden))
    solid = np.isin(kinds, exporter.GEOMETRY) & ~hidden
    if not solid.any():
        return 0.0, 0.0, lights
    def each(name, size):
        out = np.empty(n * size, np.float32)
        obs.foreach_get(name, out)
        return out.reshape(n, -1)[solid].astype(np.float64)
    M = each("matrix_world", 16).reshape(-1, 4, 4).transpose(0, 2, 1)   # stored by columns
    bb = np.einsum("oij,okj->oki", M[:, :3, :3], each("bound_box", 24).reshape(-1, 8, 3)) + M[:, None, :3, 3]
    diag = float(np.linalg.norm(bb.max((0, 1)) - bb.min((0, 1))))
    d = np.abs(each("dimensions", 3))
    boxes = 2.0 * (d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 0] * d[:, 2])
    area = float(np.where(d.min(1) > 1e-9, boxes, d.max(1) ** 2).sum())
    return area, diag, lights


def estimate(props, scene):
    """(points, rays, seconds): a rough estimate of what the chosen quality costs on this scene."""
    area, diag, lights = scene_measure(scene)
    if diag <= 0 or props.patch_size_relative <= 0:
        return 0, 0, 0.0
    patch = props.patch_size_relative * diag
    points = POINTS_PER_PATCH_AREA * area / (patch * patch)
    rays = points * props.samples_indirect * math.log(1.0 / min(props.threshold, 0.5)) * RAYS_FACTOR
    return int(points), int(rays), SECONDS_PER_POINT * points + SECONDS_PER_RAY * rays

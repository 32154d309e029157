"""One frame's bake, shared by the operators and live update: export (main thread) -> solve (any
thread) -> colours.

    job = BakeJob(context.scene, depsgraph, settings)   # main thread: export + checks
    job.solve(progress)                                  # may run in a worker thread (GIL released)
    colours = job.colours()                              # {object name: (loops, 4) float32}

    later = BakeJob(scene, depsgraph, settings, base=job)  # incremental: the same engine Solver,
    later.solve(progress)                                   # only what changed since `job` is sent
                                                            # (budget=0.04: 40 ms of shooting; the
                                                            # next job shoots on from there)

Nothing here writes to Blender data; see writeback.py.
"""
import time

import numpy as np

from . import checks, effects, texture
from . import export as exporter
from .engine import load_engine
from .errors import BakeError
from .scene_diff import align_export, apply_calls, diff_exports, outgrown
from .settings import engine_settings, settings_key


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
        checks.check_scene(scene)
        self.images = texture.Images() if images is None else images
        sx = exporter.export_scene(depsgraph, images=self.images)
        self.export = self.exported = sx
        checks.check_export(sx)
        self.warnings += sx.warnings
        if props is not None:
            self.settings = engine_settings(props, self.engine)
        else:
            self.settings = self.engine.Settings.preset(preset or "default")
        # Blender's Render > Performance > Threads (Auto-detect: every core), as Cycles follows it.
        self.settings.threads = scene.render.threads
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
        """effects.items of the scene exported, worked out when first read (a bake's report), not for every
        live edit: it sorts every mesh's edges. Once solved, with what the solve counted of their cost
        (effects.costed)."""
        if self._effects is None:
            self._effects = effects.items(self.exported)
        return self._effects if self.stats is None else effects.costed(self._effects, self.stats)

    @property
    def incremental(self):
        return self.calls is not None

    @property
    def settled(self):
        """Shot to the solve's threshold. An update stops sooner (the engine's update_threshold), a
        budget sooner still: a job with nothing to send then shoots on to it (the settle)."""
        return self.stats is not None and bool(self.stats.get("settled", True))

    @property
    def unchanged(self):
        """Incremental, nothing differs from base and base is settled: solve() does nothing."""
        return self.calls is not None and not self.calls and self.base.settled

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
            self.solver.set_threads(self.settings.threads)
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
        once more, as deforming, so that the change is still an update and not a new Solver and a full
        solve. A refused update leaves the Solver as it was, but an `add` among the calls took effect
        when made: sent again, its objects would come twice."""
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
            if m.object_type != 'MESH':   # no colour attribute to hold them: in effects.items
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

"""radiosity.bake, radiosity.bake_animation, radiosity.clear.

From a script (execute) the bake runs synchronously. From the UI (invoke) it runs modal: each frame's
solve runs in a Python thread (the engine releases the GIL), a timer polls it, Esc cancels.
Colours are written only after every frame solved; a cancel or an error leaves them untouched.
With Lightmaps on, bake writes the lightmaps (lightmap_still.py) and bake_animation each frame's
lightmaps as OpenEXR sequences (lightmap_sequence.py), evaluated in the solve's thread and written
or put in place only when every frame solved.

bake_animation solves the first frame in full and every later frame incrementally on the same engine
Solver (job.BakeJob(base=previous job)): only what changed since the previous frame is re-shot.
The handlers (frame change, live update) live in live_update.py and stay quiet while a bake runs.
"""
import json
import threading

import bpy

from . import bake_stats, display, effects, estimate, farm, lightmap, live_update, writeback
from .lightmap_sequence import SequenceBake
from .lightmap_still import StillBake
from .errors import BakeError
from .job import BakeJob
from .scene_diff import REBUILD_NOTE

# Per-frame colours of the last animation bake: {scene name: {frame: {object name: (loops,4) rgba}}}.
# Also kept in the .blend (live_update.STORE); frame_change_pre writes the current frame's colours.
frame_cache = live_update.frame_cache

MAX_REPORTS = 8


def _report_all(report, messages, kind='WARNING'):
    seen = []
    for m in messages:
        if m and m not in seen:
            seen.append(m)
    for m in seen[:MAX_REPORTS]:
        report({kind}, m)
    if len(seen) > MAX_REPORTS:
        report({kind}, f"... and {len(seen) - MAX_REPORTS} more (see the console)")
        for m in seen[MAX_REPORTS:]:
            print("Radiosity:", m)
    return seen


def _failure(e):
    """The report of a bake that stopped on exception `e`: the scene's fault (BakeError) or ours."""
    if isinstance(e, BakeError):
        return f"Radiosity: {e}"
    return f"Radiosity: the bake failed ({type(e).__name__}: {e}); colours unchanged"


def _frames(scene, animation):
    if not animation:
        return [scene.frame_current]
    return list(range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step)))


def prepare_frame(context, frame, animation, base=None):
    """BakeJob for one frame (main thread); incremental on `base`'s Solver when given.
    Raises BakeError."""
    scene = context.scene
    if animation and scene.frame_current != frame:
        scene.frame_set(frame)
    # Frames of one bake share their images: what was sampled from them is not read again.
    job = BakeJob(scene, context.evaluated_depsgraph_get(), scene.radiosity, base=base,
                       images=base.images if base is not None else None)
    if base is not None and job.rebuild_reason:
        print(f"Radiosity: frame {frame}: {job.rebuild_reason}; {REBUILD_NOTE}: new solver, full solve")
    return job


def lightmaps_for(context, animation):
    """With Lightmaps on, what the bake does with them: Bake Animation's SequenceBake, a still bake's
    StillBake; else None."""
    if not context.scene.radiosity.lightmaps:
        return None
    return SequenceBake(context.scene) if animation else StillBake()


def bake_frames(context, frames, animation, progress=None, on_frame=None, lightmap_bake=None):
    """Synchronous bake. progress(fraction, residual) -> False cancels; on_frame(frame, colours) as
    each frame is solved (a farm's chunk writes it out); `lightmap_bake` (lightmaps_for) takes each
    frame's lightmaps.
    Returns (jobs, {frame: colours}) with colours None when cancelled. Raises BakeError.
    The first frame is solved in full, later frames incrementally on the same Solver."""
    jobs, results = [], {}
    scene = context.scene
    start_frame = scene.frame_current
    n = len(frames)
    try:
        for i, f in enumerate(frames):
            job = prepare_frame(context, f, animation, jobs[-1] if jobs else None)
            jobs.append(job)
            if lightmap_bake is not None:
                lightmap_bake.prepare(job, scene.radiosity)

            def overall(fraction, residual, i=i):
                return True if progress is None else progress((i + fraction) / n, residual)
            job.solve(overall)
            if not job.succeeded:
                return jobs, None
            results[f] = job.colours()
            if lightmap_bake is not None:
                lightmap_bake.write(f, lightmap_bake.evaluate(job))
            if on_frame is not None:
                on_frame(f, results[f])
    finally:
        if animation and scene.frame_current != start_frame:
            scene.frame_set(start_frame)
    return jobs, results


def finish(context, jobs, results, animation, report, lightmap_bake=None):
    """Write the colours (current frame), fill the cache and scene.radiosity's results, write the
    lightmaps (or put their sequences in place). The last frame's Solver becomes the scene's live one (live update
    continues from it)."""
    stats = bake_stats.summary(jobs)
    if lightmap_bake is not None:
        stats["warnings"] += lightmap_bake.commit()
    written = conclude(context, results, stats, animation, report)
    live_update.live_jobs[context.scene.name] = jobs[-1]
    if isinstance(lightmap_bake, StillBake):
        live_update.lightmap_state[context.scene.name] = lightmap_bake.updates
    if not animation and stats["converged"]:
        estimate.record(context.scene, stats)
    return written


def conclude(context, results, stats, animation, report):
    """finish() for colours solved anywhere (bake_stats `stats`): a farm's come from its workers,
    whose Solvers stay there, so the scene has no live Solver after it."""
    scene = context.scene
    props = scene.radiosity
    frame = scene.frame_current
    if animation:
        frame_cache[scene.name] = results
        live_update.store_frames(scene, results)
        if not scene.render.use_lock_interface:
            # A render's frame step writes each frame's colours from the render thread; the viewport
            # drawing the same meshes meanwhile can crash Blender (bpy.app.handlers, "Note on
            # Altering Data"), unless the interface is locked while rendering.
            scene.render.use_lock_interface = True
            report({'INFO'}, "Radiosity: Render > Lock Interface turned on, so that renders can write "
                             "each baked frame's colours safely")
    else:
        cache = live_update.frames_of(scene)
        if cache is not None:
            cache[frame] = results[frame]
            live_update.store_frame(scene, frame, results[frame])
    colours = results.get(frame)
    if colours is None:                          # current frame outside the baked range
        colours = results[min(results, key=lambda f: abs(f - frame))]
    written, messages = writeback.write_all(colours, scene)
    live_update.forget(scene.name)
    live_update.remember_written(scene, colours, written)
    live_update.mark_served(scene, frame if frame in results and scene.name in frame_cache else None)
    warnings = stats["warnings"] + messages
    props.last_seconds = stats["seconds"]
    props.last_residual = stats["residual"]
    props.last_patches = stats["patches"]
    props.last_points = stats["points"]
    props.last_shots = stats["shots"]
    props.last_rays = stats["rays"]
    props.last_relaxation = stats["relaxation"]
    props.last_effects = effects.sentence(stats["effects"])
    props.last_effect_items = json.dumps(stats["effects"])
    props.last_converged = stats["converged"]
    props.last_frames = stats["frames"]
    props.has_results = True
    if not stats["converged"]:
        warnings.append("the bake stopped before reaching Light Left (see Statistics)")
    shown = _report_all(report, warnings)
    props.last_warnings = "\n".join(shown)
    report({'INFO'}, f"Radiosity: simulated: {props.last_effects}")
    display.after_bake(scene)
    # the last report is the one the status bar shows: what was baked, and where to see it
    n = stats["frames"] if animation else len(written)
    report({'INFO'}, f"Radiosity: baked {n} {'frame' if animation else 'object'}{'s' if n != 1 else ''} in {props.last_seconds:.1f} s; "
           + ("Show Bake shows it" if props.show_bake else "turn on Show Bake to see it"))
    return written


class _Bake:
    bl_options = {'REGISTER', 'UNDO'}
    animation = False

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        if self.animation and farm.wanted(context.scene):
            run = self._farm_start(context)
            if run is None:
                return {'CANCELLED'}
            try:
                run.wait()
            except BakeError as e:
                run.cancel()
                self.report({'ERROR'}, f"Radiosity: {e}")
                return {'CANCELLED'}
            return self._farm_finish(context, run)
        with live_update.suspended():
            lightmap_bake = lightmaps_for(context, self.animation)
            try:
                jobs, results = bake_frames(context, _frames(context.scene, self.animation), self.animation,
                                            lightmap_bake=lightmap_bake)
                if results is None:
                    self.report({'WARNING'}, "Radiosity: bake cancelled; colours unchanged")
                    return {'CANCELLED'}
                finish(context, jobs, results, self.animation, self.report, lightmap_bake)
            except BakeError as e:
                self.report({'ERROR'}, f"Radiosity: {e}")
                return {'CANCELLED'}
            finally:
                if lightmap_bake is not None:
                    lightmap_bake.discard()      # after commit() nothing is left to discard
        return {'FINISHED'}

    # ---------------------------------------------------------------- modal
    def invoke(self, context, event):
        scene = context.scene
        self._frames = _frames(scene, self.animation)
        self._index = 0
        self._farm = None
        if self.animation and farm.wanted(scene):
            self._farm = self._farm_start(context)
            if self._farm is None:
                return {'CANCELLED'}
            return self._modal_begin(context)
        self._jobs, self._results = [], {}
        self._lightmap_bake = lightmaps_for(context, self.animation)
        self._start_frame = scene.frame_current
        self._job = None
        self._thread = None
        live_update.suspend()               # until modal() / cancel() ends (see _end)
        self._suspended = True
        if not self._start(context):
            self._end()
            return {'CANCELLED'}
        return self._modal_begin(context)

    def _modal_begin(self, context):
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0.0, 1.0)
        wm.modal_handler_add(self)
        self._status(context, 0.0, 1.0)
        return {'RUNNING_MODAL'}

    # ---------------------------------------------------------------- farm (farm.py)
    def _farm_start(self, context):
        """The farm bake of the frame range, submitted; None when it could not start (reported)."""
        try:
            return farm.FarmBake(context.scene, _frames(context.scene, True), self.report)
        except BakeError as e:
            self.report({'ERROR'}, f"Radiosity: {e}")
            return None

    def _farm_finish(self, context, run):
        try:
            results, stats = run.collect()
        except BakeError as e:
            self.report({'ERROR'}, f"Radiosity: {e}")
            return {'CANCELLED'}
        if context.scene.radiosity.lightmaps:
            stats["warnings"] = stats["warnings"] + ["lightmaps: a farm's Bake Animation writes none; "
                                                     "bake the animation on this machine for their sequences"]
        with live_update.suspended():
            conclude(context, results, stats, True, self.report)
        self.report({'INFO'}, f"Radiosity: the farm baked {len(results)} frames in {run.chunks} chunks "
                              f"in {run.seconds:.1f} s")
        return {'FINISHED'}

    def _farm_modal(self, context, event):
        run = self._farm
        if event.type == 'ESC' and event.value == 'PRESS':
            run.cancel()
            self._cleanup(context)
            self.report({'WARNING'}, "Radiosity: farm bake cancelled; colours unchanged")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        try:
            finished = run.poll()
        except BakeError as e:
            run.cancel()
            self._cleanup(context)
            self.report({'ERROR'}, f"Radiosity: {e}")
            return {'CANCELLED'}
        context.window_manager.progress_update(run.done / len(self._frames))
        self._status(context, 0.0, 1.0)
        for area in context.screen.areas if context.screen is not None else ():   # the panel's frame count
            if area.type in {'PROPERTIES', 'VIEW_3D'}:
                area.tag_redraw()
        if not finished:
            return {'PASS_THROUGH'}
        self._cleanup(context)
        return self._farm_finish(context, run)

    def _end(self):
        if getattr(self, "_suspended", False):
            self._suspended = False
            live_update.resume()

    def _start(self, context):
        f = self._frames[self._index]
        lightmap_bake = self._lightmap_bake
        try:
            self._job = prepare_frame(context, f, self.animation, self._jobs[-1] if self._jobs else None)
            if lightmap_bake is not None:
                lightmap_bake.prepare(self._job, context.scene.radiosity)
        except Exception as e:   # noqa: BLE001 -- reported (_failure); live update must not stay held
            self.report({'ERROR'}, _failure(e))
            if lightmap_bake is not None:
                lightmap_bake.discard()
            self._restore_frame(context)
            return False
        self._jobs.append(self._job)
        job = self._job
        self._read = None            # the frame's colours, or the exception reading them raised
        self._lightmaps = {}         # the frame's lightmaps that changed (SequenceBake.evaluate)

        def run():
            try:
                job.solve()
                # Read here too: with the exact contact light a read can take seconds, which on
                # the main thread would freeze Blender.
                if job.succeeded:
                    self._read = job.colours()
                    if lightmap_bake is not None:
                        self._lightmaps = lightmap_bake.evaluate(job)
            except Exception as e:   # noqa: BLE001 -- the solve's is in job.error; both reported by modal()
                self._read = e
        self._thread = threading.Thread(target=run, name="radiosity-solve", daemon=True)
        self._thread.start()
        return True

    def _restore_frame(self, context):
        if self.animation and context.scene.frame_current != self._start_frame:
            context.scene.frame_set(self._start_frame)

    def _status(self, context, fraction, residual):
        n = len(self._frames)
        if self._farm is not None:
            text = f"Radiosity farm: {self._farm.done} of {n} frames baked, {self._farm.chunks} chunks"
        else:
            text = (f"Radiosity: {100 * fraction:.0f}%  residual {residual:.2e}"
                    + (f"  frame {self._frames[self._index]} ({self._index + 1}/{n})" if self.animation else ""))
        text += "  (Esc to cancel)"
        if context.area is not None:
            context.area.header_text_set(text)
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _cleanup(self, context):
        wm = context.window_manager
        if getattr(self, "_timer", None) is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.area is not None:
            context.area.header_text_set(None)
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        try:
            result = self._farm_modal(context, event) if self._farm is not None else self._modal(context, event)
        except Exception as e:   # noqa: BLE001 -- a fault of ours must not leave the timer and live update held
            self._stop(context)
            self.report({'ERROR'}, _failure(e))
            result = {'CANCELLED'}
        if result != {'PASS_THROUGH'}:
            self._end()
        return result

    def _stop(self, context):
        """Ends the running frame's solve (or farm bake) and puts the UI and the frame back, writing nothing."""
        if self._farm is not None:
            self._farm.cancel()
            self._cleanup(context)
            return
        if self._job is not None:
            self._job.cancel()
        if self._thread is not None:
            self._thread.join()
        if self._lightmap_bake is not None:
            self._lightmap_bake.discard()
        self._cleanup(context)
        self._restore_frame(context)

    def _modal(self, context, event):
        job = self._job
        if event.type == 'ESC' and event.value == 'PRESS':
            self._stop(context)
            self.report({'WARNING'}, "Radiosity: bake cancelled; colours unchanged")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        n = len(self._frames)
        overall = (self._index + job.fraction) / n
        context.window_manager.progress_update(overall)
        self._status(context, overall, job.residual)
        if self._thread.is_alive():
            return {'PASS_THROUGH'}
        self._thread.join()
        if job.error is not None or not job.succeeded:
            self._stop(context)
            if job.error is not None:
                self.report({'ERROR'}, f"Radiosity: {job.error}")
            else:
                self.report({'WARNING'}, "Radiosity: bake cancelled; colours unchanged")
            return {'CANCELLED'}
        if isinstance(self._read, Exception):
            raise self._read
        self._results[self._frames[self._index]] = self._read
        if self._lightmap_bake is not None:
            self._lightmap_bake.write(self._frames[self._index], self._lightmaps)
        self._index += 1
        if self._index < n:
            if not self._start(context):
                self._cleanup(context)
                return {'CANCELLED'}
            return {'PASS_THROUGH'}
        self._cleanup(context)
        self._restore_frame(context)
        finish(context, self._jobs, self._results, self.animation, self.report, self._lightmap_bake)
        return {'FINISHED'}

    def cancel(self, context):          # Blender closes the window / file while running
        self._stop(context)
        self._end()


class RADIOSITY_OT_bake(_Bake, bpy.types.Operator):
    """Compute diffuse global illumination of the whole scene into the 'Radiosity' colour attribute"""
    bl_idname = "radiosity.bake"
    bl_label = "Bake Radiosity"
    animation = False


class RADIOSITY_OT_bake_animation(_Bake, bpy.types.Operator):
    """Bake every frame of the scene's frame range; changing frame shows that frame's lighting"""
    bl_idname = "radiosity.bake_animation"
    bl_label = "Bake Radiosity Animation"
    animation = True


class RADIOSITY_OT_clear(bpy.types.Operator):
    """Remove the 'Radiosity' colour attribute from the scene's meshes"""
    bl_idname = "radiosity.clear"
    bl_label = "Clear Radiosity"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        scene = context.scene
        live_update.drop_frames(scene)
        live_update.forget(scene.name)
        n = writeback.clear(scene.objects)
        scene.radiosity.has_results = False
        self.report({'INFO'}, f"Radiosity: cleared {n} mesh(es)")
        return {'FINISHED'}


class RADIOSITY_OT_save_lightmaps(bpy.types.Operator):
    """Write the scene's lightmaps ('<object>_Radiosity' images) as OpenEXR files into a folder"""
    bl_idname = "radiosity.save_lightmaps"
    bl_label = "Save Lightmaps as EXR"
    directory: bpy.props.StringProperty(name="Folder", subtype='DIR_PATH')

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        images = lightmap.images_of(context.scene)
        if not images:
            self.report({'WARNING'}, "Radiosity: no lightmaps to save (bake with Lightmaps on)")
            return {'CANCELLED'}
        paths = lightmap.save_exr(images, self.directory)
        self.report({'INFO'}, f"Radiosity: saved {len(paths)} lightmap(s) to {self.directory}")
        return {'FINISHED'}


classes = (RADIOSITY_OT_bake, RADIOSITY_OT_bake_animation, RADIOSITY_OT_clear, RADIOSITY_OT_save_lightmaps)

"""Live update and per-frame colours: the add-on's handlers.

- Baked animation (radiosity.bake_animation): each frame's colours are kept in `frame_cache` (and in
  the .blend, scene["_radiosity_frames"], so `blender -b -a` on the saved file shows them too).
  frame_change_pre writes the new frame's colours before the frame is evaluated, so the viewport,
  F12 and `blender -b -a` all show frame N's lighting on frame N.
- Live update (scene.radiosity.live_update): one engine Solver per scene stays in memory
  (`live_jobs`, started by a bake or by the first change). On a frame change (frame_change_post) or
  an edit (depsgraph_update_post) the evaluated scene is exported and compared with what the Solver
  last got (scene_diff.diff_exports: transforms, deformed positions, objects hidden, shown or deleted,
  materials, lamps, world, and with Solver.add new objects, lamps and materials and objects whose
  topology changed); only the differences are sent, Solver.update() shoots them, and the colours
  are written (not to hidden objects: they keep theirs), and with Lightmaps on, the lightmaps whose
  light may have changed (lightmap_updates.py). New quality settings, an object added
  beyond the scene's size, or deleted and replaced objects outweighing the scene (scene_diff.outgrown)
  need a new Solver and a full solve (printed).
- In an interactive Blender the handlers never wait for the engine (play()): the export and diff
  run on the main thread, Solver.update() and the reads of the colours and lightmaps (with the exact
  contact light, seconds in a large room) in a worker thread, and the colours and lightmaps are
  written only once complete: until then the old ones stay. An update that comes while one runs
  is not queued: the next update takes the scene as it is then. The main thread only exports,
  diffs and writes.
  - While the animation plays, an update gets one frame's time of shooting (BakeJob's budget); what
    it leaves above the threshold is shot by the next update (temporal coherence). Frames that pass
    while it runs are not solved apart, and the first frame after it ends writes its colours (the
    near direct light interpolated: Exact Contact Light is read on the settle). Waiting instead would
    not keep up however small the budget: a room of thousands of vertices spends several frames'
    time in a move's gathers, which cannot be cut short, before its first shot.
  - A frame change on its own (scrubbing, the arrow keys, a script's frame_set) shoots to the
    update's stop: the engine's update_threshold, short of the solve's threshold where a frame's
    accuracy allows.
  - Edits in the viewport (an object dragged, a slider moved) get a frame's time of shooting too:
    waiting for each would freeze the UI for the whole update at every step of a drag.
  - Once playback and edits have stopped (for EDIT_QUIET seconds), _watch shoots the rest to the
    solve's threshold (the settle), in the worker as well, taking any change that came meanwhile.
  - An update that runs longer than a moment shows its progress in the status bar, and Esc stops
    it (live_progress.py, cancel()): the engine stops at a complete shot, nothing is written, and
    the Solver, consistent with its scene and what it left unshot, is kept for the next change to
    shoot on from; nothing is settled until then.
  Background mode (no event loop) finishes every frame's and edit's update before returning (sync()),
  at the update's stop.
- What the panels show: `last_sync[scene name]`, what the last update did (mode: "incremental",
  "full", "unchanged", "skipped", "cancelled" or "error"; frame, reason, seconds_total from its
  export to its colours written, residual, settled, patches, points, touched_points, shots, rays,
  warnings...), recorded when the colours are written, which redraws the panels; `progress(scene)`,
  the update running in the worker.

Never while a render runs: a render job (is_job_running('RENDER' / 'OBJECT_BAKE')) or a render
depsgraph gets no live solves. Cached frames are written only by the render pipeline's own frame
step (frame_change_pre from the render thread, before it evaluates that frame) or when no render
runs. Re-entry: the handlers do nothing while one of them, or a bake operator, is running
(`suspended()`); writes that come back as depsgraph updates find nothing changed and stop there.
"""
import contextlib
import threading
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import lightmap, live_progress, writeback
from . import export as exporter
from .lightmap_updates import Lightmaps
from .errors import BakeError
from .job import BakeJob
from .scene_diff import REBUILD_NOTE

# {scene name: {frame: {object name: (loops, 4) float32 rgba}}}: the last animation bake
frame_cache = {}
# {scene name: BakeJob}: the live engine Solver of each scene and the export it last got
live_jobs = {}
# {scene name: {object name: rgba}}: what the handlers last wrote (unchanged arrays are not rewritten)
last_written = {}
# {scene name: dict}: what the last live update did (mode, reason, seconds, touched points...)
last_sync = {}
# {scene name: (thread, job, base, info)}: the update running during playback (play())
playback = {}
# {scene name: Lightmaps}: each scene's lightmaps as its live Solver last had them evaluated
lightmap_state = {}

STORE = "_radiosity_frames"      # scene ID property: {str(frame): {object name: float32 RGB, flat}}

_state = {"suspend": 0, "busy": False, "edited": -float("inf")}   # edited: perf_counter of the last UI edit
counters = {"render_skips": 0}   # live updates refused because a render was running (tests)
_served = {}                     # {scene name: frame whose colours came from frame_cache}
_pending = {}                    # {scene name: an edit is among its updates waiting for the timer} (UI only)
_echo = {}                       # {mesh written by the last write: _geometry() then} (its update is ours)
_echo_images = set()             # lightmap images written since the last depsgraph update (ours too)


# ----------------------------------------------------------------------------- guards
def suspend():
    _state["suspend"] += 1


def resume():
    _state["suspend"] = max(0, _state["suspend"] - 1)


@contextlib.contextmanager
def suspended():
    """No handler work inside (the bake operators change frames themselves)."""
    suspend()
    try:
        yield
    finally:
        resume()


def blocked():
    return _state["suspend"] > 0 or _state["busy"]


def _job_running(kind):
    f = getattr(bpy.app, "is_job_running", None)    # Blender 3.2+
    if f is None:
        return False
    try:
        return bool(f(kind))
    except (TypeError, ValueError):
        return False


def rendering(depsgraph=None):
    """True while a render (or a Cycles bake) uses the scene data, or for a render depsgraph."""
    if depsgraph is not None and getattr(depsgraph, "mode", 'VIEWPORT') == 'RENDER':
        return True
    return _job_running('RENDER') or _job_running('OBJECT_BAKE')


def _render_thread():
    """A render job runs and this call comes from it (the render pipeline's own frame step)."""
    return threading.current_thread() is not threading.main_thread()


# ----------------------------------------------------------------------------- the frames kept
def store_frames(scene, results):
    """Keep {frame: {object: rgba}} in the .blend (RGB float32) when scene.radiosity.store_frames."""
    if STORE in scene:
        del scene[STORE]
    if not results or not scene.radiosity.store_frames:
        return
    scene[STORE] = {str(int(f)): {name: np.ascontiguousarray(rgba[:, :3], np.float32).ravel()
                                  for name, rgba in colours.items()}
                    for f, colours in results.items()}


def store_frame(scene, frame, colours):
    g = scene.get(STORE)
    if g is None:
        return
    g[str(int(frame))] = {name: np.ascontiguousarray(rgba[:, :3], np.float32).ravel()
                          for name, rgba in colours.items()}


def load_frames(scene):
    """{frame: {object: rgba}} from the .blend, or None."""
    g = scene.get(STORE)
    if g is None:
        return None
    out = {}
    for fkey, objects in g.items():
        colours = {}
        for name, flat in objects.items():
            rgb = np.asarray(memoryview(flat)).astype(np.float32).reshape(-1, 3)
            rgba = np.ones((len(rgb), 4), np.float32)
            rgba[:, :3] = rgb
            colours[name] = rgba
        out[int(fkey)] = colours
    return out


def frames_of(scene):
    """The scene's baked frames: memory first, else the .blend (loaded once)."""
    cache = frame_cache.get(scene.name)
    if cache is None and STORE in scene:
        cache = load_frames(scene)
        if cache:
            frame_cache[scene.name] = cache
    return cache


def drop_frames(scene):
    frame_cache.pop(scene.name, None)
    _served.pop(scene.name, None)
    if STORE in scene:
        del scene[STORE]


def mark_served(scene, frame):
    """The colours shown on `frame` are the baked ones (None: not from the frame cache)."""
    if frame is None:
        _served.pop(scene.name, None)
    else:
        _served[scene.name] = frame


def forget(scene_name=None):
    """Drop the live Solver(s) and what was written (clear, file load, unregister)."""
    for name in [n for n in playback if scene_name in (None, n)]:
        thread, job, _base, _info = playback.pop(name)
        job.cancel()                       # what it would write is dropped: no need to shoot on
        thread.join()
    for d in (live_jobs, last_written, last_sync, _served, lightmap_state):
        if scene_name is None:
            d.clear()
        else:
            d.pop(scene_name, None)
    if scene_name is None:
        frame_cache.clear()
        _echo.clear()
        _echo_images.clear()
        _pending.clear()


# ----------------------------------------------------------------------------- write-back
def write(scene, colours, force=False):
    """writeback.write_all for the arrays that differ from what was last written. (written, messages)"""
    done = last_written.setdefault(scene.name, {})
    todo = {}
    for name, rgba in colours.items():
        old = done.get(name)
        ob = bpy.data.objects.get(name)
        if (not force and old is not None and ob is not None and ob.type == 'MESH'
                and ob.data.color_attributes.get(writeback.ATTRIBUTE) is not None
                and (old is rgba or (old.shape == rgba.shape and np.array_equal(old, rgba)))):
            continue
        todo[name] = rgba
    if not todo:
        return [], []
    written, messages = writeback.write_all(todo, scene)
    for name in written:
        done[name] = todo[name]
        me = bpy.data.objects[name].data
        _echo[me.name] = _geometry(me)
    return written, messages


def _geometry(me):
    """A fingerprint of what the light depends on in Mesh `me` (an original), which our colour writes
    leave alone: its vertices, faces and their materials."""
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    return hash((co.tobytes(), exporter.face_materials(me).tobytes(), len(me.loops)))


def remember_written(scene, colours, written):
    done = last_written.setdefault(scene.name, {})
    for name in written:
        done[name] = colours[name]


# ----------------------------------------------------------------------------- live update
def playing():
    """The animation plays in a window (never in background mode: scripts converge every frame)."""
    wm = bpy.context.window_manager
    return (not bpy.app.background and wm is not None
            and any(w.screen is not None and w.screen.is_animation_playing for w in wm.windows))


def editing():
    """Edits keep coming from the UI (a drag in the viewport): the last came within EDIT_QUIET seconds."""
    return not bpy.app.background and time.perf_counter() - _state["edited"] < EDIT_QUIET


def frame_budget(scene):
    """Seconds of shooting an update gets during playback: one frame's time."""
    return scene.render.fps_base / scene.render.fps


def _begin(scene, depsgraph, frame_change=False):
    """Export and diff (main thread): (job to solve or None, the base it replaces, info). On a frame
    change what was sampled from images is the last export's (texture.Images): an edit comes
    through the depsgraph handler, whose exports read them anew."""
    t0 = time.perf_counter()
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    base = live_jobs.get(scene.name)
    info = {"frame": scene.frame_current, "mode": "skipped", "reason": None, "start": t0}
    try:
        images = base.images if frame_change and base is not None else None
        job = BakeJob(scene, depsgraph, scene.radiosity, base=base, images=images)
    except BakeError as e:
        info["reason"] = str(e)
        return None, base, info
    info["seconds_export"] = time.perf_counter() - t0
    if job.unchanged:
        info.update(mode="unchanged", seconds_total=time.perf_counter() - t0)
        return None, base, info
    if base is None:
        info["reason"] = "no solver for this scene yet"
    elif job.rebuild_reason:
        info["reason"] = job.rebuild_reason
    live_jobs.pop(scene.name, None)            # base's Solver is job's (or gone) from here on
    # Baked frames' lightmaps are sequences the images play (lightmap_sequence.py): kept while the
    # frames are, beyond their range too, as the images hold their first and last frames there.
    if scene.radiosity.lightmaps and not frames_of(scene):
        state = lightmap_state.setdefault(scene.name, Lightmaps())
        try:
            plan, info["lightmap_messages"] = state.prepare(job, scene.radiosity)
            info["_lightmaps"] = (state, plan)
        except Exception as e:   # noqa: BLE001 -- the colours are updated all the same
            info["lightmap_messages"] = [f"lightmaps not updated: {e}"]
    return job, base, info


def _solve(job, info, budget=None):
    """Any thread: no Blender data. The colours are read here too, and the lightmaps whose light may
    have changed evaluated, for _end to write: with the exact contact light (budget None) a read can
    take longer than the update itself, and the main thread would wait for it; lightmaps longer still."""
    lightmaps = info.pop("_lightmaps", None)
    try:
        job.solve(budget=budget)
        if job.succeeded:
            # Playing or editing, the exact contact light is left for the settle.
            info["colours"] = job.colours(exact_near_direct=job.budget is None)
    except Exception as e:   # noqa: BLE001 -- never break playback or editing
        info.update(mode="error", reason=str(e))
        return
    if lightmaps is not None and job.succeeded:
        t = time.perf_counter()
        state, plan = lightmaps
        try:
            info["lightmap_pixels"] = state.evaluate(job, plan)
        except Exception as e:   # noqa: BLE001 -- the colours are written all the same
            state.forget()
            info.setdefault("lightmap_messages", []).append(f"lightmaps not updated: {e}")
        info["lightmaps_evaluated"] = list(state.evaluated)
        info["seconds_lightmaps"] = time.perf_counter() - t


def _end(scene, job, base, info):
    """After _solve (main thread): keep the job's Solver, write its colours; the info to record."""
    colours = info.pop("colours", None)
    pixels = info.pop("lightmap_pixels", None) or {}
    if info["mode"] == "error":
        print("Radiosity: live update failed:", info["reason"])
        return info
    if job.cancel_requested:
        return _cancelled(scene, job, base, info)
    if job.rebuild_reason and base is not None:
        print(f"Radiosity: live update: {job.rebuild_reason}; {REBUILD_NOTE}: new solver, "
              f"full solve ({job.seconds:.2f} s)")
    if not job.succeeded:
        info.update(mode="error", reason="the solve did not finish")
        return info
    live_jobs[scene.name] = job
    t2 = time.perf_counter()
    written, messages = write(scene, colours)
    for name, rgba in pixels.items():           # complete: an image keeps its pixels until here
        image = lightmap.write_image(lightmap.image_name(name), rgba.shape[1], rgba.shape[0], rgba)
        _echo_images.add(image.name)
    t3 = time.perf_counter()
    st = job.stats
    points = int(st.get("points", 0))
    # the engine may count a point once per change (lamp + object): at most all of them
    touched = min(points, int(st.get("touched_points", points))) if job.incremental else points
    info.update(mode="incremental" if job.incremental else "full",
                reason=None if job.incremental else (job.rebuild_reason or info["reason"]),
                changes=len(job.calls) if job.incremental else None,
                seconds_solve=job.seconds, seconds_write=t3 - t2, seconds_total=t3 - info["start"],
                touched_points=touched, touched_points_engine=int(st.get("touched_points", -1)),
                points=points, residual=float(st.get("residual", 0.0)),
                converged=bool(st.get("converged", True)), settled=job.settled,
                restart=st.get("restart") or None, budgeted=job.budget is not None,
                rays=job.rays, shots=job.shots, written=len(written), lightmaps_written=sorted(pixels),
                patches=int(st.get("patches", 0)), warnings=list(job.warnings) + messages)
    return info


def _cancelled(scene, job, base, info):
    """_end of an update stopped by cancel(): nothing is written, the colours and lightmaps stay the
    last complete update's. The engine stops an update at a complete shot, after its gathers (which it
    does not cut short), and a solve at a complete shot: job's Solver then holds job's scene
    consistently, with what it left unshot, and the next update shoots on from it. An update stopped
    before it sent anything leaves base's Solver as it was; a new Solver stopped before its first
    solve is dropped, and the next change solves the scene afresh."""
    if job.stats is not None and job.error is None:
        job.cancel_requested = False          # a consistent state: the base of the next update
        live_jobs[scene.name] = job
        note = "the next change shoots on from where it stopped"
    elif job.incremental and job.error is None:
        live_jobs[scene.name] = base          # BakeJob.solve stopped before sending the changes
        note = "the next change updates the scene as it was before"
    else:
        note = "the next change solves the scene afresh"
    state = lightmap_state.get(scene.name)
    if state is not None:
        state.forget()                        # the light changed since the lightmaps' evaluation
    info.update(mode="cancelled", reason=f"the colours are the last complete update's; {note}",
                seconds_total=time.perf_counter() - info["start"])
    print(f"Radiosity: live update of frame {info['frame']} cancelled: {info['reason']}")
    return info


def _record(scene, info):
    last_sync[scene.name] = info
    if not bpy.app.background:
        _redraw_panels()
    return info


def _redraw_panels():
    """The panels read last_sync when drawn: a worker's update ends between the events that would
    redraw them. Only the regions that hold panels, not the viewports."""
    wm = bpy.context.window_manager
    for window in wm.windows if wm is not None else ():
        for area in window.screen.areas if window.screen is not None else ():
            for region in area.regions:
                if (area.type, region.type) in (('PROPERTIES', 'WINDOW'), ('VIEW_3D', 'UI')):
                    region.tag_redraw()


def finish(scene):
    """Wait for the playback update of `scene`, if any, and write its colours."""
    running = playback.pop(scene.name, None)
    if running is None:
        return None
    thread, job, base, info = running
    thread.join()
    _state["busy"] = True
    try:
        return _record(scene, _end(scene, job, base, info))
    finally:
        _state["busy"] = False


def _kept(info, edit):
    """Whether to record what an update did: one not known to follow an edit (the echo of our writes,
    a settle) is recorded only when it found a change."""
    return edit or info["mode"] != "unchanged"


def sync(scene, depsgraph=None, frame_change=False, edit=True):
    """Bring the scene's live Solver and the colours up to date with the evaluated scene, shooting to
    the update's stop (in the UI, _watch settles it once things stop). Returns what it did: {"mode": "unchanged" | "incremental" | "full" | "skipped" |
    "error", ...}. `frame_change`: called for one, with no edit since the last (_begin)."""
    finish(scene)
    _state["busy"] = True
    try:
        job, base, info = _begin(scene, depsgraph, frame_change)
        if job is not None:
            _solve(job, info)
            info = _end(scene, job, base, info)
        if job is not None and not bpy.app.background and not job.settled \
                and not bpy.app.timers.is_registered(_watch):
            bpy.app.timers.register(_watch, first_interval=WATCH_INTERVAL)   # settled once things stop
        return _record(scene, info) if _kept(info, edit) else info
    finally:
        _state["busy"] = False


def play(scene, depsgraph=None, frame_change=False, settle=False, edit=True):
    """Playback's and the UI's edits' step (see the module's notes): never waits for the engine.
    `settle`: shoot to the threshold (_watch). Whether it started an update: not while one runs,
    nor when nothing changed and the last one converged."""
    running = playback.get(scene.name)
    if running is not None and running[0].is_alive():
        return False
    finish(scene)
    _state["busy"] = True
    try:
        job, base, info = _begin(scene, depsgraph, frame_change)
        if job is None:
            if _kept(info, edit and not settle):          # a settle's result stays the last recorded
                _record(scene, info)
            return False
        # A frame's time of shooting while frames or edits keep coming; a frame change on its own
        # (scrubbing, the arrow keys) shoots to the update's stop. A new Solver's first solve is not
        # cut short: its first shots carry most of the light.
        quick = not settle and (playing() or not frame_change)
        budget = frame_budget(scene) if job.incremental and quick else None
        info["settle"] = settle
        thread = threading.Thread(target=_solve, args=(job, info, budget), daemon=True)
        playback[scene.name] = (thread, job, base, info)
        thread.start()
    finally:
        _state["busy"] = False
    if not bpy.app.timers.is_registered(_watch):
        bpy.app.timers.register(_watch, first_interval=WATCH_INTERVAL)
    if not bpy.app.background:
        live_progress.follow()
    return True


def running(scene):
    """(job, info) of the update of `scene` running in the worker, or None."""
    r = playback.get(scene.name)
    if r is None or not r[0].is_alive():
        return None
    return r[1], r[3]


def progress(scene):
    """The update of `scene` running in the worker as the UI shows it (live_progress's status text),
    or None: {"frame", "fraction" (0..1), "residual", "seconds" (since its export), "settle" (shooting
    to the solve's threshold after playback or edits stopped), "cancelling" (cancel() asked, the
    engine or the colour read still finishing)}."""
    r = running(scene)
    if r is None:
        return None
    job, info = r
    return {"frame": info["frame"], "fraction": job.fraction, "residual": job.residual,
            "seconds": time.perf_counter() - info["start"], "settle": info.get("settle", False),
            "cancelling": job.cancel_requested}


def cancel(scene):
    """Stop the update of `scene` running in the worker (Esc: live_progress): the engine stops at its
    next shot, nothing is read nor written (_cancelled), and nothing more is shot until the next
    change. Whether one ran."""
    r = running(scene)
    if r is None:
        return False
    r[0].cancel()
    return True


WATCH_INTERVAL = 0.1   # seconds between checks whether playback or editing stopped
EDIT_QUIET = 0.3       # seconds without an edit after which editing counts as stopped


def _watch():
    """Timer: once playback or editing stops, the scene as it is then is shot to the solve's
    threshold (settled: updates stop sooner), in the worker too (the update that ran is written
    first); polled until one ends with nothing left."""
    if playing() or editing():
        return WATCH_INTERVAL
    scene = bpy.context.scene
    if scene is None:
        return None
    running = playback.get(scene.name)
    if (running is not None and running[0].is_alive()) or rendering() or blocked():
        return WATCH_INTERVAL
    info = finish(scene)                                  # the update that ran, written
    job = live_jobs.get(scene.name)
    if info is None and (job is None or job.settled):
        return None                                       # nothing ran, nothing left to shoot
    if not scene.radiosity.live_update or (info is not None and info["mode"] == "error"):
        return None
    if info is not None and info["mode"] == "cancelled":
        return None                                       # stopped by Esc: shot on at the next change
    return WATCH_INTERVAL if play(scene, settle=True) else None


def _served_from_cache(scene):
    return _served.get(scene.name) == scene.frame_current and scene.name in frame_cache


def _user_edit(depsgraph):
    """Did this depsgraph update come from the user (not from our own colour writes)? A mesh we wrote
    comes back as updated whatever else happened to it: its geometry tells, so that a script's edit of
    its vertices on a baked frame does not pass for our echo."""
    kinds = tuple(getattr(bpy.types, n) for n in ("Material", "Light", "World", "NodeTree", "Key",
                                                  "Collection", "Armature", "Curve") if hasattr(bpy.types, n))

    def echo(me):
        me = me.original if me is not None else None
        return me is not None and me.name in _echo and _echo[me.name] == _geometry(me)
    for u in depsgraph.updates:
        idb = u.id
        if isinstance(idb, bpy.types.Object):
            if u.is_updated_transform:
                return True
            if u.is_updated_geometry and (idb.type != 'MESH' or not echo(idb.original.data)):
                return True
        elif isinstance(idb, bpy.types.Mesh):
            if not echo(idb):
                return True
        elif isinstance(idb, kinds):
            return True
    return False


def _only_echo(depsgraph):
    """Every update is one of our colour writes: nothing to compare."""
    for u in depsgraph.updates:
        idb = u.id
        if isinstance(idb, bpy.types.Mesh) and idb.name in _echo:
            continue
        if isinstance(idb, bpy.types.Image) and idb.name in _echo_images:
            continue
        if (isinstance(idb, bpy.types.Object) and not u.is_updated_transform and idb.type == 'MESH'
                and idb.data is not None and idb.data.name in _echo):
            continue
        return False
    return True


def request(scene, edit):
    """An update of `scene` from the UI's timer (_flush), which coalesces a drag's many edits into one.
    `edit`: the user edited; else only our own writes came back, and the export and diff tell."""
    _pending[scene.name] = _pending.get(scene.name, False) or edit
    if not bpy.app.timers.is_registered(_flush):
        bpy.app.timers.register(_flush, first_interval=0.0)


def _flush():
    """Timer (UI): the edits of the last event, once, as playback's updates run."""
    pending = dict(_pending)
    _pending.clear()
    scene = bpy.context.scene
    if scene is not None and scene.name in pending and not blocked() and not rendering() \
            and scene.radiosity.live_update:
        edit = pending[scene.name]
        if edit:                                  # only an edit makes the settle wait (editing())
            _state["edited"] = time.perf_counter()
        play(scene, bpy.context.evaluated_depsgraph_get(), edit=edit)
    return None


# ----------------------------------------------------------------------------- handlers
@persistent
def on_frame_change_pre(scene, *_args):
    """The new frame's baked colours, before the frame is evaluated (viewport and render)."""
    if _state["suspend"] > 0:
        return
    try:
        if rendering() and not _render_thread():
            return          # the viewport changed frame while a render job reads the meshes
        cache = frames_of(scene)
        colours = cache.get(scene.frame_current) if cache else None
        if colours is None:
            _served.pop(scene.name, None)
            return
        _served[scene.name] = scene.frame_current
        write(scene, colours)
    except Exception as e:   # noqa: BLE001 -- never break playback or rendering
        print("Radiosity: frame change write-back failed:", e)


@persistent
def on_frame_change(scene, depsgraph=None):
    """Live update on frame change (playback, scrubbing, frame_set) for frames not baked."""
    if blocked() or not scene.radiosity.live_update:
        return
    if rendering(depsgraph):
        counters["render_skips"] += 1
        return
    if _served_from_cache(scene):
        return
    try:
        # Background mode has no event loop: there the update ends before frame_set returns.
        (play if playing() or not bpy.app.background else sync)(scene, depsgraph, frame_change=True)
    except Exception as e:   # noqa: BLE001
        print("Radiosity: live update failed:", e)


@persistent
def on_depsgraph_update(scene, depsgraph=None):
    """Live update while editing: an object moved, a material, lamp or the world changed."""
    if blocked() or rendering(depsgraph):
        return
    try:
        if not scene.radiosity.live_update:
            return
        if depsgraph is None:
            depsgraph = bpy.context.evaluated_depsgraph_get()
        if _served_from_cache(scene):
            if not _user_edit(depsgraph):
                return
            drop_frames(scene)
            print("Radiosity: live update: the scene was edited; the baked animation frames are out of "
                  "date and dropped (bake the animation again to keep them)")
            edit = True
        else:
            # Our writes come back as updates of their meshes, which an edit of those meshes made
            # meanwhile (a script, a driver) looks like: the export and diff tell them apart.
            edit = not _only_echo(depsgraph)
        _echo.clear()
        _echo_images.clear()
        if bpy.app.background:
            sync(scene, depsgraph, edit=edit)
        else:
            request(scene, edit)
    except Exception as e:   # noqa: BLE001
        print("Radiosity: live update failed:", e)


@persistent
def on_load_pre(*_args):
    forget()


@persistent
def on_load_post(*_args):
    forget()          # frames come back from the .blend when first needed (frames_of)


@persistent
def on_undo_redo(*_args):
    """Undo brings back older colours with the older scene: write the next results whatever they are.
    The baked frames are the restored file's (scene[STORE]): kept in memory only, they would bring an
    undone bake back at the next frame change."""
    last_written.clear()
    _echo.clear()
    _echo_images.clear()
    lightmap_state.clear()
    frame_cache.clear()
    _served.clear()


HANDLERS = (("frame_change_pre", on_frame_change_pre),
            ("frame_change_post", on_frame_change),
            ("depsgraph_update_post", on_depsgraph_update),
            ("load_pre", on_load_pre),
            ("load_post", on_load_post),
            ("undo_post", on_undo_redo),
            ("redo_post", on_undo_redo))


def _ours(h, fn):
    return getattr(h, "__name__", "") == fn.__name__ and getattr(h, "__module__", "") == fn.__module__


def register_handlers():
    """Idempotent: an earlier registration of the same functions (e.g. before F8) is replaced."""
    for lst, fn in HANDLERS:
        handlers = getattr(bpy.app.handlers, lst)
        for h in [h for h in handlers if _ours(h, fn)]:
            handlers.remove(h)
        handlers.append(fn)


def unregister_handlers():
    for lst, fn in HANDLERS:
        handlers = getattr(bpy.app.handlers, lst)
        for h in [h for h in handlers if _ours(h, fn)]:
            handlers.remove(h)
    for timer in (_flush, _watch, live_progress.follow_timer):
        if bpy.app.timers.is_registered(timer):
            bpy.app.timers.unregister(timer)
    forget()
    _state.update(suspend=0, busy=False)

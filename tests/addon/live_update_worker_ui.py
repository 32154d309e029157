"""Live update in a real, interactive Blender (a window on Xvfb; test_live_update_worker.py runs it):

    blender --factory-startup --enable-event-simulate sample_blends/animated_room.blend \
        --python tests/addon/live_update_worker_ui.py -- OUT.json [PATCH_SIZE_RELATIVE]

Loads the add-on from addon/ (its engine from build/engine), then, each step from a timer so that the
event loop runs in between:
1. reference: bakes frame 1, moves to frame 2 and brings the colours up to date on the main thread
   (live_update.sync(): what background mode does on a frame change), timed;
2. bakes frame 1 again, turns Live Update on and runs the Right arrow's operator (screen.frame_offset)
   over the 3D viewport: how long live update's frame change handler took, whether it left the
   update running in the worker, what the status bar showed while it ran (the update is held at its
   first shot until the status bar shows it: the event loop runs meanwhile, or it never would), and
   the colours it wrote against the reference;
3. once that has settled, the Right arrow again and Esc, a key press simulated in the window (the
   update held at its first shot until Esc has cancelled it): whether the colours stayed as they
   were, and whether the next frame change updates the same Solver on from there.
Writes what it measured to OUT.json and quits.
"""
import json
import os
import sys
import threading
import time
import traceback

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from conftest import load_package  # noqa: E402
from test_live_update import read as read_scene, relative_rms, stacked  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
OUT = ARGS[0]
PATCH = float(ARGS[1]) if len(ARGS) > 1 else 0.125
POLL = 0.01          # seconds between the polls of the running update
WAIT = 60.0          # seconds any one wait may take before the script gives up

pkg = load_package()
pkg.register()
live = pkg.live_update
progress = pkg.live_progress
scene = bpy.context.scene
scene.radiosity.preset = 'DEFAULT'
scene.radiosity.patch_size_relative = PATCH
report = {"patch_size_relative": PATCH}

written = []          # (info, colours) of each update live_update wrote, in order
frame_changes = []    # (seconds live update's frame change handler took, an update then ran in the worker)
shown = []            # the status bar's texts, in order
gate = {"until": None}   # hold the worker's update at its first shot until this is true
_end, _solve, _set_text = live._end, live._solve, progress._set_text


def _spy_end(sc, job, base, info):
    out = _end(sc, job, base, info)
    written.append((dict(out), read()))
    return out


def _spy_solve(job, info, budget=None):
    until = gate["until"]
    if until is not None and threading.current_thread() is not threading.main_thread():
        solve = job.solve

        def held(_progress=None, budget=None):
            def hold(_fraction, _residual):
                t = time.perf_counter()
                while not until(job) and time.perf_counter() - t < WAIT:
                    time.sleep(POLL)
            return solve(hold, budget)
        job.solve = held
    _solve(job, info, budget)


def _spy_text(text):
    shown.append(text)
    _set_text(text)


@bpy.app.handlers.persistent
def _timed(sc, depsgraph=None):
    t = time.perf_counter()
    live.on_frame_change(sc, depsgraph)
    frame_changes.append((time.perf_counter() - t, live.running(sc) is not None))


live._end, live._solve, progress._set_text = _spy_end, _spy_solve, _spy_text
_handlers = bpy.app.handlers.frame_change_post
_handlers[_handlers.index(live.on_frame_change)] = _timed


def read():
    return read_scene(scene)


def ui():
    """The context of the largest 3D viewport (what a key press over it gets)."""
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == 'VIEW_3D'), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return window, area, region


def right_arrow():
    """The Right arrow's operator over the 3D viewport. The frame changes when the event loop next
    handles its notifier: yields until live update's handler has run; returns (the seconds it took,
    whether it left an update running in the worker)."""
    window, area, region = ui()
    del frame_changes[:]
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.frame_offset(delta=1)
    yield from wait_until(lambda: frame_changes, "the frame change")
    return frame_changes[0]


def bake():
    with live.suspended():
        scene.frame_set(1)
    assert bpy.ops.radiosity.bake() == {'FINISHED'}


def settled():
    """Nothing runs, nothing is left for the timers to start, the status bar is Blender's again."""
    return live.running(scene) is None and not any(bpy.app.timers.is_registered(t)
                                                    for t in (live._watch, progress.follow_timer))


def wait_until(done, label):
    t0 = time.perf_counter()
    while not done():
        yield POLL
        assert time.perf_counter() - t0 < WAIT, f"{label}: still waiting"


def steps():
    # 1. the reference: frame 2 updated on the main thread
    bake()
    with live.suspended():
        scene.frame_set(2)
    t = time.perf_counter()
    info = live.sync(scene, frame_change=True)
    report["sync"] = {"seconds": time.perf_counter() - t, "mode": info["mode"]}
    reference = read()

    # 2. the same update from the Right arrow, in the worker
    bake()
    scene.radiosity.live_update = True
    yield from wait_until(settled, "live update turned on")
    for got in (written, shown):
        del got[:]
    gate["until"] = lambda job: any(shown)        # held at its first shot until the status bar shows it
    report["handler_seconds"], report["started_in_worker"] = yield from right_arrow()
    assert report["started_in_worker"], "the frame change's update ran on the main thread"
    yield from wait_until(lambda: written, "the update's colours")
    gate["until"] = None
    info, colours = written[0]
    report["update"] = {"mode": info["mode"], "frame": info["frame"], "budgeted": info["budgeted"],
                        "status_texts": [t for t in shown if t]}
    report["rms_vs_sync"] = relative_rms(stacked(colours), stacked(reference))
    recorded = live.last_sync[scene.name]               # what the panel reads
    report["update"]["recorded"] = {k: recorded.get(k) for k in ("frame", "mode", "patches", "points", "settled")}
    yield from wait_until(settled, "the settle")
    report["settles"] = [(i["mode"], i["frame"]) for i, _c in written[1:]]
    report["update"]["status_cleared"] = shown[-1] is None

    # 3. Esc while the next frame's update runs
    before = read()
    del written[:]
    gate["until"] = lambda job: job.cancel_requested
    _seconds, started = yield from right_arrow()
    window, area, _region = ui()
    x, y = area.x + area.width // 2, area.y + area.height // 2
    window.event_simulate(type='ESC', value='PRESS', x=x, y=y)
    window.event_simulate(type='ESC', value='RELEASE', x=x, y=y)
    yield from wait_until(settled, "the cancelled update")
    gate["until"] = None
    info = live.last_sync[scene.name]
    report["esc"] = {"started_in_worker": started, "mode": info["mode"], "frame": info["frame"],
                     "reason": info["reason"], "ends": [i["mode"] for i, _c in written],
                     "unchanged": all(np.array_equal(before[k], v) for k, v in read().items()),
                     "solver_kept": scene.name in live.live_jobs, "status_text": progress._shown["text"]}
    del written[:]
    yield from right_arrow()
    yield from wait_until(lambda: written, "the update after Esc")
    info, colours = written[0]
    report["after_esc"] = {"mode": info["mode"], "frame": info["frame"],
                           "changed": float(relative_rms(stacked(colours), stacked(before))),
                           "finite": bool(all(np.isfinite(v).all() for v in colours.values()))}
    yield from wait_until(settled, "the last settle")
    settled_colours = read()
    scene.radiosity.live_update = False
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    report["after_esc"]["rms_vs_fresh"] = relative_rms(stacked(settled_colours), stacked(read()))


def run(gen):
    def tick():
        try:
            return next(gen)
        except StopIteration:
            finish(None)
        except Exception:   # noqa: BLE001 -- reported to the test, which fails on it
            finish(traceback.format_exc())
        return None
    return tick


def finish(error):
    report["error"] = error
    with open(OUT, "w") as f:
        json.dump(report, f, indent=1, default=float)
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(run(steps()), first_interval=0.5)

"""The UI never waits for live update: a frame change while not playing (the Right arrow) returns to
the event loop at once and the update completes in the worker, with its progress in the status bar;
the colours it writes are the same update's on the main thread; Esc stops it and leaves the colours.

This needs an interactive Blender (background mode updates on the main thread, DESIGN.md section 3):
a Blender window on a virtual display (Xvfb, installed by tools/bootstrap.sh) runs
live_update_worker_ui.py, which reports what it measured; the assertions are here.
"""
import json
import os
import shutil
import subprocess
import sys
import threading

import bpy
import numpy as np
import pytest

from conftest import ROOT, SAMPLES, load_engine
from test_live_update import (BOUND, clean_scene_after, fresh_bake, open_blend, read,  # noqa: F401
                              relative_rms, settle, stacked)

load_engine()   # when collected: a missing or broken engine fails the run (conftest.load_engine)

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "live_update_worker_ui.py")
HANDLER_LIMIT = 0.2   # seconds: a frame change's handler returns within this (export, diff, thread start)
TIMEOUT = 240         # seconds for the whole Blender run (about 20 on 2 busy cores)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    if shutil.which("xvfb-run") is None:
        pytest.fail("xvfb-run is missing: tools/bootstrap.sh installs it (Debian packages xvfb, xauth)")
    out = str(tmp_path_factory.mktemp("worker") / "report.json")
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24",
           bpy.app.binary_path, "--factory-startup", "--enable-event-simulate",
           "--window-geometry", "0", "0", "1280", "800", os.path.join(SAMPLES, "animated_room.blend"),
           "--python-exit-code", "1", "--python", SCRIPT, "--", out]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=TIMEOUT)
    if not os.path.exists(out):
        pytest.fail(f"the interactive Blender wrote no report (exit code {run.returncode}):\n"
                    f"{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    with open(out) as f:
        got = json.load(f)
    print(json.dumps(got, indent=1), file=sys.stderr)
    assert got["error"] is None, got["error"]
    return got


def test_a_frame_change_returns_at_once_and_updates_in_the_worker(report):
    sync = report["sync"]
    assert sync["mode"] == "incremental"
    print(f"Right arrow: handler {1000 * report['handler_seconds']:.1f} ms; "
          f"the same update on the main thread {1000 * sync['seconds']:.0f} ms")
    assert report["started_in_worker"]
    # The handler only exports, diffs and starts the thread: far below what the update itself costs.
    assert report["handler_seconds"] < HANDLER_LIMIT
    assert report["handler_seconds"] < sync["seconds"] / 4
    update = report["update"]
    assert (update["mode"], update["frame"], update["budgeted"]) == ("incremental", 2, False)
    recorded = update["recorded"]                       # live_update.last_sync: what the panel shows
    assert (recorded["frame"], recorded["mode"]) == (2, "incremental")
    assert recorded["patches"] > 0 and recorded["points"] > 0


def test_the_worker_writes_what_the_main_thread_would(report):
    assert report["rms_vs_sync"] < 0.005
    assert all(mode == "incremental" for mode, _frame in report["settles"])


def test_progress_shows_in_the_status_bar_while_it_runs(report):
    texts = report["update"]["status_texts"]
    assert texts and all(t.startswith("Radiosity: live update of frame 2") and "Esc" in t for t in texts), texts
    assert report["update"]["status_cleared"]


def test_esc_stops_the_update_and_leaves_the_colours(report):
    esc = report["esc"]
    assert esc["started_in_worker"]
    assert (esc["mode"], esc["frame"], esc["ends"]) == ("cancelled", 3, ["cancelled"])
    assert esc["unchanged"] and esc["solver_kept"] and esc["status_text"] is None
    after = report["after_esc"]                        # the stopped update's Solver, updated on
    assert (after["mode"], after["frame"]) == ("incremental", 4)
    assert after["finite"] and after["changed"] > 1e-3
    assert after["rms_vs_fresh"] < BOUND                # settled: a fresh bake's, as test_live_update's


def start_held_update(live, scene, monkeypatch):
    """Frame 2's update started in the worker as the UI's frame handler starts it (play), held before
    it solves until the returned event is set."""
    held = threading.Event()
    solve = live._solve
    monkeypatch.setattr(live, "_solve", lambda *args: (held.wait(), solve(*args)))
    with live.suspended():
        scene.frame_set(2)
    assert live.play(scene, frame_change=True)
    return held


def test_a_frame_change_while_one_runs_is_taken_by_the_next_update(addon, monkeypatch):
    """What the UI's frame handler does (play(frame_change=True)), here where it can be held: the
    update shoots to its stop with no frame budget; a frame change that comes meanwhile is not queued
    but taken by the settle that follows, and the colours are then a fresh bake's of that frame."""
    live = addon.live_update
    scene = open_blend("animated_room")
    scene.radiosity.live_update = True
    scene.frame_set(1)                                   # background mode: solved before it returns
    held = start_held_update(live, scene, monkeypatch)
    with live.suspended():
        scene.frame_set(3)
    assert not live.play(scene, frame_change=True)       # one runs: not queued
    thread, job, _base, info = live.playback[scene.name]
    assert info["frame"] == 2
    held.set()
    thread.join()
    assert job.succeeded and job.budget is None           # shot to the update's stop
    assert settle(live, scene)
    info = live.last_sync[scene.name]
    assert (info["frame"], info["mode"], info["budgeted"], info["settle"]) == (3, "incremental", False, True)
    now = read(scene)
    err = relative_rms(stacked(now), stacked(fresh_bake(scene)))
    print(f"frame 2 in the worker, frame 3 taken by the settle, vs fresh bake: {100 * err:.3f}% RMS")
    assert err < BOUND


def test_an_update_cancelled_before_it_sends_anything_keeps_the_solver(addon, monkeypatch):
    """Esc as the worker starts: the changes were never sent, so the scene's Solver is the one before,
    and the next frame change updates it (not a full solve); nothing is written meanwhile."""
    live = addon.live_update
    scene = open_blend("animated_room")
    scene.radiosity.live_update = True
    scene.frame_set(1)
    before = read(scene)
    base = live.live_jobs[scene.name]
    held = start_held_update(live, scene, monkeypatch)
    assert live.progress(scene)["frame"] == 2
    assert live.cancel(scene) and live.progress(scene)["cancelling"]
    held.set()
    live.playback[scene.name][0].join()
    assert live._watch() is None                         # cancelled: nothing settles
    info = live.last_sync[scene.name]
    assert (info["frame"], info["mode"]) == (2, "cancelled"), info
    assert live.live_jobs[scene.name] is base
    assert all(np.array_equal(before[k], v) for k, v in read(scene).items())
    monkeypatch.undo()                                   # the worker solves unheld again
    scene.frame_set(3)
    assert live.last_sync[scene.name]["mode"] == "incremental"

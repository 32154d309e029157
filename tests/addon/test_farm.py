"""Bake Animation on a Dask farm: a LocalCluster of two single-thread workers on this machine
(tools/local_farm.py), the animated room at the draft preset.

Every farm frame is compared with the same frame of a one-machine Bake Animation of the same file.
A farm chunk starts with a full solve where the one machine updates its Solver; both shoot to the
threshold (1e-3 of the light left unshot), each leaving it in its own places, so they agree within
0.5% RMS, not bit for bit.
"""
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import bpy
import numpy as np
import psutil
import pytest

from conftest import ROOT, SAMPLES, load_engine, load_package
from test_addon import modal_bake

load_engine()   # when collected: a missing or broken engine fails the run (conftest.load_engine)
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
from reference import relative_rms  # noqa: E402

BOUND = 0.005
FRAMES = (1, 24)


def test_chunk_size_follows_the_cost_of_a_full_solve_against_an_update(addon):
    """Each chunk pays one full solve: when it costs an update, chunks of one frame spread best at no
    cost; when it costs a hundred, one chunk a worker is the fastest."""
    import importlib
    chunk_size = importlib.import_module("dynamic_radiosity.farm_client").chunk_size
    assert chunk_size(48, 4, start=0.0, full=1.0, update=1.0) == 1
    assert chunk_size(48, 4, start=1.0, full=100.0, update=1.0) == 12
    assert 1 < chunk_size(48, 4, start=1.0, full=1.0, update=1.0) < 12        # Blender's start: a cost too


@pytest.fixture(scope="module")
def local_farm():
    """(scheduler address, the cluster's process): two single-thread workers; stopped afterwards."""
    proc = subprocess.Popen(["/usr/bin/python3.11", os.path.join(ROOT, "tools", "local_farm.py"), "--workers", "2"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    address = proc.stdout.readline().strip()
    assert address.startswith("tcp://"), address
    yield address, proc
    proc.stdin.close()
    proc.wait(timeout=60)


@pytest.fixture(scope="module", autouse=True)
def clean_scene_after():
    """Leave a fresh empty scene (default settings) for the test files that run after this one."""
    yield
    bpy.ops.wm.read_factory_settings(use_empty=True)


def open_copy(tmp_path, scheduler=""):
    """The animated room saved in tmp_path (its cache folder goes beside it), at the draft preset."""
    path = str(tmp_path / "animated_room.blend")
    shutil.copy(os.path.join(SAMPLES, "animated_room.blend"), path)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    scene.radiosity.preset = 'DRAFT'
    scene.radiosity.threshold = 1e-3
    scene.frame_start, scene.frame_end = FRAMES
    scene.radiosity.farm_scheduler = scheduler
    return scene


@pytest.fixture(scope="module")
def one_machine(addon, tmp_path_factory):
    """{frame: {object: rgba}} of Bake Animation on this machine alone (farm_scheduler empty)."""
    scene = open_copy(tmp_path_factory.mktemp("one"))
    assert bpy.ops.radiosity.bake_animation() == {'FINISHED'}
    return addon.operators.frame_cache[scene.name]


def stacked(colours):
    return np.concatenate([colours[k][:, :3] for k in sorted(colours)])


def check_frames(addon, scene, one_machine):
    """The farm's frames are Bake Animation's results, each within BOUND of the one-machine bake."""
    cache = addon.operators.frame_cache[scene.name]
    assert sorted(cache) == sorted(one_machine) == list(range(FRAMES[0], FRAMES[1] + 1))
    errors = {f: relative_rms(stacked(cache[f]), stacked(one_machine[f])) for f in cache}
    worst = max(errors, key=errors.get)
    print(f"farm vs one machine: worst frame {worst} at {100 * errors[worst]:.3f}% RMS")
    assert errors[worst] < BOUND
    assert scene.radiosity.last_frames == len(cache) and scene.radiosity.has_results
    # Playback and render read them as a one-machine bake's: frame N shows frame N's colours.
    wb = load_package().writeback
    for f in (FRAMES[1], FRAMES[0] + 5):
        scene.frame_set(f)
        got = {ob.name: wb.read_mesh(ob.data) for ob in scene.objects if ob.name in cache[f]}
        np.testing.assert_array_equal(stacked(got), stacked(cache[f]))
    assert addon.live_update.load_frames(scene).keys() == cache.keys()      # kept in the .blend too


def test_farm_frames_equal_the_one_machine_bake(addon, local_farm, one_machine, tmp_path):
    """Through the UI's path (modal, a timer polling the farm): the panel's count of frames done grows
    to every frame, and the frames are Bake Animation's results."""
    scene = open_copy(tmp_path, local_farm[0])
    counts = []

    def watch(op):
        counts.append(addon.farm.progress[scene.name][0])
        time.sleep(0.05)
        return False
    result, reports, context = modal_bake(addon, animation=True, stop=watch)
    assert result == {'FINISHED'}, reports
    frames = FRAMES[1] - FRAMES[0] + 1
    assert counts == sorted(counts) and counts[-1] == frames and any(0 < c < frames for c in counts)
    assert scene.name not in addon.farm.progress
    assert context.window_manager.timers == 0 and context.window_manager.progress is None
    check_frames(addon, scene, one_machine)
    # One file a frame and object in the cache folder beside the .blend, read by numpy as they are.
    folder = addon.farm_cache.folder_for(bpy.data.filepath)
    assert os.path.dirname(folder) == str(tmp_path)
    frame = addon.operators.frame_cache[scene.name][12]
    for name, rgba in frame.items():
        np.testing.assert_array_equal(np.load(os.path.join(folder, "0012", name + ".npy")), rgba)
    assert sorted(os.listdir(folder)) == [f"{f:04d}" for f in range(FRAMES[0], FRAMES[1] + 1)]


def workers(farm):
    """The cluster's worker processes and, for each, the chunk Blender it runs (or None)."""
    out = {}
    for w in psutil.Process(farm.pid).children():
        blenders = [c for c in w.children(recursive=True) if c.name() == "blender"]
        out[w.pid] = blenders[0] if blenders else None
    return out


def test_a_worker_killed_mid_bake_has_its_chunk_run_again(addon, local_farm, one_machine, tmp_path):
    """A worker killed while its chunk bakes, past the probe chunk with frames left to do: the
    scheduler runs the chunk again and every frame is baked; the chunk's Blender dies with it."""
    scene = open_copy(tmp_path, local_farm[0])
    folder = addon.farm_cache.folder_for(bpy.data.filepath)
    frames = range(FRAMES[0], FRAMES[1] + 1)
    killed = {}

    def kill_mid_chunk():
        deadline = time.perf_counter() + 120
        while time.perf_counter() < deadline and not killed:
            done = len(addon.farm_cache.frames_done(folder, frames)) if os.path.isdir(folder) else 0
            try:
                busy = [(pid, b) for pid, b in workers(local_farm[1]).items() if b is not None]
            except (psutil.Error, OSError):  # a chunk's Blender ended while listed: look again
                busy = []
            # past the probe chunk (2 frames), and a chunk of the rest running
            if 3 <= done < len(frames) - 2 and busy:
                pid, blender = busy[0]
                os.kill(pid, signal.SIGKILL)
                killed.update(pid=pid, blender=blender, done=done)
            time.sleep(0.02)
    killer = threading.Thread(target=kill_mid_chunk)
    killer.start()
    try:
        assert bpy.ops.radiosity.bake_animation() == {'FINISHED'}
    finally:
        killer.join()
    assert killed, "no worker was found baking a chunk mid-bake"
    print(f"killed worker {killed['pid']} with {killed['done']} of {len(frames)} frames done")
    assert killed["done"] < len(frames)
    killed["blender"].wait(timeout=10)            # gone with its worker: no orphan writes on
    check_frames(addon, scene, one_machine)


def test_esc_cancels_the_farm_tasks(addon, local_farm, tmp_path):
    """Esc while chunks bake: their Blenders end, no more frames come, nothing is loaded."""
    scene = open_copy(tmp_path, local_farm[0])
    scene.radiosity.preset = 'DEFAULT'                     # slow enough to press Esc mid-chunk
    result, reports, context = modal_bake(addon, animation=True,
                                          stop=lambda op: any(workers(local_farm[1]).values()))
    assert result == {'CANCELLED'} and "cancelled" in reports[-1][1], reports
    deadline = time.perf_counter() + 10
    while any(workers(local_farm[1]).values()) and time.perf_counter() < deadline:
        time.sleep(0.1)
    assert not any(workers(local_farm[1]).values())
    folder = addon.farm_cache.folder_for(bpy.data.filepath)
    frames = range(FRAMES[0], FRAMES[1] + 1)
    done = addon.farm_cache.frames_done(folder, frames)
    time.sleep(1.0)
    assert addon.farm_cache.frames_done(folder, frames) == done and len(done) < len(frames)
    assert scene.name not in addon.farm.progress and scene.name not in addon.operators.frame_cache
    assert context.window_manager.timers == 0 and context.window_manager.progress is None

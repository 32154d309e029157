"""Long calls release the GIL: Blender reads results on a worker thread while its UI thread runs Python.

A Python thread counts while a call runs on the main thread, stamping the time now and then. A call
that holds the GIL stops it for all of the call's work: the counter can run only before the call
starts and after it returns (when the switch back to the main thread may take a few ms). One that
releases it lets it count all along: it stalls no longer than the system's scheduling makes it.
"""
import os
import sys
import threading
import time

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, engine  # noqa: E402

SWITCH_INTERVAL = 0.0005  # s: the longest a thread waits for the GIL to be handed over
STAMP_EVERY = 64  # counts a stamp: a stamp every few microseconds, few enough to keep


def grid(n, size, x0):
    """An upward n x n grid of quads, `size` across, its centre at (x0, 0, 0)."""
    x = np.linspace(-size / 2, size / 2, n + 1)
    xs, ys = np.meshgrid(x, x, indexing="ij")
    positions = np.stack([xs.ravel() + x0, ys.ravel(), np.zeros(xs.size)], 1)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    faces = np.stack([i, i + n + 1, i + n + 2, i + 1], -1).ravel().astype(np.int32)
    return positions, np.full(n * n, 4, np.int32), faces


@pytest.fixture(scope="module")
def solved():
    """Two floors with a box on each under a point lamp, solved at draft with the exact near direct
    light, so that each read takes tens of ms: the first read of a floor works out its near direct
    light, and the one on the left is refined finely (about 100k patches). Returns (solver, left
    floor, right floor)."""
    scene = engine.Scene()
    grey = scene.add_material((0.5, 0.5, 0.5))
    floors = []
    for x0, patch_size in ((-2.0, 0.0125), (2.0, 0.05)):
        positions, sizes, faces = grid(4, 4.0, x0)
        floors.append(scene.add_mesh(positions, sizes, faces, np.zeros(len(sizes), np.int32), refine="bilinear",
                                     patch_size=patch_size))
        box = Mesh()
        box.add_box((x0, 0, 0.25), (0.5, 0.5, 0.5), grey)
        box.add_to(scene, refine="bilinear", patch_size=0.1)
    scene.add_point_light((0, 1, 2), (20, 20, 20), 0.1)
    settings = engine.Settings.preset("draft")
    settings.exact_near_direct = True
    # One engine thread leaves the counting thread a core: on a machine as busy as its cores, one
    # thread starved of CPU would stall as long as one waiting for the GIL.
    settings.threads = 1
    solver = engine.Solver(scene, settings)
    solver.solve()
    return solver, *floors


def longest_stall(call):
    """(the longest time a counting thread made no stamp while `call()` ran on this thread, the
    call's seconds)."""
    stamps, stop = [], threading.Event()

    def counter():
        n = 0
        while not stop.is_set():
            n += 1
            if n % STAMP_EVERY == 0:
                stamps.append(time.perf_counter())

    old = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL)
    thread = threading.Thread(target=counter)
    thread.start()
    try:
        time.sleep(0.01)  # the counter running
        start = time.perf_counter()
        call()
        end = time.perf_counter()
    finally:
        stop.set()
        thread.join()
        sys.setswitchinterval(old)
    s = np.array(stamps)
    times = np.concatenate([[start], s[(s > start) & (s < end)], [end]])
    return np.diff(times).max(), end - start


def more_geometry():
    """A finely refined box to add: refining it and building its BVH take tens of ms."""
    more = engine.Scene()
    m = more.add_material((0.5, 0.5, 0.5))
    box = Mesh()
    box.add_box((0.0, 1.2, 0.3), (0.3, 0.3, 0.3), m)
    box.add_to(more, refine="bilinear", patch_size=0.01)
    return more


def adding(solver):
    more = more_geometry()  # built before the call: Python code lets the counter run
    return lambda: solver.add(more)


def texels(solver, floor):
    """surface_radiance at 50,000 points of the left floor (grid(4, 4.0, -2.0): face ix * 4 + iy
    holds the unit square at x = -4 + ix, y = -2 + iy), arguments made before the call."""
    points = np.random.default_rng(0).uniform((-4.0, -2.0), (0.0, 2.0), (50000, 2))
    cell = np.minimum(np.floor(points - (-4.0, -2.0)).astype(np.int32), 3)
    faces = (cell[:, 0] * 4 + cell[:, 1]).astype(np.int32)
    positions = np.c_[points, np.zeros(len(points))]
    return lambda: solver.surface_radiance(floor, faces, positions)


# Each makes the call, its arguments ready. Add comes last, as it changes the scene.
CALLS = {
    "corner_radiance": lambda s, left, right: lambda: s.corner_radiance(left),
    "vertex_radiance": lambda s, left, right: lambda: s.vertex_radiance(right),
    "refined": lambda s, left, right: lambda: s.refined(left),
    "surface_radiance": lambda s, left, right: texels(s, left),
    "add": lambda s, left, right: adding(s),
}


@pytest.mark.parametrize("name", list(CALLS))
def test_long_calls_let_other_threads_run(solved, name):
    stall, seconds = longest_stall(CALLS[name](*solved))
    # Tens of ms at least, so that the work of a call holding the GIL is most of the time it takes.
    assert seconds > 0.02, f"{name} took {seconds * 1e3:.1f} ms: too short to tell"
    assert stall < 0.5 * seconds, f"{name}: the counter stalled {stall * 1e3:.1f} ms of {seconds * 1e3:.1f} ms"

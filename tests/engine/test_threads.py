"""The thread count a Solver works on (Settings.threads, Solver.set_threads): it changes how many
cores a call takes and nothing of its results, since every receiving point gathers on one thread
in a fixed order whichever thread that is."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import ROOM_STATE, changing_room, preset  # noqa: E402
import scenes  # noqa: E402

engine = scenes.engine


def solved(threads):
    scene, ids, cube = changing_room()
    solver = engine.Solver(scene, preset("draft", threads))
    return solver, solver.solve(), ids, cube


def test_one_thread_gives_what_every_core_gives():
    one, one_stats, ids, _ = solved(1)
    every, every_stats, _, _ = solved(0)
    assert one_stats["threads"] == 1
    assert every_stats["threads"] == os.cpu_count()
    for o in ids:
        np.testing.assert_array_equal(one.corner_radiance(o), every.corner_radiance(o))


def test_set_threads_applies_to_the_next_update():
    solver, stats, _, cube = solved(0)
    solver.set_threads(1)
    moved = np.eye(4)
    moved[:3, 3] = np.add(ROOM_STATE["cube"], (0.1, 0.0, 0.0))
    solver.set_transform(cube, moved)
    assert solver.update()["threads"] == 1


def test_a_negative_thread_count_is_refused():
    with pytest.raises(ValueError, match="threads"):
        engine.Solver(*changing_room()[:1], preset("draft", -1))

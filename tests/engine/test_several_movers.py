"""Five objects moving at once (tests/scenes.py: movers_room), all in one Solver.update() a frame:
each update against a fresh solve of its frame (DESIGN.md, section 5), and moves and their undos
against where they started."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import engine, mover_transforms, movers_room  # noqa: E402
from test_dynamic import FRAME_BOUND, relative_rms, values  # noqa: E402

PATCH_SIZE = 0.5
FRAMES = [1, 5, 9]
# A move there and back is a frame's change each way (the same step as FRAMES'), undone.
CYCLES, CYCLE_TO = 2, 13
# Consecutive frames differ far more than the bound: an update that stood still would fail.
FRAMES_APART = 0.03


def move_all(solver, movers, frame):
    for mover, transform in zip(movers, mover_transforms(frame)):
        solver.set_transform(mover, transform)
    return solver.update()


def fresh(frame, settings):
    scene, ids, _ = movers_room(frame, PATCH_SIZE)
    solver = engine.Solver(scene, settings)
    solver.solve()
    return values(solver, ids)


def test_five_movers_match_fresh_solves_and_undo_to_the_start():
    settings = engine.Settings.preset("default")
    scene, ids, movers = movers_room(FRAMES[0], PATCH_SIZE)
    solver = engine.Solver(scene, settings)
    solver.solve()
    previous = values(solver, ids)
    for frame in FRAMES[1:]:
        stats = move_all(solver, movers, frame)
        assert stats["restart"] == "", frame
        reference = fresh(frame, settings)
        assert relative_rms(previous, reference) > FRAMES_APART, frame
        got = values(solver, ids)
        assert np.isfinite(got).all(), frame
        error = relative_rms(got, reference)
        assert error <= FRAME_BOUND, f"frame {frame}: {error:.4%} from a fresh solve as updated"
        previous = reference
    start = values(solver, ids)
    for cycle in range(CYCLES):
        move_all(solver, movers, CYCLE_TO)
        move_all(solver, movers, FRAMES[-1])
        error = relative_rms(values(solver, ids), start)
        assert error <= FRAME_BOUND, f"cycle {cycle}: {error:.4%} from the start"


def test_the_db_cache_keeps_each_movers_answers_and_changes_nothing():
    # All five move a frame on and back, in one update each way. Each asks, on the way back, about
    # the rays it changed on the way there; the others' moves take only those they may block.
    def play(cache_mb):
        settings = engine.Settings.preset("draft")
        settings.db_cache_mb = cache_mb
        scene, ids, movers = movers_room(FRAMES[0], PATCH_SIZE)
        solver = engine.Solver(scene, settings)
        solver.solve()
        return [(dict(move_all(solver, movers, frame)), values(solver, ids)) for frame in (FRAMES[1], FRAMES[0])]

    cached, uncached = play(256.0), play(0.0)
    for (stats, got), (_, want) in zip(cached, uncached):
        assert np.array_equal(got, want)
    there, back = cached[0][0], cached[1][0]
    assert there["db_hits"] == 0 < there["db_entries"]
    assert back["db_hits"] > 0.25 * there["db_misses"]


def test_a_ray_near_two_movers_is_asked_about_once():
    # Movers 0 and 1 pass by each other (frames 12-13): many rays pass near both. Moved together,
    # such a ray is asked about once (what the two block of it, before and after); one after the
    # other, once in each one's update. The rays each move changes are nearly the same both ways.
    def changed_rays(together):
        scene, ids, movers = movers_room(12, PATCH_SIZE)
        solver = engine.Solver(scene, engine.Settings.preset("draft"))
        solver.solve()
        moves = [(movers[k], mover_transforms(13)[k]) for k in (0, 1)]
        asked = 0
        for step in ([moves] if together else [[m] for m in moves]):
            for mover, transform in step:
                solver.set_transform(mover, transform)
            stats = solver.update()
            asked += stats["db_hits"] + stats["db_misses"]
        return asked

    assert changed_rays(True) < 0.9 * changed_rays(False)

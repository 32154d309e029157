"""The dB cache (Settings.db_cache_mb): what the scene without a moving object does to the rays its
moves change, kept so a move back traces them no more. It keeps visibility, not light: an update
with it must give what one without it gives, bit for bit."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import ROOM_STATE, changing_room, engine  # noqa: E402
from test_dynamic import relative_rms, translation, values  # noqa: E402

PLACES = [(0.0, -0.2, 0.3), (0.3, -0.4, 0.5), (0.0, -0.2, 0.3), (0.3, -0.4, 0.5), (0.1, 0.1, 0.4),
          (0.3, -0.4, 0.5), (0.1, 0.1, 0.4)]
BLOCKS = 2  # changing_room's ids: room, ceiling lamp, blocks, cube
MOVED_BLOCKS = translation((0.1, 0.0, 0.0))


def solver(cache_mb, threshold=None):
    s = engine.Settings.preset("draft")
    s.db_cache_mb = cache_mb
    if threshold:
        s.threshold = threshold
    scene, ids, cube = changing_room(ROOM_STATE, patch_size=0.35)
    solver = engine.Solver(scene, s)
    solver.solve()
    return solver, ids, cube


def play(cache_mb, moves, threshold=None):
    """Each update's stats and values; a move is the cube's place, or (object, transform)."""
    s, ids, cube = solver(cache_mb, threshold)
    out = []
    for move in moves:
        if len(move) == 2:
            s.set_transform(*move)
        else:
            s.set_transform(cube, translation(move))
        stats = dict(s.update())
        out.append((stats, values(s, ids)))
    return out


def test_the_cache_changes_nothing_and_answers_a_move_back():
    cached, uncached = play(256.0, PLACES), play(0.0, PLACES)
    for step, ((stats, got), (plain, want)) in enumerate(zip(cached, uncached)):
        assert np.array_equal(got, want), f"update {step}"
        # What it spared is all the difference in rays: the same light, the same shots.
        assert plain["rays"] - stats["rays"] == sum(s["db_hits"] for s, _ in cached[:step + 1])
        assert stats["db_hits"] + stats["db_misses"] == plain["db_misses"] > 0
        assert plain["db_hits"] == plain["db_entries"] == plain["db_bytes"] == 0
        assert 0 < stats["db_bytes"] <= 256 * 2 ** 20
    first, back = cached[0][0], cached[1][0]
    assert first["db_hits"] == 0 and first["db_entries"] == first["db_misses"]
    # Every ray the move there changed, a move back changes, and each is answered without a trace.
    # Nearly all it changes are those: a cell near a receiver asks, with the cube where it is now,
    # which corners of its patch light the part the receiver sees, and a few rays come or go with it
    # (982 of 67,346 here, where the blocks beside the cube have large patches).
    assert back["db_hits"] == first["db_entries"] and back["db_misses"] < 0.03 * back["db_hits"]
    assert cached[4][0]["db_hits"] > 0  # a third place: the rays it shares with the other two


def test_a_tiny_cap_stays_under_it_and_changes_nothing():
    cap = 4096
    cached, uncached = play(cap / 2 ** 20, PLACES), play(0.0, PLACES)
    for (stats, got), (_, want) in zip(cached, uncached):
        assert np.array_equal(got, want)
        assert 0 < stats["db_bytes"] <= cap and stats["db_entries"] > 0


def test_another_objects_move_forgets_the_answers():
    # The cube goes and comes back (answers kept), the blocks move (the answers were about the scene
    # without the cube, the blocks where they were), then the cube goes again.
    moves = PLACES[:2] + [(BLOCKS, MOVED_BLOCKS)] + PLACES[:1]
    threshold = 1e-3  # the default's
    cached, uncached = play(256.0, moves, threshold), play(0.0, moves, threshold)
    for (_, got), (_, want) in zip(cached, uncached):
        assert np.array_equal(got, want)
    assert cached[1][0]["db_hits"] > 0
    assert cached[3][0]["db_hits"] == 0 < cached[3][0]["db_misses"]
    # And a fresh solve of where all ends, within test_dynamic.py's bound at this threshold (0.05%
    # measured).
    settings = engine.Settings.preset("draft")
    settings.threshold = threshold
    scene, ids, cube = changing_room(ROOM_STATE, patch_size=0.35)
    fresh = engine.Solver(scene, settings)
    fresh.set_transform(BLOCKS, MOVED_BLOCKS)
    fresh.set_transform(cube, translation(PLACES[0]))
    fresh.update()  # before the first solve: just applied
    fresh.solve()
    assert relative_rms(cached[-1][1], values(fresh, ids)) <= 0.01

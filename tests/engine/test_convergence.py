"""The solve's stop measures the light still to come back to surfaces, against the light that lands
on them (Solver::Impl::measure_landing)."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from scenes import Mesh, engine  # noqa: E402

RHO = 0.7
HOLE = 0.2   # half the side of the square hole in the room's roof
FIELD = 5.0  # the side of the sunlit surface beside the room


def facing_down(x0, x1, y0, y1, z):
    """A horizontal quad whose front faces down (counter-clockwise seen from below)."""
    return [(x0, y1, z), (x1, y1, z), (x1, y0, z), (x0, y0, z)]


def room_through_a_hole(field):
    """A 1 m room facing in, lit by an overhead sun through a 0.4 m hole in its roof, which is an
    open mesh: the roof's top is lit too, and its light leaves the scene. With `field`, a 5 x 5 m
    surface facing up beside the room, at its roof's height, lit by the sun: its light all goes up
    into the void (nothing it sends can reach the room, which lies behind its plane), and it takes
    150 times the light that comes in through the hole. Returns (scene, room id, the scene's
    bounding-box diagonal)."""
    scene = engine.Scene()
    grey = scene.add_material((RHO, RHO, RHO))
    box, room = Mesh(), Mesh()
    box.add_box((0.0, 0.0, 0.5), (1.0, 1.0, 1.0), grey, inward=True)
    for i, face in enumerate(box.faces):
        if i != 1:  # all but the roof (add_box's top)
            room.add_face([box.positions[k] for k in face], grey)
    for x0, x1, y0, y1 in [(-0.5, 0.5, HOLE, 0.5), (-0.5, 0.5, -0.5, -HOLE),
                           (-0.5, -HOLE, -HOLE, HOLE), (HOLE, 0.5, -HOLE, HOLE)]:
        room.add_face(facing_down(x0, x1, y0, y1, 1.0), grey)
    meshes = [room]
    if field:
        outside = Mesh()
        outside.add_face(facing_down(1.0, 1.0 + FIELD, -FIELD / 2, FIELD / 2, 1.0)[::-1], grey)  # facing up
        meshes.append(outside)
    ids = [m.add_to(scene, refine="bilinear", patch_size=0.125 if m is room else 1.0) for m in meshes]
    scene.add_sun_light((0.0, 0.0, -1.0), (3.0, 3.0, 3.0))
    corners = np.concatenate([m.positions for m in meshes])
    return scene, ids[0], np.linalg.norm(corners.max(0) - corners.min(0))


def solve(field, threshold=None):
    """The room's corner radiance and the solve's stats. Its shooters are cut at the same size with
    or without the field (a fraction of the scene's diagonal, which the field widens): the two
    rooms are then solved alike, and differ only by where the solve stops."""
    scene, room, diagonal = room_through_a_hole(field)
    settings = engine.Settings.preset("default")
    settings.shooter_size_relative *= np.sqrt(3.0) / diagonal
    if threshold:
        settings.threshold = threshold
    solver = engine.Solver(scene, settings)
    stats = solver.solve()
    assert stats["converged"]
    return solver.corner_radiance(room), stats


def test_light_that_leaves_the_scene_does_not_stop_the_inside_short():
    # Invariant: the field adds nothing to the room (its light goes where the room is not), so the
    # room's inside must reach, at the default threshold, the light it converges to far past it.
    # Stopped at 1e-3 of the light that lands, a room of reflectance 0.7 lacks about
    # 1e-3 / (1 - 0.7) of its light; 0.5% bounds that with the sampling's noise. Stopped at 1e-3 of
    # all the light reflected (the field's and the roof top's too), the inside is a quarter short
    # with the field and 1% without.
    converged, _ = solve(field=False, threshold=1e-6)
    for field in (False, True):
        radiance, stats = solve(field)
        error = np.sqrt(np.mean((radiance - converged) ** 2)) / np.mean(converged)
        assert error < 0.005, f"field {field}: {error:.3%} from the converged inside ({stats['shots']} shots)"

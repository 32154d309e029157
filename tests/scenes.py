"""Scenes built from numpy arrays for the engine's Python tests and the benchmarks."""
import os
import sys

import numpy as np

ENGINE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "engine")
sys.path.insert(0, ENGINE_DIR)
try:
    import radiosity_engine as engine  # noqa: E402
except ImportError as e:
    # Raised, not skipped: the tests that import this module fail with it, so a broken build fails the suite.
    raise ImportError(f"the engine module radiosity_engine is missing or broken in {os.path.normpath(ENGINE_DIR)} "
                      f"({e}): build it (cmake --build build)") from e


def preset(name, threads=0):
    """The engine's Settings of preset `name`, working on `threads` threads (0: one a core)."""
    settings = engine.Settings.preset(name)
    settings.threads = threads
    return settings


def threads_option(argv):
    """A bench's `--threads N`, taken out of argv: the engine's thread count (0, one a core, if absent)."""
    if "--threads" not in argv:
        return 0
    at = argv.index("--threads")
    threads = int(argv[at + 1])
    del argv[at:at + 2]
    return threads


class Mesh:
    """Faces collected as corner lists, turned into the engine's flat arrays."""

    def __init__(self):
        self.positions, self.faces, self.materials = [], [], []

    def add_face(self, corners, material):
        base = len(self.positions)
        self.positions.extend(np.asarray(corners, float))
        self.faces.append(list(range(base, base + len(corners))))
        self.materials.append(material)

    def add_box(self, centre, size, material, inward=False, angle=0.0):
        """Axis-aligned box (turned by `angle` about z), faces counter-clockwise from outside."""
        c, s = np.cos(angle), np.sin(angle)
        turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        h = np.asarray(size, float) / 2
        corner = lambda x, y, z: np.asarray(centre) + turn @ (h * np.array([x, y, z]))
        quads = [[(-1, -1, -1), (-1, 1, -1), (1, 1, -1), (1, -1, -1)],   # bottom, normal -z
                 [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],       # top
                 [(-1, -1, -1), (1, -1, -1), (1, -1, 1), (-1, -1, 1)],   # -y
                 [(1, 1, -1), (-1, 1, -1), (-1, 1, 1), (1, 1, 1)],       # +y
                 [(-1, 1, -1), (-1, -1, -1), (-1, -1, 1), (-1, 1, 1)],   # -x
                 [(1, -1, -1), (1, 1, -1), (1, 1, 1), (1, -1, 1)]]       # +x
        for q in quads:
            pts = [corner(*p) for p in q]
            self.add_face(pts[::-1] if inward else pts, material(q) if callable(material) else material)

    def weld(self):
        """Shares coincident vertices between faces, as a connected mesh (Catmull-Clark) needs."""
        unique, inverse = np.unique(np.round(np.array(self.positions), 9), axis=0, return_inverse=True)
        self.positions = list(unique)
        self.faces = [[int(inverse[i]) for i in f] for f in self.faces]
        return self

    def add_to(self, scene, **kwargs):
        return scene.add_mesh(np.array(self.positions, float),
                              np.array([len(f) for f in self.faces], np.int32),
                              np.array([i for f in self.faces for i in f], np.int32),
                              np.array(self.materials, np.int32), **kwargs)


def cornell_box(patch_size=0.0, emission=15.0):
    """A 2 m Cornell box (open front, at -y) with a ceiling emitter and two blocks.
    Returns (scene, object ids)."""
    scene = engine.Scene()
    white = scene.add_material((0.73, 0.73, 0.73))
    red = scene.add_material((0.65, 0.05, 0.05))
    green = scene.add_material((0.12, 0.45, 0.15))
    light = scene.add_material((0.78, 0.78, 0.78), (emission,) * 3)
    room = Mesh()
    def wall_material(quad):
        xs = {p[0] for p in quad}
        if xs == {-1}:
            return red
        if xs == {1}:
            return green
        return white
    # Room: an inward box without its front (-y) face.
    box = Mesh()
    box.add_box((0, 0, 1), (2, 2, 2), wall_material, inward=True)
    for face, mat in zip(box.faces, box.materials):
        corners = [box.positions[i] for i in face]
        if all(abs(p[1] + 1) < 1e-9 for p in corners):
            continue
        room.add_face(corners, mat)
    lamp = Mesh()
    lamp.add_face([(-0.25, -0.25, 1.99), (0.25, -0.25, 1.99), (0.25, 0.25, 1.99), (-0.25, 0.25, 1.99)][::-1], light)
    blocks = Mesh()
    blocks.add_box((-0.35, 0.3, 0.6), (0.6, 0.6, 1.2), white, angle=0.3)
    blocks.add_box((0.4, -0.3, 0.3), (0.6, 0.6, 0.6), white, angle=-0.3)
    ids = [m.add_to(scene, refine="bilinear", patch_size=patch_size) for m in (room, lamp, blocks)]
    return scene, ids


# The changeable state of `changing_room`, as set_* calls would change it.
ROOM_STATE = dict(cube=(0.3, -0.4, 0.5), cube_scale=(1.0, 1.0, 1.0), cube_rho=(0.5, 0.6, 0.7), lamp_emission=15.0,
                  point=((0.5, -0.5, 1.5), (3.0, 3.0, 3.0)), world=(0.05, 0.05, 0.08), cube_visible=True,
                  cube_emission=0.0)


def cube_positions(scale=(1.0, 1.0, 1.0), size=0.3):
    """A cube's corners, stretched by `scale` per axis (a deformation that keeps its edges' lengths
    at most `size`, so it refines as before), and the Mesh they came from."""
    cube = Mesh()
    cube.add_box((0, 0, 0), (size, size, size), 0)
    cube.weld()  # connected, as a Catmull-Clark surface needs; the same patches when bilinear
    return np.array(cube.positions) * np.asarray(scale), cube


def changing_room(state=ROOM_STATE, patch_size=0.0, smooth=False):
    """The Cornell box with a small dynamic cube, a point lamp and a dim world, in `state`.
    Returns (scene, object ids, cube id); the cube's material is the last one, the ceiling lamp's 3.
    state["cube_visible"] None: no cube at all (ids without it, cube id None). `smooth`: the cube
    is a Catmull-Clark surface (level 2), smooth-shaded."""
    scene, ids = cornell_box(patch_size, state["lamp_emission"])
    m = scene.add_material(state["cube_rho"], (state["cube_emission"],) * 3)
    cube_id = None
    if state["cube_visible"] is not None:
        positions, cube = cube_positions(state["cube_scale"])
        cube.positions = list(positions)
        cube.materials = [m] * len(cube.faces)
        transform = np.eye(4)
        transform[:3, 3] = state["cube"]
        refine = dict(refine="catmull_clark", level=2) if smooth else dict(refine="bilinear", patch_size=patch_size)
        cube_id = cube.add_to(scene, **refine, transform=transform, dynamic=True, visible=state["cube_visible"])
    scene.add_point_light(*state["point"], 0.05)
    world = np.asarray(state["world"], float)
    scene.set_world_map(world) if world.ndim == 3 else scene.set_world(world)
    return scene, ids + ([cube_id] if cube_id is not None else []), cube_id


# The five boxes of `movers_room`: (width, depth, height) and where each stands at frame f (1-24),
# its base's centre. Paths differ (across, along, round, overhead, back along a wall); the floating
# one passes over the first, whose shadow its own then overlaps, and the round one crosses two others'.
MOVER_SIZES = [(0.4, 0.4, 0.4), (0.35, 0.35, 0.5), (0.3, 0.3, 0.3), (0.3, 0.3, 0.15), (0.45, 0.3, 0.8)]
MOVER_FRAMES = (1, 24)


def mover_places(frame):
    """(5, 3): where the five boxes stand at `frame` (their bases' centres, in metres)."""
    t = (frame - MOVER_FRAMES[0]) / (MOVER_FRAMES[1] - MOVER_FRAMES[0])
    turn = 2 * np.pi * t
    return np.array([(-1.2 + 2.4 * t, 0.3, 0.0),
                     (-0.6, -1.3 + 2.4 * t, 0.0),
                     (0.4 + 0.7 * np.cos(turn), -0.6 + 0.7 * np.sin(turn), 0.0),
                     (1.0 - 2.0 * t, 0.2, 1.2),
                     (1.4, 1.2 - 2.2 * t, 0.0)])


def movers_room(frame, patch_size=0.4):
    """A 4 x 4 x 3 m room lit by a point lamp under its ceiling, with the five boxes of
    mover_places(frame) (bottomless, as they stand on the floor; the floating one closed).
    Returns (scene, ids, mover ids)."""
    scene = engine.Scene()
    wall = scene.add_material((0.7, 0.7, 0.7))
    floor = scene.add_material((0.5, 0.55, 0.5))
    colours = [scene.add_material(c) for c in [(0.8, 0.2, 0.15), (0.2, 0.5, 0.8), (0.8, 0.7, 0.2),
                                                 (0.6, 0.6, 0.6), (0.3, 0.7, 0.3)]]
    room = Mesh()
    room.add_box((0, 0, 1.5), (4, 4, 3), lambda q: floor if all(p[2] == -1 for p in q) else wall, inward=True)
    ids = [room.add_to(scene, refine="bilinear", patch_size=patch_size)]
    movers = []
    for k, (size, place, transform) in enumerate(zip(MOVER_SIZES, mover_places(frame), mover_transforms(frame))):
        box = Mesh()
        box.add_box((0, 0, size[2] / 2), size, colours[k])
        if place[2] == 0:  # standing on the floor: no face in the floor's plane
            del box.faces[0], box.materials[0]
        movers.append(box.add_to(scene, refine="bilinear", patch_size=patch_size / 2, transform=transform,
                                 dynamic=True))
    scene.add_point_light((0.0, -0.5, 2.7), (25.0, 25.0, 25.0), 0.05)
    return scene, ids + movers, movers


def mover_transforms(frame):
    """The five boxes' transforms at `frame`, as Solver.set_transform takes them."""
    out = []
    for place in mover_places(frame):
        t = np.eye(4)
        t[:3, 3] = place
        out.append(t)
    return out


def room_balance(wall_corners, wall_lobes, lamp):
    """The power balance of a closed 4 x 2 x 2 m room (nothing escapes) holding one more face of a
    material with `wall_lobes` (Scene.add_material's arguments), lit by a point lamp at `lamp`,
    solved at draft down to a threshold of 1e-5: light that lands is absorbed, still unshot, or
    passed on by the face (through it, or mirrored) to land again."""
    scene = engine.Scene()
    room, wall = Mesh(), Mesh()
    room.add_box((0.0, 0.0, 1.0), (4.0, 2.0, 2.0), scene.add_material((0.6, 0.5, 0.4)), inward=True)
    wall.add_face(wall_corners, scene.add_material(*wall_lobes[0], **wall_lobes[1]))
    for m in (room, wall):
        m.add_to(scene, refine="bilinear", patch_size=0.25)
    scene.add_point_light(lamp, (10.0, 10.0, 10.0))
    s = engine.Settings.preset("draft")
    s.threshold = 1e-5
    solver = engine.Solver(scene, s)
    solver.solve()
    b = solver.power_balance()
    assert b["transmitted"] > 0.1 * b["injected"]
    assert abs(b["unshot"]) < 1e-3 * b["injected"]
    assert abs((b["unshot"] + b["absorbed"] + b["transmitted"]) / b["injected"] - 1.0) <= 0.01


def placed(offset):
    """A transform moving by `offset`."""
    move = np.eye(4)
    move[:3, 3] = offset
    return move


# A Cornell box with a mirror fixed on its left wall and a sliding one (dynamic) on its back wall,
# lit by its ceiling, a point lamp in front and the world, with a cube inside. The sliding mirror
# stays within the scene's bounds: a fresh solve of a scene of other bounds samples differently.
MIRRORED_STATE = dict(slide=0.0, mirror_visible=True, specular=(0.9, 0.8, 0.7), roughness=0.0,
                      cube=(0.3, -0.4, 0.5), lamp=(0.3, -2.5, 1.3))
SLIDING_MATERIAL = 6  # after the box's four, the cube's and the fixed mirror's


def mirrored_box(state, patch_size=0.35):
    scene, ids = cornell_box(patch_size, emission=1.0)
    cube_material = scene.add_material((0.5, 0.6, 0.7))
    fixed = scene.add_material((0.05, 0.05, 0.05), specular=(0.8, 0.8, 0.8))
    sliding = scene.add_material((0.05, 0.05, 0.05), specular=state["specular"], roughness=state["roughness"])
    assert sliding == SLIDING_MATERIAL
    _, cube = cube_positions()
    cube.materials = [cube_material] * len(cube.faces)
    cube_id = cube.add_to(scene, refine="bilinear", patch_size=patch_size, transform=placed(state["cube"]),
                          dynamic=True)
    left = Mesh()  # facing +x
    left.add_face([(-0.99, -0.6, 0.4), (-0.99, 0.2, 0.4), (-0.99, 0.2, 1.4), (-0.99, -0.6, 1.4)], fixed)
    back = Mesh()  # facing -y
    back.add_face([(-0.4, 0.99, 0.7), (0.4, 0.99, 0.7), (0.4, 0.99, 1.6), (-0.4, 0.99, 1.6)], sliding)
    mirrors = [left.add_to(scene, refine="bilinear", patch_size=patch_size),
               back.add_to(scene, refine="bilinear", patch_size=patch_size, transform=placed((state["slide"], 0, 0)),
                           dynamic=True, visible=state["mirror_visible"])]
    scene.add_point_light(state["lamp"], (30.0, 30.0, 30.0), 0.05)
    scene.set_world((0.05, 0.05, 0.08))
    return scene, ids + [cube_id] + mirrors, cube_id, mirrors[1]


def sliding_material(s, state):
    s.set_material(SLIDING_MATERIAL, (0.05, 0.05, 0.05), specular=state["specular"], roughness=state["roughness"])


def slide(s, mirror, state):
    s.set_transform(mirror, placed((state["slide"], 0.0, 0.0)))


# Each step: the change to the state, and how the solver is told (solver, cube, mirror, new state).
MIRRORED_STEPS = [
    ("the cube moves", dict(cube=(-0.2, -0.1, 0.4)), lambda s, c, m, st: s.set_transform(c, placed(st["cube"]))),
    ("the mirror slides", dict(slide=0.45), lambda s, c, m, st: slide(s, m, st)),
    ("it changes colour", dict(specular=(0.4, 0.7, 0.9)), lambda s, c, m, st: sliding_material(s, st)),
    ("it turns rough, a mirror no more", dict(roughness=0.4), lambda s, c, m, st: sliding_material(s, st)),
    ("and sharp again", dict(roughness=0.0), lambda s, c, m, st: sliding_material(s, st)),
    ("it vanishes", dict(mirror_visible=False), lambda s, c, m, st: s.set_visible(m, False)),
    ("it appears elsewhere", dict(slide=-0.4, mirror_visible=True),
     lambda s, c, m, st: (slide(s, m, st), s.set_visible(m, True))),
    ("cube and mirror move together", dict(cube=(0.2, 0.1, 0.3), slide=0.1),
     lambda s, c, m, st: (s.set_transform(c, placed(st["cube"])), slide(s, m, st))),
    ("the lamp moves", dict(lamp=(-0.3, -2.0, 1.0)),
     lambda s, c, m, st: s.set_point_light(0, st["lamp"], (30.0, 30.0, 30.0), 0.05)),
]


# The accuracy an updated frame needs (DESIGN.md, section 5): its RMS against a fresh solve.
FRAME_BOUND = 0.005


def follow_updates(build, state, steps, settings, settled_bound):
    """Takes one solver of `build(state)` (scene, object ids, then the objects the steps change)
    through `steps` (name, change to the state, apply(solver, *those objects, new state)): each
    update restarts nothing and leaves the scene within FRAME_BOUND of a fresh solve of the new
    state, and within `settled_bound` of it once settled (solve() after it)."""
    def solved(state):
        scene, ids, *changed = build(state)
        solver = engine.Solver(scene, settings)
        solver.solve()
        return solver, ids, changed

    def values(solver, ids):
        return np.concatenate([solver.refined(i)[1] for i in ids])

    def relative_rms(got, reference):
        return np.sqrt(np.mean((got - reference) ** 2)) / np.mean(reference)

    state = dict(state)
    solver, ids, changed = solved(state)
    for name, change, apply in steps:
        state.update(change)
        apply(solver, *changed, state)
        assert solver.update()["restart"] == "", name
        reference = values(solved(state)[0], ids)
        got = values(solver, ids)
        assert np.isfinite(got).all() and got.min() >= 0, name
        error = relative_rms(got, reference)
        assert error <= FRAME_BOUND, f"{name}: {error:.4%} from a fresh solve as updated"
        solver.solve()
        error = relative_rms(values(solver, ids), reference)
        assert error <= settled_bound, f"{name}: {error:.4%} from a fresh solve once settled"

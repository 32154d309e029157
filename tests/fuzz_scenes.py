"""Random scenes from a seed, baked through the add-on, and the promises a bake keeps on any input.

A seed builds, in an empty Blender file, a few objects of the kinds that break geometry code: soups of
crossing triangles, 3- to 120-gons (star-shaped, bent out of their plane), slivers, stacks of
coincident copies of one quad, boxes under a Subdivision Surface modifier; object scales from 1e-6 to
1e5, zero and negative; lamps of every kind from 0 to 1e9 W, and sometimes a bright world.

`bake_and_check(seed)` bakes the scene with `bpy.ops.radiosity.bake()` and checks:
- a finished bake writes only finite, non-negative colours;
- a refused or failed bake names an object of the scene, and leaves every mesh's old colours;
- nothing crashes (a crash ends the Blender process, which the caller sees).

Run one seed in Blender (tools/fuzz.py runs many, each in its own process with a time cap):
    blender -b --factory-startup --python-exit-code 1 --python tests/fuzz_scenes.py -- SEED [PRESET]
"""
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "addon"))
from conftest import load_package  # noqa: E402
OLD = 0.25      # the colour every mesh holds before the bake: what a failure must leave


def _mesh_object(name, positions, faces, rng):
    """An object from corner positions (n, 3) and faces (lists of corner indices)."""
    me = bpy.data.meshes.new(name)
    me.from_pydata(np.asarray(positions, float).tolist(), [], [list(map(int, f)) for f in faces])
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    ob.location = rng.uniform(-2, 2, 3)
    ob.rotation_euler = rng.uniform(0, 2 * np.pi, 3)
    kind = rng.integers(10)
    if kind == 0:                                   # scales from 1e-6 to 1e5
        ob.scale = (10.0 ** rng.uniform(-6, 5),) * 3
    elif kind == 1:                                 # a zero or negative axis
        ob.scale = rng.choice([0.0, -1.0, -0.5, 2.0], 3)
    return ob


def soup(rng, name):
    n = int(rng.integers(5, 200))
    corners = rng.uniform(-1, 1, (n, 3, 3)).reshape(-1, 3)
    return _mesh_object(name, corners, np.arange(3 * n).reshape(n, 3), rng)


def ngon(rng, name):
    k = int(rng.integers(3, 121))
    angle = np.sort(rng.uniform(0, 2 * np.pi, k))
    radius = rng.uniform(0.2, 1.0, k)
    bend = rng.uniform(0, 0.3) * rng.standard_normal(k)
    corners = np.stack([radius * np.cos(angle), radius * np.sin(angle), bend], axis=1)
    return _mesh_object(name, corners, [range(k)], rng)


def slivers(rng, name):
    n = int(rng.integers(1, 20))
    a = rng.uniform(-1, 1, (n, 3))
    b = a + rng.uniform(-1, 1, (n, 3))
    c = (a + b) / 2 + 10.0 ** rng.uniform(-9, -3, (n, 1)) * rng.standard_normal((n, 3))
    corners = np.stack([a, b, c], axis=1).reshape(-1, 3)
    return _mesh_object(name, corners, np.arange(3 * n).reshape(n, 3), rng)


def stacked_quads(rng, name):
    copies = int(rng.integers(2, 7))
    quad = np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], float)
    corners = np.tile(quad, (copies, 1))
    return _mesh_object(name, corners, np.arange(4 * copies).reshape(copies, 4), rng)


def subsurf_box(rng, name):
    corners = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    corners *= rng.uniform(0.2, 1.0, 3)
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    ob = _mesh_object(name, corners, faces, rng)
    sub = ob.modifiers.new("Subdivision", 'SUBSURF')
    sub.levels = sub.render_levels = int(rng.integers(1, 3))
    return ob


KINDS = (soup, ngon, slivers, stacked_quads, subsurf_box)


def _material(rng, name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rng.uniform(0, 1, 3), 1)
    if rng.integers(4) == 0:
        bsdf.inputs["Emission"].default_value = (*rng.uniform(0, 1, 3), 1)
        bsdf.inputs["Emission Strength"].default_value = float(10.0 ** rng.uniform(-1, 3))
    return mat


def _lamp(rng, name):
    kind = str(rng.choice(['POINT', 'SPOT', 'SUN', 'AREA']))
    data = bpy.data.lights.new(name, kind)
    data.energy = 0.0 if rng.integers(6) == 0 else float(10.0 ** rng.uniform(-2, 9 if kind != 'SUN' else 3))
    ob = bpy.data.objects.new(name, data)
    ob.location = rng.uniform(-4, 4, 3)
    ob.rotation_euler = rng.uniform(0, 2 * np.pi, 3)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def build(seed, preset='DRAFT'):
    """The scene of `seed` in a new empty file; returns its mesh objects."""
    rng = np.random.default_rng(seed)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obs = []
    for i in range(int(rng.integers(1, 6))):
        kind = KINDS[int(rng.integers(len(KINDS)))]
        ob = kind(rng, f"{kind.__name__}.{i}")
        ob.data.materials.append(_material(rng, f"Material.{i}"))
        obs.append(ob)
    for i in range(int(rng.integers(0, 4))):
        _lamp(rng, f"Lamp.{i}")
    if rng.integers(3) == 0:
        world = bpy.data.worlds.new("World")
        world.color = rng.uniform(0, 1, 3)
        scene.world = world
    scene.radiosity.preset = preset
    return obs


def bake_and_check(seed, preset='DRAFT'):
    """Builds and bakes the scene of `seed` with the add-on loaded; raises AssertionError on a broken
    promise. Returns (finished, message): message is the refusal or failure the bake reported, if any."""
    writeback = load_package().writeback
    obs = build(seed, preset)
    for ob in obs:
        writeback.write_mesh(ob.data, np.full((len(ob.data.loops), 4), OLD, np.float32))
    try:
        finished = bpy.ops.radiosity.bake() == {'FINISHED'}
        message = None
    except RuntimeError as e:               # an operator's ERROR report, as a script sees it
        finished, message = False, str(e)
    if finished:
        for ob in obs:
            c = writeback.read_mesh(ob.data)
            assert c is not None, f"seed {seed}: {ob.name} has no Radiosity attribute"
            assert np.isfinite(c).all(), f"seed {seed}: {ob.name} has non-finite colours"
            assert (c >= 0).all(), f"seed {seed}: {ob.name} has negative colours"
        return True, None
    names = [ob.name for ob in bpy.context.scene.objects]
    assert message is not None and any(f"'{n}'" in message or n in message for n in names), \
        f"seed {seed}: the failure names no object: {message}"
    for ob in obs:
        assert np.all(writeback.read_mesh(ob.data) == OLD), f"seed {seed}: the failed bake changed {ob.name}'s colours"
    return False, message


def load_addon():
    pkg = load_package()
    pkg.register()
    return pkg


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    load_addon()
    seed, preset = int(args[0]), (args[1] if len(args) > 1 else 'DRAFT')
    finished, message = bake_and_check(seed, preset)
    print(f"fuzz seed {seed}: {'baked' if finished else 'refused: ' + message}")

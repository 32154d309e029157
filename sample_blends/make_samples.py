"""Regenerate the sample .blend files next to this script.

    blender -b --factory-startup --python sample_blends/make_samples.py [-- cornell_box subsurf_room ...]

Deterministic (no randomness), no absolute paths: files are written next to this script.
Scenes are simple cages: flat walls are single quads (the engine refines them itself).
Every object uses a Diffuse BSDF or an Emission node material, so Cycles is a fair reference.

  cornell_box.blend    5.5 m Cornell box, open at -Y; red left wall, green right wall; emissive
                       ceiling quad (object "Light") sitting in a hole of the ceiling (coplanar).
  subsurf_room.blend   closed 4 x 4 x 2.5 m room, a Catmull-Clark object ("Blob", Subdivision
                       Surface modifier, level 2), a plain box, a point lamp and an area lamp.
  animated_room.blend  closed 5 x 5 x 3 m room; "Box" moves along x over frames 1-24 (linear keys)
                       and the point lamp's power ramps 30 W -> 120 W (linear keys).
  interior_room.blend  closed 5 x 4 x 2.7 m room modelled as artists model interiors: walls, floor
                       and ceiling one quad each, a table, a sofa, a cabinet and a wall shelf of
                       boxes with few large faces; an area lamp under the ceiling and a spot lamp,
                       so that shadows and the spot's hot spot fall inside faces.
  window_room.blend    closed 5 x 4 x 2.7 m room lit only through a 1.6 x 1.2 m window in its +Y wall:
                       a one-quad pane ("Pane", Transparent BSDF), the sun 35 degrees up shining
                       through it onto the floor, a 0.2 grey world seen through it.
  window_room_glass.blend  the window room with a 6 mm slab of clear glass ("Pane", Glass BSDF, IOR 1.5,
                       roughness 0) in its window, lit through it by a 2 x 1.5 m area lamp outside and
                       the world (no sun: through glass it is a caustic Cycles barely converges).
  mirror_room.blend    closed 4 x 4 x 2.5 m room, an area lamp under the ceiling, a 1.5 x 1 m mirror
                       ("Mirror", Glossy BSDF of roughness 0) 5 mm in front of a wall, a box on the floor.

The last three are the optics scenes: their panes and mirror are what Cycles compares the engine's
transmission and mirrors on (their references raise Cycles' glossy and transmission bounces).
"""
import math
import os

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))

# Cube corner i = x + 2y + 4z (x, y, z in {0, 1}); quads wound counter-clockwise seen from outside.
CUBE_FACES = {
    "-Z": (0, 2, 3, 1), "+Z": (4, 5, 7, 6),
    "-Y": (0, 1, 5, 4), "+Y": (2, 6, 7, 3),
    "-X": (0, 4, 6, 2), "+X": (1, 3, 7, 5),
}


def cube_verts(lo, hi):
    return [(hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2]) for i in range(8)]


# ----------------------------------------------------------------------------- scene set-up
def new_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = 'CYCLES'
    cy = sc.cycles
    cy.device = 'CPU'
    cy.samples = 1024
    cy.preview_samples = 64
    cy.use_denoising = False
    cy.use_preview_denoising = False
    cy.use_adaptive_sampling = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.max_bounces = 64
    cy.diffuse_bounces = 64
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.transparent_max_bounces = 8
    cy.seed = 0
    sc.render.resolution_x = 512
    sc.render.resolution_y = 512
    sc.frame_start, sc.frame_end, sc.frame_current = 1, 1, 1
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    world.color = (0.0, 0.0, 0.0)
    sc.world = world
    return sc


def shader_material(name, node_type, rgb, **inputs):
    """A node material of one shader (colour `rgb` plus `inputs`) into the output."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.location = (300, 0)
    shader = nt.nodes.new(node_type)
    shader.inputs["Color"].default_value = (*rgb, 1.0)
    for key, value in inputs.items():
        shader.inputs[key].default_value = value
    nt.links.new(shader.outputs[0], out.inputs["Surface"])
    m.diffuse_color = (*rgb, 1.0)
    return m


def diffuse(name, rgb):
    """A Diffuse BSDF material; also the opaque or black stand-in the optics references swap in
    for a pane or a mirror."""
    return shader_material(name, "ShaderNodeBsdfDiffuse", rgb, Roughness=0.0)


def emission(name, rgb, strength):
    return shader_material(name, "ShaderNodeEmission", rgb, Strength=strength)


def mesh_object(name, verts, faces, materials, face_materials=None, location=(0, 0, 0), rotation=(0, 0, 0)):
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(f) for f in faces])
    for m in materials:
        me.materials.append(m)
    if face_materials is not None:
        me.polygons.foreach_set("material_index", list(face_materials))
    me.validate()
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    ob.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(ob)
    return ob


def room(name, lo, hi, sides, materials, face_materials):
    """Inward-facing box walls (one quad per side listed in `sides`)."""
    faces = [tuple(reversed(CUBE_FACES[s])) for s in sides]
    return mesh_object(name, cube_verts(lo, hi), faces, materials, face_materials)


def box(name, size, location, rot_z_deg, material, sides=("+Z", "-Y", "+Y", "-X", "+X")):
    """Outward-facing box centred on its origin in x, y, resting on z = 0 of its local frame."""
    sx, sy, sz = size
    faces = [CUBE_FACES[s] for s in sides]
    return mesh_object(name, cube_verts((-sx / 2, -sy / 2, 0), (sx / 2, sy / 2, sz)), faces, [material],
                       location=location, rotation=(0, 0, math.radians(rot_z_deg)))


def boxes(name, parts, material, location, rot_z_deg=0.0):
    """One object of several outward-facing boxes, each (lo, hi, sides) in the object's frame:
    furniture as artists model it, a few large faces, the faces that touch something left out."""
    verts, faces = [], []
    for lo, hi, sides in parts:
        faces += [tuple(len(verts) + i for i in CUBE_FACES[s]) for s in sides]
        verts += cube_verts(lo, hi)
    return mesh_object(name, verts, faces, [material], location=location,
                       rotation=(0, 0, math.radians(rot_z_deg)))


def lamp(name, kind, location, rotation=(0, 0, 0), color=(1, 1, 1), **props):
    ld = bpy.data.lights.new(name, kind)
    ld.color = color
    for k, v in props.items():
        setattr(ld, k, v)
    ob = bpy.data.objects.new(name, ld)
    ob.location = location
    ob.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(ob)
    return ob


def camera(location, rotation_deg, lens=35.0):
    cd = bpy.data.cameras.new("Camera")
    cd.lens = lens
    ob = bpy.data.objects.new("Camera", cd)
    ob.location = location
    ob.rotation_euler = tuple(math.radians(a) for a in rotation_deg)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.scene.camera = ob
    return ob


def save(filename):
    path = os.path.join(HERE, filename)
    bpy.context.preferences.filepaths.save_version = 0      # no .blend1 backups
    bpy.ops.wm.save_as_mainfile(filepath=path, check_existing=False, compress=True, relative_remap=True)
    print("wrote", path)


def linear_keys(id_data):
    ad = id_data.animation_data
    if ad and ad.action:
        for fc in ad.action.fcurves:
            for kp in fc.keyframe_points:
                kp.interpolation = 'LINEAR'


def world_colour(sc, grey):
    bg = sc.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (grey, grey, grey, 1.0)
    sc.world.color = (grey, grey, grey)


# ----------------------------------------------------------------------------- scenes
def make_cornell():
    new_scene()
    white = diffuse("White", (0.725, 0.71, 0.68))
    red = diffuse("Red", (0.63, 0.065, 0.05))
    green = diffuse("Green", (0.14, 0.45, 0.091))
    light = emission("LightEmission", (1.0, 0.85, 0.7), 50.0)
    H = 2.75
    # floor, back wall, left (red), right (green); open at -Y, ceiling separate
    room("Room", (-H, -H, 0.0), (H, H, 2 * H), ("-Z", "+Y", "-X", "+X"), [white, red, green], (0, 0, 1, 2))
    # ceiling at z = 5.5 facing down, a 3 x 3 grid of quads without its centre (the light's hole)
    lx, ly = 0.65, 0.525                       # light 1.3 x 1.05 m
    xs, ys = (-H, -lx, lx, H), (-H, -ly, ly, H)
    verts = [(x, y, 2 * H) for y in ys for x in xs]
    faces = []
    for j in range(3):
        for i in range(3):
            if i == 1 and j == 1:
                continue
            a, b, c, d = j * 4 + i, j * 4 + i + 1, (j + 1) * 4 + i + 1, (j + 1) * 4 + i
            faces.append((a, d, c, b))             # clockwise from above -> normal -Z
    mesh_object("Ceiling", verts, faces, [white])
    mesh_object("Light", [(-lx, -ly, 2 * H), (lx, -ly, 2 * H), (lx, ly, 2 * H), (-lx, ly, 2 * H)],
                [(0, 3, 2, 1)], [light])
    box("ShortBox", (1.65, 1.65, 1.65), (0.95, -0.7, 0.0), -17.0, white)
    box("TallBox", (1.65, 1.65, 3.3), (-0.95, 0.75, 0.0), 17.0, white)
    camera((0.0, -10.4, H), (90.0, 0.0, 0.0), lens=40.0)
    save("cornell_box.blend")


def make_subsurf_room():
    new_scene()
    wall = diffuse("Wall", (0.8, 0.8, 0.8))
    floor = diffuse("Floor", (0.5, 0.45, 0.4))
    blue = diffuse("BlueWall", (0.2, 0.3, 0.7))
    orange = diffuse("Orange", (0.8, 0.4, 0.1))
    grey = diffuse("Grey", (0.6, 0.6, 0.6))
    room("Room", (-2.0, -2.0, 0.0), (2.0, 2.0, 2.5), ("-Z", "+Z", "-Y", "+Y", "-X", "+X"),
         [wall, floor, blue], (1, 0, 0, 2, 0, 0))
    blob = mesh_object("Blob", cube_verts((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5)), list(CUBE_FACES.values()),
                       [orange], location=(0.6, 0.4, 0.8), rotation=(0.0, 0.0, math.radians(30.0)))
    mod = blob.modifiers.new("Subdivision", 'SUBSURF')
    mod.levels = 2
    mod.render_levels = 2
    mod.subdivision_type = 'CATMULL_CLARK'
    # Smooth shading: Cycles then shades the subdivided mesh with interpolated normals (close to the
    # limit surface's); flat shading would give each level-2 facet its own normal.
    blob.data.polygons.foreach_set("use_smooth", [True] * len(blob.data.polygons))
    box("Pedestal", (0.8, 0.8, 0.6), (-0.8, -0.6, 0.0), 0.0, grey)
    lamp("PointLamp", 'POINT', (-1.2, 1.0, 1.9), energy=40.0, shadow_soft_size=0.1, color=(1.0, 0.9, 0.8))
    lamp("AreaLamp", 'AREA', (0.8, -0.8, 2.45), energy=40.0, shape='RECTANGLE', size=1.0, size_y=0.6,
         color=(0.8, 0.9, 1.0))
    camera((-1.85, -1.85, 1.7), (75.0, 0.0, -45.0), lens=20.0)
    save("subsurf_room.blend")


def make_animated_room():
    sc = new_scene()
    sc.frame_start, sc.frame_end, sc.frame_current = 1, 24, 1
    wall = diffuse("Wall", (0.75, 0.75, 0.75))
    floor = diffuse("Floor", (0.4, 0.5, 0.4))
    boxm = diffuse("BoxRed", (0.8, 0.2, 0.15))
    room("Room", (-2.5, -2.5, 0.0), (2.5, 2.5, 3.0), ("-Z", "+Z", "-Y", "+Y", "-X", "+X"),
         [wall, floor], (1, 0, 0, 0, 0, 0))
    b = box("Box", (1.0, 1.0, 1.0), (-1.5, 0.3, 0.0), 0.0, boxm)
    b.location = (-1.5, 0.3, 0.0)
    b.keyframe_insert("location", frame=1)
    b.location = (1.5, 0.3, 0.0)
    b.keyframe_insert("location", frame=24)
    linear_keys(b)
    lo = lamp("Lamp", 'POINT', (0.0, -0.5, 2.6), energy=30.0, shadow_soft_size=0.0)
    lo.data.energy = 30.0
    lo.data.keyframe_insert("energy", frame=1)
    lo.data.energy = 120.0
    lo.data.keyframe_insert("energy", frame=24)
    linear_keys(lo.data)
    sc.frame_set(1)
    camera((0.0, -2.4, 1.6), (80.0, 0.0, 0.0), lens=18.0)
    save("animated_room.blend")


def make_interior_room():
    new_scene()
    wall = diffuse("Wall", (0.75, 0.73, 0.68))
    floor = diffuse("Floor", (0.45, 0.3, 0.18))
    ceiling = diffuse("Ceiling", (0.8, 0.8, 0.8))
    wood = diffuse("Wood", (0.5, 0.33, 0.2))
    fabric = diffuse("Fabric", (0.2, 0.3, 0.55))
    paint = diffuse("Paint", (0.65, 0.66, 0.6))
    room("Room", (-2.5, -2.0, 0.0), (2.5, 2.0, 2.7), ("-Z", "+Z", "-Y", "+Y", "-X", "+X"),
         [wall, floor, ceiling], (1, 2, 0, 0, 0, 0))
    sides = ("-Y", "+Y", "-X", "+X")
    legs = [((x - 0.03, y - 0.03, 0.0), (x + 0.03, y + 0.03, 0.7), sides)
            for x in (-0.62, 0.62) for y in (-0.32, 0.32)]
    boxes("Table", [((-0.7, -0.4, 0.7), (0.7, 0.4, 0.75), tuple(CUBE_FACES))] + legs, wood,
          (0.3, -0.3, 0.0), 10.0)
    # against the -Y wall: the back the sofa's full width, the arms and the seat in front of it
    boxes("Sofa", [((-1.0, -0.45, 0.0), (1.0, -0.25, 0.85), ("+Z", "+Y", "-X", "+X")),
                   ((-1.0, -0.25, 0.0), (-0.8, 0.45, 0.62), ("+Z", "+Y", "-X", "+X")),
                   ((0.8, -0.25, 0.0), (1.0, 0.45, 0.62), ("+Z", "+Y", "-X", "+X")),
                   ((-0.8, -0.25, 0.0), (0.8, 0.45, 0.42), ("+Z", "+Y"))],
          fabric, (0.2, -1.55, 0.0))
    boxes("Cabinet", [((-0.5, -0.25, 0.0), (0.5, 0.25, 1.8), ("+Z", "-Y", "-X", "+X"))], paint, (1.6, 1.75, 0.0))
    boxes("Shelf", [((0.0, -0.6, 1.45), (0.25, 0.6, 1.49), ("+Z", "-Z", "-Y", "+Y", "+X"))], wood,
          (-2.5, 0.6, 0.0))
    lamp("CeilingLamp", 'AREA', (-0.4, 0.2, 2.68), energy=120.0, shape='RECTANGLE', size=1.2, size_y=0.6,
         color=(1.0, 0.95, 0.88))
    # aimed down at the floor between table and cabinet, its cone's edge on the +X wall
    lamp("Spot", 'SPOT', (1.9, 0.2, 2.5), rotation=(math.radians(20.0), 0.0, math.radians(-30.0)), energy=150.0,
         spot_size=math.radians(50.0), spot_blend=0.15, shadow_soft_size=0.05, color=(1.0, 0.85, 0.7))
    camera((-2.3, -1.8, 1.6), (78.0, 0.0, -50.0), lens=18.0)
    save("interior_room.blend")


def window_room(sc):
    """The window room's shell: a closed 5 x 4 x 2.7 m room with a 1.6 x 1.2 m hole (sill 0.8 m up) in
    its +Y wall, a 0.2 grey world and the camera. Returns the hole (x0, x1, z0, z1) and the wall's y."""
    world_colour(sc, 0.2)
    wall = diffuse("Wall", (0.75, 0.73, 0.68))
    floor = diffuse("Floor", (0.45, 0.3, 0.18))
    ceiling = diffuse("Ceiling", (0.8, 0.8, 0.8))
    X, Y, Z = 2.5, 2.0, 2.7
    room("Room", (-X, -Y, 0.0), (X, Y, Z), ("-Z", "+Z", "-Y", "-X", "+X"), [wall, floor, ceiling], (1, 2, 0, 0, 0))
    # The +Y wall around the hole: four quads facing -Y, into the room.
    x0, x1, z0, z1 = -0.8, 0.8, 0.8, 2.0
    xs, zs = (-X, x0, x1, X), (0.0, z0, z1, Z)
    verts = [(x, Y, z) for z in zs for x in xs]
    quads = [(i, j) for j in range(3) for i in range(3) if (i, j) != (1, 1)]
    faces = [(j * 4 + i, j * 4 + i + 1, (j + 1) * 4 + i + 1, (j + 1) * 4 + i) for i, j in quads]
    mesh_object("WindowWall", verts, faces, [wall])
    camera((-2.3, -1.8, 1.6), (78.0, 0.0, -35.0), lens=18.0)
    return (x0, x1, z0, z1), Y


def make_window_room():
    sc = new_scene()
    (x0, x1, z0, z1), Y = window_room(sc)
    pane = shader_material("Pane", "ShaderNodeBsdfTransparent", (0.9, 0.92, 0.9))
    mesh_object("Pane", [(x0, Y, z0), (x0, Y, z1), (x1, Y, z1), (x1, Y, z0)], [(0, 3, 2, 1)], [pane])
    # 35 degrees up, 20 degrees round from the wall's normal: the patch of sun lands on the floor
    lamp("Sun", 'SUN', (0.0, 4.0, 4.0), rotation=(math.radians(-55.0), 0.0, math.radians(20.0)), energy=3.0,
         angle=math.radians(2.0), color=(1.0, 0.95, 0.9))
    save("window_room.blend")


def make_window_room_glass():
    sc = new_scene()
    (x0, x1, z0, z1), Y = window_room(sc)
    glass = shader_material("Pane", "ShaderNodeBsdfGlass", (0.95, 0.97, 0.95), Roughness=0.0, IOR=1.5)
    glass.node_tree.nodes["Glass BSDF"].distribution = 'SHARP'
    # A 6 mm slab filling the hole from its inner face in the wall's plane outward, as glass sits in a
    # frame: sides standing into the room would glow with light the glass carries along inside it.
    mesh_object("Pane", cube_verts((x0, Y, z0), (x1, Y + 0.006, z1)), list(CUBE_FACES.values()), [glass])
    # Outside, 1.2 m from the wall, facing in and 25 degrees down through the window onto the floor. An
    # area lamp and the world only: a sun or a point lamp seen through glass is a caustic Cycles' bake
    # barely converges (DESIGN.md section 4).
    lamp("WindowLamp", 'AREA', (0.0, Y + 1.2, 2.3), rotation=(math.radians(-65.0), 0.0, 0.0), energy=150.0,
         shape='RECTANGLE', size=2.0, size_y=1.5, color=(1.0, 0.95, 0.9))
    save("window_room_glass.blend")


def make_mirror_room():
    new_scene()
    wall = diffuse("Wall", (0.75, 0.75, 0.75))
    floor = diffuse("Floor", (0.4, 0.45, 0.5))
    boxm = diffuse("BoxOrange", (0.8, 0.45, 0.15))
    mirror = shader_material("Mirror", "ShaderNodeBsdfGlossy", (0.9, 0.9, 0.9), Roughness=0.0)
    room("Room", (-2.0, -2.0, 0.0), (2.0, 2.0, 2.5), ("-Z", "+Z", "-Y", "+Y", "-X", "+X"),
         [wall, floor], (1, 0, 0, 0, 0, 0))
    # on the -X wall, facing +X: its light lands on the floor and the far walls
    y0, y1, z0, z1, x = -0.75, 0.75, 0.8, 1.8, -2.0 + 0.005
    mesh_object("Mirror", [(x, y0, z0), (x, y1, z0), (x, y1, z1), (x, y0, z1)], [(0, 1, 2, 3)], [mirror])
    box("Box", (0.8, 0.6, 0.7), (0.7, -0.6, 0.0), 25.0, boxm)
    lamp("AreaLamp", 'AREA', (0.3, 0.5, 2.45), energy=150.0, shape='RECTANGLE', size=1.0, size_y=0.6,
         color=(1.0, 0.95, 0.88))
    camera((1.85, -1.85, 1.6), (78.0, 0.0, 45.0), lens=18.0)
    save("mirror_room.blend")


if __name__ == "__main__":
    import sys
    only = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    for name, fn in (("cornell_box", make_cornell), ("subsurf_room", make_subsurf_room),
                     ("animated_room", make_animated_room), ("interior_room", make_interior_room),
                     ("window_room", make_window_room), ("window_room_glass", make_window_room_glass),
                     ("mirror_room", make_mirror_room)):
        if not only or name in only:
            fn()

"""Measure Cycles' lighting conventions by baking (Blender 3.4.1).

Run:  blender -b --factory-startup --python tests/cycles_reference/measure_units.py

Each case builds a tiny scene from scratch, bakes COMBINED into a FLOAT_COLOR colour attribute
(direct light only: diffuse_bounces = 0, unless stated) and compares the baked value per face
corner with an analytic prediction. Results are printed; they are summarised in
addon/CYCLES_UNITS.md.
"""
import math
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "sample_blends"))
import cycles_settings  # noqa: E402
import make_samples  # noqa: E402  (its node materials)

RHO = 0.8
PI = math.pi


# ----------------------------------------------------------------------------- scene helpers
def fresh(samples=256, bounces=0):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    cycles_settings.unbiased(sc, samples, bounces, seed=1)
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    sc.world = world
    return sc


def diffuse_material(name, rho=RHO):
    return make_samples.diffuse(name, (rho, rho, rho))


def emission_material(name, color, strength):
    return make_samples.emission(name, color, strength)


def grid(name, half, n, location=(0, 0, 0), rotation=(0, 0, 0), material=None):
    """n x n vertex grid in the local XY plane (normal +Z), side 2*half."""
    xs = np.linspace(-half, half, n)
    verts = [(x, y, 0.0) for y in xs for x in xs]
    faces = [(j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i)
             for j in range(n - 1) for i in range(n - 1)]
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    ob.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(ob)
    ob.data.materials.append(material or diffuse_material(name + "_mat"))
    return ob


def bake(objects, domain='CORNER'):
    """Bake COMBINED into a FLOAT_COLOR attribute; returns {name: (values (K,3), world corner pos (K,3), world normal (K,3))}."""
    bpy.ops.object.select_all(action='DESELECT')
    for ob in objects:
        me = ob.data
        if "Bake" in me.color_attributes:
            me.color_attributes.remove(me.color_attributes["Bake"])
        a = me.color_attributes.new("Bake", 'FLOAT_COLOR', domain)
        me.color_attributes.active_color = a
        me.attributes.active_color = a
        ob.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.context.scene.render.bake.target = 'VERTEX_COLORS'
    bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')
    res = {}
    for ob in objects:
        me = ob.data
        a = me.color_attributes["Bake"]
        col = np.empty(len(a.data) * 4, np.float32)
        a.data.foreach_get("color", col)
        col = col.reshape(-1, 4)[:, :3].astype(np.float64)
        co = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        lv = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", lv)
        M = np.array(ob.matrix_world)
        if domain == 'CORNER':
            p = co[lv]
        else:
            p = co
        pw = p @ M[:3, :3].T + M[:3, 3]
        nw = (M[:3, :3] @ np.array([0, 0, 1.0]))
        nw = nw / np.linalg.norm(nw)
        res[ob.name] = (col, pw, np.tile(nw, (len(pw), 1)))
    return res


def add_light(kind, name="L", location=(0, 0, 0), rotation=(0, 0, 0), **props):
    ld = bpy.data.lights.new(name, kind)
    for k, v in props.items():
        setattr(ld, k, v)
    ob = bpy.data.objects.new(name, ld)
    ob.location = location
    ob.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(ob)
    return ob


def report(title, ratio):
    ratio = np.asarray(ratio, float)
    print(f"  {title}: mean {ratio.mean():.6f}  min {ratio.min():.6f}  max {ratio.max():.6f}  (n={ratio.size})")
    return ratio.mean()


def fc_corner(a, b, c):
    X, Y = a / c, b / c
    return (X / math.sqrt(1 + X * X) * math.atan(Y / math.sqrt(1 + X * X))
            + Y / math.sqrt(1 + Y * Y) * math.atan(X / math.sqrt(1 + Y * Y))) / (2 * PI)


def polygon_ff(poly, x, n):
    """Lambert: point x with normal n to polygon (V,3) (no hemisphere clipping)."""
    R = poly - x
    R1 = np.roll(R, -1, axis=0)
    cr = np.cross(R, R1)
    ncr = np.linalg.norm(cr, axis=1)
    g = np.arctan2(ncr, (R * R1).sum(1))
    return abs(float((g * (cr @ n) / ncr).sum()) / (2 * PI))


# ----------------------------------------------------------------------------- cases
def case_point():
    print("\n== POINT lamp: value = rho * k * P * cos / r^2 ; k ?=", 1 / (4 * PI * PI))
    P = 100.0
    for radius in (0.0, 0.25):
        for d, tilt in ((2.0, 0.0), (4.0, 0.0), (2.0, 60.0), (1.0, 0.0), (0.5, 0.0)):
            sc = fresh(samples=1024 if radius else 16)
            ob = grid("R", 0.05, 3, location=(0, 0, 0), rotation=(math.radians(tilt), 0, 0))
            add_light('POINT', location=(0, 0, d), energy=P, shadow_soft_size=radius)
            col, pw, nw = bake([ob])["R"]
            v = np.array([0, 0, d]) - pw
            r2 = (v * v).sum(1)
            cos = (v * nw).sum(1) / np.sqrt(r2)
            k = col[:, 0] / (RHO * P * cos / r2)
            km = report(f"radius {radius} d {d} tilt {tilt:4.0f}  k*4pi^2", k * 4 * PI * PI)
            if radius:
                # disc of radius R facing the receiver, radiance P/(4 pi * pi R^2): on-axis factor
                print(f"    disc model (d^2/(d^2+R^2)) predicts {d*d/(d*d+radius*radius):.6f}")


def smoothstep(x):
    x = np.clip(x, 0, 1)
    return x * x * (3 - 2 * x)


def case_spot():
    print("\n== SPOT lamp (pointing -Z) at height h above a plane")
    P, h = 100.0, 1.0
    for size_deg, blend in ((90.0, 0.0), (90.0, 0.5), (60.0, 1.0)):
        sc = fresh(samples=16)
        ob = grid("R", 1.5, 61)
        add_light('SPOT', location=(0, 0, h), energy=P, shadow_soft_size=0.0,
                  spot_size=math.radians(size_deg), spot_blend=blend)
        col, pw, nw = bake([ob])["R"]
        v = np.array([0, 0, h]) - pw
        r2 = (v * v).sum(1)
        r = np.sqrt(r2)
        cos_recv = v[:, 2] / r          # receiver normal +Z
        cos_axis = v[:, 2] / r          # lamp axis -Z, direction from lamp to point is -v
        point = RHO * P * cos_recv / r2 / (4 * PI * PI)
        f = col[:, 0] / point
        ca = math.cos(math.radians(size_deg) / 2)
        smooth = (1 - ca) * blend
        t = cos_axis - ca
        ss = np.where(cos_axis <= ca, 0.0, smoothstep(t / smooth) if smooth > 0 else 1.0)
        m1 = cos_axis * ss
        m2 = ss
        inside = cos_axis > ca + 1e-3
        print(f"  spot_size {size_deg} blend {blend}: max|f - cos*smoothstep| = {np.abs(f - m1)[inside].max():.5f}"
              f"   max|f - smoothstep| = {np.abs(f - m2)[inside].max():.5f}")
        on_axis = r2 < (1e-9 + h * h)
        print(f"    on-axis k*4pi^2 = {(f[on_axis]).mean():.6f}")
        # also sample a few angles
        for ang in (0, 10, 20, 30, 40, 44):
            sel = np.abs(np.degrees(np.arccos(cos_axis)) - ang) < 0.6
            if sel.any():
                print(f"    angle {ang:3d}: f={f[sel].mean():.5f}  cos*ss={m1[sel].mean():.5f}  ss={m2[sel].mean():.5f}")


def case_sun():
    print("\n== SUN strength S: value = rho * S * cos / pi ?")
    S = 3.0
    for tilt in (0.0, 30.0, 60.0):
        sc = fresh(samples=16)
        ob = grid("R", 0.5, 3)
        add_light('SUN', rotation=(math.radians(tilt), 0, 0), energy=S, angle=0.0)
        col, pw, nw = bake([ob])["R"]
        report(f"tilt {tilt}: value / (rho S cos/pi)", col[:, 0] / (RHO * S * math.cos(math.radians(tilt)) / PI))


def case_area():
    print("\n== AREA lamp power P, emitting -Z, plane at distance c under centre: value = rho * L * F")
    P = 100.0
    cases = (('SQUARE', 1.0, 1.0, 1.0), ('SQUARE', 1.0, 1.0, 0.5), ('RECTANGLE', 2.0, 0.5, 1.0),
             ('DISK', 1.0, 1.0, 1.0), ('ELLIPSE', 2.0, 1.0, 1.0))
    for shape, a, b, c in cases:
        sc = fresh(samples=4096)
        ob = grid("R", 0.005, 2)
        add_light('AREA', location=(0, 0, c), energy=P, shape=shape, size=a, size_y=b)
        col, pw, nw = bake([ob])["R"]
        if shape in ('SQUARE', 'RECTANGLE'):
            A = a * b
            F = 4 * fc_corner(a / 2, b / 2, c)
        elif shape == 'DISK':
            R = a / 2
            A = PI * R * R
            F = R * R / (R * R + c * c)
        else:
            A = PI * a * b / 4
            F = None
        if F is None:   # ellipse: Lambert's polygon formula on a 1024-gon
            t = np.linspace(0, 2 * PI, 1025)[:-1]
            F = polygon_ff(np.stack([a / 2 * np.cos(t), b / 2 * np.sin(t), np.full_like(t, c)], 1),
                           np.zeros(3), np.array([0, 0, 1.0]))
        L = col[:, 0].mean() / (RHO * F)
        print(f"  {shape} {a}x{b} at c={c}: F={F:.6f} measured L={L:.6f}  L*pi*A/P={L*PI*A/P:.6f}  L*4*pi*A/P={L*4*PI*A/P:.6f}")
    # object scale: SQUARE size 1 scaled (2, 0.5, 1) -> world rectangle 2 x 0.5
    sc = fresh(samples=4096)
    ob = grid("R", 0.005, 2)
    lo = add_light('AREA', location=(0, 0, 1.0), energy=P, shape='SQUARE', size=1.0)
    lo.scale = (2.0, 0.5, 1.0)
    col, pw, nw = bake([ob])["R"]
    F = 4 * fc_corner(1.0, 0.25, 1.0)
    L = col[:, 0].mean() / (RHO * F)
    print(f"  SQUARE 1 scaled (2,0.5,1) at c=1: measured L={L:.6f}; P/(4*A_world)={P/4:.6f}  P/(4*A_size)={P/4:.6f}"
          f" -> scale enters via A_world (same here); irradiance check F={F:.6f}")
    lo.scale = (2.0, 2.0, 1.0)
    col, pw, nw = bake([ob])["R"]
    F = 4 * fc_corner(1.0, 1.0, 1.0)
    print(f"  SQUARE 1 scaled (2,2,1): L = {col[:,0].mean()/(RHO*F):.6f}  P/(4*A_world)={P/16:.6f}  P/(4*A_size)={P/4:.6f}")
    # one-sidedness: receiver above the lamp, facing down
    sc = fresh(samples=256)
    ob = grid("R", 0.005, 2, location=(0, 0, 1), rotation=(PI, 0, 0))
    add_light('AREA', location=(0, 0, 0), energy=P, shape='SQUARE', size=1.0)
    col, _, _ = bake([ob])["R"]
    print(f"  receiver behind (+Z side of) the area lamp: value {col[:,0].mean():.6g}")


def case_world():
    print("\n== WORLD colour C strength s, upward plane: value = rho * C * s ?")
    sc = fresh(samples=1024)
    C, s = (0.5, 0.25, 1.0), 2.0
    bg = sc.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*C, 1)
    bg.inputs["Strength"].default_value = s
    ob = grid("R", 0.5, 3)
    col, _, _ = bake([ob])["R"]
    for ch in range(3):
        report(f"channel {ch}: value/(rho C s)", col[:, ch] / (RHO * C[ch] * s))


def case_emission():
    print("\n== EMISSION shader colour C strength s")
    C, s = (1.0, 0.5, 0.25), 3.0
    sc = fresh(samples=2048)
    em = grid("E", 0.5, 2, location=(0, 0, 1), material=emission_material("em", C, s))  # normal +Z (away from receiver)
    rc = grid("R", 0.005, 2)
    res = bake([em, rc])
    ecol = res["E"][0]
    for ch in range(3):
        report(f"emitter own baked value / (C s), ch {ch}", ecol[:, ch] / (C[ch] * s))
    F = 4 * fc_corner(0.5, 0.5, 1.0)
    report("receiver under emitter's BACK side: value/(rho C s F) (ch 0)", res["R"][0][:, 0] / (RHO * C[0] * s * F))
    sc = fresh(samples=2048)
    em = grid("E", 0.5, 2, location=(0, 0, 1), rotation=(PI, 0, 0), material=emission_material("em", C, s))
    rc = grid("R", 0.005, 2)
    res = bake([em, rc])
    report("receiver under emitter's FRONT side: value/(rho C s F) (ch 0)", res["R"][0][:, 0] / (RHO * C[0] * s * F))


def case_domain():
    print("\n== Domain: box corner, floor vs wall (point lamp inside an open box)")
    for domain in ('CORNER', 'POINT'):
        sc = fresh(samples=64)
        verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
        faces = [(0, 1, 2, 3),          # floor, normal +Z (inside)
                 (0, 4, 5, 1)]          # wall y=0, normal +Y (inside)
        me = bpy.data.meshes.new("Box")
        me.from_pydata(verts, [], faces)
        me.update()
        ob = bpy.data.objects.new("Box", me)
        sc.collection.objects.link(ob)
        me.materials.append(diffuse_material("w"))
        add_light('POINT', location=(0.5, 0.7, 0.6), energy=50, shadow_soft_size=0)
        col, pw, _ = bake([ob], domain)["Box"]
        lv = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", lv)
        if domain == 'CORNER':
            for li, vi in enumerate(lv):
                if vi in (0, 1):
                    face = 0 if li < 4 else 1
                    print(f"  CORNER loop {li} vertex {vi} face {'floor' if face == 0 else 'wall'}: {col[li,0]:.5f}")
            # analytic at vertex 0 for the floor (normal +Z) and wall (normal +Y)
            L = np.array([0.5, 0.7, 0.6])
            for nm, n in (("floor", np.array([0, 0, 1.0])), ("wall", np.array([0, 1.0, 0]))):
                v = L - np.array([0, 0, 0.0])
                r2 = v @ v
                print(f"    analytic vertex 0 {nm}: {RHO*50*(v@n)/math.sqrt(r2)/r2/(4*PI*PI):.5f}")
        else:
            print(f"  POINT vertex 0: {col[0,0]:.5f}  vertex 1: {col[1,0]:.5f}")


def case_backside():
    print("\n== Back side of a single plane")
    # lamp below a plane whose normal points up: baked (front) value?
    sc = fresh(samples=64)
    ob = grid("R", 0.5, 2)
    add_light('POINT', location=(0, 0, -1), energy=100, shadow_soft_size=0)
    col, _, _ = bake([ob])["R"]
    print(f"  lamp on the back side only: baked value {col[:,0].mean():.6g}")
    # does the back side reflect? lamp below plane A (normal +Z), receiver B below A facing up,
    # one diffuse bounce. B's direct light is blocked by a tiny occluder? Instead: B faces up and
    # sits beside the lamp, lamp shines up at A's back; B only sees A's back side.
    for bounces in (0, 1):
        sc = fresh(samples=2048, bounces=bounces)
        a = grid("A", 1.0, 2, location=(0, 0, 1))                    # normal +Z, back faces down
        b = grid("B", 0.005, 2, location=(0, 0, 0))                  # faces up towards A's back
        add_light('SPOT', location=(0, 0, 0.5), energy=100, shadow_soft_size=0,
                  spot_size=math.radians(60), spot_blend=0.0, rotation=(0, 0, 0))
        # spot points -Z by default -> rotate to point +Z
        bpy.data.objects["L"].rotation_euler = (PI, 0, 0)
        res = bake([a, b])
        print(f"  bounces={bounces}: B (sees only A's back) = {res['B'][0][:,0].mean():.6g};"
              f" A front baked = {res['A'][0][:,0].mean():.6g}")


if __name__ == "__main__":
    which = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    cases = [case_point, case_spot, case_sun, case_area, case_world, case_emission, case_domain, case_backside]
    for c in cases:
        if not which or c.__name__[5:] in which:
            c()

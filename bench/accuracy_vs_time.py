"""What accuracy costs in time: our presets and Cycles' vertex bake against the cached Cycles reference.

    blender -b --factory-startup --python bench/accuracy_vs_time.py -- [--scenes cornell_box,...] [--quick]
        [--presets draft,default,high,reference] [--spp 16,64,256,1024,4096] [--dense-spp 16,64,256,1024]
        [--max-seconds 600]
    blender -b --factory-startup --python bench/accuracy_vs_time.py -- --plot-only   (PNG and table from the CSV)

--quick: cornell_box, draft, Cycles at 16/64 spp (corners) and 16 (dense), into results/*_quick.* (~30 s).
--scenes: the rows of the scenes not run are kept from the CSV as they are.
--keep-cycles: only our presets run; Cycles' rows (which do not change with the engine) and ours of
the presets not run are kept from the CSV as they are too (~3 min for draft, default and high).
The full run takes about 30 min on 2 cores, most of it the `reference` preset.

For each sample scene (animated_room at frame 1; window_room, window_room_glass and mirror_room, the
optics samples, against their own references, optics_references.py: Cycles with glossy and
transmission bounces on, and the pane's or the mirror's corners left out of every error):
  ours    each preset through the add-on's pipeline (addon/bake.py BakeJob with the preset, then
          writeback.write_all): seconds = export + solve + write-back wall time. A solve still running
          after --max-seconds is cancelled (row kept, no error); `reference` only runs when its
          predicted time (high's time x high/default) fits in --max-seconds.
  cycles  COMBINED bake into a face-corner FLOAT_COLOR attribute at 16..4096 samples, settings
          cycles_settings.unbiased (DESIGN.md section 4, 64 bounces; with_optics too for the optics
          samples), seed 1 (the reference is seed 0: with the same seed its first samples would be
          Cycles' own). seconds = the bake operator.
          It bakes only the cage's corners (92 on the Cornell box), so it is cheap on these cages.
  cycles_dense  the same bake on the dense reference's layout (per-face 0.25 m grids, the evaluated
          mesh of subdivided objects: thousands of points, about our patch density) at 16..1024 spp;
          not for the optics samples, which have no dense reference.
Errors: reference.relative_rms. corner_rms: over the non-emitting face corners against the cached
262,144-spp corner bake, as tests/addon/test_cycles_agreement.py computes it. dense_rms: ours, the
engine's refined patch corners against the 4,096-spp dense reference interpolated there, as
compare_engine.py does; cycles_dense, its grid points against the same reference's. limit_rms:
the corners against the limit reference (Cycles' corners off junctions, trace_corner.py's on them:
reference.limit_reference), where the scene is traced; for the optics samples not traced Cycles'
inset bake (a little inside the face) stands on the junctions, as test_cycles_agreement.py judges them. A row
"cycles_converged" gives the reference corners' own limit_rms, the floor that no sample count of
Cycles' vertex bake goes under.
Runs under 10 s are repeated (3 in all) and the median time kept.

Writes bench/results/accuracy_vs_time.csv, .md (tables.py) and .png, and prints the table, the speed-up at equal
error (Cycles' time at our error, interpolated on the log-log line between its neighbouring sample
counts) and, for the default preset, where the corner error sits (contact / junction / other corners).
"""
import csv
import math
import os
import statistics
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
sys.path.insert(0, os.path.join(ROOT, "bench"))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
from conftest import load_package  # noqa: E402  (the add-on from addon/, its engine from build/engine)
import compare_engine  # noqa: E402  (grid_lookup, face_frames; puts build/engine on sys.path)
import cycles_settings  # noqa: E402
import make_references  # noqa: E402  (grid_mesh: the dense layout; world_faces, emitting_corners)
import optics_references  # noqa: E402  (the optics samples' references and their pane or mirror)
import plot_png  # noqa: E402
import reference  # noqa: E402
import tables  # noqa: E402

SCENES = {"cornell_box": None, "subsurf_room": None, "animated_room": 1, "window_room": None, "window_room_glass": None,
          "mirror_room": None}
PRESETS = ["draft", "default", "high", "reference"]
SPP = [16, 64, 256, 1024, 4096]
DENSE_SPP = [16, 64, 256, 1024]      # the dense reference itself is 4,096 spp
CYCLES_SEED = 1
ATTR = "CyclesBench"
CSV = tables.path_for("accuracy_vs_time")
PNG = CSV.replace(".csv", ".png")
FIELDS = ["scene", "method", "setting", "seconds", "corner_rms", "dense_rms", "limit_rms", "load1", "note"]
COLUMNS = [("scene", "scene", None), ("method", "method", None), ("setting", "preset / spp", None),
           ("seconds", "time", tables.seconds), ("corner_rms", "corner RMS", tables.percent),
           ("dense_rms", "dense RMS", tables.percent), ("limit_rms", "limit RMS", tables.percent)]
NOTES = """Relative RMS error against cached Cycles references (tests/cycles_reference/). corner: the
non-emitting cage corners (what the `Radiosity` attribute holds) against Cycles' 262,144-spp vertex
bake; dense: our refined patch corners (cycles_dense: Cycles' 0.25 m grid points) against a
4,096-spp dense bake; limit: the corners against the limit reference (Cycles off junctions, a path
tracer 1e-5 inside the face on them; traced scenes only; window_room: Cycles a little inside the face
on them). The optics samples are judged against their own references (glossy and
transmission bounces on; 1,048,576 and 524,288 spp), over every corner but the pane's or the mirror's,
and Cycles bakes them with the same bounces on. Time: export + solve + write-back for ours
(median of 3 under 10 s), the bake operator for Cycles; `cycles_converged` is the reference bake
itself; a row of ours without errors was stopped at --max-seconds. 2 shared cores: the CSV's load1
column gives the load average at each row."""
METHODS = ["ours", "cycles", "cycles_dense", "cycles_converged"]


def save(rows, path):
    """The CSV and its Markdown table, rows grouped by scene, method and setting."""
    scenes = [label(name, frame) for name, frame in SCENES.items()]

    def key(r):
        setting = r["setting"]
        return (scenes.index(r["scene"]) if r["scene"] in scenes else len(scenes), METHODS.index(r["method"]),
                PRESETS.index(setting) if setting in PRESETS else int(setting))
    tables.write(path, FIELDS, sorted(rows, key=key), "Accuracy against time", COLUMNS, NOTES)


def options():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []

    def get(flag, default):
        return argv[argv.index(flag) + 1] if flag in argv else default
    quick = "--quick" in argv
    return dict(
        scenes=get("--scenes", "cornell_box" if quick else ",".join(SCENES)).split(","),
        presets=get("--presets", "draft" if quick else ",".join(PRESETS)).split(","),
        spp=[int(s) for s in get("--spp", "16,64" if quick else ",".join(map(str, SPP))).split(",")],
        dense_spp=[int(s) for s in get("--dense-spp", "16" if quick else ",".join(map(str, DENSE_SPP))).split(",")
                   if s],
        max_seconds=float(get("--max-seconds", 600)),
        plot_only="--plot-only" in argv, quick=quick, keep_cycles="--keep-cycles" in argv)


def load_reference(name, frame):
    """The scene's Cycles corner reference; the optics samples' own (optics_references.py)."""
    if name in optics_references.OPTIC:
        return reference.read_npz(optics_references.path_of(name))
    return reference.load(name, frame)


def load_traced(name, frame):
    """trace_corner.py's corners of the scene (the optics samples' beside their references), or None."""
    if name in optics_references.OPTIC:
        return optics_references.load_traced(name)
    return reference.load_traced(name, frame)


def optic(name):
    """The objects whose corners no error counts: the optics sample's pane or mirror."""
    return (optics_references.OPTIC[name],) if name in optics_references.OPTIC else ()


def open_scene(name, frame):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", name + ".blend"))
    if frame is not None:
        bpy.context.scene.frame_set(frame)
    return bpy.context.scene


# ----------------------------------------------------------------------------- error
def corner_table(scene, read, ref, skip=()):
    """Non-emitting corners of every rendered mesh but those named in `skip`: (values (K,3) read by
    `read`, or None without it, reference (K,3), [(object, loop)])."""
    vals, refs, where = [], [], []
    for ob in scene.objects:
        if ob.type != 'MESH' or ob.hide_render or ob.name in skip:
            continue
        keep = ~make_references.emitting_corners(ob)
        if read is not None:
            vals.append(read(ob)[keep])
        refs.append(ref[ob.name + ":corner"][keep])
        where += [(ob.name, int(i)) for i in np.flatnonzero(keep)]
    return None if read is None else np.concatenate(vals), np.concatenate(refs), where


def limit_error(name, values, r, where, kinds, ref, traced):
    """Relative RMS of `values` against the limit reference at the corners `where` (r: Cycles'
    corners there, kinds: classify's), as a CSV field; "" where the scene is not traced. On the
    junctions of an optics sample not traced: Cycles' inset corners (`ref`)."""
    objects = dict.fromkeys(o for o, _ in where)
    if name in optics_references.OPTIC and traced is None:
        per = {o: reference.corner_reference(ref, o, inset=True) for o in objects}
    else:
        per = {o: reference.traced_reference(traced, o) for o in objects}
    if any(t is None for t in per.values()):
        return ""
    t = np.array([per[o][li] for o, li in where])
    limit = reference.limit_reference(r, t, np.array(kinds) != "other")
    return f"{reference.relative_rms(values, limit):.5f}"


def cycles_converged(name, frame):
    """The corner reference's own corners against the limit reference: Cycles' floor there."""
    ref, traced = load_reference(name, frame), load_traced(name, frame)
    scene = open_scene(name, frame)
    _, r, where = corner_table(scene, None, ref, optic(name))
    return dict(scene=label(name, frame), method="cycles_converged", setting=str(int(ref["samples_corner"])),
                seconds=f"{float(ref['seconds_corner']):.3f}", corner_rms="", dense_rms="",
                limit_rms=limit_error(name, r, r, where, classify(scene, where), ref, traced), load1="",
                note="the corner reference itself; seconds as it was baked")


def dense_error(job, ref):
    """compare_engine.py's dense error: refined patch corners against the interpolated reference grid
    (flat all-quad cages) or the nearest evaluated vertex (subdivided objects); emitters left out."""
    sx, solver = job.export, job.solver
    d_all, r_all = [], []
    for m in sx.meshes:
        emissive = np.array([max(sx.materials[i].emission) > 0 for i in m.face_materials])
        if emissive.all():
            continue
        pos, rad = solver.refined(job.ids[m.name])
        pts, rad = pos.reshape(-1, 4, 3), rad.reshape(-1, 4, 3)
        if m.name + ":grid" in ref:
            nrm = np.cross(pts[:, 2] - pts[:, 0], pts[:, 3] - pts[:, 1])
            nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
            rv, ok = compare_engine.grid_lookup(compare_engine.face_frames(m), ref[m.name + ":grid"], pts, nrm)
            d_all.append(rad[ok].reshape(-1, 3))
            r_all.append(rv[ok].reshape(-1, 3))
        else:
            M = m.transform
            ep = ref[m.name + ":eval_pos"].astype(np.float64) @ M[:3, :3].T + M[:3, 3]
            q = pts.reshape(-1, 3)
            idx = np.argmin(((q[:, None, :] - ep[None]) ** 2).sum(2), 1)
            d_all.append(rad.reshape(-1, 3))
            r_all.append(ref[m.name + ":eval_value"][idx])
    return reference.relative_rms(np.concatenate(d_all), np.concatenate(r_all))


# ----------------------------------------------------------------------------- runs
def median_time(run, first_seconds):
    """run() -> seconds; repeats runs under 10 s (3 in all), returns the median."""
    times = [first_seconds]
    while first_seconds < 10 and len(times) < 3:
        times.append(run())
    return statistics.median(times)


def run_ours(pkg, name, frame, preset, max_seconds):
    """One preset through export + solve + write-back. Returns (row, detail or None)."""
    ref = load_reference(name, frame)

    def once():
        scene = open_scene(name, frame)
        t0 = time.perf_counter()
        job = pkg.job.BakeJob(scene, bpy.context.evaluated_depsgraph_get(), preset=preset)
        t1 = time.perf_counter()
        job.solve(progress=lambda f, r: time.perf_counter() - t1 < max_seconds)
        t2 = time.perf_counter()
        if job.succeeded:
            pkg.writeback.write_all(job.colours(), scene)
        t3 = time.perf_counter()
        return scene, job, (t1 - t0, t2 - t1, t3 - t2, t3 - t0)

    scene, job, (t_export, t_solve, t_write, total) = once()
    load1 = os.getloadavg()[0]
    row = dict(scene=label(name, frame), method="ours", setting=preset, load1=f"{load1:.2f}")
    if not job.succeeded:
        row.update(seconds=f"{total:.3f}", corner_rms="", dense_rms="",
                   note=f"stopped after {t_solve:.0f} s (--max-seconds), residual {job.residual:.2g}")
        return row, None
    v, r, where = corner_table(scene, lambda ob: pkg.writeback.read_mesh(ob.data)[:, :3], ref, optic(name))
    corner = reference.relative_rms(v, r)
    kinds = classify(scene, where)
    limit = limit_error(name, v, r, where, kinds, ref, load_traced(name, frame))
    dense = "" if name in optics_references.OPTIC else f"{dense_error(job, ref):.5f}"
    st = job.stats
    detail = dict(values=v, ref=r, where=where, kinds=kinds)
    seconds = median_time(lambda: once()[2][3], total)
    row.update(seconds=f"{seconds:.3f}", corner_rms=f"{corner:.5f}", dense_rms=dense, limit_rms=limit,
               note=f"export {t_export:.2f} s, solve {t_solve:.2f} s, write {t_write:.3f} s; "
                    f"{st.get('patches', 0)} patches, {st.get('points', 0)} points, "
                    f"{st.get('rays', 0) / 1e6:.0f} Mrays, residual {st.get('residual', 0):.1e}")
    return row, detail


def cycles_bake(scene, samples, domain='CORNER', optics=False):
    """Cycles' COMBINED bake of every rendered mesh into a new ATTR attribute (`optics`: with glossy
    and transmission bounces on, as the optics samples' references); returns its seconds."""
    cycles_settings.unbiased(scene, samples, 64, CYCLES_SEED)
    if optics:
        cycles_settings.with_optics(scene)
    scene.render.bake.target = 'VERTEX_COLORS'
    scene.render.bake.use_selected_to_active = False
    bpy.ops.object.select_all(action='DESELECT')
    meshes = [ob for ob in scene.objects if ob.type == 'MESH' and not ob.hide_render]
    for ob in meshes:
        old = ob.data.color_attributes.get(ATTR)
        if old is not None:
            ob.data.color_attributes.remove(old)
        a = ob.data.color_attributes.new(ATTR, 'FLOAT_COLOR', domain)
        ob.data.color_attributes.active_color = a
        ob.data.attributes.active_color = a
        ob.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    t = time.perf_counter()
    bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS')
    return time.perf_counter() - t


def read_attr(ob):
    a = ob.data.color_attributes[ATTR]
    c = np.empty(len(a.data) * 4, np.float32)
    a.data.foreach_get("color", c)
    return c.reshape(-1, 4)[:, :3]


def run_cycles(name, frame, spp):
    """Cycles at the cage corners, against the corner reference."""
    ref = load_reference(name, frame)
    optics = name in optics_references.OPTIC
    scene = open_scene(name, frame)
    seconds = cycles_bake(scene, spp, optics=optics)
    load1 = os.getloadavg()[0]
    v, r, where = corner_table(scene, read_attr, ref, optic(name))
    corner = reference.relative_rms(v, r)
    limit = limit_error(name, v, r, where, classify(scene, where), ref, load_traced(name, frame))
    seconds = median_time(lambda: cycles_bake(open_scene(name, frame), spp, optics=optics), seconds)
    n = len(v)
    note = f"{n} corners" + ("; includes the reference's own error (README)" if spp >= 1024 else "")
    return dict(scene=label(name, frame), method="cycles", setting=str(spp), seconds=f"{seconds:.3f}",
                corner_rms=f"{corner:.5f}", dense_rms="", limit_rms=limit, load1=f"{load1:.2f}", note=note)


def dense_layout(scene, ref):
    """Replace each mesh by the dense reference's layout (make_references.py): per-face n x n grids
    for flat all-quad cages, the evaluated mesh for the others."""
    dg = bpy.context.evaluated_depsgraph_get()
    for ob in [o for o in scene.objects if o.type == 'MESH' and not o.hide_render]:
        if ob.name + ":grid" in ref:
            ob.data = make_references.grid_mesh(ob, int(ref[ob.name + ":grid_n"]))
        else:
            me = bpy.data.meshes.new_from_object(ob.evaluated_get(dg))
            ob.modifiers.clear()
            ob.data = me


def run_cycles_dense(name, frame, spp):
    """Cycles on the dense layout (what our refined patches are compared with), against the
    4,096-spp dense reference; emitter-only objects left out, as compare_engine.py does."""
    ref = reference.load(name, frame)

    def once():
        scene = open_scene(name, frame)
        dense_layout(scene, ref)
        return scene, cycles_bake(scene, spp, 'POINT')
    scene, seconds = once()
    load1 = os.getloadavg()[0]
    v, r = [], []
    for ob in scene.objects:
        if ob.type != 'MESH' or ob.hide_render or make_references.emitting_corners(ob).all():
            continue
        v.append(read_attr(ob))
        r.append(ref[ob.name + (":grid" if ob.name + ":grid" in ref else ":eval_value")].reshape(-1, 3))
    dense = reference.relative_rms(np.concatenate(v), np.concatenate(r))
    n = sum(len(x) for x in v)
    seconds = median_time(lambda: once()[1], seconds)
    note = f"{n} points" + ("; includes the reference's own error (README)" if spp >= 1024 else "")
    return dict(scene=label(name, frame), method="cycles_dense", setting=str(spp), seconds=f"{seconds:.3f}",
                corner_rms="", dense_rms=f"{dense:.5f}", load1=f"{load1:.2f}", note=note)


def label(name, frame):
    return name + (f"@{frame}" if frame is not None else "")


# ----------------------------------------------------------------------------- error breakdown
def classify(scene, where):
    """Each corner: 'contact' (it lies on a face of another object rising in front of its own: box
    bottoms on the floor, walls against a separate ceiling), 'junction' (on one of its own object's:
    a room's edges), else 'other' (convex edges, free corners); reference.junction_faces decides."""
    faces, owner, place = [], [], {}
    for ob in scene.objects:
        if ob.type != 'MESH' or ob.hide_render:
            continue
        co, normals, f = make_references.world_faces(ob)
        place[ob.name] = (co, normals)
        faces += f
        owner += [ob.name] * len(f)
    pos = np.array([place[o][0][li] for o, li in where])
    nrm = np.array([place[o][1][li] for o, li in where])
    hits = reference.junction_faces(pos, nrm, faces)
    own = np.array(owner)[None, :] == np.array([o for o, _ in where])[:, None]
    return list(np.where((hits & ~own).any(1), "contact", np.where((hits & own).any(1), "junction", "other")))


def breakdown(name, detail):
    v, r, where = detail["values"], detail["ref"], detail["where"]
    kinds = np.array(detail["kinds"])
    objs = np.array([w[0] for w in where])
    mean = r.mean()
    sq = ((v - r) ** 2).mean(1)                      # per corner, mean over channels
    total = math.sqrt(sq.mean()) / mean
    lines = [f"\n{name}: default preset, corner RMS {total:.2%} over {len(sq)} corners "
             f"(rms within a group is normalised by the scene's mean reference, as the total is; "
             f"share = the group's part of the total squared error; ratio = ours/Cycles mean)"]
    lines.append(f"  {'group':26} {'corners':>7} {'rms':>7} {'share':>6} {'ratio':>6}")
    groups = [(k, kinds == k) for k in ("contact", "junction", "other")]
    groups += [(f"{o}/{k}", (objs == o) & (kinds == k)) for o in dict.fromkeys(objs) for k in
               ("contact", "junction", "other")]
    for g, m in groups:
        if m.any():
            lines.append(f"  {g:26} {m.sum():7d} {math.sqrt(sq[m].mean()) / mean:7.2%} "
                         f"{sq[m].sum() / sq.sum():6.1%} {v[m].sum() / r[m].sum():6.3f}")
    worst = np.argsort(-sq)[:6]
    lines.append("  worst corners: " + "; ".join(
        f"{where[i][0]} loop {where[i][1]} ({kinds[i]}) ours {v[i].mean():.3g} Cycles {r[i].mean():.3g}"
        for i in worst))
    return "\n".join(lines)


# ----------------------------------------------------------------------------- report
def cycles_time_at(rows, err, col):
    """Cycles' seconds at error err (column col) on the log-log line between its neighbouring sample
    counts; outside its range the end segment is extended and the note says so."""
    pts = sorted((int(r["setting"]), float(r["seconds"]), float(r[col])) for r in rows)
    if len(pts) < 2:
        return None, ""
    i = next((k for k in range(len(pts) - 1) if pts[k][2] >= err >= pts[k + 1][2]), None)
    note = ""
    if i is None:
        above = err > pts[0][2]
        i = 0 if above else len(pts) - 2
        note = f"extrapolated {'below' if above else 'beyond'} {pts[0 if above else -1][0]} spp"
    (_, t0, e0), (_, t1, e1) = pts[i], pts[i + 1]
    f = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0))
    return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), note


def report(rows):
    print(f"\n{'scene':16} {'method':16} {'setting':>9} {'seconds':>9} {'corner RMS':>10} {'dense RMS':>9} "
          f"{'limit RMS':>9} {'load':>5}  note")
    for r in rows:
        print(f"{r['scene']:16} {r['method']:16} {r['setting']:>9} {float(r['seconds']):9.2f} "
              f"{pct(r['corner_rms']):>10} {pct(r['dense_rms']):>9} {pct(r.get('limit_rms')):>9} {r['load1']:>5}  "
              f"{r['note']}")
    for col, cmethod, what in (("corner_rms", "cycles", "cage corners (the attribute's values)"),
                               ("dense_rms", "cycles_dense", "dense (our refined patch corners / Cycles' grid)"),
                               ("limit_rms", "cycles", "cage corners against the limit reference")):
        print(f"\nAt equal error, {what}; Cycles' time interpolated at our error:")
        for sc in dict.fromkeys(r["scene"] for r in rows):
            cyc = [r for r in rows if r["scene"] == sc and r["method"] == cmethod and r.get(col)]
            ours = [r for r in rows if r["scene"] == sc and r["method"] == "ours" and r.get(col)]
            # No sample count takes Cycles' corners under their converged value's own error.
            floor = min((float(r[col]) for r in rows if r["scene"] == sc and r["method"] == "cycles_converged"
                         and r.get(col)), default=0.0)
            if len(cyc) < 2:
                continue
            for r in ours:
                e, t = float(r[col]), float(r["seconds"])
                if e <= floor:
                    print(f"  {sc:16} {r['setting']:9} {e:6.2%} in {t:8.2f} s; Cycles never: its converged "
                          f"corners are at {floor:.2%}")
                    continue
                tc, note = cycles_time_at(cyc, e, col)
                print(f"  {sc:16} {r['setting']:9} {e:6.2%} in {t:8.2f} s; Cycles {tc:8.2f} s"
                      f"{' (' + note + ')' if note else ''}: we are {speed(tc / t)}")
            tc1, note = cycles_time_at(cyc, 0.01, col)
            best = min(ours, key=lambda r: float(r[col]), default=None)
            print(f"  {sc:16} 1%: " + (f"Cycles never (converged at {floor:.2%})" if floor >= 0.01 else
                                        f"Cycles {tc1:.2f} s{' (' + note + ')' if note else ''}") + "; "
                  + ("we have no result" if best is None else
                     f"our best is {float(best[col]):.2%} ({best['setting']}): 1% not reached"
                     if float(best[col]) > 0.01 else "we reach 1%"))


def speed(x):
    return f"{x:.2f}x faster" if x >= 1 else f"{1 / x:.1f}x slower"


def pct(s):
    return f"{float(s):.2%}" if s else "-"


def nice_range(values, margin=1.25):
    """Log-axis limits on the 1-2-5 sequence around values, with a margin."""
    steps = [m * 10.0 ** k for k in range(-4, 5) for m in (1, 2, 5)]
    return (max(v for v in steps if v <= min(values) / margin), min(v for v in steps if v >= max(values) * margin))


def plot(rows, path):
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    columns = ("corner_rms", "dense_rms", "limit_rms")
    have = [r for r in rows if r["method"] != "cycles_converged" and any(r.get(k) for k in columns)]
    xlim = nice_range([float(r["seconds"]) for r in have])
    ylim = nice_range([float(r[k]) for r in have for k in columns if r.get(k)] + [0.01])
    steps = [m * 10.0 ** e for e in range(-4, 5) for m in (1, 2, 5)]
    decades = lambda lim: [10.0 ** i for i in range(math.ceil(math.log10(lim[0]) - 1e-9),
                                                    math.floor(math.log10(lim[1]) + 1e-9) + 1)]
    pw, ph, left, top = 400, 360, 120, 50
    width = max(left + len(scenes) * (pw + 40) + 10, 900)
    per_row = (width - left) // 380
    styles = [("ours", "corner_rms", (31, 119, 180), "o", "ours, cage corners"),
              ("cycles", "corner_rms", (214, 39, 40), "s", "Cycles, cage corners"),
              ("ours", "dense_rms", (44, 160, 44), "^", "ours, dense (patches)"),
              ("cycles_dense", "dense_rms", (255, 127, 14), "d", "Cycles, dense (grid)"),
              ("ours", "limit_rms", (148, 103, 189), "o", "ours, vs limit (traced)"),
              ("cycles", "limit_rms", (140, 86, 75), "s", "Cycles, vs limit (traced)")]
    c = plot_png.Canvas(width, top + ph + 90 + 30 * math.ceil(len(styles) / per_row) + 40)
    for k, sc in enumerate(scenes):
        x0 = left + k * (pw + 40)
        ax = plot_png.LogAxes(c, (x0, top, x0 + pw, top + ph), xlim, ylim, "wall time (s)",
                              "relative RMS error" if k == 0 else "", sc)
        ax.frame(decades(xlim), [v for v in steps if ylim[0] <= v <= ylim[1]], fmt_y=lambda v: f"{v * 100:g}%",
                 ylabels=(k == 0))
        ax.hline(0.01, (120, 120, 120), "1% goal")
        for method, col, color, marker, _ in styles:
            sel = [r for r in have if r["scene"] == sc and r["method"] == method and r.get(col)]
            sel.sort(key=lambda r: float(r["seconds"]))
            ax.polyline([(float(r["seconds"]), float(r[col])) for r in sel], color, marker,
                        dash={"dense_rms": 6, "limit_rms": 2}.get(col, 0), labels=[r["setting"] for r in sel],
                        label_side="r" if method == "ours" else "l")
    y = top + ph + 70
    for i, (_, col, color, marker, text) in enumerate(styles):
        x, yy = left + (i % per_row) * 380, y + 30 * (i // per_row)
        c.line(x - 14, yy + 7, x + 14, yy + 7, color, 2, dash={"dense_rms": 6, "limit_rms": 2}.get(col, 0))
        c.dot(x, yy + 7, 6, color, marker)
        c.text(x + 24, yy, text, (0, 0, 0), 2)
    y += 30 * math.ceil(len(styles) / per_row) + 6
    c.text(left, y, "Error: against Cycles at 262,144 spp (cage corners) and 4,096 spp (dense grid); limit: Cycles "
           "off junctions, a path tracer 1e-5 into the face on them. "
           "Time: export + solve + write-back (ours), the bake operator (Cycles).", (90, 90, 90), 1)
    c.text(left, y + 14, "Labels: preset (ours), samples per pixel (Cycles). 2 cores, shared: see the CSV's load column. "
           "Window and mirror rooms: against their own references (optics on), Cycles inset on junctions.",
           (90, 90, 90), 1)
    c.save(path)


def main():
    opt = options()
    if opt["plot_only"]:
        with open(CSV) as f:
            rows = list(csv.DictReader(f))
        report(rows)
        save(rows, CSV)
        plot(rows, PNG)
        print("wrote", PNG, "and the table beside it")
        return
    pkg = load_package()
    engine = pkg.engine.load_engine()
    print(f"engine: {engine.__file__}; cores {os.cpu_count()}; load average at start {os.getloadavg()}")
    rows, details = [], {}
    if not opt["quick"] and os.path.exists(CSV):
        with open(CSV) as f:
            kept = list(csv.DictReader(f))
        # The scenes not run keep their rows; with --keep-cycles, so do the Cycles rows of those run
        # and our presets not run again.
        run = {label(name, SCENES[name]) for name in opt["scenes"]}
        rows = [r for r in kept if r["scene"] not in run or opt["keep_cycles"] and (
                r["method"] in ("cycles", "cycles_dense") or (r["method"] == "ours" and r["setting"] not in opt["presets"]))]
    for name in opt["scenes"]:
        frame = SCENES[name]
        if name == opt["scenes"][0] and not opt["keep_cycles"]:
            cycles_bake(open_scene(name, frame), 1)          # warm-up, untimed
        rows.append(cycles_converged(name, frame))
        for spp in [] if opt["keep_cycles"] else opt["spp"]:
            rows.append(run_cycles(name, frame, spp))
            print("ROW", rows[-1], flush=True)
        for spp in [] if opt["keep_cycles"] or name in optics_references.OPTIC else opt["dense_spp"]:
            rows.append(run_cycles_dense(name, frame, spp))
            print("ROW", rows[-1], flush=True)
        times = {}
        for preset in opt["presets"]:
            if preset == "reference":
                if "high" not in times or "default" not in times:
                    continue
                predicted = times["high"] ** 2 / times["default"]
                if predicted > opt["max_seconds"]:
                    print(f"{name}: reference preset skipped (predicted {predicted:.0f} s)", flush=True)
                    continue
            row, detail = run_ours(pkg, name, frame, preset, opt["max_seconds"])
            rows.append(row)
            print("ROW", row, flush=True)
            if detail is not None:
                times[preset] = float(row["seconds"])
                if preset == "default":
                    details[label(name, frame)] = detail
                    print(breakdown(label(name, frame), detail), flush=True)
        save(rows, tables.path_for("accuracy_vs_time", opt["quick"]))
    report(rows)
    for sc, d in details.items():
        print(breakdown(sc, d))
    png = PNG if not opt["quick"] else PNG.replace(".png", "_quick.png")
    plot(rows, png)
    print(f"\nwrote {png}; load average at end {os.getloadavg()}")


if __name__ == "__main__":
    main()

"""Dynamic update cost: per-frame incremental update against a full re-solve of the same frame.

    blender -b --factory-startup --python bench/dynamic_update.py -- [preset] [frames] [full_repeats] [scenes] [db_cache_mb] [playbacks]

preset: draft (default) | default | high; frames: frames played per scene, spread evenly over its
range (0, the default: every frame, so that each update is one frame's change; 6 steps 4 frames at
a time, as live playback's updates at 10k span 4-6 frames);
full_repeats: full re-solves timed per scene (default 2), of the last frames played, each also the
reference its frame's update is measured against (RMS; the worst goes to the table); scenes: comma-separated names (all);
db_cache_mb: the dB cache's cap (the add-on's default; 0 = no cache); playbacks: runs of the
playback below (default 3; 0 skips it). Scenes:

  animated_room  the sample: a box moves and the point lamp ramps 30 W -> 120 W every frame
  room_20k       a 4 m room of ~20k vertices, one 0.4 m box moving across the floor, lamp fixed
  room_10k       the same room at ~10k vertices: does playback with write-back keep 24 fps?
  room_10k_tex   the same with a 4k image texture on the floor (a generated UV grid)
  wave_10k       room_10k with a flat-shaded 2 m sheet (24 x 24 faces) over the floor under a Wave
                 modifier: its faces bend apart at their shared vertices every frame
  movers_10k     room_10k with five boxes moving at once on different paths (tests/scenes.py:
                 mover_places), one floating over another; shadows overlap

Incremental = what live update does on a frame change (export, diff, Solver.update(), colours,
write-back) through the add-on's own handler; "update" is the engine's Solver.update() alone,
"frame" the whole scene.frame_set() (depsgraph evaluation, handlers, write-back). Full = a new Solver
and solve() of the same frame's export. Medians; no timed asserts.

The dB cache: the frames are played forward, then back (each move the reverse of one before);
"cpu s" is the process CPU time of an update (run Blender with `-t 1` for one thread's), "rays"
all rays it traced, "changed" the rays the move changed (each needs a trace of the scene without
the box, unless the cache answers: "hits"), "cache MB" what the cache holds after the last frame.

Shooting on (same updates): an update's signed gathers leave the light the change made unshot,
"left" times the threshold; it is shot down to the update's stop (the engine's update_threshold)
in "shots" shots taking "shoot s". "bound" = full / shoot s: no update that shoots that light back
as far with the same shots gets past it, whatever the gathers before cost.

Playback: the frame range played as the UI plays it (live_update.playing() forced on; every frame,
1/fps apart, later when a frame's own work ran over): updates in a worker thread with a frame's time
of shooting, colours written on the first frame after each ends. "main ms" is a frame_set's wall
time (what the viewport waits for), "frames/update" how many frames an update spans, "residual" the
median residual its colours were written at; "rms playing" compares the colours shown on the last
frame with a fresh solve of it (they are some frames behind), "own frame" with a fresh solve of the
frame they were solved for (the residual's share), "rms settled" the colours after playback stopped
(live_update._watch) and the rest was shot to the threshold in the worker, which took "settle s"
(wall time until written, polled every live_update.WATCH_INTERVAL as the timer polls), of which
the longest timer call held the main thread "held ms" (export, diff, write-back).

Writes bench/results/dynamic_update_PRESET.csv (per scene: cost and playback) and
dynamic_update_PRESET_moves.csv (per scene and way: dB cache and shooting on), each with its .md.
"""
import os
import statistics
import sys
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "addon"))
sys.path.insert(0, os.path.join(ROOT, "sample_blends"))
sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
sys.path.insert(0, os.path.join(ROOT, "tests"))
from conftest import load_package  # noqa: E402
import make_samples as ms  # noqa: E402
from reference import relative_rms  # noqa: E402
import scenes  # noqa: E402
sys.path.insert(0, os.path.join(ROOT, "bench"))
import tables  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
PRESET = (args[0] if args else "draft").upper()
FRAMES = int(args[1]) if len(args) > 1 else 0
FULL_REPEATS = int(args[2]) if len(args) > 2 else 2
SCENES = args[3].split(",") if len(args) > 3 and args[3] else ["animated_room", "room_20k", "room_10k"]
DB_CACHE_MB = float(args[4]) if len(args) > 4 and args[4] else None
PLAYBACKS = int(args[5]) if len(args) > 5 else 3

pkg = load_package()
pkg.register()
live = pkg.live_update
updated = []  # per Solver.update() through the add-on: its stats and process CPU time
_update = pkg.job.BakeJob._update


def timed_update(job):
    t = time.process_time()
    st = _update(job)
    updated.append(dict(st, cpu=time.process_time() - t))
    return st


pkg.job.BakeJob._update = timed_update


def grid(origin, u, v, nu, nv):
    """(verts, quads) of a nu x nv grid spanning origin + [0,1]u + [0,1]v."""
    a, b = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
    verts = np.asarray(origin) + a.ravel()[:, None] * np.asarray(u) + b.ravel()[:, None] * np.asarray(v)
    i = np.arange(nv)[:, None] * (nu + 1) + np.arange(nu)[None, :]
    quads = np.stack([i, i + 1, i + nu + 2, i + nu + 1], -1).reshape(-1, 4)
    return verts, quads


def room_scene(vertices, texture=0, wave=False, movers=False):
    """A 4 x 4 x 3 m room split into quads (about `vertices` vertices), a point lamp under the
    ceiling and a 0.4 m box crossing the floor over frames 1-24 (linear keys); with `texture`, a
    texture x texture image on the floor's colour, over UVs projected from above; with `wave`, a
    flat-shaded sheet 0.3 m over the floor, rippled by a Wave modifier; with `movers`, five boxes
    moving at once in place of the one (scenes.mover_places, keyed every frame)."""
    sc = ms.new_scene()
    sc.frame_start, sc.frame_end = 1, 24
    W, H = 4.0, 3.0
    # 2 walls of 4 x 4 (floor, ceiling) and 4 of 4 x 3: n x n and n x 3n/4 quads
    n = int(round(np.sqrt(vertices / (2 + 4 * 0.75))))
    m = max(1, int(round(0.75 * n)))
    sides = [((-2, -2, 0), (W, 0, 0), (0, W, 0), n, n, 1),        # floor
             ((-2, -2, H), (0, W, 0), (W, 0, 0), n, n, 0),        # ceiling
             ((-2, -2, 0), (0, 0, H), (W, 0, 0), m, n, 0),
             ((-2, 2, 0), (W, 0, 0), (0, 0, H), n, m, 0),
             ((-2, -2, 0), (0, W, 0), (0, 0, H), n, m, 0),
             ((2, -2, 0), (0, 0, H), (0, W, 0), m, n, 0)]
    verts, faces, mats, base = [], [], [], 0
    for o, u, v, nu, nv, mat in sides:
        vs, qs = grid(o, u, v, nu, nv)
        verts.append(vs)
        faces.append(qs + base)
        mats.append(np.full(len(qs), mat))
        base += len(vs)
    verts, faces, mats = np.concatenate(verts), np.concatenate(faces), np.concatenate(mats)
    me = bpy.data.meshes.new("Room")
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", verts.astype(np.float32).ravel())
    me.loops.add(faces.size)
    me.loops.foreach_set("vertex_index", faces.astype(np.int32).ravel())
    me.polygons.add(len(faces))
    me.polygons.foreach_set("loop_start", (np.arange(len(faces)) * 4).astype(np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(faces), 4, np.int32))
    me.materials.append(ms.diffuse("Wall", (0.7, 0.7, 0.7)))
    me.materials.append(ms.diffuse("Floor", (0.5, 0.55, 0.5)))
    if texture:
        me.uv_layers.new()
        me.uv_layers.active.data.foreach_set("uv", ((verts[faces.ravel()][:, :2] + 2) / 4).astype(np.float32).ravel())
        image = bpy.data.images.new("FloorGrid", texture, texture)
        image.generated_type = 'UV_GRID'
        nodes = me.materials[1].node_tree.nodes
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = image
        me.materials[1].node_tree.links.new(tex.outputs["Color"], nodes["Diffuse BSDF"].inputs["Color"])
    me.polygons.foreach_set("material_index", mats.astype(np.int32))
    me.update()
    me.validate()
    ob = bpy.data.objects.new("Room", me)
    sc.collection.objects.link(ob)
    if movers:
        for k, size in enumerate(scenes.MOVER_SIZES):
            floats = scenes.mover_places(1)[k][2] > 0
            b = ms.box(f"Mover{k}", size, (0.0, 0.0, 0.0), 0.0, ms.diffuse(f"Mover{k}", (0.8, 0.2 + 0.15 * k, 0.15)),
                       sides=("+Z", "-Y", "+Y", "-X", "+X") + (("-Z",) if floats else ()))
            for f in range(sc.frame_start, sc.frame_end + 1):
                b.location = scenes.mover_places(f)[k]
                b.keyframe_insert("location", frame=f)
            ms.linear_keys(b)
    else:
        b = ms.box("Box", (0.4, 0.4, 0.4), (-1.2, 0.3, 0.0), 0.0, ms.diffuse("BoxRed", (0.8, 0.2, 0.15)))
        b.keyframe_insert("location", frame=1)
        b.location = (1.2, 0.3, 0.0)
        b.keyframe_insert("location", frame=24)
        ms.linear_keys(b)
    ms.lamp("Lamp", 'POINT', (0.0, -0.5, 2.7), energy=300.0, shadow_soft_size=0.0)
    if wave:
        vs, qs = grid((-1.0, -1.0, 0.3), (2.0, 0, 0), (0, 2.0, 0), 24, 24)
        sheet = ms.mesh_object("Sheet", vs, qs, [ms.diffuse("Sheet", (0.6, 0.6, 0.3))])
        mod = sheet.modifiers.new("Wave", 'WAVE')
        mod.height, mod.width, mod.speed, mod.time_offset = 0.1, 0.6, 0.05, -20.0
    sc.frame_set(1)
    return sc


def animated_room():
    bpy.ops.wm.open_mainfile(filepath=os.path.join(ROOT, "sample_blends", "animated_room.blend"))
    return bpy.context.scene


def med(xs):
    return statistics.median(xs) if xs else float("nan")


def shown(scene, names):
    return np.concatenate([pkg.writeback.read_mesh(bpy.data.objects[n].data)[:, :3] for n in names])


def fresh_solve(scene, frame):
    """(object names, stacked RGB) of a new Solver's solve of `frame`; the live Solver is untouched."""
    current = scene.frame_current
    with live.suspended():
        scene.frame_set(frame)
        job = pkg.job.BakeJob(scene, bpy.context.evaluated_depsgraph_get(), scene.radiosity)
        job.solve()
        scene.frame_set(current)
    colours = job.colours()
    names = sorted(colours)
    return names, np.concatenate([colours[n][:, :3] for n in names])


def play_back(scene):
    """One playback of the frame range from a converged first frame (see the module's notes)."""
    live.playing = lambda: False
    scene.frame_set(scene.frame_start)
    live.playing = lambda: True
    step = live.frame_budget(scene)
    main, written = [], []
    start = tick = time.perf_counter()
    for f in range(scene.frame_start + 1, scene.frame_end + 1):
        tick += step
        wait = tick - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        else:
            tick = time.perf_counter()
        before = live.last_sync.get(scene.name)
        t = time.perf_counter()
        scene.frame_set(f)
        main.append(time.perf_counter() - t)
        info = live.last_sync.get(scene.name)
        if info is not before and info.get("budgeted"):
            written.append(info)
    seconds = time.perf_counter() - start
    names, reference = fresh_solve(scene, scene.frame_current)
    playing = relative_rms(shown(scene, names), reference)
    # the same colours against their own frame's light: what the residual costs, without the lag
    # (none, when a single update outlasts the frame range)
    own = relative_rms(shown(scene, names), fresh_solve(scene, written[-1]["frame"])[1]) if written else float("nan")
    live.playing = lambda: False
    t = time.perf_counter()
    watch = []                                      # the main thread's time in each timer call
    while True:                                     # the settle runs in the worker: as the timer polls
        w = time.perf_counter()
        more = live._watch()
        watch.append(time.perf_counter() - w)
        if more is None:
            break
        time.sleep(live.WATCH_INTERVAL)
    settle = time.perf_counter() - t
    assert live.last_sync[scene.name]["settled"]
    return dict(fps=len(main) / seconds, main=med(main), main_max=max(main), updates=len(written),
                span=len(main) / max(1, len(written)), residual=med([i["residual"] for i in written]),
                playing=playing, own=own, settled=relative_rms(shown(scene, names), reference), settle=settle,
                settle_main=max(watch))


def run(name, make, frames=FRAMES, full_repeats=FULL_REPEATS):
    scene = make()
    scene.radiosity.preset = PRESET
    if DB_CACHE_MB is not None:
        scene.radiosity.db_cache_mb = DB_CACHE_MB
    scene.radiosity.live_update = True
    verts = sum(len(o.data.vertices) for o in scene.objects if o.type == 'MESH')
    scene.frame_set(scene.frame_start)             # live update's first, full solve
    first = live.last_sync[scene.name]
    assert first["mode"] == "full", first
    span = scene.frame_end - scene.frame_start
    steps = frames if 0 < frames < span else span
    todo = sorted({scene.frame_start + max(1, round(span * (i + 1) / steps)) for i in range(steps)})
    inc, upd, frame_wall, touched, writes = [], [], [], [], []
    names = sorted(live.live_jobs[scene.name].colours())
    updated_colours = {}                           # frame -> colours its update wrote (forward)
    del updated[:]
    for f in todo:
        t = time.perf_counter()
        scene.frame_set(f)
        frame_wall.append(time.perf_counter() - t)
        info = live.last_sync[scene.name]
        assert info["frame"] == f and info["mode"] == "incremental", info
        updated_colours[f] = shown(scene, names)
        inc.append(info["seconds_total"])
        upd.append(info["seconds_solve"])
        writes.append(info["seconds_write"])
        touched.append(info["touched_points"] / max(1, info["points"]))

    def played():  # the updates since the last call
        d = dict(cpu=med([u["cpu"] for u in updated]), rays=med([u["rays"] - u["rays_before"] for u in updated]),
                 changed=med([u["db_hits"] + u["db_misses"] for u in updated]),
                 hits=med([u["db_hits"] for u in updated]),
                 left=med([u["shoot_residual"] for u in updated]), shoot=med([u["shoot_seconds"] for u in updated]),
                 shots=med([u["shots"] - u["shots_before"] for u in updated]),
                 seconds=med([u["seconds"] for u in updated]))
        del updated[:]
        return d

    db = {"forward": played()}
    for f in todo[-2::-1]:
        scene.frame_set(f)
        assert live.last_sync[scene.name]["mode"] == "incremental"
    db["back"] = played()
    db_mb = live.live_jobs[scene.name].stats["db_bytes"] / 2 ** 20
    playing = live.playing
    plays = [play_back(scene) for _ in range(PLAYBACKS)]
    live.playing = playing
    playback = {k: med([p[k] for p in plays]) for k in plays[0]} if plays else None
    # full re-solves of frames just played (same export, a new Solver), each the reference its
    # update's colours are measured against
    full, frame_rms, fresh = [], {}, {}
    for f in todo[-full_repeats:]:
        with live.suspended():
            scene.frame_set(f)
        job = pkg.job.BakeJob(scene, bpy.context.evaluated_depsgraph_get(), scene.radiosity)
        t = time.perf_counter()
        job.solve()
        full.append(time.perf_counter() - t)
        colours = job.colours()
        fresh[f] = np.concatenate([colours[n][:, :3] for n in names])
        frame_rms[f] = relative_rms(updated_colours[f], fresh[f])
    live.forget(scene.name)
    scene.radiosity.live_update = False
    # Playback after Bake Animation: each frame's stored colours are written in frame_change_pre.
    # Bake Animation itself, against baking each of its frames fresh: its time a frame, and each
    # re-solved frame's stored colours against that frame's fresh solve.
    scene.frame_start, scene.frame_end = todo[0], todo[-1]
    t = time.perf_counter()
    assert bpy.ops.radiosity.bake_animation() == {'FINISHED'}
    animation = (time.perf_counter() - t) / (todo[-1] - todo[0] + 1)
    baked, animation_rms = [], {}
    for f in todo:
        t = time.perf_counter()
        scene.frame_set(f)
        baked.append(time.perf_counter() - t)
        if f in fresh:
            animation_rms[f] = relative_rms(shown(scene, names), fresh[f])
    threshold = pkg.settings.engine_settings(scene.radiosity).threshold
    return dict(scene=name, vertices=verts, points=first["points"], frames=len(todo), full=med(full),
                frame_rms=frame_rms, by_frame=dict(zip(todo, upd)),
                threshold=threshold,
                update=med(upd), incremental=med(inc), frame=med(frame_wall), write=med(writes),
                touched=med(touched), first=first["seconds_solve"], baked=med(baked), animation=animation,
                animation_rms=animation_rms, db=db, db_mb=db_mb,
                db_cap=scene.radiosity.db_cache_mb, playback=playback, fps=scene.render.fps / scene.render.fps_base)


def table(head, lines):
    print(head)
    print("-" * len(head))
    for line in lines:
        print(line)
    print()


def main():
    print(f"Radiosity dynamic update bench: preset {PRESET.lower()}, {f'{FRAMES} frames' if FRAMES else 'every frame'} of a scene, "
          f"{FULL_REPEATS} full re-solves a scene; medians; 2 cores (shared)")
    makers = {"animated_room": animated_room, "room_20k": lambda: room_scene(20000),
              "room_10k": lambda: room_scene(10000), "room_10k_tex": lambda: room_scene(10000, 4096),
              "wave_10k": lambda: room_scene(10000, wave=True), "movers_10k": lambda: room_scene(10000, movers=True)}
    rows = [run(name, makers[name]) for name in SCENES]
    table(f"{'scene':14} {'vertices':>8} {'points':>7} {'full s':>8} {'update s':>9} {'ratio':>6} "
          f"{'touched':>8} {'live s':>8} {'write ms':>8} {'frame s':>8} {'fps':>6} {'baked fps':>9}",
          [f"{r['scene']:14} {r['vertices']:8d} {r['points']:7d} {r['full']:8.3f} {r['update']:9.3f} "
           f"{r['full'] / r['update'] if r['update'] > 0 else float('inf'):6.1f} {100 * r['touched']:7.1f}% "
           f"{r['incremental']:8.3f} {1000 * r['write']:8.2f} {r['frame']:8.3f} {1 / r['frame']:6.1f} "
           f"{1 / r['baked']:9.1f}" for r in rows])
    print("Each re-solved frame: its update (Solver.update() through the add-on) against the full solve, and the "
          "colours the update wrote against the full solve's (RMS)")
    table(f"{'scene':14} {'frame':>5} {'update s':>9} {'full / update':>13} {'rms':>8}",
          [f"{r['scene']:14} {f:5d} {r['by_frame'][f]:9.3f} {r['full'] / r['by_frame'][f]:13.1f} "
           f"{100 * rms:7.3f}%" for r in rows for f, rms in sorted(r['frame_rms'].items())])
    print(f"dB cache (cap {rows[0]['db_cap']:g} MB): the frames above played forward, then back; medians per update")
    table(f"{'scene':14} {'way':8} {'cpu s':>7} {'rays':>10} {'changed':>9} {'hits':>9} {'hit %':>6} {'cache MB':>8}",
          [f"{r['scene']:14} {way:8} {d['cpu']:7.3f} {d['rays']:10.0f} {d['changed']:9.0f} {d['hits']:9.0f} "
           f"{100 * d['hits'] / max(1, d['changed']):6.1f} {r['db_mb']:8.2f}" for r in rows for way, d in r["db"].items()])
    print("Shooting on: what an update's gathers left unshot (in thresholds), the shots and seconds that took "
          "it down to the update's stop, their share of the update, and full / those seconds: the most full / update "
          "could be were the rest of the update free")
    table(f"{'scene':14} {'way':8} {'left':>6} {'shots':>6} {'shoot s':>8} {'share':>6} {'bound':>6}",
          [f"{r['scene']:14} {way:8} {d['left'] / r['threshold']:6.1f} {d['shots']:6.0f} {d['shoot']:8.3f} "
           f"{100 * d['shoot'] / max(1e-9, d['seconds']):5.0f}% {r['full'] / max(1e-9, d['shoot']):6.1f}"
           for r in rows for way, d in r["db"].items()])
    if PLAYBACKS:
        print(f"playback ({PLAYBACKS} runs of the frame range, medians)")
        table(f"{'scene':14} {'fps':>5} {'of':>4} {'main ms':>8} {'max ms':>7} {'updates':>7} {'frames/upd':>10} "
              f"{'residual':>8} {'rms playing':>11} {'own frame':>9} {'rms settled':>11} {'settle s':>8} {'held ms':>7}",
              [f"{r['scene']:14} {p['fps']:5.1f} {r['fps']:4.0f} {1000 * p['main']:8.1f} {1000 * p['main_max']:7.1f} "
               f"{p['updates']:7.0f} {p['span']:10.1f} {100 * p['residual']:7.2f}% {100 * p['playing']:10.3f}% "
               f"{100 * p['own']:8.3f}% {100 * p['settled']:10.3f}% {p['settle']:8.3f} {1000 * p['settle_main']:7.1f}"
               for r in rows for p in [r["playback"]]])
    print("full s: new Solver + solve() of a played frame; update s: Solver.update() of a frame change;")
    print("ratio = full / update (goal 50); touched: receiving points the update recomputed (engine's")
    print("touched_points / points); live s: export + diff + update + colours + write-back;")
    print("frame s: scene.frame_set() wall time with live update on (what playback waits for);")
    print("baked fps: playback after Bake Animation of the same frames (stored colours written back).")
    for r in rows:
        if r["scene"] == "room_10k" and PLAYBACKS:
            verdict = "yes" if r["frame"] <= 1 / 24 else "no"
            print(f"24 fps with write-back at ~10k vertices ({r['vertices']} vertices, {r['points']} points): "
                  f"live update {verdict} ({1 / r['frame']:.1f} fps, {1000 * r['frame']:.0f} ms a frame); "
                  f"playing {'yes' if r['playback']['fps'] >= 0.95 * r['fps'] else 'no'} ({r['playback']['fps']:.1f} fps, "
                  f"residual {100 * r['playback']['residual']:.2f}%); "
                  f"after Bake Animation {'yes' if r['baked'] <= 1 / 24 else 'no'} ({1 / r['baked']:.0f} fps)")
    save(rows)


def save(rows):
    """The two tables above as CSVs with their Markdown, named for the preset."""
    run = " ".join(sys.argv[sys.argv.index("--") + 1:]) if "--" in sys.argv else ""
    how = (f"`blender -b --factory-startup --python bench/dynamic_update.py -- {run}`".replace(" -- `", "`")
           + f": preset {PRESET.lower()}, {f'{FRAMES} frames' if FRAMES else 'every frame'} of each scene "
           f"(animated_room: the sample; room_20k / room_10k: a 4 m room with a 0.4 m box crossing the floor; "
           f"movers_10k: room_10k with five boxes moving at once), "
           f"medians; 2 shared cores.")
    per_scene = []
    for r in rows:
        p = r["playback"] or {}
        per_scene.append(dict(
            scene=r["scene"], vertices=r["vertices"], points=r["points"], full_s=f"{r['full']:.3f}",
            update_s=f"{r['update']:.3f}", ratio=f"{r['full'] / r['update']:.1f}" if r["update"] > 0 else "",
            rms_updated=f"{max(r['frame_rms'].values()):.4f}",
            touched=f"{r['touched']:.3f}", live_s=f"{r['incremental']:.3f}", frame_s=f"{r['frame']:.3f}",
            baked_fps=f"{1 / r['baked']:.0f}", animation_s=f"{r['animation']:.3f}",
            animation_ratio=f"{r['full'] / r['animation']:.1f}",
            rms_animation=f"{max(r['animation_rms'].values()):.4f}", playing_fps=f"{p['fps']:.1f}" if p else "",
            frames_per_update=f"{p['span']:.1f}" if p else "", residual=f"{p['residual']:.4f}" if p else "",
            rms_playing=f"{p['playing']:.4f}" if p else "", rms_settled=f"{p['settled']:.4f}" if p else "",
            settle_s=f"{p['settle']:.3f}" if p else ""))
    tables.write(tables.path_for(f"dynamic_update_{PRESET.lower()}"), list(per_scene[0]), per_scene,
                 f"Dynamic update cost ({PRESET.lower()} preset)",
                 [("scene", "scene", None), ("points", "points", tables.count), ("full_s", "full solve", tables.seconds),
                  ("update_s", "update", tables.seconds), ("ratio", "full / update", None),
                  ("rms_updated", "RMS updated (worst)", tables.percent),
                  ("live_s", "live update", tables.seconds), ("playing_fps", "playing fps", None),
                  ("frames_per_update", "frames an update", None), ("rms_playing", "RMS playing", tables.percent),
                  ("rms_settled", "RMS settled", tables.percent),
                  ("animation_s", "Bake Animation a frame", tables.seconds),
                  ("animation_ratio", "full / Bake Animation", None),
                  ("rms_animation", "RMS Bake Animation (worst)", tables.percent),
                  ("baked_fps", "baked playback fps", None)],
                 how + " full: a new solver and solve of a played frame; update: Solver.update() of a frame "
                 "change; live update: export + diff + update + colours + write-back; playing: the frame range "
                 "played as the UI plays it (updates in a worker, a frame's time of shooting each), its colours "
                 "against a fresh solve of the last frame while playing and once settled; Bake Animation: its "
                 "time over the frame range a frame, and the re-solved frames' stored colours against their fresh "
                 "solves; baked playback: after Bake Animation, each frame's stored colours written.")
    moves = [dict(scene=r["scene"], way=way, cpu_s=f"{d['cpu']:.3f}", rays=f"{d['rays']:.0f}",
                  changed=f"{d['changed']:.0f}", hits=f"{d['hits']:.0f}",
                  hit_share=f"{d['hits'] / max(1, d['changed']):.3f}", cache_mb=f"{r['db_mb']:.1f}",
                  left=f"{d['left'] / r['threshold']:.1f}", shots=f"{d['shots']:.0f}", shoot_s=f"{d['shoot']:.3f}",
                  shoot_share=f"{d['shoot'] / max(1e-9, d['seconds']):.3f}",
                  bound=f"{r['full'] / max(1e-9, d['shoot']):.1f}")
             for r in rows for way, d in r["db"].items()]
    tables.write(tables.path_for(f"dynamic_update_{PRESET.lower()}_moves"), list(moves[0]), moves,
                 f"Dynamic updates forward and back: dB cache and shooting on ({PRESET.lower()} preset)",
                 [("scene", "scene", None), ("way", "way", None), ("cpu_s", "CPU an update", tables.seconds),
                  ("rays", "rays", tables.mega), ("changed", "changed rays", tables.count),
                  ("hit_share", "answered by the dB cache", tables.percent), ("cache_mb", "cache MB", None),
                  ("left", "left (thresholds)", None), ("shots", "shots", None),
                  ("shoot_s", "shooting on", tables.seconds), ("shoot_share", "share of the update", tables.percent),
                  ("bound", "full / shooting on", None)],
                 how + " The frames are played forward, then back. changed rays: rays the move changed, each "
                 "a trace of the scene without the moving object unless the dB cache answers it. left: the light "
                 "an update's gathers leave unshot, in thresholds; shooting on: the shots that take it down to "
                 "the update's stop; full / shooting on bounds full / update for any update shooting like this.")


main()

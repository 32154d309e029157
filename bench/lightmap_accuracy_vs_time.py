"""Accuracy against time at the texels: our presets' lightmaps and Cycles' image bake of the same images.

    blender -b --factory-startup --python bench/lightmap_accuracy_vs_time.py -- [--scenes cornell_box,...]
        [--presets draft,default,high] [--spp 16,64,256,512,1024,2048,4096] [--resume] [--quick]
    blender -b --factory-startup --python bench/lightmap_accuracy_vs_time.py -- --plot-only

For each sample scene of tests/cycles_reference/lightmap_reference.py (the animated room at frame 1),
against its Cycles image bake at 8,192 samples (seed 0), over the texels that bake covers:
  ours    lightmaps_vs_cycles.measure: the add-on's Bake with lightmaps into the reference's maps and
          image sizes; seconds = the whole operator, as a user waits for it.
  cycles  lightmap_reference.bake (its settings, DESIGN.md section 4) of the same objects into the
          same maps and image sizes at --spp samples, seed 1 so that its samples are not the
          reference's own; seconds = the bake operator.
Runs under 10 s are repeated (3 in all) and the median times kept.

Errors are relative RMS (reference.relative_rms). `rms` is against the reference as it is; the
reference holds noise of its own, n_ref, which at 1% is most of the error. Cycles at N samples and
the reference at R differ by independent noise of the same estimator, so rms^2 = n_ref^2 (1 + R/N):
n_ref comes from the bakes at 1,024 samples and more, pooled. `net` = sqrt(max(0, rms^2 - n_ref^2))
is the error against a noiseless reference, for ours and Cycles alike; the speed-ups use it.

Speed-up at an error e: Cycles' time at e on the log-log line between its neighbouring sample counts
(accuracy_vs_time.cycles_time_at; extended past its ends, and the note says so) over ours: the time
of the quickest preset whose error is e or less (a preset is what a user can pick), and our time on
the log-log line between the presets either side of e (as Cycles' is taken; settings between the
presets' exist). Rows at each preset's own error, at 2% and at 1%. The same in CPU time (the
process's, all threads, over the same span): what a bake costs whatever else the machine runs, which
on a shared machine moves less than the wall time.

Writes bench/results/lightmap_accuracy_vs_time.csv and .md (the measurements),
lightmap_accuracy_vs_time_speedup.csv and .md (the speed-ups) and lightmap_accuracy_vs_time.png.
Every row is saved as soon as it is measured; rows of cases not run are kept from the CSV, and
--resume skips the cases the CSV already has, so an interrupted run goes on where it stopped.
--quick: cornell_box, draft and default, Cycles at 16/64/256, into *_quick.* files (about a minute).
The full run takes about 25 minutes, most of it Cycles at 2,048 and 4,096 samples and High on the
interior room.
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
import accuracy_vs_time  # noqa: E402  (cycles_time_at, median_time, nice_range, speed, CYCLES_SEED)
import lightmap_reference  # noqa: E402
import lightmaps_vs_cycles  # noqa: E402  (measure: our bake with lightmaps against the reference)
import plot_png  # noqa: E402
import reference  # noqa: E402
import tables  # noqa: E402


def ratio(s):
    """A speed-up's table format: three figures, so that 0.058 shows as well as 23.4."""
    return f"{float(s):.3g}"


PRESETS = ["draft", "default", "high"]
SPP = [16, 64, 256, 512, 1024, 2048, 4096]
NOISE_SPP = 1024          # bakes from this many samples on estimate the reference's noise
TARGETS = [0.02, 0.01]
NAME = "lightmap_accuracy_vs_time"
FIELDS = ["scene", "method", "setting", "seconds", "cpu", "texels", "rms", "net", "load1", "note"]
COLUMNS = [("scene", "scene", None), ("method", "method", None), ("setting", "preset / spp", None),
           ("seconds", "time", tables.seconds), ("cpu", "CPU time", tables.seconds),
           ("texels", "texels", tables.count),
           ("rms", "relative RMS", tables.percent), ("net", "net of the reference's noise", tables.percent)]
SPEEDUP_FIELDS = ["scene", "basis", "error", "ours", "ours_seconds", "cycles_seconds", "speedup", "between_seconds",
                  "between_speedup", "cpu_speedup", "note"]
SPEEDUP_COLUMNS = [("scene", "scene", None), ("basis", "error", None), ("error", "at", tables.percent),
                   ("ours", "ours", None), ("ours_seconds", "our time", tables.seconds),
                   ("cycles_seconds", "Cycles' time", tables.seconds), ("speedup", "Cycles / ours", ratio),
                   ("between_seconds", "ours between presets", tables.seconds),
                   ("between_speedup", "Cycles / that", ratio),
                   ("cpu_speedup", "in CPU time: Cycles / ours", ratio), ("note", "note", None)]
MACHINE = ("Times on a 2-core machine shared with other work, the bench under nice (the CSV's load1 column "
           "gives the load average at each row): wall times move with that load from run to run, CPU times "
           "(the process's, all threads) much less.")
NOTES = ("Relative RMS over the texels Cycles' 8,192-sample image bake covers (lightmap_reference.py), "
         "shadow edges and feet included. net: with the reference's own noise n_ref taken out "
         "(sqrt(rms^2 - n_ref^2)); n_ref from Cycles' bakes at 1,024 samples and more (seed 1 against "
         "the reference's 0), the `noise` row. Time: the whole bake with lightmaps for ours, the bake "
         "operator for Cycles; median of 3 under 10 s. " + MACHINE)
SPEEDUP_NOTES = ("Cycles' time at the error (log-log between its sample counts) over ours: the quickest "
                 "preset at that error or under it (what picking a preset gives), and our time on the log-log "
                 "line between the presets either side of the error (as Cycles' is taken); then the first "
                 "ratio in CPU time (the process's, all threads). net: errors with "
                 "the reference's noise taken out (what the speed-up is quoted on); raw: as measured, where "
                 "both sides level off at the reference's noise. " + MACHINE)


def options():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []

    def get(flag, default):
        return argv[argv.index(flag) + 1] if flag in argv else default
    quick = "--quick" in argv
    scenes = "cornell_box" if quick else ",".join(lightmap_reference.SAMPLE_SCENES)
    return dict(scenes=get("--scenes", scenes).split(","),
                presets=get("--presets", "draft,default" if quick else ",".join(PRESETS)).split(","),
                spp=[int(s) for s in get("--spp", "16,64,256" if quick else ",".join(map(str, SPP))).split(",")],
                quick=quick, resume="--resume" in argv, plot_only="--plot-only" in argv)


def label(name, frame):
    return name + ("" if frame is None else f"@{frame}")


# ----------------------------------------------------------------------------- runs
def timed(run):
    """run() -> (seconds, cpu seconds, result): the first result and the median times of 3 runs if the
    first is under 10 s (accuracy_vs_time.median_time)."""
    seconds, cpu, result = run()
    cpus = [cpu]

    def again():
        seconds, cpu, _ = run()
        cpus.append(cpu)
        return seconds
    seconds = accuracy_vs_time.median_time(again, seconds)
    return seconds, statistics.median(cpus), result


def run_ours(name, frame, preset):
    """Our bake with lightmaps."""
    def once():
        row = lightmaps_vs_cycles.measure(name, frame, preset)
        return float(row["seconds"]), float(row["cpu"]), row
    seconds, cpu, first = timed(once)
    return dict(scene=first["scene"], method="ours", setting=preset, seconds=f"{seconds:.3f}", cpu=f"{cpu:.3f}",
                texels=first["texels"], rms=first["rms"], load1=f"{os.getloadavg()[0]:.2f}", note=first["objects"])


def cycles_once(name, frame, spp):
    """Cycles' image bake of the reference's objects into its maps and image sizes. Returns
    (seconds, cpu seconds, (relative RMS against the reference, texels))."""
    ref = lightmap_reference.open_with_reference(name, frame)
    names = lightmap_reference.objects_of(ref)
    objects = {n: bpy.data.objects[n] for n in names}
    sizes = {n: ref[n].shape[1::-1] for n in names}
    cpu = time.process_time()
    images, seconds = lightmap_reference.bake(objects, sizes, spp, accuracy_vs_time.CYCLES_SEED)
    cpu = time.process_time() - cpu
    covered = {n: ref[n][..., 0] >= 0 for n in names}
    for n in names:
        assert np.array_equal(covered[n], images[n][..., 0] >= 0), f"{n}: Cycles covered other texels"
    baked = np.concatenate([images[n][covered[n]] for n in names])
    truth = np.concatenate([ref[n][covered[n]].astype(np.float64) for n in names])
    return seconds, cpu, (reference.relative_rms(baked, truth), len(baked))


def run_cycles(name, frame, spp):
    seconds, cpu, (rms, texels) = timed(lambda: cycles_once(name, frame, spp))
    return dict(scene=label(name, frame), method="cycles", setting=str(spp), seconds=f"{seconds:.3f}",
                cpu=f"{cpu:.3f}", texels=str(texels), rms=f"{rms:.5f}", load1=f"{os.getloadavg()[0]:.2f}", note="")


# ----------------------------------------------------------------------------- errors and speed-ups
def reference_samples(scene):
    name, _, frame = scene.partition("@")
    with np.load(lightmap_reference.sample_path(name, int(frame) if frame else None)) as z:
        return int(z["samples"])


def reference_noise(rows, scene):
    """n_ref of the scene's reference from Cycles' bakes at NOISE_SPP samples and more (module
    docstring); None without one."""
    pts = [(int(r["setting"]), float(r["rms"])) for r in rows
           if r["scene"] == scene and r["method"] == "cycles" and int(r["setting"]) >= NOISE_SPP]
    if not pts:
        return None
    samples = reference_samples(scene)
    return math.sqrt(sum(e * e for _, e in pts) / sum(1 + samples / n for n, _ in pts))


def with_noise(rows):
    """The measured rows with `net` filled in, and a `noise` row per scene that has n_ref."""
    rows = [r for r in rows if r["method"] != "noise"]
    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        n_ref = reference_noise(rows, scene)
        for r in (r for r in rows if r["scene"] == scene):
            net = "" if n_ref is None else f"{math.sqrt(max(0.0, float(r['rms']) ** 2 - n_ref ** 2)):.5f}"
            out.append(dict(r, net=net))
        if n_ref is not None:
            out.append(dict(scene=scene, method="noise", setting=str(reference_samples(scene)), seconds="",
                            cpu="", texels="", rms=f"{n_ref:.5f}", net="", load1="",
                            note=f"the reference's own, from Cycles at {NOISE_SPP} spp and more"))
    return out


def between_presets(ours, col, err):
    """Our time at err on the log-log line between the presets either side of it, as Cycles' is taken
    between sample counts (`ours` in time order, the first above err)."""
    pts = [{"setting": str(i), "seconds": r["seconds"], col: r[col]} for i, r in enumerate(ours)]
    return accuracy_vs_time.cycles_time_at(pts, err, col)[0]


def speedups(rows):
    """Rows of the speed-up table: per scene and basis (net, raw), at each preset's error and TARGETS."""
    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for basis, col in (("net", "net"), ("raw", "rms")):
            cyc = [r for r in rows if r["scene"] == scene and r["method"] == "cycles" and r.get(col)
                   and float(r[col]) > 0]
            ours = sorted((r for r in rows if r["scene"] == scene and r["method"] == "ours" and r.get(col)
                           and float(r[col]) > 0), key=lambda r: float(r["seconds"]))
            if len(cyc) < 2 or not ours:
                continue
            errors = [(float(r[col]), r["setting"]) for r in ours] + [(e, f"{e:.0%}") for e in TARGETS]
            for err, what in errors:
                row = dict(scene=scene, basis=basis, error=f"{err:.5f}", ours="", ours_seconds="",
                           cycles_seconds="", speedup="", between_seconds="", between_speedup="", cpu_speedup="",
                           note="")
                quickest = next((r for r in ours if float(r[col]) <= err), None)
                if quickest is None:
                    best = min(ours, key=lambda r: float(r[col]))
                    row.update(note=f"ours: not reached (best {float(best[col]):.2%}, {best['setting']})")
                    out.append(row)
                    continue
                seconds, note = accuracy_vs_time.cycles_time_at(cyc, err, col)
                between = float(quickest["seconds"]) if quickest is ours[0] else between_presets(ours, col, err)
                if quickest.get("cpu") and all(r.get("cpu") for r in cyc):
                    cpu = accuracy_vs_time.cycles_time_at([dict(r, seconds=r["cpu"]) for r in cyc], err, col)[0]
                    row.update(cpu_speedup=f"{cpu / float(quickest['cpu']):.3f}")
                row.update(ours=quickest["setting"], ours_seconds=quickest["seconds"],
                           cycles_seconds=f"{seconds:.3f}", speedup=f"{seconds / float(quickest['seconds']):.3f}",
                           between_seconds=f"{between:.3f}", between_speedup=f"{seconds / between:.3f}",
                           note="; ".join(filter(None, ["" if what in PRESETS else f"target {what}",
                                                       note and "Cycles " + note])))
                out.append(row)
    return out


def report(rows, speedup_rows):
    print(f"\n{'scene':16} {'method':8} {'setting':>8} {'seconds':>9} {'rms':>7} {'net':>7} {'load':>5}")
    for r in rows:
        net = f"{float(r['net']):.2%}" if r["net"] else "-"
        print(f"{r['scene']:16} {r['method']:8} {r['setting']:>8} {r['seconds'] or '-':>9} "
              f"{float(r['rms']):7.2%} {net:>7} {r['load1'] or '-':>5}")
    print("\nAt equal error (Cycles' time interpolated at ours; ours, the quickest preset there, and between presets):")
    for r in speedup_rows:
        head = f"  {r['scene']:16} {r['basis']} {float(r['error']):6.2%}"
        if not r["speedup"]:
            print(f"{head}: {r['note']}")
        else:
            print(f"{head}: ours ({r['ours']}) {float(r['ours_seconds']):.2f} s, Cycles "
                  f"{float(r['cycles_seconds']):.2f} s: we are {accuracy_vs_time.speed(float(r['speedup']))}; "
                  f"between presets {float(r['between_seconds']):.2f} s, "
                  f"{accuracy_vs_time.speed(float(r['between_speedup']))}" + (f"  ({r['note']})" if r["note"] else ""))


# ----------------------------------------------------------------------------- plot
def plot(rows, path):
    """Error against wall time, one panel a scene; below, against CPU time where the rows have it."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    have = [r for r in rows if r["method"] in ("ours", "cycles")]
    times = [(x, label) for x, label in (("seconds", "wall time (s)"), ("cpu", "CPU time (s)"))
             if any(r.get(x) for r in have)]
    xlim = accuracy_vs_time.nice_range([float(r[x]) for r in have for x, _ in times if r.get(x)])
    ylim = accuracy_vs_time.nice_range([float(r[k]) for r in have for k in ("rms", "net") if r.get(k)]
                                       + TARGETS)
    steps = [m * 10.0 ** k for k in range(-4, 5) for m in (1, 2, 5)]
    decades = [10.0 ** i for i in range(math.ceil(math.log10(xlim[0]) - 1e-9),
                                        math.floor(math.log10(xlim[1]) + 1e-9) + 1)]
    styles = [("ours", "net", (31, 119, 180), "o", 0, "ours, net"),
              ("cycles", "net", (214, 39, 40), "s", 0, "Cycles, net"),
              ("ours", "rms", (120, 170, 215), "o", 6, "ours, raw"),
              ("cycles", "rms", (235, 140, 140), "s", 6, "Cycles, raw")]
    pw, ph, left, top, gap, vgap = 360, 340, 120, 50, 64, 100
    width = max(left + len(scenes) * (pw + gap), 900)
    c = plot_png.Canvas(width, top + len(times) * (ph + vgap) + 90)
    for j, (x, xlabel) in enumerate(times):
        y0 = top + j * (ph + vgap)
        for k, sc in enumerate(scenes):
            x0 = left + k * (pw + gap)
            ax = plot_png.LogAxes(c, (x0, y0, x0 + pw, y0 + ph), xlim, ylim, xlabel,
                                  "relative RMS error" if k == 0 else "", sc)
            ax.frame(decades, [v for v in steps if ylim[0] <= v <= ylim[1]], fmt_y=lambda v: f"{v * 100:g}%",
                     ylabels=(k == 0))
            for target in TARGETS:
                ax.hline(target, (120, 120, 120), f"{target:.0%}")
            labelled = "net" if any(r["scene"] == sc and r.get("net") for r in have) else "rms"
            for method, col, color, marker, dash, _ in styles:
                sel = sorted((r for r in have if r["scene"] == sc and r["method"] == method and r.get(col)
                              and r.get(x) and float(r[col]) > ylim[0]), key=lambda r: float(r[x]))
                ax.polyline([(float(r[x]), float(r[col])) for r in sel], color, marker, dash=dash,
                            labels=[r["setting"] for r in sel] if col == labelled else None,
                            label_side="r" if method == "ours" else "l")
    y = top + len(times) * (ph + vgap) - 30
    for i, (_, _, color, marker, dash, text) in enumerate(styles):
        xx = left + i * 200
        c.line(xx - 14, y + 7, xx + 14, y + 7, color, 2, dash)
        c.dot(xx, y + 7, 6, color, marker)
        c.text(xx + 24, y, text, (0, 0, 0), 2)
    notes = ["Error over the texels against Cycles' image bake at 8,192 spp; net: with that bake's own noise",
             "taken out. Time: the whole bake with lightmaps (ours), the bake operator (Cycles); CPU time: the",
             "process's, all threads. Labels: preset (ours), samples per pixel (Cycles). 2 cores, shared."]
    for i, line in enumerate(notes):
        c.text(left, y + 36 + 14 * i, line, (90, 90, 90), 1)
    c.save(path)


# ----------------------------------------------------------------------------- main
def read_rows(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def save(rows, path):
    """Both tables and the plot from `rows` (measured rows; `noise` rows are made anew)."""
    order = {m: i for i, m in enumerate(("noise", "cycles", "ours"))}
    scenes = [label(n, f) for n, f in lightmap_reference.SAMPLE_SCENES.items()]

    def key(r):
        s = r["setting"]
        return (scenes.index(r["scene"]) if r["scene"] in scenes else len(scenes), order[r["method"]],
                PRESETS.index(s) if s in PRESETS else int(s))
    rows = sorted(with_noise(rows), key=key)
    tables.write(path, FIELDS, rows, "Lightmaps: accuracy against time, ours and Cycles' image bake", COLUMNS, NOTES)
    speedup_rows = speedups(rows)
    tables.write(path.replace(".csv", "_speedup.csv"), SPEEDUP_FIELDS, speedup_rows,
                 "Lightmaps: speed-up over Cycles' image bake at equal error", SPEEDUP_COLUMNS, SPEEDUP_NOTES)
    if any(r["method"] in ("ours", "cycles") for r in rows):
        plot(rows, path.replace(".csv", ".png"))
    return rows, speedup_rows


def main():
    opt = options()
    path = tables.path_for(NAME, opt["quick"])
    rows = [r for r in read_rows(path) if r["method"] != "noise"]
    if opt["plot_only"]:
        report(*save(rows, path))
        return
    load_package().register()
    print(f"cores {os.cpu_count()}; load average at start {os.getloadavg()}", flush=True)
    done = {(r["scene"], r["method"], r["setting"]) for r in rows} if opt["resume"] else set()
    warm = False
    for name in opt["scenes"]:
        frame = lightmap_reference.SAMPLE_SCENES[name]
        cases = [("cycles", str(spp)) for spp in opt["spp"]] + [("ours", p) for p in opt["presets"]]
        for method, setting in cases:
            if (label(name, frame), method, setting) in done:
                continue
            if method == "cycles" and not warm:
                cycles_once(name, frame, 1)          # loads Cycles' kernels: untimed
                warm = True
            row = run_cycles(name, frame, int(setting)) if method == "cycles" else run_ours(name, frame, setting)
            print("ROW", row, flush=True)
            rows = tables.kept_rows(path, [row], ("scene", "method", "setting"))
            rows = [r for r in rows if r["method"] != "noise"]
            save(rows, path)
    report(*save(rows, path))
    print(f"\nwrote {path} and beside it; load average at end {os.getloadavg()}")


if __name__ == "__main__":
    main()

"""What the add-on writes (the `Radiosity` attribute) against Cycles' COMBINED bake references.

Metric: relative RMS (reference.relative_rms: sqrt(mean |v - r|^2) / mean(r), all channels) over
every non-emitting face corner of the scene, i.e. the values a user sees. The target is 2% at the
default preset and 1% at high (where Exact Reflected Contact Light is on). Each bound below is the
error measured on a 2-core machine (the bench alone; references' corners at 262,144 spp, ~0.2% noise),
written beside it, plus a small margin.

Off junctions (reference.junction_faces: corners on another surface that rises in front of theirs, a
room's corners, a box's feet; there Cycles' own corner value is ill-posed) count 40 of 88 corners
(Cornell box), 36 of 68 (subsurf room: the Blob's corners, whose three Cycles values differ by up to
1.4% between faces) and 12 of 44. The subsurf room is not traced (the tracer takes cages; its Blob is
a Subdivision Surface). Cycles' own corners are 1.06 / 0.48 / 1.11 / 0.77% from the limit reference
(Cornell box, animated room @1 / @12 / @24).

The bounds are NOT the 1% target at high against Cycles' corners, which the Cornell box and the
animated room at frame 12 miss; against the limit reference every traced scene meets it. Tightening
them is the engine's work; do not loosen them without measuring.

The inset metric compares the same `Radiosity` corner values (our value at a corner stands for the
face near it) with Cycles baked 0.5% of the way from each corner to its face's centroid
(reference.corner_reference(..., inset=True); make_references.py: corner_inset). At a corner on a
junction with another surface Cycles' own corner value is ill-posed (Cornell ShortBox's foot: 0.053
at the corner, 0.072 a few millimetres up the face); at a room's concave corners, though, Cycles'
value rises steadily into the face, so there the inset reference is the value 1-2 cm in and our
corner values sit nearer the junction one (Room: 0.8-2.7% junction, 3.1-5.2% inset). The limit
metric keeps Cycles' corners off junctions and takes, on them, a numpy path tracer's value 1e-5 of
the way into the corner's face (trace_corner.py, 100,000 paths a corner, *_traced.npz): the value
the face holds as one comes to its corner. Off junctions the tracer is within its noise of Cycles
(0.40-0.61% RMS); on them it parts from Cycles both ways by up to 25%, and sides with ours (the
Cornell ShortBox's foot: traced 0.0708, Cycles 0.0532, ours 0.0733). The test prints every metric
per object and the five corners worst against the junction reference (run with -s).

The default-preset bakes take 2-4 s each: only cornell_box and subsurf_room run by default;
DR_SLOW=1 runs every scene and frame, and the high preset (12-45 s a bake).

The optics samples (window_room, window_room_glass, mirror_room) are compared at the default preset
against Cycles with glossy and transmission bounces on (optics_references.py), over the non-emitting
corners of everything but the pane or the mirror, at the 2% target, or 3% where the bake's report
lists an effect as approximated (the glass room: refraction, its direction kept). On junctions the
reference is the limit: trace_corner.py's where the sample is traced (all three:
optics/*_traced.npz, the tracer taking their area lamps, sun, world, panes and mirror), else
Cycles' inset corners. At a room's concave corner the inset bake reads the value 1-2 cm in, which
has risen fast from the corner: mirror_room's inset corners are 4% RMS from the traced limit (up to
11% over it at the ceiling's corners, which no direct light reaches), where Cycles' own corners are
within 0.8%. Measured: window_room 1.48% (1.97% on junctions, 0.40% off), window_room_glass 2.50%
(2.68%, 2.09%: its area lamp seen through the window, sampled without bias, is noisy), mirror_room
1.04% (1.20%, 0.78%).
Their share tests check the light the pane or the mirror carries: each scene baked again with it black
(optics_references.blacken), by us and by Cycles; our change must be Cycles' change within 10% of it
(relative RMS of the two changes).
"""
import json
import os
import sys

import bpy
import numpy as np
import pytest

from conftest import ROOT, SAMPLES
from test_addon import colours

sys.path.insert(0, os.path.join(ROOT, "tests", "cycles_reference"))
import make_references  # noqa: E402  (world_faces, emitting_corners)
import optics_references  # noqa: E402
import reference  # noqa: E402

SLOW = os.environ.get("DR_SLOW") == "1"

# (scene, frame, preset) -> relative RMS bounds (measured + margin), per metric: "junction", every
# corner against Cycles' value at the corner itself (the target's metric); "inset", against Cycles a
# little inside the faces (make_references.py: corner_inset); "open", the corners off junctions
# (reference.junction_faces), where Cycles' corner is well-posed, checked where measured (None:
# printed only); "limit", Cycles' corner off junctions and on them a path tracer's value a hair
# inside the corner's face (reference.limit_reference; scenes traced by trace_corner.py only).
# The target stands in for all but "open" where it is met (within()). Beside each: what it measured,
# metric by metric, and the bake's time.
METRICS = ("junction", "inset", "open", "limit")
BOUNDS = {
    ("cornell_box", None, "DEFAULT"): (0.014, 0.016, 0.005, 0.0095),      # 1.25 / 1.40 / 0.33 / 0.83%, 1.6 s
    ("subsurf_room", None, "DEFAULT"): (0.016, 0.028, 0.011, None),       # 1.38 / 2.50 / 0.88 / -, 3.5 s
    ("animated_room", 1, "DEFAULT"): (0.015, 0.027, 0.009, 0.0145),       # 1.29 / 2.38 / 0.58 / 1.28%, 4.6 s
    ("animated_room", 12, "DEFAULT"): (0.019, 0.026, None, 0.014),        # 1.71 / 2.38 / 0.93 / 1.26%, 4.6 s
    ("animated_room", 24, "DEFAULT"): (0.017, 0.028, None, 0.0135),       # 1.43 / 2.54 / 0.82 / 1.20%, 4.5 s
    # the shelf's corners at the wall and the furniture's feet read 10-35% under Cycles: contact light
    ("interior_room", None, "DEFAULT"): (0.068, 0.072, 0.015, None),      # 6.51 / 6.93 / 1.28 / -, 22.6 s
    ("cornell_box", None, "HIGH"): (0.0125, 0.016, None, 0.006),          # 1.15 / 1.49 / 0.26 / 0.47%, 12.5 s
    ("subsurf_room", None, "HIGH"): (0.0095, 0.033, None, None),          # 0.92 / 3.11 / 0.81 / -, 26 s
    ("animated_room", 1, "HIGH"): (0.0068, 0.027, None, 0.0045),          # 0.61 / 2.56 / 0.40 / 0.37%, 41 s
    ("animated_room", 12, "HIGH"): (0.011, 0.026, None, 0.0065),          # 1.02 / 2.44 / 0.59 / 0.55%, 42 s
    ("animated_room", 24, "HIGH"): (0.0088, 0.028, None, 0.005),          # 0.81 / 2.60 / 0.48 / 0.41%, 42 s
    ("interior_room", None, "HIGH"): (0.016, 0.029, None, None),         # 1.48 / 2.74 / 0.46 / -, 65 s
}
# reference kind -> corner_reference's inset: at the corner itself (ill-posed where it lies on a
# junction with another surface), or a little inside its face
REFERENCES = {"junction": False, "inset": True}
FAST = {("cornell_box", None, "DEFAULT"), ("subsurf_room", None, "DEFAULT")}
TARGET = {"DEFAULT": 0.02, "HIGH": 0.01}


def scene_corners(scene, ref, traced=None, skip=()):
    """The scene's non-emitting corners but those of the objects named in `skip` (whose faces still
    make junctions): object names, world positions, our values, the reference values by kind (the
    inset kind where `ref` has it; "traced" and "limit" too where `traced` holds every object:
    reference.py), and whether each lies on a junction (reference.junction_faces)."""
    kinds = {kind: inset for kind, inset in REFERENCES.items()
             if not inset or any(key.endswith(":corner_inset") for key in ref)}
    names, pos, nrm, vals, refs = [], [], [], [], {kind: [] for kind in kinds}
    faces, traced_refs = [], []
    for ob in scene.objects:
        if ob.type != 'MESH' or ob.hide_render:
            continue
        co, normals, f = make_references.world_faces(ob)
        faces += f
        if ob.name in skip:
            continue
        v = colours(ob)[:, :3]
        keep = ~make_references.emitting_corners(ob)
        if not keep.any():
            continue
        names += [ob.name] * int(keep.sum())
        pos.append(co[keep])
        nrm.append(normals[keep])
        vals.append(v[keep])
        for kind, inset in kinds.items():
            refs[kind].append(reference.corner_reference(ref, ob.name, inset)[keep])
        t = reference.traced_reference(traced, ob.name)
        traced_refs.append(None if t is None else t[keep])
    pos = np.concatenate(pos)
    junction = reference.junction_faces(pos, np.concatenate(nrm), faces).any(1)
    refs = {kind: np.concatenate(r) for kind, r in refs.items()}
    if all(t is not None for t in traced_refs):
        refs["traced"] = np.concatenate(traced_refs)
        refs["limit"] = reference.limit_reference(refs["junction"], refs["traced"], junction)
    return np.array(names), pos, np.concatenate(vals), refs, junction


def within(err, case):
    """Each metric's measured bound; for the junction and inset metrics, the target where it is met.
    The open metric has no target: 2% would leave its bound (0.8-1.6%) nothing to decide."""
    target = TARGET[case[2]]
    return all(bound is None or m not in err or err[m] <= (bound if m == "open" else max(bound, target))
               for m, bound in zip(METRICS, BOUNDS[case]))


CASES = [k for k in BOUNDS if SLOW or k in FAST]


@pytest.mark.parametrize("case", CASES, ids=[f"{s}{'' if f is None else '@' + str(f)}-{p.lower()}"
                                             for s, f, p in CASES])
def test_agreement_with_cycles(addon, case):
    name, frame, preset = case
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, name + ".blend"))
    scene = bpy.context.scene
    if frame is not None:
        scene.frame_set(frame)
    scene.radiosity.preset = preset
    assert bpy.ops.radiosity.bake() == {'FINISHED'}
    names, pos, v, refs, junction = scene_corners(scene, reference.load(name, frame),
                                                  reference.load_traced(name, frame))
    err = {}
    for kind, r in refs.items():
        err[kind] = reference.relative_rms(v, r)
        print(f"\n{name}@{frame} {preset}: {kind} corner relative RMS {100 * err[kind]:.2f}% "
              + " ".join(f"{n} {100 * reference.relative_rms(v, r, names == n):.2f}%" for n in np.unique(names)),
              end="")
    err["open"] = reference.relative_rms(v, refs["junction"], ~junction)
    print(f"\n  off junctions ({(~junction).sum()} of {len(junction)} corners): {100 * err['open']:.2f}%, "
          f"on them {100 * reference.relative_rms(v, refs['junction'], junction):.2f}%", end="")
    if "traced" in refs:  # the tracer against Cycles where both are well-posed: its own check
        print(f"\n  traced against Cycles off junctions: "
              f"{100 * reference.relative_rms(refs['traced'], refs['junction'], ~junction):.2f}%; Cycles' "
              f"corners against the limit: {100 * reference.relative_rms(refs['junction'], refs['limit']):.2f}%", end="")
    print(f"  ({scene.radiosity.last_seconds:.1f} s); worst corners against the junction reference:")
    for i in np.argsort(-((v - refs["junction"]) ** 2).sum(1))[:5]:
        print(f"  {names[i]} ({pos[i][0]:+.3f},{pos[i][1]:+.3f},{pos[i][2]:+.3f}) ours {v[i].mean():.4f} "
              + " ".join(f"{kind} {r[i].mean():.4f}" for kind, r in refs.items()))
    assert within(err, case), err


# ----------------------------------------------------------------------------- glass and mirrors
SHARE = 0.1                    # our change against Cycles' when the pane or mirror turns black
APPROXIMATED = 0.03            # the target where the bake's report lists an effect as approximated
# (sample, its variant with the optic black, the optic's object and material)
OPTICS = [("window_room", "window_room_opaque", "Pane"), ("window_room_glass", "window_room_glass_opaque", "Pane"),
          ("mirror_room", "mirror_room_black", "Mirror")]
# sample -> why its agreement test, its share test misses
AGREEMENT_MISSES = {}
SHARE_MISSES = {}


def optics_cases(misses):
    """OPTICS for parametrize, those in `misses` as strict xfails with the reason it gives."""
    return [pytest.param(*case, marks=pytest.mark.xfail(strict=True, reason=misses[case[0]]))
            if case[0] in misses else case for case in OPTICS]


_optics_bakes = {}


def optics_corners(reference_name, optic, black):
    """scene_corners' (our values, the reference values by kind, which lie on a junction) at the
    non-emitting corners of every mesh but `optic`, and the kinds of effect the bake's report lists,
    after a default bake of the sample VARIANTS[reference_name] names (its optic made black where
    `black`). Baked once a session: the agreement and share tests share the sample's bake."""
    if reference_name not in _optics_bakes:
        sample, _ = optics_references.VARIANTS[reference_name]
        bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, sample + ".blend"))
        if black:
            optics_references.blacken(bpy.data.materials[optic])
        scene = bpy.context.scene
        scene.radiosity.preset = 'DEFAULT'
        assert bpy.ops.radiosity.bake() == {'FINISHED'}
        ref = reference.read_npz(optics_references.path_of(reference_name))
        _names, _pos, ours, refs, junction = scene_corners(scene, ref, optics_references.load_traced(reference_name),
                                                           skip=(optic,))
        kinds = {row[0] for row in json.loads(scene.radiosity.last_effect_items)}
        _optics_bakes[reference_name] = ours, refs, junction, kinds
    return _optics_bakes[reference_name]


@pytest.mark.parametrize("sample, variant, optic", optics_cases(AGREEMENT_MISSES))
def test_optics_samples_agree_with_cycles(addon, sample, variant, optic):
    """Corners off junctions against Cycles' own, those on one at their limit from inside their face
    (DESIGN.md: Cycles' vertex bake is ill-posed there): trace_corner.py's value a hair inside where
    the sample is traced, else Cycles' inset bake."""
    ours, refs, junction, kinds = optics_corners(sample, optic, False)
    limit = refs.get("limit", reference.limit_reference(refs["junction"], refs["inset"], junction))
    err = reference.relative_rms(ours, limit)
    bound = APPROXIMATED if "approximated" in kinds else TARGET["DEFAULT"]
    on = {"the limit traced": refs.get("traced"), "Cycles inside the face": refs["inset"],
          "Cycles' corners": refs["junction"]}
    print(f"\n{sample} default: corner relative RMS {100 * err:.2f}% (bound {100 * bound:.0f}%) over {len(ours)} "
          f"corners ({100 * reference.relative_rms(ours, refs['junction'], ~junction):.2f}% off junctions; on them "
          + ", ".join(f"{100 * reference.relative_rms(ours, r, junction):.2f}% against {kind}"
                      for kind, r in on.items() if r is not None) + ")", end="")
    assert err <= bound


@pytest.mark.parametrize("sample, variant, optic", optics_cases(SHARE_MISSES))
def test_the_light_a_pane_or_mirror_carries_is_cycles_share(addon, sample, variant, optic):
    ours, refs, _, _ = optics_corners(sample, optic, False)
    ours_black, refs_black, _, _ = optics_corners(variant, optic, True)
    theirs, theirs_black = refs["junction"], refs_black["junction"]
    ours_change, cycles_change = ours - ours_black, theirs - theirs_black
    err = reference.relative_rms(ours_change, cycles_change)
    print(f"\n{sample}: {optic} carries {100 * cycles_change.mean() / theirs.mean():.1f}% of the light at the "
          f"corners in Cycles, {100 * ours_change.mean() / max(ours.mean(), 1e-30):.1f}% in ours; our change is "
          f"{100 * err:.1f}% (relative RMS) from Cycles'; with it black ours are "
          f"{100 * reference.relative_rms(ours_black, theirs_black):.2f}% from Cycles'", end="")
    assert err <= SHARE

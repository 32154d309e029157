"""Cycles corner references for the optics samples (window_room, window_room_glass, mirror_room) and their
share variants.

    blender -b --factory-startup --python tests/cycles_reference/optics_references.py [-- --corner-samples N] [--only NAME]
        [--seed S] [--inset-only]

Writes tests/cycles_reference/optics/<name>.npz, one per entry of VARIANTS: the sample as it is, and
the sample with its pane made opaque or its mirror black (a Diffuse BSDF of black, `blacken`), whose
difference is the share of the light the pane or the mirror carries. Settings: make_references'
(cycles_settings.unbiased, 64 bounces) plus cycles_settings.with_optics (glossy and transmission
bounces on, caustics allowed, no glossy blur). Layout: make_references' "<name>:corner" and
"<name>:matrix_world" per mesh object, plus "samples_corner", "seconds_corner", "blender_version";
the samples as they are (not the variants) also make_references' "<name>:corner_inset" of every mesh
but the pane or mirror (an inset copy of it would stack a second pane on it), the reference of
corners on a junction (DESIGN.md: judged a little inside their face). --inset-only bakes those into
the existing files. trace_corner.py adds <name>_traced.npz beside them (load_traced): the limit
reference of the corners on a junction.
The files sit in their own folder: test_references.py checks the sample scenes' own files, and a
variant has no .blend of its own. --seed S (noise estimates) writes <name>_seedS.npz beside them.
"""
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cycles_settings  # noqa: E402
import make_references  # noqa: E402

OUT = os.path.join(HERE, "optics")
# reference name -> (sample scene, the material made black or None)
VARIANTS = {"window_room": ("window_room", None), "window_room_opaque": ("window_room", "Pane"),
            "window_room_glass": ("window_room_glass", None), "window_room_glass_opaque": ("window_room_glass", "Pane"),
            "mirror_room": ("mirror_room", None), "mirror_room_black": ("mirror_room", "Mirror")}


def blacken(material):
    """Material `material` (a bpy Material) as a black Diffuse BSDF: an opaque pane, a black mirror."""
    nt = material.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    shader = nt.nodes.new("ShaderNodeBsdfDiffuse")
    shader.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    nt.links.new(shader.outputs[0], out.inputs["Surface"])


def path_of(name, seed=0):
    return os.path.join(OUT, name + (f"_seed{seed}" if seed else "") + ".npz")


def traced_path_of(name):
    """trace_corner.py's file of sample `name`: its junction corners a hair inside their faces."""
    return path_of(name).replace(".npz", "_traced.npz")


def load_traced(name):
    """{key: array} of traced_path_of(name), or None where the sample is not traced."""
    path = traced_path_of(name)
    if not os.path.exists(path):
        return None
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


# sample -> its pane's or mirror's object (and material) name
OPTIC = {"window_room": "Pane", "window_room_glass": "Pane", "mirror_room": "Mirror"}


def run(name, samples_corner, seed=0, inset_only=False):
    scene_name, black = VARIANTS[name]
    bpy.ops.wm.open_mainfile(filepath=os.path.join(make_references.SAMPLES_DIR, scene_name + ".blend"))
    sc = bpy.context.scene
    make_references.configure(sc, samples_corner, seed)
    cycles_settings.with_optics(sc)
    if black is not None:
        blacken(bpy.data.materials[black])
    meshes = sorted([o for o in sc.objects if o.type == 'MESH'], key=lambda o: o.name)
    out = path_of(name, seed)
    if inset_only:
        with np.load(out) as z:
            data, note = {k: z[k] for k in z.files}, "kept corners"
    else:
        data, note = make_references.bake_corner(sc, meshes, samples_corner)
    if black is None:
        inset, inset_note = make_references.bake_inset(sc, [o for o in meshes if o.name != OPTIC[scene_name]],
                                                       samples_corner, make_references.INSET)
        data.update(inset)
        note += "; " + inset_note
    data["blender_version"] = np.array(bpy.app.version_string)
    os.makedirs(OUT, exist_ok=True)
    np.savez_compressed(out, **data)
    print(f"REF optics/{os.path.basename(out)}: {note}, {os.path.getsize(out) / 1024:.0f} KiB", flush=True)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    samples = int(argv[argv.index("--corner-samples") + 1]) if "--corner-samples" in argv else 65536
    only = argv[argv.index("--only") + 1] if "--only" in argv else None
    seed = int(argv[argv.index("--seed") + 1]) if "--seed" in argv else 0
    inset_only = "--inset-only" in argv
    for name in VARIANTS:
        if (only is None or only == name) and not (inset_only and VARIANTS[name][1] is not None):
            run(name, samples, seed, inset_only)


if __name__ == "__main__":
    main()

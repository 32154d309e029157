"""The farm's cache folder: what its workers baked, one file a frame and object, beside the .blend.

    <file>_radiosity/0012/<object>.npy    frame 12's colours of <object>: (face corners, 4) float32 RGBA,
                                          the Radiosity attribute's values in its loop order (numpy.load)

Object names are percent-encoded into file names. A worker writes a frame into a folder of its own
and renames it into place whole, so a frame's folder holds all its objects or does not exist: the
frames done are the folders there, whichever worker wrote them, and a worker killed mid-frame leaves
no half frame. Workers and the Blender that gathers the frames must see the folder at the same path
(the .blend's folder, shared).

No bpy here: the workers' task (farm_task.py) and tests read it outside Blender too.
"""
import os
import shutil
import urllib.parse

import numpy as np

SUFFIX = "_radiosity"


def folder_for(blend_path):
    """The cache folder of a .blend: beside it, named after it."""
    stem = os.path.splitext(os.path.basename(blend_path))[0]
    return os.path.join(os.path.dirname(os.path.abspath(blend_path)), stem + SUFFIX)


def frame_folder(folder, frame):
    return os.path.join(folder, f"{int(frame):04d}")


def write_frame(folder, frame, colours):
    """Write {object name: (corners, 4) rgba} as frame `frame`'s files. A frame already there (the same
    chunk run again after its worker was lost) is kept: both are the same bake of the same frame."""
    final = frame_folder(folder, frame)
    if os.path.isdir(final):
        return
    part = f"{final}.part-{os.getpid()}"
    os.makedirs(part, exist_ok=True)
    for name, rgba in colours.items():
        np.save(os.path.join(part, urllib.parse.quote(name, safe="") + ".npy"),
                np.ascontiguousarray(rgba, np.float32))
    # Lightmaps join here: each object's texels as <object>.exr (float RGBA, what Blender's image
    # loader reads) in the same frame folder, written before the rename like the colours.
    try:
        os.rename(part, final)
    except OSError:                       # written meanwhile by another run of the chunk
        shutil.rmtree(part, ignore_errors=True)


def frames_done(folder, frames):
    """The frames among `frames` whose files are all written."""
    return [f for f in frames if os.path.isdir(frame_folder(folder, f))]


def read_frames(folder, frames):
    """{frame: {object name: (corners, 4) float32 rgba}} of `frames`."""
    out = {}
    for f in frames:
        path = frame_folder(folder, f)
        out[f] = {urllib.parse.unquote(n[:-4]): np.load(os.path.join(path, n))
                  for n in sorted(os.listdir(path)) if n.endswith(".npy")}
    return out


def clear(folder):
    """Remove the frames of an earlier bake (a new bake fills the folder anew)."""
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder, exist_ok=True)

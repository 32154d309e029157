"""Bake Animation's lightmaps: each frame's lightmap of each lit mesh an OpenEXR file, beside the
.blend and named after it (as the farm's cache folder),

    <file>_lightmaps/<image name>/<image name>_0012.exr    frame 12 of image <image name>

and the image `<object>_Radiosity` a sequence of them (float RGBA, as a still bake writes it),
which the Image Texture nodes reading it play frame by frame (their image user set to the baked
range, refreshed as the frame changes), in the viewport, in renders and in `blender -b -a`.

Frames go into a staging folder as the bake goes, each frame's lightmaps evaluated only where
their light may have changed (lightmap_updates.py; the others' files are the frame before's).
Only when every frame is solved are they put in place and the images pointed at them (commit):
a cancelled or failed bake leaves the files and the images as they were (discard). Frames
between baked ones (a frame step above 1) hold the one before, as the colours do.
"""
import os
import shutil
import tempfile

import bpy
import numpy as np

from . import lightmap
from .lightmap_updates import Lightmaps

SUFFIX = "_lightmaps"
SCRATCH = ".radiosity_exr"   # the image each file is saved from (a dot: hidden in lists)
FRAMES = "radiosity_frames"  # on a sequence image: the first and last frame baked into it


def folder_for(blend_path):
    """The lightmap folder of a .blend: beside it, named after it."""
    stem = os.path.splitext(os.path.basename(blend_path))[0]
    return os.path.join(os.path.dirname(os.path.abspath(blend_path)), stem + SUFFIX)


def frame_path(folder, image_name, frame):
    name = bpy.path.clean_name(image_name)
    return os.path.join(folder, name, f"{name}_{int(frame):04d}.exr")


def save_exr(rgba, path):
    """(height, width, 4) float32 pixels as a float OpenEXR file."""
    height, width = rgba.shape[:2]
    image = bpy.data.images.get(SCRATCH)
    if image is None or tuple(image.size) != (width, height):
        if image is not None:
            bpy.data.images.remove(image)
        image = bpy.data.images.new(SCRATCH, width, height, alpha=True, float_buffer=True)
    image.pixels.foreach_set(np.ascontiguousarray(rgba, np.float32).ravel())
    image.file_format = 'OPEN_EXR'
    # Saved as made, a generated image writes other pixels than it holds; packed, it saves its own.
    image.pack()
    image.filepath_raw = path
    image.save()


def image_users(image):
    """The image users of every Image Texture node that reads `image` (materials, worlds, groups)."""
    trees = [owner.node_tree for owner in list(bpy.data.materials) + list(bpy.data.worlds) + list(bpy.data.lights)
             if getattr(owner, "node_tree", None) is not None] + list(bpy.data.node_groups)
    return [node.image_user for tree in trees for node in tree.nodes
            if node.bl_idname == 'ShaderNodeTexImage' and node.image == image]


def point(image_name, first_path, first, last, size):
    """Image `image_name` (made if missing) a sequence starting at `first_path`, played from frame
    `first` to `last` by every node that reads it."""
    image = bpy.data.images.get(image_name)
    if image is None:
        image = bpy.data.images.new(image_name, size[0], size[1], alpha=True, float_buffer=True)
    image.use_fake_user = True
    if image.packed_file is not None:
        image.unpack(method='REMOVE')      # a packed image cannot be a sequence
    image.filepath = bpy.path.relpath(first_path)       # the folder moves with the .blend
    image.source = 'SEQUENCE'
    image.reload()
    image[FRAMES] = (first, last)
    play(image)
    return image


def play(image):
    """Every node reading sequence `image` plays it over the frames baked into it: also a node
    added after the bake (Show Bake's)."""
    frames = image.get(FRAMES)
    if frames is None:
        return
    first, last = frames
    # The number shown at frame f: (f - frame_start + 1, within 1..frame_duration) + frame_offset = f.
    for user in image_users(image):
        user.frame_start, user.frame_duration, user.frame_offset = first, last - first + 1, first - 1
        user.use_auto_refresh, user.use_cyclic = True, False


class SequenceBake:
    """The lightmap sequences of one Bake Animation: prepare() and write() on the main thread,
    evaluate() anywhere (a modal bake's worker), then commit() or discard()."""

    def __init__(self, scene):
        self.messages = []
        self.updates = Lightmaps()
        self.frames = {}       # {image name: {frame: path in staging}}
        self.sizes = {}        # {image name: (width, height)}
        self._plan = {}
        self.folder = self.staging = None
        if not bpy.data.filepath:
            self.messages.append("lightmaps: save the .blend first: Bake Animation writes each frame's "
                                 f"lightmaps as OpenEXR files into a folder beside it (<file>{SUFFIX})")
            return
        self.folder = folder_for(bpy.data.filepath)
        os.makedirs(self.folder, exist_ok=True)
        self.staging = tempfile.mkdtemp(prefix=".staging-", dir=self.folder)

    def prepare(self, job, props):
        if self.staging is None:
            return
        self._plan, messages = self.updates.prepare(job, props)
        self.messages += [m for m in messages if m not in self.messages]

    def evaluate(self, job):
        """{object name: rgba} of the lightmaps of job's frame whose light may have changed."""
        return self.updates.evaluate(job, self._plan) if self.staging is not None else {}

    def write(self, frame, pixels):
        """Frame `frame`'s files: `pixels` (evaluate()) saved, the other lightmaps the frame before's."""
        if self.staging is None:
            return
        for object_name in self._plan:
            name = lightmap.image_name(object_name)
            path = frame_path(self.staging, name, frame)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            if object_name in pixels:
                rgba = pixels[object_name]
                save_exr(rgba, path)
                self.sizes[name] = (rgba.shape[1], rgba.shape[0])
            else:
                shutil.copyfile(self.frames[name][max(self.frames[name])], path)
            self.frames.setdefault(name, {})[frame] = path

    def commit(self):
        """The sequences put in place and the images pointed at them. Returns the messages."""
        if self.staging is None:
            return self.messages
        for name, frames in self.frames.items():
            first, last = min(frames), max(frames)
            held = frames[first]
            for f in range(first, last + 1):          # a frame step above 1: the frame before's
                if f in frames:
                    held = frames[f]
                else:
                    shutil.copyfile(held, frame_path(self.staging, name, f))
            final = os.path.join(self.folder, os.path.basename(os.path.dirname(held)))
            shutil.rmtree(final, ignore_errors=True)
            os.replace(os.path.dirname(held), final)
            point(name, frame_path(self.folder, name, first), first, last, self.sizes[name])
        self.discard()
        return self.messages

    def discard(self):
        """Nothing of this bake stays: its staging folder and scratch image go."""
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            self.staging = None
        scratch = bpy.data.images.get(SCRATCH)
        if scratch is not None:
            bpy.data.images.remove(scratch)

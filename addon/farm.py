"""Bake Animation on a Dask farm (scene.radiosity.farm_scheduler: a scheduler's address; docs/farm.md).

The frame range goes in chunks to the farm's workers (farm_client.py, in its own process with the
system Python); each chunk bakes in a background Blender on the saved .blend (farm_chunk.py: a full
solve, then an update a frame) and writes each frame's colours into the cache folder beside the .blend
(farm_cache.py), where the frames done are counted across the farm. When every chunk has returned, the
frames are loaded into the scene as Bake Animation's own results (operators.conclude): playback and
render read them as they read a bake of this machine's.
"""
import json
import os
import subprocess
import sys
import threading
import time

import bpy

from . import farm_cache
from .errors import BakeError

POLL = 0.25          # seconds between looks at the farm when waiting in a script

# {scene name: (frames done, frames)} while a farm bake of that scene runs (the panel shows it)
progress = {}


def wanted(scene):
    return bool(scene.radiosity.farm_scheduler.strip())



def system_python():
    """The interpreter of the Python library Blender runs (Debian's, where python3-distributed is).
    Not sys.executable: Blender takes that from PATH, where a pyenv shim or a virtualenv may come first."""
    return os.path.join(sys.prefix, "bin", f"python{sys.version_info.major}.{sys.version_info.minor}")

class FarmBake:
    """One farm bake of `frames` of `scene`: submitted on construction; poll() until it says done,
    then collect(); cancel() stops the farm's tasks. Raises BakeError (unsaved file, no scheduler, a
    chunk that failed)."""

    def __init__(self, scene, frames, report):
        if not bpy.data.filepath:
            raise BakeError("the farm's workers open the saved .blend: save the file first")
        # Saved whether it looks changed or not: scripts' edits in background mode leave no mark.
        try:
            bpy.ops.wm.save_mainfile()
        except RuntimeError as e:
            raise BakeError(f"the farm's workers open the saved .blend, and saving it failed: {e}") from e
        report({'INFO'}, f"Radiosity: saved {bpy.data.filepath} for the farm's workers")
        self.scene_name = scene.name
        self.frames = list(frames)
        self.cache = farm_cache.folder_for(bpy.data.filepath)
        farm_cache.clear(self.cache)
        job = {"scheduler": scene.radiosity.farm_scheduler.strip(), "blend": bpy.data.filepath,
               "frames": self.frames, "cache": self.cache}
        client = os.path.join(os.path.dirname(os.path.abspath(__file__)), "farm_client.py")
        self.started = time.perf_counter()
        self.proc = subprocess.Popen([system_python(), client, json.dumps(job)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True)
        self.messages = {}
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.done = 0
        progress[self.scene_name] = (0, len(self.frames))

    def _read(self):
        for line in self.proc.stdout:
            self.messages.update(json.loads(line))

    @property
    def chunks(self):
        return self.messages.get("chunks", 1)

    @property
    def seconds(self):
        return time.perf_counter() - self.started

    def poll(self):
        """Whether every frame is baked. Counts the frames done; raises BakeError when the farm failed."""
        self.done = len(farm_cache.frames_done(self.cache, self.frames))
        progress[self.scene_name] = (self.done, len(self.frames))
        if self.proc.poll() is None:
            return False
        self._reader.join()
        if "error" in self.messages or "stats" not in self.messages:
            self.close()
            raise BakeError(f"the farm bake failed: {self.messages.get('error', f'exit status {self.proc.returncode}')}")
        return True

    def wait(self):
        """Poll until done (scripts, background mode)."""
        while not self.poll():
            time.sleep(POLL)

    def collect(self):
        """({frame: {object: rgba}}, bake_stats) of the finished bake."""
        self.close()
        missing = sorted(set(self.frames) - set(farm_cache.frames_done(self.cache, self.frames)))
        if missing:
            raise BakeError(f"the farm's chunks returned but frames {missing} are not in {self.cache}")
        return farm_cache.read_frames(self.cache, self.frames), self.messages["stats"]

    def cancel(self):
        """Stop the farm's tasks (farm_client cancels them when its stdin closes)."""
        self.close()
        self.proc.wait()

    def close(self):
        progress.pop(self.scene_name, None)
        if not self.proc.stdin.closed:
            self.proc.stdin.close()

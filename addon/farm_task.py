"""The Dask task of a farm's chunk, run by a worker: a background Blender bakes the chunk (farm_chunk.py)
and writes its frames into the cache folder; the task returns what the chunk reported, with its wall
time (Blender's start and the file's load included).

bpy cannot run inside a Dask worker, hence the subprocess. The worker needs Blender on its PATH and the
add-on at the path the task names; it needs no copy of this module: farm_client.py sends it by value
(cloudpickle), so only distributed and the standard library are imported here.

Cancelling: Dask cannot stop a running task, so the task polls a distributed.Event that farm_client.py
sets (Esc in the Blender that submitted, or a chunk that failed) and kills its Blender. A worker that dies takes its Blender with it
(PR_SET_PDEATHSIG): the scheduler runs the chunk again on another worker, and no orphan writes on.
"""
import ctypes
import json
import os
import signal
import subprocess
import tempfile
import time

from distributed import Event

POLL = 0.5          # seconds between looks at the cancel event
PR_SET_PDEATHSIG = 1


class ChunkFailed(RuntimeError):
    pass


def blender_env():
    """The worker's environment without pyenv: Blender must run on the system Python 3.11 (a pyenv
    shim first on PATH hides Debian's numpy from it)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYENV")}
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep) if "pyenv" not in p)
    return env


def bake_chunk(blend, script, frames, cache, cancel_event):
    """Bake `frames` of `blend` in a background Blender; {"frames", "seconds", "stats", "wall"}."""
    with tempfile.TemporaryDirectory(prefix="radiosity-chunk-") as tmp:
        result = os.path.join(tmp, "result.json")
        cmd = ["blender", "-b", "--factory-startup", blend, "--python-exit-code", "1", "--python", script,
               "--", json.dumps({"frames": list(frames), "cache": cache, "result": result})]
        prctl = ctypes.CDLL(None).prctl        # looked up before the fork: the child only calls it
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                env=blender_env(),
                                preexec_fn=lambda: prctl(PR_SET_PDEATHSIG, signal.SIGKILL))
        cancel = Event(cancel_event)
        while True:
            try:
                out, _ = proc.communicate(timeout=POLL)
                break
            except subprocess.TimeoutExpired:
                if cancel.is_set():
                    proc.kill()
                    proc.communicate()
                    raise ChunkFailed(f"frames {frames[0]}-{frames[-1]}: cancelled")
        if proc.returncode != 0 or not os.path.exists(result):
            raise ChunkFailed(f"frames {frames[0]}-{frames[-1]}: Blender exited with {proc.returncode}:\n"
                              + "\n".join(out.splitlines()[-20:]))
        with open(result, encoding="utf-8") as f:
            return dict(json.load(f), wall=time.perf_counter() - start)

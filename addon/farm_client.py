"""The Dask client of a farm bake: submits a .blend's frames in chunks to a scheduler and waits for them.

    python3 farm_client.py '{"scheduler": ADDRESS, "blend": FILE, "frames": [...], "cache": FOLDER}'

Run by farm.py with the system Python, outside Blender: a Blender that has held a Dask connection
crashes on quitting (the modules the client brings in), which a pipeline's `blender -b` would report
as a failed bake. Prints one JSON object a line: {"chunks": n} once the chunks are planned, then
{"stats": bake_stats of the whole bake, "chunks": n} when every chunk has returned, or {"error": why}
(exit status 1). Closing its stdin (Esc in Blender, or Blender gone) cancels the farm's tasks.

Chunks (farm_task.bake_chunk) hold consecutive frames: each pays Blender's start and one full solve
before its cheap updates, so a chunk per worker is fastest when a full solve costs many updates; when
it costs about one, small chunks cost nothing more and spread better over workers that differ, join
late or die. The first chunk is a probe of two frames whose measured seconds (Blender's start, the
full solve, the update) size the rest (chunk_size). A worker lost mid-chunk has its chunk run again on
another by Dask's scheduler.
"""
import json
import os
import sys
import threading
import time
import uuid

HERE = os.path.dirname(os.path.abspath(__file__))
PROBE = 2            # frames of the first chunk: a full solve and an update, measured
TOLERANCE = 1.1      # a chunk size whose estimated wall time is within 10% of the best's will do
POLL = 0.25          # seconds between looks at the futures and at stdin


def chunk_size(frames, workers, start, full, update):
    """Frames a chunk for `frames` frames on `workers` workers, given the seconds of Blender's start,
    of a full solve and of an update: the smallest whose estimated wall time (rounds of chunks over
    the workers) is within TOLERANCE of the best chunk size's."""
    def wall(n):
        chunks = -(-frames // n)
        return -(-chunks // workers) * (start + full + (n - 1) * update)
    sizes = range(1, frames + 1)
    best = min(wall(n) for n in sizes)
    return next(n for n in sizes if wall(n) <= TOLERANCE * best)


def say(**message):
    print(json.dumps(message), flush=True)


def bake(job, cancelled):
    """Submit and wait; the bake_stats of the whole bake and the chunks' count, or None if cancelled."""
    try:
        import cloudpickle
        from distributed import Client, Event
    except ImportError as e:
        raise RuntimeError(f"{e}: the farm needs Dask's distributed scheduler (python3-distributed)") from e

    import bake_stats
    import farm_task
    # Workers have no copy of the add-on's modules to import: the task goes by value.
    cloudpickle.register_pickle_by_value(farm_task)
    frames, token = job["frames"], uuid.uuid4().hex[:8]
    script = os.path.join(HERE, "farm_chunk.py")
    cancel_event = f"radiosity-cancel-{token}"
    with Client(job["scheduler"], timeout=10, set_as_default=False) as client:
        def submit(chunk):
            return client.submit(farm_task.bake_chunk, job["blend"], script, chunk, job["cache"], cancel_event,
                                 key=f"radiosity-{token}-{chunk[0]}-{chunk[-1]}", pure=False)

        def finish(futures):
            """Wait for `futures`; False when cancelled first. Cancelled, or a chunk failed, the farm's
            tasks stop (a running chunk kills its Blender: farm_task)."""
            while not all(f.done() for f in futures):
                failed = next((f for f in futures if f.status == 'error'), None)
                if cancelled.is_set() or failed is not None:
                    Event(cancel_event, client=client).set()
                    client.cancel(futures)
                    if failed is not None:
                        failed.result()          # raises the chunk's error
                    return False
                time.sleep(POLL)
            return True
        futures = [submit(frames[:PROBE])]
        if not finish(futures):
            return None
        probe = futures[0].result()
        rest = frames[PROBE:]
        if rest:
            seconds = probe["seconds"]
            start = max(0.0, probe["wall"] - sum(seconds))
            workers = max(1, sum(client.nthreads().values()))
            n = chunk_size(len(rest), workers, start, seconds[0], seconds[-1])
            print(f"Radiosity farm: Blender starts in {start:.1f} s, a full solve takes {seconds[0]:.2f} s, "
                  f"an update {seconds[-1]:.2f} s: {len(rest)} more frames in chunks of {n} on {workers} "
                  f"worker(s)", file=sys.stderr, flush=True)
            futures += [submit(rest[i:i + n]) for i in range(0, len(rest), n)]
        say(chunks=len(futures))
        if not finish(futures):
            return None
        return bake_stats.merge([f.result()["stats"] for f in futures]), len(futures)


def main():
    sys.path.insert(0, HERE)
    job = json.loads(sys.argv[1])
    cancelled = threading.Event()

    def watch_stdin():
        sys.stdin.read()
        cancelled.set()
    threading.Thread(target=watch_stdin, daemon=True).start()
    try:
        done = bake(job, cancelled)
    except Exception as e:   # noqa: BLE001 -- told to the Blender that waits (farm.py)
        say(error=f"{type(e).__name__}: {e}")
        sys.exit(1)
    if done is None:
        say(error="cancelled")
        sys.exit(1)
    say(stats=done[0], chunks=done[1])


if __name__ == "__main__":
    main()

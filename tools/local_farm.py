#!/usr/bin/python3.11
"""A Dask farm on this machine alone: a LocalCluster of single-thread workers, each baking one chunk at a
time. Prints the scheduler's address on its first line (for scene.radiosity.farm_scheduler or
tools/farm_bake.py) and runs until stdin closes or it is interrupted.

    tools/local_farm.py [--workers 2]

It runs outside Blender: Dask's worker processes start by re-running the parent's main script, which
inside Blender is Blender's.
"""
import argparse
import sys

from distributed import LocalCluster


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    with LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        print(cluster.scheduler_address, flush=True)
        try:
            sys.stdin.read()
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()

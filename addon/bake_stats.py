"""What a bake cost and found, as a plain dict (JSON-safe): the panel's Last Bake shows it.

A farm's chunks each send theirs from a worker's Blender (farm_chunk.py); merge() adds them up in frame
order, as summary() does for the frames of one process.
"""


def summary(jobs):
    """The stats of the BakeJobs of one bake, in frame order."""
    last = jobs[-1]
    return {"seconds": sum(j.seconds for j in jobs),
            "residual": float(max(j.stats["residual"] for j in jobs)),
            "patches": int(last.stats.get("patches", 0)),
            "points": int(last.stats.get("points", 0)),
            "shots": int(sum(j.shots for j in jobs)),
            "rays": float(sum(j.rays for j in jobs)),
            "relaxation": float(jobs[0].stats.get("relaxation", 0.0)),
            "effects": last.effects,
            "frames": len(jobs),
            "incremental": sum(1 for j in jobs if j.incremental),
            "converged": all(j.stats.get("converged", True) for j in jobs),
            "warnings": [w for j in jobs for w in j.warnings]}


def merge(parts):
    """The stats of several bakes of consecutive frame ranges (a farm's chunks, in frame order)."""
    first, last = parts[0], parts[-1]
    return {"seconds": sum(p["seconds"] for p in parts),
            "residual": max(p["residual"] for p in parts),
            "patches": last["patches"], "points": last["points"],
            "shots": sum(p["shots"] for p in parts),
            "rays": sum(p["rays"] for p in parts),
            "relaxation": first["relaxation"],
            "effects": last["effects"],
            "frames": sum(p["frames"] for p in parts),
            "incremental": sum(p["incremental"] for p in parts),
            "converged": all(p["converged"] for p in parts),
            "warnings": [w for p in parts for w in p["warnings"]]}

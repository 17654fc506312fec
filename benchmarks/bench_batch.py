#!/usr/bin/env python
"""Batch cloning on Dask (issue 22): faces per minute with 1 and 2 workers, what the
shared source preparation saves, the scheduler's overhead per task, and from these an
estimate for 10,000 faces on 100 workers.

    python benchmarks/bench_batch.py [--faces N] [--seed S] [--bare] [--resolution R]

The targets are reference heads of random proportions (each of face width, jaw, nose,
eye spacing and mouth width drawn from 0.85-1.2 with ``--seed``, printed), written as
VRML faces with their feature points, or with ``--bare`` as OBJ meshes with none (each
target's points are then found on its geometry, as a user's own heads need).  The
source is the built-in reference head.  Each run is ``clone_many`` on a fresh local
cluster (process workers, one thread each) with every output (.wrl, .glb, points,
preview PNG, report); times are wall clock, the cluster's start-up reported apart.

* source preparation: reading the source and :class:`PreparedSource` (its parts, skin,
  motion; its found points with ``--bare``), which each target would otherwise redo;
* overhead per task: 2,000 tasks that do nothing on the 2-worker cluster;
* what is sent: the prepared source's pickled size, once per worker.
"""
from __future__ import annotations

import argparse
import os
import pickle
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def make_targets(folder: Path, n: int, seed: int, bare: bool, resolution: float) -> list:
    from mpeg4fba.fba.fat import FAT
    from mpeg4fba.formats.wrl_face import save_face
    from mpeg4fba.models import reference_head

    rng = np.random.default_rng(seed)
    paths = []
    for i in range(n):
        shape = dict(zip(("face_width", "jaw", "nose", "eye_spacing", "mouth_width"),
                         rng.uniform(0.85, 1.2, 5).round(3)))
        face = reference_head(resolution=resolution, seed=int(rng.integers(1 << 30)), **shape)
        face.fat = FAT()
        if bare:
            p = folder / f"head{i:03d}.obj"
            with open(p, "w") as f:
                off = 1
                for name, mesh in face.meshes.items():
                    f.write(f"o {name}\n")
                    for v in face.world_vertices(name):
                        f.write(f"v {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}\n")
                    for t in mesh.triangles + off:
                        f.write(f"f {t[0]} {t[1]} {t[2]}\n")
                    off += len(mesh.vertices)
        else:
            p = folder / f"head{i:03d}.wrl"
            save_face(face, p)
        paths.append(str(p))
    return paths


def run(targets: list, workers: int, out: Path) -> dict:
    import distributed

    from mpeg4fba.batch import clone_many

    t = time.perf_counter()
    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None,
                                       silence_logs=50)
    client = distributed.Client(cluster)
    start = time.perf_counter() - t
    try:
        t = time.perf_counter()
        results = clone_many(None, targets, out, client=client)
        took = time.perf_counter() - t
    finally:
        client.close()
        cluster.close()
    ok = results.counts().get("ok", 0)
    secs = [r["seconds"] for r in results if r.get("status") == "ok"]
    return {"start": start, "took": took, "ok": ok, "failed": results.failed_count,
            "prepare": results.info.get("prepare_seconds", 0.0), "task_seconds": secs,
            "per_minute": 60 * ok / took, "bytes": sum(
                f.stat().st_size for f in out.rglob("*") if f.is_file())}


def overhead(n: int = 2000) -> float:
    import distributed

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None,
                                  silence_logs=50) as cluster, distributed.Client(cluster) as c:
        c.gather(c.map(_nothing, range(50), pure=False))         # warm
        t = time.perf_counter()
        futures = [c.submit(_nothing, i, pure=False) for i in range(n)]
        for _ in distributed.as_completed(futures):
            pass
        return (time.perf_counter() - t) / n


def _nothing(i: int) -> int:
    return i


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--faces", type=int, default=8)
    ap.add_argument("--seed", type=int, default=int(time.time()) % 100000)
    ap.add_argument("--bare", action="store_true", help="OBJ targets without feature points")
    ap.add_argument("--resolution", type=float, default=1.0)
    args = ap.parse_args()
    from mpeg4fba.cloning import PreparedSource
    from mpeg4fba.models import reference_head

    print(f"# {args.faces} {'bare OBJ' if args.bare else 'VRML (with points)'} targets, "
          f"resolution {args.resolution}, seed {args.seed}; {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        targets = make_targets(d, args.faces, args.seed, args.bare, args.resolution)
        t = time.perf_counter()
        source = reference_head()
        build = time.perf_counter() - t
        t = time.perf_counter()
        prepared = PreparedSource(source).warm(detect=args.bare)
        prep = time.perf_counter() - t
        size = len(pickle.dumps(prepared, protocol=5))
        runs = {w: run(targets, w, d / f"out{w}") for w in (1, 2)}
        per_task = overhead()
    one, two = runs[1], runs[2]
    task = float(np.median(one["task_seconds"]))
    print("\n| figure | value |\n|---|---|")
    for w, r in runs.items():
        print(f"| {w} worker{'s' * (w > 1)}: faces per minute | {r['per_minute']:.1f} "
              f"({r['ok']} ok, {r['failed']} failed in {r['took']:.1f} s; cluster start "
              f"{r['start']:.1f} s apart) |")
    print(f"| speed-up 2 workers / 1 | {two['per_minute'] / one['per_minute']:.2f}x |")
    ts = np.array(one["task_seconds"])
    print(f"| one target's task, 1 worker (median / p95 / worst) | {np.median(ts):.2f} / "
          f"{np.percentile(ts, 95):.2f} / {ts.max():.2f} s |")
    print(f"| source preparation, shared (build {build:.2f} s + prepare {prep:.2f} s) | "
          f"{build + prep:.2f} s a target saves ({100 * (build + prep) / (task + build + prep):.0f} % "
          f"of a target's time without it) |")
    print(f"| prepared source sent to each worker once | {size / 2 ** 20:.1f} MiB |")
    print(f"| scheduler overhead per task (2,000 empty tasks, 2 workers) | {1000 * per_task:.2f} ms |")
    out_per_face = one["bytes"] / max(one["ok"], 1)
    print(f"| output per face | {out_per_face / 2 ** 20:.2f} MiB |")
    # 10,000 faces on 100 workers: the work divides; the scheduler's per-task cost and
    # the source's broadcast do not; the outputs go to one file system
    n, w = 10000, 100
    work = n * task / w
    sched = n * per_task
    send = w * size / 100e6                    # 100 MB/s out of the client, one worker after another
    write = n * out_per_face / 200e6           # a 200 MB/s shared file system
    total = max(work, sched, write) + send + prep + build
    print(f"| estimate, {n:,} faces on {w} workers | {total / 60:.1f} min (work {work / 60:.1f} min "
          f"= {n:,} x {task:.2f} s / {w}; scheduler {sched / 60:.2f} min; broadcast "
          f"{send:.1f} s; writing {n * out_per_face / 2 ** 30:.1f} GiB at 200 MB/s "
          f"{write / 60:.1f} min) |")


if __name__ == "__main__":
    main()

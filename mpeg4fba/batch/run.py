"""Batches on Dask's distributed scheduler: :func:`clone_many`, :func:`validate_many`
and :func:`play_many`, each returning a :class:`~mpeg4fba.batch.results.Results`.

The cluster: an existing :class:`distributed.Client` (``client=``), an existing
scheduler's address (``scheduler="tcp://host:8786"``), or by default a local cluster of
process workers with one thread each, one per core (``workers=N`` to choose).  What
every task shares (the prepared source, the streams) is sent to each worker once.  A
worker that dies takes none of the results with it: the scheduler runs its tasks again
on another worker, and each output is written atomically.
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import logging
import os
import time
from typing import Callable, Iterable, Iterator, Optional, Sequence

from .. import __version__
from .results import Results
from .targets import Target, content_key, expand_targets, file_digest
from .tasks import clone_task, one_line, play_task, report_done, validate_task

__all__ = ["clone_many", "validate_many", "play_many", "open_client", "BatchError",
           "default_workers", "DEFAULT_PREVIEW"]

#: The preview PNG's size (width, height) in a clone batch.
DEFAULT_PREVIEW = (320, 384)

Progress = Callable[[dict, dict], None]


class BatchError(ValueError):
    """A batch that can't start: no Dask, no targets, an unreadable source or stream."""


def _distributed():
    try:
        import distributed
    except ImportError:
        raise BatchError('batch work runs on Dask: pip install "mpeg4fba[batch]"') from None
    return distributed


def default_workers() -> int:
    """One worker per core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:          # not on Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def open_client(workers: Optional[int] = None, scheduler: Optional[str] = None,
                client=None, dashboard: bool = True) -> Iterator:
    """A :class:`distributed.Client`: ``client`` itself, one connected to ``scheduler``,
    or one of a new local cluster of ``workers`` process workers (default
    :func:`default_workers`), one thread each, closed at the end."""
    if client is not None:
        yield client
        return
    distributed = _distributed()
    if scheduler is not None:
        if workers is not None:
            raise BatchError("--workers sizes a local cluster; an existing scheduler has its own")
        try:
            c = distributed.Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise BatchError(f"no Dask scheduler answers at {scheduler} ({one_line(e)})") from None
        with c:
            yield c
        return
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise BatchError(f"workers must be at least 1, not {workers}")
    # the dashboard needs bokeh (in the batch extra); without it, none
    address = ":8787" if dashboard and importlib.util.find_spec("bokeh") else None
    cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=address,
                                       silence_logs=logging.ERROR)
    with cluster, distributed.Client(cluster) as c:
        yield c


def dashboard_link(client) -> Optional[str]:
    """The Dask dashboard's address when one is running."""
    try:
        info = client.scheduler_info()
        if "dashboard" not in (info.get("services") or {}):
            return None
        return client.dashboard_link
    except Exception:           # noqa: BLE001 - only a hint for the user
        return None


# how often a target is sent again when a shared input (the prepared source, the
# streams) is lost with the worker that held it
RESENDS = 3


def _gather(submit: Callable, names: list, progress: Optional[Progress], counts: dict,
            failed_record: Callable[[str, str], dict]) -> dict:
    """name -> record as the tasks end; a task that raised (its worker died too often,
    say) becomes a failed record.

    ``submit(names, attempt)`` sends the tasks of ``names`` (their futures, in order).
    Their shared input is scattered data, which Dask cannot recompute: its replicas are
    thinned by the active memory manager, so a worker killed at the wrong moment can take
    the last one with it, and every task still waiting on it is cancelled.  Those tasks
    are sent again with the input scattered afresh (up to :data:`RESENDS` times)."""
    distributed = _distributed()
    by_future = dict(zip(submit(names, 0), names))
    attempts = dict.fromkeys(names, 0)
    queue = distributed.as_completed(list(by_future))
    out: dict = {}
    for fut in queue:
        name = by_future.pop(fut, None)
        if name is None:                # cancelled with another one, already sent again
            continue
        if fut.cancelled() and attempts[name] < RESENDS:
            lost = [name] + [n for f, n in by_future.items() if f.cancelled()]
            for f in [f for f, n in by_future.items() if n in lost]:
                del by_future[f]
            attempt = max(attempts[n] for n in lost) + 1
            attempts.update(dict.fromkeys(lost, attempt))
            again = submit(lost, attempt)
            by_future.update(zip(again, lost))
            queue.update(again)
            continue
        try:
            record = fut.result()
        except Exception as e:          # noqa: BLE001 - recorded, the batch goes on
            record = failed_record(name, one_line(e) if not fut.cancelled() else
                                   f"its shared input was lost with a worker "
                                   f"{attempts[name] + 1} times")
        out[name] = record
        _tally(record, counts, progress)
        fut.release()
    return out


def _tally(record: dict, counts: dict, progress: Optional[Progress]) -> None:
    """Count a finished record by its status and tell ``progress``."""
    status = record.get("status", "failed")
    counts[status] = counts.get(status, 0) + 1
    if progress is not None:
        progress(record, dict(counts))


def _on_cluster(workers: Optional[int], scheduler: Optional[str], client, info: dict,
                on_client: Optional[Callable], submit: Callable, names: list,
                progress: Optional[Progress], counts: dict,
                failed_record: Callable[[str, str], dict]) -> dict:
    """Open the cluster, note its size and dashboard in ``info``, send the tasks by
    ``submit(client, names, attempt)`` (their futures, in the order of ``names``) and
    gather their records."""
    with open_client(workers, scheduler, client) as c:
        info["workers"] = len(c.scheduler_info().get("workers", {}))
        info["dashboard"] = dashboard_link(c)
        if on_client is not None:
            on_client(c)
        return _gather(lambda ns, attempt: submit(c, ns, attempt), names, progress, counts,
                       failed_record)


def _source_key(source, source_points: Optional[str]) -> list:
    """What the source contributes to each target's content key."""
    if source is None:
        return ["reference_head", __version__]
    if isinstance(source, (str, os.PathLike)):
        return [file_digest(os.fspath(source)), file_digest(source_points)]
    return ["face", _face_digest(source)]


def _source_face(source, source_points: Optional[str], lenient: bool):
    """The source as a FaceModel: read from a path, the reference head for None."""
    if source is None:
        from ..models import reference_head
        return reference_head()
    if isinstance(source, (str, os.PathLike)):
        from ..formats.face_files import read_face
        return read_face(os.fspath(source), source_points, lenient=lenient)
    return source


def _needs_points(targets: list) -> bool:
    """Whether some target is a bare mesh (no FDP inside, no point file given)."""
    from ..formats.face_files import MESH_SUFFIXES
    return any(t.points is None and t.path.lower().endswith(MESH_SUFFIXES) for t in targets)


def _not_done(items: list, keys: dict, outdir: str, resume: bool, records: dict,
              counts: dict, progress: Optional[Progress]) -> list:
    """The targets to work on; with ``resume``, those done before with the same key are
    recorded as skipped instead."""
    todo = []
    for tg in items:
        done = report_done(os.path.join(outdir, tg.name), keys[tg.name]) if resume else None
        if done is None:
            todo.append(tg)
            continue
        records[tg.name] = dict(done, status="skipped")
        _tally(records[tg.name], counts, progress)
    return todo


def _face_digest(face) -> str:
    """SHA-256 of a FaceModel as VRML text (a face given as an object, for --resume)."""
    from ..formats.wrl_face import scene_from_face
    from ..vrml import dumps
    return hashlib.sha256(dumps(scene_from_face(face)).encode("utf-8")).hexdigest()


def _targets(targets: Iterable, points_dir: Optional[str]) -> list:
    """Targets with absolute paths (a worker's working folder may not be ours)."""
    items = list(targets)
    if not (items and all(isinstance(t, Target) for t in items)):
        items = expand_targets([os.fspath(t) for t in items], points_dir)
    if not items:
        raise BatchError("no targets given")
    return [Target(os.path.abspath(t.path), t.points and os.path.abspath(t.points), t.name)
            for t in items]


def _prepare_outdir(outdir) -> str:
    outdir = os.fspath(outdir)
    if os.path.exists(outdir) and not os.path.isdir(outdir):
        raise BatchError(f"{outdir}: the output must be a folder, and this is a file")
    os.makedirs(outdir, exist_ok=True)
    return os.path.abspath(outdir)


def clone_many(source, targets: Iterable, outdir, *, source_points: Optional[str] = None,
               points_dir: Optional[str] = None, method: str = "fmc", snap: bool = False,
               check: bool = True, scale: bool = True, lenient: bool = False,
               formats: Sequence[str] = ("wrl", "glb"),
               preview: Optional[tuple] = DEFAULT_PREVIEW, resume: bool = False,
               workers: Optional[int] = None, scheduler: Optional[str] = None, client=None,
               progress: Optional[Progress] = None, on_client: Optional[Callable] = None,
               detect: Optional[bool] = None, **options) -> Results:
    """Clone ``source`` (a face file, a FaceModel, or None for the reference head) onto
    every target (files, glob patterns, manifest CSVs or :class:`Target` s) into
    ``outdir/<name>/``, and write ``outdir/results.csv`` and ``results.json``.

    Each target is what ``mpeg4fba clone SOURCE TARGET`` makes of it, with the same
    options (``options`` go to the cloner: ``support``, ``positions``,
    ``triangulation``...).  The source is prepared once
    (:class:`~mpeg4fba.cloning.PreparedSource`) and sent to each worker once.  With
    ``resume``, a target whose folder holds a complete result made from the same
    inputs (by content) and options is not done again (status ``skipped``).
    ``progress(record, counts)`` is called as each target ends; ``on_client(client)``
    once the cluster is up.

    ``detect``: find the source's feature points once, before the source is sent (they
    put a target's found points in the source's convention).  By default that is done
    when a target is a mesh file (.obj, .glb, .gltf) without a point file, which always
    needs its points found; a VRML target without points has them found too, and the
    source's then once per worker.
    """
    from ..cloning import PreparedSource

    t0 = time.perf_counter()
    outdir = _prepare_outdir(outdir)
    items = _targets(targets, points_dir)
    settings = {"method": method, "snap": bool(snap), "check": bool(check), "scale": bool(scale),
                "lenient": bool(lenient), "formats": tuple(formats),
                "preview": None if not preview else tuple(int(v) for v in preview),
                "options": options}
    source_key = _source_key(source, source_points)
    keys = {t.name: content_key([__version__, "clone", source_key, file_digest(t.path),
                                 file_digest(t.points), settings]) for t in items}
    records: dict = {}
    counts: dict = {}
    todo = _not_done(items, keys, outdir, resume, records, counts, progress)
    info = {"source": "reference_head" if source is None else str(getattr(source, "name", source)),
            "method": method, "settings": settings, "outdir": outdir}
    if todo:
        face = _source_face(source, source_points, lenient)
        if not len(face.fat):
            raise BatchError(f"the source face {face.name} has no FAT: nothing to clone")
        # the source's side, once: sent to each worker once, not redone per target
        prep = {k: options[k] for k in ("positions", "mouth_angle") if k in options}
        t = time.perf_counter()
        prepared = PreparedSource(face, **prep).warm(detect=_needs_points(todo) if detect is None
                                                     else bool(detect))
        info["prepare_seconds"] = round(time.perf_counter() - t, 3)
        by_name = {tg.name: tg for tg in todo}

        def submit(c, names: list, attempt: int) -> list:
            shared = c.scatter(prepared, broadcast=True, hash=False)
            return [c.submit(clone_task, shared, by_name[n], settings, outdir, keys[n],
                             key=f"clone-{n}-{keys[n][:12]}-{attempt}", pure=False)
                    for n in names]

        records.update(_on_cluster(workers, scheduler, client, info, on_client, submit,
                                   list(by_name), progress, counts,
                                   lambda n, e: {"name": n, "target": by_name[n].path,
                                                 "points": by_name[n].points,
                                                 "status": "failed", "error": e,
                                                 "folder": os.path.join(outdir, n)}))
    info["seconds"] = round(time.perf_counter() - t0, 3)
    results = Results("clone", [records[t.name] for t in items], info)
    results.write(outdir)
    return results


def validate_many(files: Iterable, *, tolerance: float = 0.05, strict: bool = False,
                  outdir=None, workers: Optional[int] = None, scheduler: Optional[str] = None,
                  client=None, progress: Optional[Progress] = None,
                  on_client: Optional[Callable] = None) -> Results:
    """Validate every face and FAP stream of ``files`` (names or glob patterns); with
    ``outdir``, write the results table there.  ``progress`` and ``on_client`` as for
    :func:`clone_many`."""
    t0 = time.perf_counter()
    paths = [t.path for t in expand_targets([os.fspath(f) for f in files])]
    if not paths:
        raise BatchError("no files given")
    info: dict = {"tolerance": tolerance, "strict": strict}
    counts: dict = {}
    records = _on_cluster(workers, scheduler, client, info, on_client,
                          lambda c, names, attempt: [
                              c.submit(validate_task, os.path.abspath(p), tolerance, strict, p,
                                       pure=False) for p in names],
                          paths, progress, counts,
                          lambda n, e: {"name": n, "status": "failed", "error": e})
    info["seconds"] = round(time.perf_counter() - t0, 3)
    results = Results("validate", [records[p] for p in paths], info)
    if outdir is not None:
        results.write(_prepare_outdir(outdir))
    return results


def play_many(faces: Iterable, streams: Sequence, outdir, *, glb: bool = True,
              png: Optional[dict] = None, lenient: bool = False, resume: bool = False,
              workers: Optional[int] = None, scheduler: Optional[str] = None, client=None,
              progress: Optional[Progress] = None,
              on_client: Optional[Callable] = None) -> Results:
    """Play every stream (``.fap`` paths or FapStreams) on every face into
    ``outdir/<face>/``: ``<stream>.glb`` and, with ``png`` (``{"size": (w, h), "view":
    "front", "frames": (first, last) or None}``), PNG frames in ``<stream>/``.  The
    streams are read once and sent to each worker once.  ``resume``, ``progress`` and
    ``on_client`` as for :func:`clone_many`."""
    from ..fba.stream import FapStream
    from ..formats.fap import read_fap

    t0 = time.perf_counter()
    if not glb and not png:
        raise BatchError("nothing to write: ask for glTF (.glb) or PNG frames")
    outdir = _prepare_outdir(outdir)
    items = _targets(faces, None)
    named, digests, taken = [], [], set()
    for s in streams:
        if isinstance(s, FapStream):
            from ..formats.fap import dumps_fap
            name, stream = s.name or "stream", s
            digest = hashlib.sha256(dumps_fap(s).encode("utf-8")).hexdigest()
        else:
            path = os.fspath(s)
            stream, digest = read_fap(path), file_digest(path)
            name = expand_targets([path])[0].name
        base, n = name, 2
        while name.lower() in taken:
            name, n = f"{base}-{n}", n + 1
        taken.add(name.lower())
        named.append((name, stream))
        digests.append(digest)
    if not named:
        raise BatchError("no streams given")
    settings = {"glb": bool(glb), "png": png, "lenient": bool(lenient)}
    keys = {t.name: content_key([__version__, "play", file_digest(t.path), digests, settings])
            for t in items}
    records: dict = {}
    counts: dict = {}
    todo = _not_done(items, keys, outdir, resume, records, counts, progress)
    info = {"streams": [n for n, _ in named], "settings": settings, "outdir": outdir}
    if todo:
        by_name = {tg.name: tg for tg in todo}

        def submit(c, names: list, attempt: int) -> list:
            shared = c.scatter(named, broadcast=True, hash=False)
            return [c.submit(play_task, by_name[n].path, n, shared, settings, outdir, keys[n],
                             pure=False) for n in names]

        records.update(_on_cluster(workers, scheduler, client, info, on_client, submit,
                                   [tg.name for tg in todo], progress, counts,
                                   lambda n, e: {"name": n, "status": "failed", "error": e}))
    info["seconds"] = round(time.perf_counter() - t0, 3)
    results = Results("play", [records[t.name] for t in items], info)
    results.write(outdir)
    return results


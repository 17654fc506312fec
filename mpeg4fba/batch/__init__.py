"""Many faces at once on Dask's distributed scheduler: clone one source onto thousands
of targets, validate a library of faces and streams, play streams on many faces.

Runs on a local cluster by default (process workers, one thread each, one per core) or
on an existing one (``scheduler="tcp://host:8786"``; Dask's own tools start clusters
over SSH, Kubernetes and HPC queues).  Needs the ``batch`` extra:
``pip install "mpeg4fba[batch]"``.

Modules: :mod:`~mpeg4fba.batch.targets` (files, globs, manifests; content keys),
:mod:`~mpeg4fba.batch.tasks` (one task's work, as a worker runs it),
:mod:`~mpeg4fba.batch.run` (the cluster and the three batches),
:mod:`~mpeg4fba.batch.results` (the results table).

>>> from mpeg4fba.batch import clone_many, validate_many, play_many, Results
>>> callable(clone_many)
True
"""
from __future__ import annotations

from .results import COLUMNS, STATUSES, Results
from .run import (DEFAULT_PREVIEW, BatchError, clone_many, default_workers, open_client,
                  play_many, validate_many)
from .targets import ManifestError, Target, expand_targets, read_manifest

__all__ = ["clone_many", "validate_many", "play_many", "Results", "Target", "BatchError",
           "ManifestError", "expand_targets", "read_manifest", "open_client",
           "default_workers", "COLUMNS", "STATUSES", "DEFAULT_PREVIEW"]

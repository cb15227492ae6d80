"""Parameter sweeps from Python: the jobs of a manifest on any executor.

A manifest is the TOML file ``crumble sweep`` reads (``docs/sweeps.md``), its
text, or the same as a dict. Each job runs in Rust exactly as ``crumble sweep
MANIFEST --index I`` runs it and writes the same ``OUT/ID/result.npz`` and
``OUT/ID/job.json``; a job whose files exist is skipped. The jobs go to a
``concurrent.futures`` executor: a process pool by default, or a Dask
``distributed`` client's (``client.get_executor()``) to spread them over a
cluster with the same code. Each job runs on one thread.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
import uuid
from pathlib import Path
from typing import Any, List, Mapping, NamedTuple, Optional, Tuple, Union

from . import _crumble

__all__ = ["SweepJob", "sweep", "sweep_jobs"]

# What a worker needs to run a job: the manifest's text, its name in
# messages, the folder its paths start from, and the results' folder when
# it names none. Plain strings, so that any executor can send them.
_Source = Tuple[str, str, str, str]

Manifest = Union[str, "os.PathLike[str]", Mapping[str, Any]]


class SweepJob(NamedTuple):
    """One job of a sweep, as :func:`sweep` returns it."""

    index: int
    """Its number in the manifest, from 0."""
    id: str
    """16 hex digits hashed from what decides its result."""
    path: Path
    """Its folder: ``result.npz`` and ``job.json``."""
    ran: bool
    """False when its files were there already and it was skipped."""


def _source(manifest: Manifest) -> _Source:
    if isinstance(manifest, Mapping):
        return (_crumble._manifest_text(dict(manifest)), "<dict>", os.getcwd(), "sweep.results")
    # As load_scene reads a scene: a path-like is a file; a str holding a
    # line break is text; else an existing file, else text if it holds `=`.
    text_given = isinstance(manifest, str) and (
        "\n" in manifest or ("=" in manifest and not os.path.isfile(manifest))
    )
    if not text_given:
        path = Path(os.fsdecode(manifest)).resolve()
        return (path.read_text(encoding="utf-8"), str(path), str(path.parent), f"{path.stem}.results")
    return (str(manifest), "<string>", os.getcwd(), "sweep.results")


def sweep_jobs(manifest: Manifest) -> List[Tuple[int, str, List[Tuple[str, str]], Optional[int]]]:
    """The jobs of ``manifest`` without running them: ``(index, id, settings,
    seed)`` each, ``settings`` the ``(key, value)`` pairs applied in order
    (as ``crumble sweep MANIFEST --list`` prints them)."""
    return _crumble._sweep_jobs(*_source(manifest))[1]


def _run(source: _Source, index: int, call: str) -> SweepJob:
    # `call` is unused here: it makes each sweep's tasks differ from an
    # earlier sweep's, so that an executor that caches results by their
    # arguments (Dask's, whose tasks are pure by default) runs them again.
    del call
    ran, folder = _crumble._sweep_run(*source, index)
    path = Path(folder)
    return SweepJob(index, path.name, path, ran)


def sweep(manifest: Manifest, executor: Optional[concurrent.futures.Executor] = None) -> List[SweepJob]:
    """Runs every job of ``manifest`` on ``executor`` and returns them in
    index order.

    ``manifest`` is a manifest file's path, its TOML text (a ``str`` holding a
    line break, or ``=`` and not naming a file), or a dict of the same keys (``{"scene": "brick_wall",
    "seconds": 1, "set": {...}, "grid": [{...}]}``). A file's relative paths
    and results start from its folder; text's and a dict's from the current
    folder (``sweep.results`` unless ``out`` is given).

    ``executor`` is any ``concurrent.futures.Executor``; by default a
    ``ProcessPoolExecutor`` of one process a core (started with ``spawn``),
    shut down at the end: a script that sweeps so calls ``sweep`` under ``if
    __name__ == "__main__":``, as any process pool needs. With Dask:
    ``sweep(m, Client(cluster).get_executor())``.
    The workers must see the same files (the scene, the results' folder).

    Errors: a bad manifest raises ``SceneError``; a job that fails raises
    ``StepError`` (from the executor, as it reports a job's exception).
    """
    source = _source(manifest)
    _, jobs = _crumble._sweep_jobs(*source)
    indices = [j[0] for j in jobs]
    args = ([source] * len(indices), indices, [uuid.uuid4().hex] * len(indices))
    if executor is None:
        workers = max(1, min(len(indices), os.cpu_count() or 1))
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            return list(pool.map(_run, *args))
    return list(executor.map(_run, *args))

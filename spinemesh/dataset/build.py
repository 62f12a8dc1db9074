"""Building a data set: projects run in worker processes, one writer appends shards and rows.

Workers (:func:`~spinemesh.dataset.extract.extract_project`) decode, cut, hash and encode;
the parent process alone writes, in project order, so the result does not depend on which
worker finished first: when two projects hold the same image, the one that sorts first
keeps it. At most ``2 * jobs`` projects are in flight, so memory is bounded by the largest
projects, not by the corpus.

Resuming: a project listed in ``projects.jsonl`` is done and is not read again (unless
``retry_failed`` and it had errors). Images already in the index are known by their hash,
so even a project redone after a kill adds nothing twice.
"""

from __future__ import annotations

import fcntl
import itertools
import json
import re
import time
from collections import Counter, deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..cluster import WorkerLost, open_workers
from ..errors import SpineMeshError
from ..files.atomic import atomic_write_json
from ..files.names import name_as_text
from ..project import no_skeleton_said
from ..written_folder import (
    check_written_folder, mark_written_folder, refuse_linked_folders, remove_listed_files, temporary_files,
)
from .extract import ProjectResult, extract_project, find_projects, game_of
from .format import (FORMAT, FORMAT_VERSION, INDEX, MASK_ALPHA_THRESHOLD, META, PROJECTS, SHARDS,
                     VAL_FRACTION, append_jsonl, read_jsonl, repair_tail, write_shard)

#: Samples per shard: a few tens of MB, so shards copy and stream well.
SHARD_SAMPLES = 1000


class HashSet:
    """Set of 64-bit hash prefixes in a sorted numpy array: 8 bytes per sample.

    A Python ``set`` of strings costs about 100 bytes per entry; a million samples would
    be 100 MB. New hashes wait in a small set and are merged in batches.
    """

    def __init__(self) -> None:
        self._sorted = np.zeros(0, np.uint64)
        self._pending: set[int] = set()

    @staticmethod
    def key(hex_id: str) -> int:
        return int(hex_id[:16], 16)

    def __contains__(self, hex_id: str) -> bool:
        k = self.key(hex_id)
        if k in self._pending:
            return True
        i = np.searchsorted(self._sorted, np.uint64(k))
        return bool(i < len(self._sorted) and self._sorted[i] == k)

    def add(self, hex_id: str) -> None:
        self._pending.add(self.key(hex_id))
        if len(self._pending) >= 65536:
            self._merge()

    def _merge(self) -> None:
        new = np.fromiter(self._pending, np.uint64, len(self._pending))
        self._sorted = np.union1d(self._sorted, new)
        self._pending.clear()

    def __len__(self) -> int:
        return len(self._sorted) + len(self._pending)


@dataclass
class Summary:
    """What a run did. Counts are for this run; ``total_*`` include earlier runs."""

    projects: int = 0
    projects_done_before: int = 0
    projects_with_errors: int = 0
    samples: int = 0
    by_type: Counter = field(default_factory=Counter)
    by_project: Counter = field(default_factory=Counter)
    by_split: Counter = field(default_factory=Counter)
    skipped: Counter = field(default_factory=Counter)
    errors: list[str] = field(default_factory=list)
    total_samples: int = 0
    seconds: float = 0.0
    #: projects not read because their worker process died twice (exit status 3)
    lost: int = 0


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_")[:80] or "project"


def _project_names(corpora: list[Path]) -> list[tuple[Path, str]]:
    """``(folder, name)`` for every project; the name starts with the corpus folder's name."""
    out = []
    for corpus in corpora:
        corpus = Path(corpus)
        for folder in find_projects(corpus):
            rel = folder.relative_to(corpus).as_posix()
            base = corpus.resolve().name
            out.append((folder, name_as_text(base if rel == "." else f"{base}/{rel}")))  # written as UTF-8
    names = [n for _, n in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise SpineMeshError(f"two corpus folders give the same project names: {sorted(dup)[:3]}")
    return out


def _check_output(out: Path) -> None:
    """Refuse, before anything is written there, a data set folder that is not one: a
    ``meta.json`` of another kind, or files but none spinemesh wrote (:func:`check_written_folder`;
    its ``index.jsonl`` would be appended to, a torn last line of it cut, its ``.lock`` emptied)."""
    path = out / META
    if not path.is_file():
        check_written_folder(out, "data set folder", "data set")
        return
    try:
        old = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError) as e:  # cut short by a full disk, edited by hand: not resumed
        raise SpineMeshError(f"unreadable data set metadata ({e}); give a new --out folder, or remove "
                             "this folder to start over", path) from None
    if not isinstance(old, dict) or old.get("format") != FORMAT or old.get("version") != FORMAT_VERSION:
        raise SpineMeshError("folder holds something else than a spinemesh data set of this version", path)
    refuse_linked_folders(out, "data set folder")  # shards/ a link: they would be written outside


def _open_output(out: Path) -> None:
    _check_output(out)  # again, under the lock
    remove_listed_files(out, temporary_files(out))  # a killed run's: the lock held, no other run writes here
    (out / SHARDS).mkdir(exist_ok=True)
    meta = {"format": FORMAT, "version": FORMAT_VERSION, "mask_alpha_threshold": MASK_ALPHA_THRESHOLD,
            "val_fraction": VAL_FRACTION,
            "split": "by game: val when blake2b-64(game) / 2^64 < val_fraction"}
    path = out / META
    if not path.is_file():
        atomic_write_json(path, meta)
    for name in (INDEX, PROJECTS):
        repair_tail(out / name)
    for tmp in (out / SHARDS).glob(".*.tmp"):
        tmp.unlink()  # a shard a killed run did not finish; no row points into it


def _free_shard_path(out: Path, project: str) -> Path:
    """A new shard file name: never reuse one, since old rows may point into it."""
    base = _slug(project)
    n = 0
    while (out / SHARDS / f"{base}.{n:04d}.tar").exists():
        n += 1
    return out / SHARDS / f"{base}.{n:04d}.tar"


def _write(out: Path, result: ProjectResult, known: HashSet, summary: Summary) -> None:
    """Append one project's new samples (shards, then rows), then its project line."""
    fresh = []
    for s in result.samples:
        if s.row["id"] in known:
            summary.skipped["same image in an earlier project"] += 1
            continue
        known.add(s.row["id"])
        fresh.append(s)
    for start in range(0, len(fresh), SHARD_SAMPLES):
        chunk = fresh[start:start + SHARD_SAMPLES]
        path = _free_shard_path(out, result.project)
        members = []
        for s in chunk:
            members.append((f"{s.row['id']}.png", s.image))
            members.append((f"{s.row['id']}.mask.png", s.mask))
            if s.mesh is not None:
                members.append((f"{s.row['id']}.mesh.npz", s.mesh))
        offsets = write_shard(path, members)
        rows = []
        for s in chunk:
            i = s.row["id"]
            rows.append({**s.row, "shard": f"{SHARDS}/{path.name}", "image": list(offsets[f"{i}.png"]),
                         "mask": list(offsets[f"{i}.mask.png"]),
                         "mesh": list(offsets[f"{i}.mesh.npz"]) if s.mesh is not None else None})
        append_jsonl(out / INDEX, rows)
        for r in rows:
            summary.by_type[r["type"]] += 1
            summary.by_split[r["split"]] += 1
        summary.by_project[result.project] += len(rows)
        summary.samples += len(rows)
    summary.skipped.update(result.skipped)
    summary.errors.extend(result.errors)
    summary.projects += 1
    summary.projects_with_errors += bool(result.errors)
    append_jsonl(out / PROJECTS, [{"project": result.project, "game": result.game,
                                   "skeletons": result.skeletons, "samples_added": len(fresh),
                                   "samples_found": len(result.samples), "skipped": result.skipped,
                                   "errors": result.errors}])


def _extract_task(task: tuple[str, str]) -> ProjectResult:
    return extract_project(task[0], task[1])


def build_dataset(corpora: list[str | Path], out: str | Path, jobs: int = 1, retry_failed: bool = False,
                  on_project: Callable[[str, int, int], None] | None = None, dask: str | None = None) -> Summary:
    """Extract every unique attachment image of the projects under ``corpora`` into ``out``.

    Parameters
    ----------
    corpora : list of path
        Folders holding Spine projects (any depth; see :func:`find_projects`).
    out : path
        The data set folder; created, or resumed when it exists. A folder that holds files but no
        data set (nor anything else spinemesh wrote) is refused with :class:`~spinemesh.errors.OutputError`.
    jobs : int
        Worker processes; 1 runs in this process.
    dask : str, optional
        Run the projects on a Dask cluster instead (see :func:`spinemesh.cluster.open_workers`:
        ``"local"``, a scheduler address or a scheduler file); the data set is the same.
    retry_failed : bool
        Read again the projects that had errors last time (e.g. after a reader got better).
    on_project : callable, optional
        Called as ``on_project(name, done, total)`` after each project, for progress bars.

    Returns
    -------
    Summary
    """
    t0 = time.perf_counter()
    out = Path(out)
    projects = _project_names([Path(c) for c in corpora])
    if not projects:  # nothing to do is refused, as everywhere (exit status 2), before OUT is made
        raise SpineMeshError(no_skeleton_said(at_any_depth=True), ", ".join(map(str, corpora)))
    _check_output(out)
    mark_written_folder(out)  # before its first file: a run cut short is resumed, not refused
    lock = open(out / ".lock", "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        lock.close()
        raise SpineMeshError("another spinemesh dataset run is writing this folder", out) from None
    try:
        _open_output(out)
        return _run(out, projects, jobs, retry_failed, on_project, t0, dask)
    finally:
        lock.close()


def _run(out: Path, projects, jobs: int, retry_failed: bool, on_project, t0: float,
         dask: str | None = None) -> Summary:
    summary = Summary()
    done: dict[str, bool] = {}
    for p in read_jsonl(out / PROJECTS):
        # Done for good once one run read it without errors.
        done[p["project"]] = done.get(p["project"], False) or not p["errors"]
    known = HashSet()
    for row in read_jsonl(out / INDEX):
        known.add(row["id"])
    todo = []
    for folder, name in projects:
        if name in done and (done[name] or not retry_failed):
            summary.projects_done_before += 1
        else:
            todo.append((str(folder), name))
    total = len(todo)
    if on_project:
        on_project("", 0, total)
    with open_workers(jobs, dask, max_tasks_per_child=20) as workers:
        # A sliding window in project order: bounded memory, deterministic writes (the
        # parent writes each project's result in order, whichever worker made it).
        pending: deque = deque()
        it = iter(todo)
        for task in itertools.islice(it, 2 * workers.slots):
            pending.append((task, workers.submit(_extract_task, task)))
        i = 0
        while pending:
            task, future = pending.popleft()
            try:
                result = future.result()
            except WorkerLost as e:  # listed with its error: --retry-failed reads it again
                try:
                    game = game_of(Path(task[0]))
                except SpineMeshError:
                    game = name_as_text(Path(task[0]).name)
                result = ProjectResult(task[1], game, errors=[f"{task[0]}: not read: {e}"])
                summary.lost += 1
            _write(out, result, known, summary)
            i += 1
            if on_project:
                on_project(task[1], i, total)
            nxt = next(it, None)
            if nxt is not None:
                pending.append((nxt, workers.submit(_extract_task, nxt)))
    summary.total_samples = len(known)
    summary.seconds = time.perf_counter() - t0
    return summary

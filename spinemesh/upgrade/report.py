"""What a run did, attachment by attachment: the rows every stage fills in, and the report.

A :class:`Target` is made for every region attachment when the project is planned
(:mod:`.plan`); the meshing and writing stages set its status, and :func:`write_report`
writes one row per target. A library run :func:`merge` s its projects' results into one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..files.atomic import atomic_write_json
from ..files.names import named_within
from ..runs import RunSummary


@dataclass
class Target:
    """One region attachment and what became of it."""

    skeleton: str
    skin: str
    slot: str
    name: str
    paths: list[str]
    # meshed | kept (a deliberate, documented skip; ``reason`` says why) | failed;
    # planned while the run is under way, "would mesh" in a dry run.
    status: str = "pending"
    reason: str = ""
    key: str = ""                    # content key of its (composited) image
    vertices: int = 0
    triangles: int = 0
    coverage: float | None = None
    waste: float | None = None
    seconds: float = 0.0

    weights: dict | None = None      # --weights auto: bones chosen and why (spinemesh.rig.upgraded_meshes)
    # --weights auto, meshed only because it would bend: the keep rule's reason, and the region
    # it replaced (put back if the mesh does not get more than one bone); not report columns
    overruled: str = ""
    region: dict | None = None

    def row(self) -> dict:
        """The report's row: the bones left out listed as
        :func:`~spinemesh.rig.document.left_out_reported` gives them."""
        from ..rig.document import left_out_reported

        row = {k: v for k, v in self.__dict__.items()
               if k not in ("key", "overruled", "region") and not (k == "weights" and v is None)}
        if self.weights is not None and "left_out" in self.weights:
            row["weights"] = self.weights | left_out_reported(self.weights["left_out"])
        return row


@dataclass
class Result(RunSummary):
    """What a run did: every target, the skeletons written and the problems met."""

    targets: list[Target] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    #: what was used all the same but draws differently from one runtime to another (an atlas
    #: page whose size line disagrees with its image); the run's exit status does not change
    warnings: list[str] = field(default_factory=list)
    #: skeletons that could not be read (their path in the project or library -> the error,
    #: which is in ``errors`` too); the project's other skeletons are upgraded all the same
    not_read: dict[str, str] = field(default_factory=dict)
    seconds: dict = field(default_factory=lambda: {"read": 0.0, "mesh": 0.0, "weights": 0.0, "write": 0.0})
    #: ``--pack``: one :class:`spinemesh.pack.report.AtlasRow` per atlas written
    atlases: list = field(default_factory=list)

    def _items(self):
        return self.targets


def selection_left_nothing(result: Result) -> bool:
    """Whether ``--only``/``--exclude`` left no region attachment to upgrade: every skeleton read,
    every region kept on purpose (none meshed, failed or still to be decided), at least one by
    them. :func:`~.run.upgrade_project` then writes nothing, and the command refuses in one line."""
    from .options import NOT_SELECTED

    return (not result.errors and bool(result.targets) and all(t.status == "kept" for t in result.targets)
            and any(t.reason in NOT_SELECTED for t in result.targets))


def mark_would_mesh(result: Result) -> None:
    """A dry run: what would have been meshed says so."""
    for t in result.targets:
        if t.status == "planned":
            t.status = "would mesh"


def merge(into: Result, part: Result, prefix: str) -> None:
    """Add one project's result to a library's, naming its skeletons by their path in the library."""
    for t in part.targets:
        t.skeleton = prefix + t.skeleton
    into.targets += part.targets
    into.written += [prefix + w for w in part.written]
    into.errors += part.errors  # they name their files already
    into.warnings += part.warnings
    into.not_read.update({prefix + name: error for name, error in part.not_read.items()})
    for row in part.atlases:
        row.atlas = prefix + row.atlas
    into.atlases += part.atlases
    for k, v in part.seconds.items():
        into.seconds[k] = into.seconds.get(k, 0.0) + v


def write_report(result: Result, path: str | Path, project: str | Path | None = None) -> None:
    """``report.json``: one row per region attachment, plus totals and timings.

    Parameters
    ----------
    result : Result
        The run's result (:func:`.run.upgrade_project`, :func:`.library.upgrade_library`).
    path : path
        The report file, written atomically as strict JSON.
    project : path, optional
        The folder upgraded: its files are named from its name
        (:func:`~spinemesh.files.names.named_within`), so the report is the same bytes from any
        folder; default: paths as they are.
    """
    atomic_write_json(path, named_within({
        "counts": result.counts(),
        "skeletons_written": result.written,
        "errors": result.errors,
        "warnings": result.warnings,
        "skeletons_not_read": result.not_read,
        "seconds": {k: round(v, 3) for k, v in result.seconds.items()},
        "attachments": [t.row() for t in result.targets],
        **({"atlases": [a.row() for a in result.atlases], "atlas_totals": _atlas_totals(result.atlases)}
           if result.atlases else {}),
    }, project))


def _atlas_totals(rows: list) -> dict:
    from ..pack.report import atlas_totals  # pack is loaded only by runs that packed

    return atlas_totals(rows)

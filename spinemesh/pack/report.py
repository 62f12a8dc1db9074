"""What a packing run reports: one :class:`AtlasRow` per atlas, the run's :class:`PackResult`,
their totals and the ``--report`` JSON.

Separate from :mod:`.run` because ``pack``, ``upgrade --pack`` and their summaries read these
rows without running anything.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..files.atomic import atomic_write_json
from ..files.names import named_within
from ..runs import RunSummary


@dataclass
class AtlasRow:
    """One atlas of the report: what it was, what it became, and why regions kept their rectangles."""

    atlas: str
    #: packed (its layout written anew); cleared (its layout kept, its pages written with the
    #: rectangles' texels only: :func:`.run.rectangles_only_outcome`); kept (as it was, its PNG pages
    #: perhaps re-encoded smaller: ``pages_reencoded``); failed (copied as it was)
    status: str
    reason: str = ""
    pages_before: int = 0
    pages_after: int = 0
    texels_before: int = 0
    texels_after: int = 0
    bytes_before: int = 0
    bytes_after: int = 0
    padding: int | None = None
    # the regions' counts, and the texels they take, of an atlas whose layout was written anew;
    # None for one that kept its layout (its regions stay where they were: counting them as
    # packed by rectangle would say otherwise)
    by_outline: int | None = None
    by_rectangle: int | None = None
    rotated: int | None = None
    rectangle_reasons: dict = field(default_factory=dict)
    regions_by_rectangle: list = field(default_factory=list)
    cpu_seconds: float = 0.0  # this process's CPU time packing it (reading, placing, encoding)
    #: the packed pages' texels its regions take (what each draws, grown by what bilinear sampling
    #: reads and half the padding; texels two regions share count once): over ``texels_after``,
    #: how full its pages are
    texels_used: int | None = None
    pages_reencoded: int = 0  # kept: its PNG pages written smaller, losslessly, the atlas as it was
    #: an atlas written as it was (:func:`.run.untouched_row`): each page file it names, once, as
    #: (real path, texels, bytes), so that totals count a page two atlases share once; not in the report
    page_files: tuple = field(default=(), repr=False)

    def row(self) -> dict:
        row = dict(self.__dict__)
        del row["page_files"]
        return row


@dataclass
class PackResult(RunSummary):
    """Every atlas with what became of it, the files written and the problems met."""

    atlases: list[AtlasRow] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    #: One line per atlas page that runtimes draw differently (``Project.warnings``), as ``upgrade`` says them
    warnings: list[str] = field(default_factory=list)
    #: (atlas path, before pages, after pages) for previews: page images by name
    previews: list = field(default_factory=list, repr=False)

    def _items(self):
        return self.atlases

    def totals(self) -> dict:
        return atlas_totals(self.atlases)


def atlas_totals(rows: list[AtlasRow]) -> dict:
    """Pages, page texels and bytes before and after, summed over ``rows``, and regions by outline and
    by rectangle over those whose layout was written anew (the report's ``totals``; ``upgrade
    --pack``'s ``atlas_totals``).

    A page file that several atlases name (each kept as it was) is counted once: each row counts
    it, and the totals said twice the pages, texels and bytes there are. ``shared_pages``: how
    many such files were counted once (0 where none).
    """
    keys = ("pages_before", "pages_after", "texels_before", "texels_after", "bytes_before", "bytes_after",
            "by_outline", "by_rectangle")
    totals = {k: sum(getattr(a, k) or 0 for a in rows) for k in keys}  # None: a kept atlas's regions
    seen: set[str] = set()
    shared: set[str] = set()
    for a in rows:
        for path, texels, size in a.page_files:
            if path in seen:  # counted in an earlier row, the same before and after (kept as it was)
                shared.add(path)
                for side in ("before", "after"):
                    totals[f"pages_{side}"] -= 1
                    totals[f"texels_{side}"] -= texels
                    totals[f"bytes_{side}"] -= size
            seen.add(path)
    totals["shared_pages"] = len(shared)
    return totals


def failed_lines(rows: list[AtlasRow]) -> list[str]:
    """The error line of each atlas of ``rows`` that failed (its files copied as they were), as
    ``pack`` and ``upgrade --pack`` print them on stderr: ``hero.atlas: not packed: why``."""
    return [f"{a.atlas}: not packed: {a.reason}" for a in rows if a.status == "failed"]


def megabytes(n: int) -> str:
    """A byte count for people: ``1.2 MB``, ``340 kB``, ``512 bytes`` (powers of 1000, as file browsers)."""
    return f"{n / 1e6:.1f} MB" if n >= 1e6 else f"{n / 1e3:.0f} kB" if n >= 1e3 else f"{n} bytes"


def write_report(result: PackResult, path: str | Path, project: str | Path | None = None) -> None:
    """The ``--report`` JSON: totals, then one row per atlas; the files of ``project`` (the folder
    packed) named from its name (:func:`~spinemesh.files.names.named_within`)."""
    atomic_write_json(path, named_within({"totals": result.totals(), "errors": result.errors,
                                          "warnings": result.warnings,
                                          "atlases": [a.row() for a in result.atlases]}, project))

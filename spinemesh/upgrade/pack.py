"""``upgrade --pack``: the written project's atlas pages packed anew by the upgraded meshes' outlines.

It runs after the project is written (:func:`.run.finish_project`), on the output folder in
place: it packs by the skeleton files a game will load (the meshes just written, ``--repack``'s
untrimmed pages included) and changes no skeleton, only atlases and page images, with the
rules of ``spinemesh pack`` (:mod:`spinemesh.pack`). An atlas that cannot be packed stays as
the upgrade wrote it, with the reason in the report.
"""

from __future__ import annotations

import time
from pathlib import Path

from ..errors import SpineMeshError
from ..project import Project, find_project, is_skeleton_file
from .progress import SILENT, Progress
from .report import Result


def pack_written(out: Path, result: Result, options=None, workers=None, progress: Progress = SILENT,
                 source: Project | None = None, told=None) -> None:
    """Pack every atlas of the project just written to ``out``; rows go to ``result.atlases``.

    The ``--pack`` stage of :mod:`.run`, after the files are written: it changes no document,
    so it packs by the skeleton files a game loads, in place (:mod:`spinemesh.pack`).

    Parameters
    ----------
    out : Path
        The output folder as written; its atlases and pages are replaced there.
    result : Result
        Gets one :class:`spinemesh.pack.report.AtlasRow` per atlas in ``atlases``, the packing's
        problems in ``errors`` and ``warnings``, its time in ``seconds["pack"]``.
    options : Options, optional
        Its page rules, jobs and Dask cluster; default: :class:`spinemesh.pack.run.PackOptions`'s.
    workers : Workers, optional
        The run's workers; default: opened from ``options``.
    progress : Progress, optional
        Told the packing's steps as the ``pack`` phase; default: nobody.
    source : Project, optional
        The project upgraded. Its skeletons that were not written to ``out`` (the others of
        the folder, when one skeleton file was upgraded) still load its atlases in the game,
        so what they draw counts in the packing as it is. Its problems are in
        ``result.errors`` already: the same problem of a copy in ``out`` (an atlas whose page
        the export lacks) is not said again.
    told : callable, optional
        ``told()``: the work of this packing the ``pack`` phase was told ahead (a library run's
        :meth:`PackAhead.tell`), so that its own tells only the difference; default: none.
    """
    from ..pack.report import PackResult, failed_lines
    from ..pack.run import PackOptions, pack_project_into
    from ..pack.uses import collect_uses

    t0 = time.perf_counter()
    packed = PackResult()
    pack_options = PackOptions()
    if options is not None:
        pack_options = PackOptions(rules=options.pack_rules, jobs=options.jobs, dask=options.dask,
                                   keep_files_as_exported=options.pack_keep_files)
    try:
        written = find_project(out)
        # the skeleton files of its folder that were not given (the upgrade read those, and said
        # why one it could not read is not in OUT: not said again here)
        given = set() if source is None else set(source.skeletons)
        others = {} if source is None else {
            out / rel: path for path in source.files
            if path not in given and is_skeleton_file(path)
            and not (out / (rel := path.relative_to(source.root))).is_file()}
        pack_project_into(written, out, pack_options, packed, uses=collect_uses(written, others), workers=workers,
                          progress=PhaseProgress(progress, told))
    except SpineMeshError as e:
        result.errors.append(f"not packed: {e}")
    if source is not None:
        for row in packed.atlases:
            row.reason = said_of_input(row.reason, out, source.root)
    result.atlases += packed.atlases
    result.errors += failed_lines(packed.atlases)
    said = set(result.errors)
    result.errors += [f"packing: {e}" for e in packed.errors
                      if source is None or not e.startswith(str(out)) or str(source.root) + e[len(str(out)):] not in said]
    result.seconds["pack"] = result.seconds.get("pack", 0.0) + time.perf_counter() - t0


def said_of_input(reason: str, out: Path, root: Path) -> str:
    """``reason`` (a packed atlas's row) that names a file of ``out`` it could not read, said of the
    file of the project ``root`` it was copied from: the upgrade copied it there a moment before
    (the same bytes: an export replaced or cut short mid-run), and that one is the file the user
    must fix (``hero/page.png: cannot decode image``, not ``out/page.png``). Other reasons are
    returned as they are."""
    path, colon, said = reason.partition(": ")
    try:
        rel = Path(path).resolve().relative_to(out.resolve())  # the packing names the folder it found
    except (ValueError, OSError):
        return reason
    return f"{root / rel}{colon}{said}" if colon and (root / rel).is_file() else reason


class PhaseProgress:
    """Packing's progress (:class:`spinemesh.pack.run.PackProgress`) told as the upgrade's ``pack``
    phase; ``told()``: the part of the project's work told ahead (:class:`PackAhead`), if any."""

    def __init__(self, progress: Progress, told=None):
        self.progress = progress
        self.told = told
        self.whole = False  # the project's whole work told: each atlas's first steps are in it
        self.begun: set[str] = set()

    def work(self, steps: int) -> None:
        ahead = self.told() if self.told is not None else 0
        if steps != ahead:  # told ahead alike (the upgraded copies' pages are the project's): the total stands
            self.progress.add("pack", steps - ahead)
        self.whole = True

    def atlas(self, name: str, steps: int) -> None:
        if self.whole and name not in self.begun:
            self.begun.add(name)
            return
        self.progress.add("pack", steps)

    def advance(self, name: str, steps: int = 1) -> None:
        self.progress.advance("pack", steps)

    def step(self, name: str, what: str) -> None:
        self.progress.step("pack", what, name)

    def done(self, name: str) -> None:
        pass


class PackAhead:
    """A library run's packing work, known before its first project is packed: each project's
    (:func:`spinemesh.pack.run.project_pack_work`, from the projects as found; their upgraded
    copies' pages are the same files), told to the ``pack`` phase as a whole when the first
    is packed, so that its total and time left stand from then on; they grew project by project.

    ``work``: each project's work by its path under the library.
    """

    def __init__(self, work: dict[str, int]):
        self.work = dict(work)
        self.told = False

    def tell(self, progress: Progress, rel: str) -> int:
        """The work of project ``rel`` told ahead (the whole, first, at the first call); its own
        packing tells only how far it differs (:class:`PhaseProgress`)."""
        if not self.told:
            self.told = True
            progress.add("pack", sum(self.work.values()))
        return self.work.pop(rel, 0)

    def settle(self, progress: Progress, rel: str) -> None:
        """Project ``rel`` is done: work told ahead for a packing that did not happen (the project
        could not be read, or failed before its packing) is taken back."""
        left = self.work.pop(rel, 0)
        if left and self.told:
            progress.add("pack", -left)

    @classmethod
    def of(cls, library: Path, folders: list[Path]) -> "PackAhead":
        """The packing work of the projects in ``folders`` under ``library`` (0 for one that
        cannot be found as a project: said when it is upgraded)."""
        from ..pack.run import project_pack_work

        work = {}
        for folder in folders:
            try:
                work[folder.relative_to(library).as_posix()] = project_pack_work(find_project(folder))
            except SpineMeshError:
                continue
        return cls(work)

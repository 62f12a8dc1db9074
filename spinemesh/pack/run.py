"""Packing whole projects (and folders of projects) into an output folder, with a report.

The rules are ``upgrade``'s: the input is never written; the output folder is refused when it
is not empty unless ``overwrite`` (and then only a folder spinemesh wrote); every file is
written atomically; one atlas that cannot be packed keeps its original pages and the others
go on; skeletons are copied byte for byte (packing changes only atlases and pages).
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..files.atomic import atomic_copy, atomic_write_files, stop_if_every_write_refused, utf8
from ..files.inside import as_written
from ..images.decode import decode_rgba, image_file_bytes
from ..images.sources import AtlasImages
from ..memory import out_of_memory
from ..project import Project, find_project, find_projects, project_atlases
from .atlas_pack import (
    AtlasLayouts,
    PackedAtlas,
    PackRefused,
    PageRules,
    compose,
    page_groups,
    plan_layouts,
)
from .checks import (
    check_bytes_shrink,
    check_eight_bits,
    check_lossy_pages_shrink,
    check_no_repeat,
    check_one_upright_image,
    check_page_sizes,
)
from .page_colours import colours_by_settings, packed_page_colours, page_colour
from .page_files import PAGE_FORMATS, EncodedPage, encode_page, page_mode, reencoded_page
from .progress import AtlasMeter, atlas_work, page_kilotexels
from .report import AtlasRow, PackResult, megabytes
from .uses import ProjectUses, collect_uses


@dataclass
class PackOptions:
    """What the user asked for (see ``spinemesh pack --help``)."""

    overwrite: bool = False
    rotate: bool = True
    padding: int | None = None  # None: the original pages' measured padding (at least 2)
    rules: PageRules = field(default_factory=PageRules)  # the pages a packed atlas may have
    jobs: int = 1  # processes packing side by side (atlases, and an atlas's fills)
    larger_files: bool = False  # write a packed atlas whose files take more bytes than before (fewer texels)
    #: copy a kept atlas's pages byte for byte instead of re-encoding its PNG pages losslessly where smaller
    keep_files_as_exported: bool = False
    dask: str | None = None  # or a Dask cluster (see spinemesh.cluster)


class PackProgress:
    """Told how packing goes, atlas by atlas; this base class tells nobody (the Python API's default).

    An atlas's steps are its work (:mod:`spinemesh.pack.progress`: its page texels weighed by
    what each phase costs a texel), told whole before any is done; :meth:`atlas` is called
    again for the same atlas with more only where another layout is written after the first,
    and :meth:`step` says in words what the atlas is doing (:data:`STEPS`).
    """

    def atlases(self, count: int) -> None:
        """The run packs ``count`` atlases in all (told once, before the first; :func:`pack_project`
        and :func:`pack_library` know them all before they start)."""

    def work(self, steps: int) -> None:
        """The atlases of a project about to be packed take ``steps`` in all: the sum of what
        :meth:`atlas` will be told first of each (told once per project, before its first atlas)."""

    def atlas(self, name: str, steps: int) -> None:
        """``steps`` more steps of the atlas ``name`` are known (its whole work first)."""

    def advance(self, name: str, steps: int = 1) -> None:
        """``steps`` steps of the atlas ``name`` are done."""

    def step(self, name: str, what: str) -> None:
        """The atlas ``name`` now does ``what`` (one of :data:`STEPS`, or the next layout's words)."""

    def done(self, name: str) -> None:
        """The atlas ``name`` is packed, kept or failed."""


#: The progress of a run that tells nobody.
SILENT = PackProgress()

#: What an atlas is doing, in the words its progress bar shows (:meth:`PackProgress.step`), in
#: the order they come: its pages read and decoded; its fills tried (with power-of-two pages,
#: whole page sizes too); its packed pages encoded (oxipng, for PNG) and decoded back; the
#: packed atlas proven to draw as the original; a kept atlas's PNG pages re-encoded where smaller;
#: an atlas whose whole packing runs on a worker (several atlases side by side).
STEPS = {"read": "reading pages", "place": "placing regions", "sizes": "placing regions, trying page sizes",
         "write": "writing pages", "prove": "proving", "reencode": "re-encoding its pages",
         "rectangles": "writing its rectangles' texels only", "worker": "packing on a worker"}


def prove_written(atlas, texels: list[np.ndarray], text: str, encoded: dict[str, EncodedPage], uses: dict,
                  pinned: str) -> int:
    """Prove the packed atlas as it will be written (:func:`spinemesh.pack.proof.prove_packed`): its
    text parsed back, its pages as their bytes decode. Texels compared; :class:`PackRefused` when not.
    """
    from ..atlas import parse_atlas
    from .proof import ProofFailed, prove_packed

    try:
        after = parse_atlas(text, atlas.path)
        if any(p.name not in encoded for p in after.pages):
            raise ProofFailed("a page the packed atlas names is not written")
        return prove_packed(atlas, texels, after, [encoded[p.name].texels for p in after.pages], uses, pinned)
    except (ProofFailed, SpineMeshError) as e:
        raise PackRefused(f"the packed pages failed the proof that they draw as the original ({e}); its "
                          "pages are kept") from None


def _page_files(atlas, root: Path) -> list[Path]:
    return [AtlasImages.page_path(atlas, p.name, root) for p in atlas.pages]


def project_pack_work(proj) -> int:
    """The work :func:`pack_project_into` tells for packing ``proj`` (a :class:`~spinemesh.project.Project`):
    each usable atlas's :func:`~spinemesh.pack.progress.atlas_work` of its pages' kilotexels, from
    their headers as read with the atlas. A library run sums it over its projects before the first is packed."""
    return sum(atlas_work(_atlas_pages(a)) for a in project_atlases(proj).values())


def _row_from(packed: PackedAtlas, rel: str, bytes_before: int, bytes_after: int) -> AtlasRow:
    rect = [r for r in packed.regions if not r.by_outline]
    reasons = Counter(r.reason.split(" (")[0] for r in rect)
    return AtlasRow(rel, "packed", "", packed.pages_before, len(packed.pages), packed.texels_before,
                    packed.texels_after, bytes_before, bytes_after, packed.padding,
                    len(packed.regions) - len(rect), len(rect), packed.rotated, dict(reasons.most_common()),
                    [{"region": r.name, "reason": r.reason} for r in rect], round(packed.seconds, 3),
                    packed.footprint_texels)


@dataclass
class AtlasJob:
    """What packing one atlas needs, as a worker gets it (everything picklable)."""

    path: Path
    atlas: object  # the parsed Atlas
    rel: str
    files: list
    uses: dict
    pinned: str
    options: PackOptions
    refused: str = ""  # why it is kept before any work (pages shared with another atlas)
    keep_previews: bool = False


def _atlas_pages(atlas) -> list[int]:
    """Each page's kilotexels of ``atlas`` (:func:`~spinemesh.pack.progress.page_kilotexels` of its
    ``image_sizes``; one each where its images were not looked at): the work its bar counts,
    known before packing decodes a page."""
    return page_kilotexels(atlas.image_sizes or [None] * len(atlas.pages))


@dataclass
class AtlasOutcome:
    """One atlas packed (``encoded`` page bytes by name and the atlas ``text``), or its row alone; or
    kept with some pages re-encoded (``encoded`` those, ``text`` None: the atlas file is copied)."""

    row: AtlasRow
    encoded: dict | None = None
    text: str | None = None
    previews: tuple | None = None


def files_bytes(job: AtlasJob) -> int:
    """The bytes of ``job``'s atlas file and its page files (each once) on disk; a file that cannot
    be read counts 0 (its atlas fails, and says why)."""
    total = 0
    for f in {*job.files, job.path}:
        try:
            total += f.stat().st_size
        except OSError:
            continue
    return total


def untouched_row(job: AtlasJob, status: str, reason: str, texels: list[np.ndarray] | None = None) -> AtlasRow:
    """The row of an atlas written as it was (``kept`` or ``failed``): its pages, page texels and
    bytes, the same before and after.

    ``texels``: its pages as decoded, where they were read; else each page's size from its
    image's header, as read with the atlas (``Atlas.image_sizes``: an atlas kept before its pages
    are read: pages shared with another atlas, a JPEG page, a ``size:`` line its image disagrees
    with; one whose worker was lost), 0 for a page whose header cannot be read. The totals of a
    run sum these: an atlas counted as 0 texels made a project's saving look larger than it is.
    """
    sizes = ([(int(t.shape[1]), int(t.shape[0])) for t in texels] if texels
             else [size or (0, 0) for size in _image_sizes(job.atlas, job.files)])
    texel_count = sum(w * h for w, h in sizes)
    size = files_bytes(job)
    return AtlasRow(job.rel, status, reason, len(job.atlas.pages), len(job.atlas.pages), texel_count, texel_count,
                    size, size, page_files=_page_files_once(job.files, sizes))


def _image_sizes(atlas, files: list[Path]) -> list[tuple[int, int] | None]:
    """Each page image's ``(width, height)``: ``atlas.image_sizes`` as read with the atlas, or from
    ``files``' headers where the atlas was read without its images."""
    if len(atlas.image_sizes) == len(files):
        return atlas.image_sizes
    from ..images.decode import image_size

    return [image_size(f) for f in files]


def _page_files_once(files: list[Path], sizes: list[tuple[int, int]]) -> tuple:
    """Each of ``files`` once (the first of its names), as (real path, texels, bytes) by its ``sizes``
    (width, height); a file whose bytes cannot be read counts 0 bytes, as :func:`files_bytes` does."""
    once = {}
    for f, (w, h) in zip(files, sizes):
        key = str(f.resolve())
        if key not in once:
            try:
                size = f.stat().st_size
            except OSError:
                size = 0
            once[key] = (key, w * h, size)
    return tuple(once.values())


def _page_by_page(task, args: list[tuple], workers, on_step) -> list:
    """``task(arg)`` for each of ``args``, in order: on ``workers`` side by side when given (all
    submitted first), else here one after another; ``on_step(1)`` as each ends."""
    if workers is not None:
        futures = [workers.submit(task, arg, first=True) for arg in args]
        answers = (future.result() for future in futures)
    else:
        answers = (task(arg) for arg in args)
    results = []
    for answer in answers:
        results.append(answer)
        on_step(1)
    return results


def _encode_packed_pages(pages: dict[str, np.ndarray], modes: dict, colour_of: dict, workers, on_step) -> dict:
    """Each packed page encoded (:func:`encode_page`): ``{name: EncodedPage}``, on ``workers`` when
    given, else here. ``pages`` then holds what each file decodes to (one copy of each page)."""
    args = [(rgba, name, modes.get(name), colour_of[name]) for name, rgba in pages.items()]
    encoded = dict(zip(pages, _page_by_page(_encode_task, args, workers, on_step)))
    for name, page in encoded.items():
        pages[name] = page.texels
    return encoded


#: Why an atlas failed when memory ran out while it was packed (its files are copied as they are).
NO_MEMORY = "not enough memory to pack it (the regions' shapes, the placements tried and the pages take memory by their texels)"


def _read_pages(job: AtlasJob, meter: AtlasMeter) -> tuple[list[bytes], list[np.ndarray]]:
    """Each page file of ``job``'s atlas read once, for everything packing needs of it (texels,
    palette, colour chunks, lossy or not, and the file itself where a kept page is re-encoded),
    and its texels: ``(files' bytes, texels)`` in page order.

    Raises
    ------
    PackRefused
        For a page in a format that cannot be written back texel for texel (JPEG) or is not read
        at all (BMP, KTX2), before any is read, and for a PNG page of 16 bits a channel (:func:`check_eight_bits`).
    """
    for page in job.atlas.pages:
        suffix = Path(page.name).suffix.lower()
        if suffix in (".jpg", ".jpeg"):
            raise PackRefused(f"page {page.name!r} is not PNG, WebP or AVIF but JPEG, which has no alpha and "
                              "loses texels when written: it would not come back texel for texel")
        if suffix not in PAGE_FORMATS:  # a BMP, a KTX2: no format spinemesh decodes, its page passed as it is
            raise PackRefused(f"page {page.name!r} is not PNG, WebP or AVIF, the page formats spinemesh reads "
                              "and writes; it is kept as it is")
        check_no_repeat(page)
    meter.begin("read", [1], STEPS["read"])
    data = [image_file_bytes(f) for f in job.files]
    for d, page in zip(data, job.atlas.pages):
        check_eight_bits(d, page.name)
        check_one_upright_image(d, page.name)
    texels = [decode_rgba(d, f) for d, f in zip(data, job.files)]
    meter.end_part()
    return data, texels


def pack_atlas_files(job: AtlasJob, workers=None, on_step=None) -> AtlasOutcome:
    """Read one atlas's pages, pack them and encode the new ones; nothing is written.

    ``workers`` (:class:`spinemesh.cluster.Workers` of several slots): the atlas's fills and
    page encodings run on them side by side; default here, one after another. ``on_step(done,
    planned, step)``: told the atlas's work (``planned``, :mod:`spinemesh.pack.progress`: all of
    it first, before any is done; more only where another layout is written) and the work
    ``done`` as its parts end, and what the atlas does from now on (``step``, words of
    :data:`STEPS`; empty: no change).
    """
    from .parallel import FillRunner

    atlas, options = job.atlas, job.options
    t0 = time.process_time()
    meter = AtlasMeter(_atlas_pages(job.atlas), [pages for _, pages, _ in page_groups(atlas)], on_step)
    meter.start()
    bytes_before = files_bytes(job)
    texels: list[np.ndarray] = []
    data: list[bytes] = []
    parallel = workers is not None and workers.slots > 1
    # kept for what packing saves (no fewer texels, more bytes), not for a fault: its PNG pages may
    # be re-encoded (kept_pages_reencoded); kept for anything else, its files are copied as they are
    reencode_kept = False
    try:
        if job.refused:
            raise PackRefused(job.refused)
        data, texels = _read_pages(job, meter)
        check_page_sizes(atlas, texels)
        reencode_kept = True
        modes = {page.name: page_mode(d) for d, page in zip(data, atlas.pages)}
        colours = [page_colour(d) for d in data]
        group_colour = colours_by_settings(atlas, colours)
        pot = options.rules.limits([(int(t.shape[1]), int(t.shape[0])) for t in texels])[2]
        meter.say(STEPS["sizes" if pot else "place"])  # whole page sizes are tried for powers of two
        layouts = plan_layouts(atlas, texels, job.uses, job.pinned, rotate=options.rotate, padding=options.padding,
                               rules=options.rules, fills=FillRunner(workers, meter) if parallel else None,
                               on_fill=meter)
        packed = compose(layouts)
        layouts.release()  # made again only if another layout is tried
        reencode_kept = False  # a page that does not come back, a packing that fails its proof
        encoded, text = _written(packed, texels, modes, group_colour, job, workers if parallel else None, meter)
        reencode_kept = True
        bytes_after = sum(map(len, encoded.values())) + len(text.encode("utf-8"))
        if not options.larger_files:  # what it promises: fewer texels, whatever the bytes (lossy pages too)
            check_lossy_pages_shrink(data, bytes_before, bytes_after)
            try:
                check_bytes_shrink(bytes_before, bytes_after, packed.texels_before, packed.texels_after)
            except PackRefused as grows:
                other = next_layout_outcome(job, layouts, texels, modes, group_colour, bytes_before,
                                            (packed.texels_after, bytes_after), workers if parallel else None, meter)
                if other is None:
                    meter.say(STEPS["rectangles"])
                    other = rectangles_only_outcome(job, texels, modes, colours, bytes_before, str(grows), t0)
                if other is None:
                    raise
                other.row.cpu_seconds = round(time.process_time() - t0, 3)
                return other
    except PackRefused as e:
        row = untouched_row(job, "kept", str(e), texels)
        outcome = AtlasOutcome(row)
        if reencode_kept and not options.keep_files_as_exported:
            outcome = kept_pages_reencoded(job, texels, data, row, workers if parallel else None, meter)
        row.cpu_seconds = round(time.process_time() - t0, 3)
        return outcome
    except SpineMeshError as e:
        row = untouched_row(job, "failed", str(e), texels)
        row.cpu_seconds = round(time.process_time() - t0, 3)
        return AtlasOutcome(row)
    except Exception as e:  # memory refused here or on a worker (MemoryError, OpenCV's, a library's): this atlas alone
        if not out_of_memory(e):
            raise
        row = untouched_row(job, "failed", NO_MEMORY, texels)
        row.cpu_seconds = round(time.process_time() - t0, 3)
        return AtlasOutcome(row)
    row = _row_from(packed, job.rel, bytes_before, bytes_after)
    row.cpu_seconds = round(time.process_time() - t0, 3)
    return AtlasOutcome(row, encoded, text, _previews(job, texels, packed))


def _previews(job: AtlasJob, texels: list[np.ndarray], packed: PackedAtlas) -> tuple | None:
    """What ``--preview`` shows of a packed atlas: its pages before and after, by name (when asked)."""
    if not job.keep_previews:
        return None
    return job.rel, dict(zip((p.name for p in job.atlas.pages), texels)), packed.pages


def _written(packed: PackedAtlas, texels: list[np.ndarray], modes: dict, group_colour: dict, job: AtlasJob,
             workers, meter: AtlasMeter, layout: str = "") -> tuple[dict[str, bytes], str]:
    """A packed atlas as it would be written, proven: its pages' bytes by name (:func:`encode_page`, on
    ``workers`` when given) and its text, once :func:`prove_written` holds of them.

    Raises
    ------
    PackRefused
        A page that cannot be written losslessly or does not come back, or a failed proof.

    ``layout``: words that name the layout in the steps told (``meter``), for one after the first.
    """
    # a page's encoding takes time by its texels
    meter.begin("write", [p.shape[0] * p.shape[1] for p in packed.pages.values()], layout + STEPS["write"])
    colour_of = packed_page_colours(packed.atlas, group_colour)
    encoded = _encode_packed_pages(packed.pages, modes, colour_of, workers, meter)
    text = packed.atlas.dumps()
    meter.begin("prove", [1], layout + STEPS["prove"])
    prove_written(job.atlas, texels, text, encoded, job.uses, job.pinned)
    meter.end_part()
    return {name: page.data for name, page in encoded.items()}, text


def next_layout_outcome(job: AtlasJob, layouts: AtlasLayouts, texels: list[np.ndarray], modes: dict,
                        group_colour: dict, bytes_before: int, first: tuple[int, int], workers=None,
                        meter: AtlasMeter | None = None) -> AtlasOutcome | None:
    """The atlas in the next layouts its fills found, when the one of fewest page texels takes more
    bytes than the atlas as exported (``first``: its page texels and bytes): of those that take
    fewer bytes than the atlas as exported, the one of fewest bytes (the first, of fewer texels,
    on a tie); None when none does.

    Every layout :func:`~spinemesh.pack.atlas_pack.plan_layouts` kept stores fewer page texels
    than the atlas as exported, so the one written beats it on both. Each is encoded and proven
    (:func:`_written`): at most :data:`~spinemesh.pack.atlas_pack.NEXT_LAYOUTS` more encodes.
    A page's bytes depend on what lies next to what, not only on how many texels there are:
    a layout of a few more texels can take fewer bytes (verse-rabby's).
    """
    meter = meter or AtlasMeter(_atlas_pages(job.atlas))
    best = None
    for rank in range(1, layouts.count):
        try:
            packed = compose(layouts, rank)
            encoded, text = _written(packed, texels, modes, group_colour, job, workers, meter,
                                     f"layout {rank + 1} of {layouts.count}: ")
        except (PackRefused, SpineMeshError):
            continue
        size = sum(map(len, encoded.values())) + len(text.encode("utf-8"))
        if size < bytes_before and (best is None or size < best[0]):
            best = (size, packed, encoded, text)
    if best is None:
        return None
    size, packed, encoded, text = best
    row = _row_from(packed, job.rel, bytes_before, size)
    row.reason = next_layout_reason(first, bytes_before, (packed.texels_after, size))
    return AtlasOutcome(row, encoded, text, _previews(job, texels, packed))


def next_layout_reason(first: tuple[int, int], bytes_before: int, written: tuple[int, int]) -> str:
    """Why an atlas was written in another layout than that of fewest page texels (:func:`next_layout_outcome`):
    ``first`` and ``written`` are ``(page texels, bytes)`` of that layout and of the one written."""
    return (f"packed to the fewest page texels ({first[0]:,}), its files would take {first[1]:,} bytes against "
            f"{bytes_before:,}; written in another layout the fills found, {written[0]:,} page texels in "
            f"{written[1]:,} bytes (--larger-files writes the first)")


def rectangles_only(atlas, texels: list[np.ndarray]) -> list[np.ndarray]:
    """The atlas's pages with only the texels a region's quad can read: its stored rectangle and the
    one-texel ring around it; every other texel all zero (what packers leave between regions, and
    what compresses best). Regions drawn by meshes are proven apart (:func:`prove_written`)."""
    cleared = []
    for i, page in enumerate(texels):
        keep = np.zeros(page.shape[:2], bool)
        for r in atlas.regions:
            if r.page == i:
                g = r.geometry()
                keep[max(0, g.y - 1):g.y + g.page_height + 1, max(0, g.x - 1):g.x + g.page_width + 1] = True
        cleared.append(np.where(keep[..., None], page, 0).astype(np.uint8))
    return cleared


def rectangles_only_outcome(job: AtlasJob, texels: list[np.ndarray], modes: dict, colours: list, bytes_before: int,
                            why: str, t0: float) -> AtlasOutcome | None:
    """The atlas as it is, its pages written with the rectangles' texels only (:func:`rectangles_only`),
    when that takes fewer bytes than its files do and draws alike (proven); else None.

    The packed atlas was refused for its bytes (``why``): this keeps the atlas's layout and page
    texels, and saves what clearing the texels no region reads, and oxipng, save. Each page
    carries its own colour chunks (``colours``, :func:`page_colour` in page order).
    """
    atlas = job.atlas
    try:
        text = job.path.read_bytes().decode("utf-8")
        pages = {page.name: encode_page(cleared, page.name, modes.get(page.name), colour)
                 for page, cleared, colour in zip(atlas.pages, rectangles_only(atlas, texels), colours)}
        bytes_after = sum(len(p.data) for p in pages.values()) + len(text.encode("utf-8"))
        if bytes_after >= bytes_before:
            return None
        prove_written(atlas, texels, text, pages, job.uses, job.pinned)
    except (PackRefused, SpineMeshError, OSError, UnicodeDecodeError):
        return None
    texel_count = sum(int(t.shape[0]) * int(t.shape[1]) for t in texels)
    row = AtlasRow(job.rel, "cleared", f"{why}; written as it was, with the rectangles' texels only",
                   len(atlas.pages), len(atlas.pages), texel_count, texel_count, bytes_before, bytes_after,
                   cpu_seconds=round(time.process_time() - t0, 3))
    return AtlasOutcome(row, {name: p.data for name, p in pages.items()}, text)


def kept_pages_reencoded(job: AtlasJob, texels: list[np.ndarray], files: list[bytes], row: AtlasRow,
                         workers=None, meter: AtlasMeter | None = None) -> AtlasOutcome:
    """A kept atlas (``row``) with its PNG pages written smaller by :func:`reencoded_page` where
    that holds, its atlas text and every other page as exported. ``texels`` and ``files``: each
    page's texels and its file's bytes, in page order.

    ``workers`` (several slots): the pages are re-encoded side by side. Returns ``row``'s outcome
    as it is when no page gets smaller; else ``row`` says so and counts the bytes written.
    """
    atlas = job.atlas
    pages = [(page.name, f, t) for page, f, t in zip(atlas.pages, files, texels)
             if Path(page.name).suffix.lower() == ".png"]
    if not pages:
        return AtlasOutcome(row)
    meter = meter or AtlasMeter(_atlas_pages(job.atlas))
    meter.begin("write", [t.shape[0] * t.shape[1] for _, _, t in pages], STEPS["reencode"],
                [i for i, page in enumerate(atlas.pages) if Path(page.name).suffix.lower() == ".png"])
    results = _page_by_page(_reencode_task, pages, workers, meter)
    written = {name: data for (name, _, _), data in zip(pages, results) if data is not None}
    if not written:
        return AtlasOutcome(row)
    before = sum(len(f) for name, f, _ in pages if name in written)
    after = sum(map(len, written.values()))
    which = (f"{len(written)} of its {len(atlas.pages)} pages" if len(written) < len(atlas.pages)
             else "its page" if len(written) == 1 else "its pages")
    row.reason = f"{row.reason}; kept its layout, {which} re-encoded losslessly, {megabytes(before)} -> " \
                 f"{megabytes(after)}"
    row.bytes_after = row.bytes_before - before + after
    row.pages_reencoded = len(written)
    return AtlasOutcome(row, written, None)


def _reencode_task(arg: tuple) -> bytes | None:
    """A worker's task: :func:`reencoded_page` of ``(name, file's bytes, texels)``, or None where the page stays."""
    name, original, texels = arg
    try:
        return reencoded_page(original, texels, name)
    except PackRefused:
        return None


def _encode_task(arg: tuple) -> EncodedPage:
    """A worker's task: :func:`encode_page` of ``(texels, name, like, colour)``."""
    return encode_page(*arg)


def _pack_atlas_task(job: AtlasJob) -> AtlasOutcome:
    """A worker's task: one whole atlas, its fills one after another (:func:`pack_atlas_files`)."""
    return pack_atlas_files(job)


def pack_project_into(proj: Project, out: Path, options: PackOptions, result: PackResult,
                      prefix: str = "", uses: ProjectUses | None = None, keep_previews: bool = False,
                      workers=None, progress: PackProgress = SILENT) -> None:
    """Pack every atlas of ``proj`` and write the whole project to ``out`` (same layout).

    ``out`` may be the project folder itself when it is an output of ours (``upgrade --pack``
    packs what it has just written): atlases and pages are then replaced in place, pages the
    packed atlas no longer names are removed, and nothing is copied.

    ``workers`` (:class:`spinemesh.cluster.Workers`; default: opened from ``options.jobs`` and
    ``options.dask``): with several slots, a project of several atlases packs them side by side
    (each one's fills one after another), a project of one atlas its fills and pages side by
    side. Results are written in atlas order whatever order they come back in.
    """
    from ..cluster import open_workers

    if workers is None:
        with open_workers(options.jobs, options.dask) as opened:
            return pack_project_into(proj, out, options, result, prefix, uses, keep_previews, opened, progress)
    in_place = out.resolve() == proj.root.resolve()
    atlases = project_atlases(proj)
    uses = uses or collect_uses(proj)
    result.errors += [f"{p}" for p in proj.problems]
    result.errors += uses.problems
    result.warnings += [w for w in proj.warnings if w not in result.warnings]
    # a page image named by two atlases (twin exports) would be rewritten under the other's feet
    by_page = Counter(f.resolve() for a in atlases.values() for f in set(_page_files(a, proj.root)))
    named_by_unused = pages_named_by_unused(proj, set(by_page))
    jobs = []
    for path, atlas in atlases.items():
        files = _page_files(atlas, proj.root)
        shared = any(by_page[f.resolve()] > 1 for f in files)
        unused = next((named_by_unused[f.resolve()] for f in files if f.resolve() in named_by_unused), None)
        # pages that disagree with their images or with each other (page_mismatches) are kept as they are
        refused = ("its page images are shared with another atlas" if shared
                   else f"its page images are also named by {unused.relative_to(proj.root).as_posix()}, an atlas "
                        "spinemesh does not use but a runtime may load" if unused is not None
                   else atlas.mismatches[0].message if atlas.mismatches else "")
        jobs.append(AtlasJob(path, atlas, prefix + path.relative_to(proj.root).as_posix(), files,
                             uses.regions.get(path, {}), uses.everything_pinned, options, refused, keep_previews))
    skip: set[Path] = set()
    progress.work(sum(atlas_work(_atlas_pages(job.atlas)) for job in jobs))
    for job, outcome in zip(jobs, _outcomes(jobs, workers, progress)):
        _write_outcome(job, outcome, proj, out, in_place, result, skip)
    # an atlas is copied after its pages, and not when one of them could not be (a full disk): a
    # runtime would read it and miss its page
    from ..output import atlas_pages, copy_atlases_last

    def copy_unless_written(source: Path, target: Path) -> None:
        if not target.exists():
            atomic_copy(source, target)

    files = [] if in_place else proj.files  # only files inside the project by real path (find_project)
    result.errors += copy_atlases_last([(f, out / f.relative_to(proj.root)) for f in files if f.resolve() not in skip],
                                       atlas_pages(proj), copy_unless_written)


def pages_named_by_unused(proj: Project, pages: set[Path]) -> dict[Path, Path]:
    """The page files of ``pages`` (real paths) that an atlas of ``proj`` left out names, each with
    that atlas (``proj.broken_atlases``, filled by :func:`~spinemesh.project.project_atlases`).

    spinemesh leaves such an atlas out (its line says why), but a runtime may load it all the
    same (a page ``scale:`` beyond the limits, which the runtimes do not read; more regions than
    the limit): a page it names is shared, and packed for another atlas it would draw other
    texels. Its lines are scanned, not parsed (it may not parse): a line that names one of
    ``pages`` from the atlas's folder counts (a region named like a page file only keeps more
    atlases). A file that cannot be read at all, or is beyond the atlas size limit, counts as
    naming every one of ``pages``.
    """
    from ..files.inside import resolve_inside
    from ..limits import check_file_size

    found: dict[Path, Path] = {}
    names = {p.name for p in pages}
    root = proj.root.resolve()
    for path in proj.broken_atlases:
        try:
            check_file_size(path, "atlas")
            text = path.read_bytes().decode("utf-8", "replace")
            folder = path.parent.resolve().relative_to(root).as_posix()
        except (OSError, SpineMeshError, ValueError):
            found.update((p, path) for p in pages if p not in found)
            continue
        for line in text.splitlines():
            name = line.strip().lstrip("\ufeff").strip()
            if not name or as_written(name).rsplit("/", 1)[-1] not in names:
                continue
            try:
                page = resolve_inside(proj.root, f"{folder}/{name}", path).resolve()
            except (SpineMeshError, OSError):  # a name that leaves the project names none of them
                continue
            if page in pages:
                found.setdefault(page, path)
    return found


def _outcomes(jobs: list[AtlasJob], workers, progress: PackProgress):
    """Each job's :class:`AtlasOutcome`, in order: atlases side by side on ``workers`` when there are
    several of both (a few ahead of the one written, so that memory holds a few atlases), else one
    after another with their fills side by side."""
    from collections import deque

    from ..cluster import WorkerLost

    if workers.slots > 1 and len(jobs) > 1:
        ahead: deque = deque()
        waiting = iter(jobs)

        def submit() -> None:
            job = next(waiting, None)
            if job is not None:
                work = atlas_work(_atlas_pages(job.atlas))  # told whole as the atlas ends there
                progress.atlas(job.rel, work)
                progress.step(job.rel, STEPS["worker"])
                future = workers.submit(_pack_atlas_task, job)
                future.add_done_callback(lambda _, rel=job.rel, work=work: (progress.advance(rel, work),
                                                                             progress.done(rel)))
                ahead.append((job, future))

        for _ in range(2 * workers.slots):
            submit()
        while ahead:
            job, future = ahead.popleft()
            try:
                yield future.result()
            except WorkerLost as e:
                yield AtlasOutcome(untouched_row(job, "failed", str(e)))
            except Exception as e:  # no memory to hand the atlas over or its outcome back: this atlas alone
                if not out_of_memory(e):
                    raise
                yield AtlasOutcome(untouched_row(job, "failed", NO_MEMORY))
            submit()
        return
    for job in jobs:
        def on_step(done: int = 1, planned: int = 0, step: str = "", rel=job.rel) -> None:
            if planned:
                progress.atlas(rel, planned)
            if step:
                progress.step(rel, step)
            if done:
                progress.advance(rel, done)

        outcome = pack_atlas_files(job, workers, on_step)  # its bar begins with its whole work
        progress.done(job.rel)
        yield outcome


def _write_outcome(job: AtlasJob, outcome: AtlasOutcome, proj: Project, out: Path, in_place: bool,
                   result: PackResult, skip: set) -> None:
    """Write one packed atlas and its pages (atomically), or note why it was not; its row into ``result``."""
    row = outcome.row
    if outcome.encoded is None:
        result.atlases.append(row)
        return
    dest = out / job.path.relative_to(proj.root)
    # pages\hero.png (a Windows export) is written where it was read: pages/hero.png
    files = {dest.parent / as_written(name): data for name, data in outcome.encoded.items()}
    try:
        if outcome.text is not None:
            files[dest] = utf8(outcome.text, dest)
        # as one: a page written beside an atlas that is not (disk full) would draw other texels
        atomic_write_files(files)
    except SpineMeshError as e:
        stop_if_every_write_refused(e)
        result.atlases.append(AtlasRow(row.atlas, "failed", f"not written: {e}", row.pages_before, row.pages_before,
                                       row.texels_before, row.texels_before, row.bytes_before, row.bytes_before))
        return
    if outcome.text is None:  # kept, some pages re-encoded: the atlas and its other pages are copied as they are
        files = dict(zip((p.name for p in job.atlas.pages), job.files))
        skip.update(files[name].resolve() for name in outcome.encoded)
        result.atlases.append(row)
        return
    skip.add(job.path.resolve())
    skip.update(f.resolve() for f in job.files)
    if in_place:  # pages the packed atlas no longer names were dropped
        kept = {(dest.parent / as_written(n)).resolve() for n in outcome.encoded}
        for f in set(job.files):
            if f.resolve() not in kept:
                f.unlink(missing_ok=True)
    # an original page whose name the packed atlas reuses was replaced; the others are dropped
    result.atlases.append(row)
    if outcome.previews is not None:
        result.previews.append(outcome.previews)


def pack_project(project: str | Path, out: str | Path, options: PackOptions | None = None,
                 keep_previews: bool = False, progress: PackProgress = SILENT) -> PackResult:
    """Pack every atlas of a project (a folder, or the folder of one skeleton file) into ``out``.

    A skeleton file stands for its folder: an atlas is packed for every skeleton that loads
    it, so all of them are read. The project is written whole to ``out``, skeletons unchanged.

    Parameters
    ----------
    project : path
        A project folder, or a skeleton file in it.
    out : path
        The output folder; refused if it is the project or inside it.
    options : PackOptions, optional
        What ``spinemesh pack``'s options ask for; default: ``PackOptions()``.
    keep_previews : bool, default False
        Keep each atlas's pages before and after in ``result.previews`` (``--preview``).
    progress : PackProgress, optional
        Told each atlas's steps; default: nobody.

    Returns
    -------
    PackResult
        One :class:`AtlasRow` per atlas (``packed``, ``cleared``, ``kept`` with the reason, or
        ``failed``) and the problems met.

    Raises
    ------
    SpineMeshError
        Before anything is written: not a project, no usable atlas, ``out`` refused.

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> from spinemesh.upgrade import upgrade_project
    >>> _ = upgrade_project(make_demo_project("demo"), "meshed")
    >>> result = pack_project("meshed", "packed")
    >>> [(row.atlas, row.status) for row in result.atlases], result.totals()["texels_after"] < 131072
    ([('demo.atlas', 'packed')], True)
    """
    from ..output import check_output_folder, output_folder

    options = options or PackOptions()
    project, out = Path(project), Path(out)
    if project.is_file():
        find_project(project)  # refuses a file that is no skeleton (an atlas, a page), saying what to give
    folder = project.parent if project.is_file() else project
    proj = find_project(folder)
    if not project_atlases(proj):
        raise nothing_to_pack(proj.root, proj.problems, "no atlas to pack" if proj.atlases else
                              "no atlas to pack: no atlas file (.atlas) in it nor in a folder below it")
    check_output_folder(proj.root, out)
    result = PackResult()
    progress.atlases(len(project_atlases(proj)))
    with output_folder(out, options.overwrite):
        pack_project_into(proj, out, options, result, keep_previews=keep_previews, progress=progress)
    return result


def nothing_to_pack(root: Path, problems: list[str], why: str = "no atlas to pack") -> SpineMeshError:
    """The one line refusing a project (or a folder of them) without a usable atlas, before
    anything is written: ``root``, ``why`` and why the first atlas left out was (of ``problems``,
    those :func:`~spinemesh.project.project_atlases` noted: a page image not found, an unreadable
    file)."""
    left_out = [p for p in problems if p.endswith("; atlas not used")]
    if left_out:
        more = len(left_out) - 1
        why += f": {left_out[0]}" + (f" (and {more} more atlas{'es' if more > 1 else ''} left out)" if more else "")
    return SpineMeshError(why, root)


def pack_library(library: str | Path, out: str | Path, options: PackOptions | None = None,
                 on_project=None, progress: PackProgress = SILENT, folders: list[Path] | None = None) -> PackResult:
    """Pack every project under ``library`` into the same place under ``out``; one result.

    Parameters
    ----------
    library : path
        A folder of projects (:func:`spinemesh.project.find_projects`).
    out : path
        The output folder; refused if it is the library or inside it.
    options : PackOptions, optional
        As for :func:`pack_project`; one set of workers packs every project.
    on_project : callable, optional
        Told each project's path under ``library`` before it is packed.
    progress : PackProgress, optional
        Told each atlas's steps; default: nobody.
    folders : list of path, optional
        The projects under ``library`` as the caller found them
        (:func:`spinemesh.upgrade.library_projects`); found when not given.

    Returns
    -------
    PackResult
        Every project's atlas rows, named by their path under ``library``; a project that
        cannot be packed is one line of ``errors``, and the others are packed all the same.
    """
    from ..output import check_output_folder, output_folder

    options = options or PackOptions()
    library, out = Path(library), Path(out)
    check_output_folder(library, out)
    result = PackResult()
    from ..cluster import open_workers

    # each project found and its atlases read once, before OUT: a folder none of whose projects
    # has a usable atlas is refused as one project is, nothing written (one that could not be
    # read is said on its own line: finish_pack refuses the run after)
    projects: list[tuple[Path, Project | SpineMeshError]] = []
    for folder in find_projects(library) if folders is None else folders:
        try:
            projects.append((folder, find_project(folder)))
        except SpineMeshError as e:
            projects.append((folder, e))
    found = [p for _, p in projects if isinstance(p, Project)]
    if len(found) == len(projects) and not any(project_atlases(p) for p in found):
        raise nothing_to_pack(library, [q for p in found for q in p.problems], "no atlas to pack in any of its projects")
    progress.atlases(sum(len(project_atlases(p)) for p in found))
    with output_folder(out, options.overwrite), open_workers(options.jobs, options.dask) as workers:
        for folder, proj in projects:
            rel = folder.relative_to(library).as_posix()
            if on_project:
                on_project(rel)
            prefix = "" if rel == "." else rel + "/"
            try:
                if isinstance(proj, SpineMeshError):
                    raise proj
                pack_project_into(proj, out / rel, options, result, prefix, workers=workers, progress=progress)
            except SpineMeshError as e:
                result.errors.append(str(e))
    return result



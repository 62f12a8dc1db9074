"""``--repack``: store chosen atlas regions untrimmed, so one mesh can serve frames trimmed differently.

A sequence's frames share one mesh, and a mesh samples each frame at the same UVs. Packers
strip each frame's transparent border separately, so a mesh covering every frame's art
reaches, for some frame, beyond the rectangle that frame stores on the page: there it would
sample the neighbouring regions. Re-packed untrimmed (the whole original image stored, the
stripped border transparent again), every UV of the mesh lands inside each frame's own
rectangle.

:func:`repack_atlas` moves the named regions of one atlas to new pages, one per original page
they came from (same format, filter, wrap, premultiplication and scale), packed shelf by
shelf with two texels of transparent padding. The texels are copied as stored, premultiplied
or not. Every other region, page and field is kept as it was.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np

from ..atlas import Atlas, AtlasPage, AtlasRegion, Entry
from ..files.names import portable_name
from ..images.regions import cut_region

#: Transparent texels around each re-packed region (bilinear sampling never reaches a neighbour).
PADDING = 2

#: Widest new page, in texels (every GPU takes 4096).
MAX_PAGE_SIDE = 4096

#: Region fields that describe where and how the region is stored; rewritten on re-packing.
_GEOMETRY_KEYS = {"bounds", "offsets", "xy", "size", "orig", "offset", "rotate"}


@dataclass
class NewPage:
    """A page added by re-packing: its file name (next to the atlas), its texels, (H, W, 4) uint8,
    and the index of the atlas page its regions come from (one page each)."""

    name: str
    rgba: np.ndarray
    source: int = -1


def shelf_pack(sizes: list[tuple[int, int]], padding: int = PADDING,
               max_side: int = MAX_PAGE_SIDE) -> tuple[list[tuple[int, int, int]], list[tuple[int, int]]]:
    """Place rectangles on pages, shelf by shelf, tallest first.

    Parameters
    ----------
    sizes : list of (width, height)
    padding : int
        Empty texels left around every rectangle.
    max_side : int
        Largest page width and height; a rectangle larger than that gets a page of its own.

    Returns
    -------
    places : list of (page, x, y)
        Where each rectangle's top-left texel goes, in the order of ``sizes``.
    pages : list of (width, height)
        The size of each page.
    """
    order = sorted(range(len(sizes)), key=lambda i: (-sizes[i][1], -sizes[i][0], i))
    widest = max((w for w, _ in sizes), default=1) + 2 * padding
    area = sum((w + padding) * (h + padding) for w, h in sizes)
    width = int(min(max_side, max(widest, 2 ** int(np.ceil(np.log2(max(1.0, np.sqrt(area))))))))
    places: list[tuple[int, int, int] | None] = [None] * len(sizes)
    pages: list[list[int]] = [[0, 0]]
    x = y = shelf = padding
    page = 0
    for i in order:
        w, h = sizes[i]
        if x + w + padding > width and x > padding:  # next shelf
            x, y, shelf = padding, y + shelf + padding, 0
        if y + h + padding > max_side and y > padding:  # next page
            page, x, y, shelf = page + 1, padding, padding, 0
            pages.append([0, 0])
        places[i] = (page, x, y)
        pages[page][0] = max(pages[page][0], x + w + padding)
        pages[page][1] = max(pages[page][1], y + h + padding)
        x += w + padding
        shelf = max(shelf, h)
    return [p for p in places if p is not None], [(w, h) for w, h in pages]


def untrimmed_entries(region: AtlasRegion, syntax: str, x: int, y: int, width: int, height: int,
                      indent: str) -> list[Entry]:
    """``region``'s fields with its geometry replaced: stored whole at ``(x, y)``, not rotated.

    Other fields (``index``, ``split``, ``pad``...) keep their place after the geometry.
    """
    if syntax == "4":
        geometry = [Entry("bounds", [str(x), str(y), str(width), str(height)], indent)]
    else:
        geometry = [Entry("rotate", ["false"], indent), Entry("xy", [str(x), str(y)], indent),
                    Entry("size", [str(width), str(height)], indent),
                    Entry("orig", [str(width), str(height)], indent), Entry("offset", ["0", "0"], indent)]
    return geometry + [e for e in region.entries if e.key not in _GEOMETRY_KEYS]


def repack_atlas(atlas: Atlas, names: set[str], page_pixels, taken: set[str] = frozenset()) -> tuple[Atlas, list[NewPage]]:
    """A copy of ``atlas`` in which the regions called ``names`` are stored untrimmed on new pages.

    Parameters
    ----------
    atlas : Atlas
        Parsed atlas (with ``path`` set); not changed.
    names : set of str
        Regions to re-pack; names the atlas lacks are ignored.
    page_pixels : callable
        ``page_pixels(page_index)`` -> (H, W, 4) uint8, the page's texels as stored.
    taken : set of str, optional
        File names the new pages may not take, as :func:`spinemesh.files.names.portable_name` gives them (one
        file on every disk; files beside the atlas, in the project and in the output folder:
        another atlas of the same stem writes its pages there).

    Returns
    -------
    Atlas
        The new atlas: the moved regions under the new pages, appended after the old ones.
    list of NewPage
        The new pages' images, named ``<atlas stem>-untrimmed-<n>.png`` beside the atlas.
    """
    out = copy.deepcopy(atlas)
    moved = [r for r in out.regions if r.name in names]
    if not moved:
        return out, []
    stem = PurePosixPath(atlas.path.name if atlas.path else "atlas").name.split(".")[0]
    taken = {portable_name(p.name) for p in out.pages} | set(taken)
    indent = next((e.indent for r in out.regions for e in r.entries), "  " if out.syntax == "3" else "\t")
    new_pages: list[NewPage] = []
    for old_index in sorted({r.page for r in moved}):
        group = [r for r in moved if r.page == old_index]
        pixels = page_pixels(old_index)
        images = [cut_region(pixels, r, pma=False, source=str(atlas.path)) for r in group]
        places, sizes = shelf_pack([(im.shape[1], im.shape[0]) for im in images])
        first_new = len(out.pages)
        for k, (w, h) in enumerate(sizes):
            n = len(new_pages) + 1
            name = f"{stem}-untrimmed-{n}.png"
            while portable_name(name) in taken:
                n += 1
                name = f"{stem}-untrimmed-{n}.png"
            taken.add(portable_name(name))
            template: AtlasPage = out.pages[old_index]
            entries = [Entry(e.key, [str(w), str(h)] if e.key == "size" else list(e.values), e.indent, e.sep, e.colon)
                       for e in template.entries]
            if not any(e.key == "size" for e in entries):
                entries.insert(0, Entry("size", [str(w), str(h)], template.entries[0].indent if template.entries else ""))
            out.pages.append(AtlasPage(name, entries))
            new_pages.append(NewPage(name, np.zeros((h, w, 4), np.uint8), old_index))
        for region, image, (page, x, y) in zip(group, images, places):
            h, w = image.shape[:2]
            new_pages[first_new - len(atlas.pages) + page].rgba[y:y + h, x:x + w] = image
            region.page = first_new + page
            region.entries = untrimmed_entries(region, out.syntax, x, y, w, h, indent)
    return out, new_pages


def page_png(rgba: np.ndarray, source: Path, colour: tuple | None = None) -> bytes:
    """A new page's PNG file: ``rgba`` with the colour chunks of the page ``source`` its regions come
    from (gamma, sRGB, colour profile: :func:`spinemesh.pack.page_colours.page_colour`), so that an engine
    that manages colour draws them in the colours it drew them in. ``colour``: those chunks, when
    the caller has read them already."""
    import io

    from PIL import Image

    from ..pack.page_colours import page_colour
    from ..pack.png import with_colour_chunks

    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="PNG")
    colour = page_colour(source.read_bytes()) if colour is None else colour
    return with_colour_chunks(buf.getvalue(), colour) if colour else buf.getvalue()


def write_repacked_atlas(atlas_path: Path, names: set[str], project_root: Path, out: Path) -> list[str]:
    """Write the re-packed copy of ``atlas_path`` (and its new pages) to its place under ``out``.

    Parameters
    ----------
    atlas_path : Path
        An atlas of the project; read, never changed.
    names : set of str
        Its regions to store untrimmed.
    project_root, out : Path
        The project folder and the output folder (same layout).

    Returns
    -------
    list of str
        The new page files written, relative to ``out``.
    """
    from ..atlas import read_atlas
    from ..files.atomic import atomic_write_bytes, atomic_write_text
    from ..images.decode import load_rgba
    from ..images.sources import AtlasImages

    atlas = read_atlas(atlas_path)
    rel = atlas_path.relative_to(project_root)
    # two atlases of one stem (x.atlas, x.2.atlas) would name their new pages alike: the names of
    # every file beside the atlas, in the project and in the output (pages re-packed before), are taken
    taken = {portable_name(f.name) for folder in (atlas_path.parent, out / rel.parent) if folder.is_dir()
             for f in folder.iterdir()}
    repacked, pages = repack_atlas(
        atlas, names, lambda i: load_rgba(AtlasImages.page_path(atlas, atlas.pages[i].name, project_root)), taken)
    written = []
    for page in pages:
        source = AtlasImages.page_path(atlas, atlas.pages[page.source].name, project_root)
        atomic_write_bytes(out / rel.parent / page.name, page_png(page.rgba, source))
        written.append((rel.parent / page.name).as_posix())
    atomic_write_text(out / rel, repacked.dumps())
    return written

"""The rules that keep an atlas as it was: a page the packing cannot write back as it was drawn
(16 bits a channel, repeating, animated, turned by EXIF, sizes its atlas disagrees with) and a
packed atlas whose files would take more bytes.

Each raises :class:`~spinemesh.pack.atlas_pack.PackRefused` with the reason the report gives;
separate from :mod:`.run` so that every reason an atlas is kept can be read in one file.
"""

from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np

from ..images.decode import UNREADABLE_IMAGE
from .atlas_pack import PackRefused
from .png import png_bit_depth, png_chunks


def check_page_sizes(atlas, texels: list[np.ndarray]) -> None:
    """Refuse an atlas whose decoded pages disagree with its pages' fields (:func:`spinemesh.atlas.page_mismatches`).

    :func:`spinemesh.project.project_atlases` checked the images' headers already; this is the
    same rule on the texels the atlas is packed from.
    """
    from ..atlas import page_mismatches

    for m in page_mismatches(atlas, [(int(t.shape[1]), int(t.shape[0])) for t in texels]):
        raise PackRefused(m.message)


def check_eight_bits(data: bytes, name: str) -> None:
    """Refuse a PNG page of 16 bits a channel: texels are decoded, compared and written at 8,
    so a page written from it would lose the low bits of every texel unseen.

    Raises
    ------
    PackRefused
        Naming the page.
    """
    depth = png_bit_depth(data)
    if depth is not None and depth > 8:
        raise PackRefused(f"page {name!r} has 16 bits a channel, and packed pages are written at 8 "
                          "(its texels would lose their low bits)")


def check_no_repeat(page) -> None:
    """Refuse an atlas page (:class:`~spinemesh.atlas.AtlasPage`) that repeats (``repeat: x``, ``y``,
    ``xy``): it is sampled beyond its regions (a tiling texture, UVs a game scrolls), which no
    skeleton says, so no page its regions move to could be proven to draw as it.

    Raises
    ------
    PackRefused
        Naming the page and its axes.
    """
    from .proof import page_repeat

    if page_repeat(page) != "none":
        raise PackRefused(f"page {page.name!r} repeats ({page_repeat(page)}): a repeating page is sampled "
                          "beyond its regions (a tiling texture, UVs a game scrolls), which no skeleton says, "
                          "so a packed page could not be proven to draw as it")


#: EXIF's orientation tag: 1 is upright; 2 to 8 turn or mirror the stored image to show it.
EXIF_ORIENTATION = 0x0112


def check_one_upright_image(data: bytes, name: str) -> None:
    """Refuse a page file that runtimes draw differently: an animated one (an APNG, an animated
    WebP: a browser shows its frames in turn where texture loaders take one, and a packed page
    holds one) or one whose EXIF orientation turns or mirrors it (browsers turn such an image,
    texture loaders take its texels as stored). A packed page would silently drop either.

    Raises
    ------
    PackRefused
        Naming the page and what it holds.
    """
    from PIL import Image

    frames, exif = 1, None
    chunks = png_chunks(data)
    if chunks is not None:
        kinds = [kind for kind, _ in chunks]
        if b"acTL" in kinds:  # an APNG: its frames, and its default image where it is not the first
            frames = kinds.count(b"fcTL")
            if b"IDAT" in kinds and (b"fcTL" not in kinds or kinds.index(b"IDAT") < kinds.index(b"fcTL")):
                frames += 1
        exif = next((body for kind, body in chunks if kind == b"eXIf"), None)
    else:
        try:
            with Image.open(io.BytesIO(data)) as im:
                frames, exif = getattr(im, "n_frames", 1), im.info.get("exif")
        except UNREADABLE_IMAGE:  # its decode says why
            return
    if frames > 1:
        raise PackRefused(f"page {name!r} is animated ({frames:,} frames): a browser shows them in turn where "
                          "texture loaders take one, and a packed page would hold one")
    orientation = 1
    if exif:
        try:
            orientation = Image.Exif()
            orientation.load(bytes(exif))
            orientation = orientation.get(EXIF_ORIENTATION, 1)
        except (*UNREADABLE_IMAGE, KeyError, TypeError, struct.error):  # unreadable EXIF turns nothing
            orientation = 1
    if orientation not in (1, None):
        raise PackRefused(f"page {name!r} says to show it turned or mirrored (EXIF orientation {orientation}): "
                          "browsers turn it and texture loaders do not, and a packed page would drop it")


def is_lossy_webp(page: bytes | Path) -> bool:
    """Whether ``page`` (a file's bytes, or its path) is a WebP image stored lossy (a ``VP8 ``
    bitstream, not ``VP8L``).

    Reads the RIFF chunk headers only: the simple format starts with the bitstream chunk, the
    extended one (``VP8X``) lists its chunks (alpha, animation) before it.
    """
    with io.BytesIO(page) if isinstance(page, bytes) else open(page, "rb") as f:
        head = f.read(12)
        if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WEBP":
            return False
        for _ in range(64):  # a still image has a handful of chunks; never read a whole file
            chunk = f.read(8)
            if len(chunk) < 8:
                return False
            kind, size = chunk[:4], int.from_bytes(chunk[4:], "little")
            if kind in (b"VP8 ", b"VP8L"):
                return kind == b"VP8 "
            f.seek(size + (size & 1), 1)
    return False


def check_bytes_shrink(bytes_before: int, bytes_after: int, texels_before: int, texels_after: int) -> None:
    """Refuse a packed atlas whose files would take more bytes on disk than the original's.

    Fewer page texels is less texture memory, but a download grows with the bytes: an atlas
    whose original pages were optimised PNGs can take more bytes packed, even through oxipng
    (:mod:`spinemesh.pack.png`). By default such an atlas keeps its pages; ``larger_files``
    (``--larger-files``) writes it for its texels.

    Raises
    ------
    PackRefused
        When ``bytes_after`` exceeds ``bytes_before``.
    """
    if bytes_after > bytes_before:
        raise PackRefused(f"packed, its files would take {bytes_after:,} bytes against {bytes_before:,} "
                          f"(+{bytes_after / bytes_before - 1:.1%}) for {1 - texels_after / texels_before:.0%} fewer "
                          "page texels; --larger-files writes it all the same")


def check_lossy_pages_shrink(files: list, bytes_before: int, bytes_after: int) -> None:
    """Refuse a packed atlas whose lossy WebP pages, written losslessly, take more bytes on disk.

    Packed pages are written losslessly so that every texel a mesh samples stays as it was (a
    lossy re-encode would change the renders). For lossy originals that can cost more download
    size than the texture memory it saves: on every third corpus project, the packed WebP atlases
    took 143% more bytes for 9% fewer page texels. Such an atlas keeps its pages, unless
    ``larger_files`` (``--larger-files``): its pages written losslessly draw exactly what the
    lossy ones drew (their texels as decoded), for fewer texels and more bytes.

    Raises
    ------
    PackRefused
        When a page in ``files`` (paths, or the files' bytes) is lossy WebP and ``bytes_after``
        exceeds ``bytes_before``.
    """
    if bytes_after > bytes_before and any(is_lossy_webp(f) for f in files):
        raise PackRefused(f"its pages are lossy WebP: written losslessly, as packing must, they would take "
                          f"{bytes_after:,} bytes on disk against {bytes_before:,}; --larger-files writes it all the same")

"""What a page file says of the colours its texels stand for (its colour chunks), and which of
them the pages packed from each group of pages carry.

Separate from :mod:`.page_files` (the files written) because it is one rule of its own: pages whose
regions would share packed pages must say the same of their colours, or the atlas is kept.
"""

from __future__ import annotations

import io

from ..images.decode import UNREADABLE_IMAGE
from .atlas_pack import PackRefused, page_settings
from .png import chunk_differences, colour_chunks

#: What each colour chunk says, in words (the reason an atlas whose pages disagree is kept).
_COLOUR_WORDS = {b"iCCP": "a colour profile", b"sRGB": "sRGB", b"gAMA": "a gamma", b"cHRM": "chromaticities",
                 b"cICP": "colour code points", b"mDCv": "a mastering display", b"cLLi": "light levels"}


#: Which colour chunks each format written can carry (WebP and AVIF: a colour profile, as Pillow writes it).
_CARRIED = {"PNG": set(_COLOUR_WORDS), "WEBP": {b"iCCP"}, "AVIF": {b"iCCP"}}


def page_colour(data: bytes) -> tuple[tuple[bytes, bytes], ...]:
    """What a page file says of the colours its texels stand for: its colour chunks, ``(type,
    data)`` as a PNG file stores them (:func:`spinemesh.pack.png.colour_chunks`); for another
    format its colour profile as a PNG ``iCCP`` chunk would hold it, or nothing.

    Read from the original pages (packed pages carry them) and from every page written (which
    must say the same, :func:`.page_files.decoded_as`). A file Pillow cannot open says nothing (it fails
    its decode elsewhere).
    """
    import zlib

    from PIL import Image

    found = colour_chunks(data)
    if found is not None:
        return found
    try:
        with Image.open(io.BytesIO(data)) as im:
            profile = im.info.get("icc_profile")
    except UNREADABLE_IMAGE:  # its decode says why
        return ()
    return ((b"iCCP", b"icc\0\0" + zlib.compress(profile)),) if profile else ()


def colour_words(colour: tuple[tuple[bytes, bytes], ...]) -> str:
    """:func:`page_colour` in words: ``sRGB and a gamma``, ``no colour information``."""
    words = list(dict.fromkeys(_COLOUR_WORDS.get(k, k.decode("latin-1")) for k, _ in colour))
    return " and ".join(words) if words else "no colour information"


def colours_by_settings(atlas, colours: list) -> dict[tuple, tuple]:
    """The colour chunks of the pages packed from each group of ``atlas``'s pages, by the group's
    settings (:func:`spinemesh.pack.atlas_pack.page_settings`: pages of the same settings share
    packed pages).

    Parameters
    ----------
    atlas : Atlas
    colours : list of tuple
        :func:`page_colour` of each page, in page order.

    Raises
    ------
    PackRefused
        When two pages whose regions would share packed pages say different things of their
        colours (one sRGB, one a colour profile; one a gamma, one none): one page cannot say both.
    """
    found: dict[tuple, tuple[str, tuple]] = {}
    for page, colour in zip(atlas.pages, colours):
        key = page_settings(page)
        if key not in found:
            found[key] = (page.name, colour)
            continue
        first, seen = found[key]
        if chunk_differences(seen, colour):
            a, b = colour_words(seen), colour_words(colour)
            if a == b:
                a, b = f"{a}, one", f"{b}, another"
            raise PackRefused(f"its pages are in different colour spaces (page {first!r} says {a}, page "
                              f"{page.name!r} {b}): packed, their regions would share pages, which can say "
                              "only one")
    return {key: colour for key, (_, colour) in found.items()}


def packed_page_colours(packed_atlas, group_colour: dict[tuple, tuple]) -> dict[str, tuple]:
    """The colour chunks each page of ``packed_atlas`` carries, by page name: those of the original
    pages of its settings (:func:`colours_by_settings`).

    Raises
    ------
    PackRefused
        For a packed page whose settings no original page has, unless every original page says
        the same (a page whose origin cannot be told cannot say whose colours it holds).
    """
    said = list(group_colour.values())
    colours = {}
    for page in packed_atlas.pages:
        key = page_settings(page)
        if key in group_colour:
            colours[page.name] = group_colour[key]
        elif said and all(not chunk_differences(said[0], c) for c in said):
            colours[page.name] = said[0]
        else:
            raise PackRefused(f"packed page {page.name!r} has settings no original page has, so its "
                              "colour information cannot be told")
    return colours

"""``--images``: the original-size image of each region, for the editor to re-import.

Written to a folder of its own as the planning stage meets each image
(:func:`write_editor_image`).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..files.atomic import atomic_write_bytes
from ..files.disk import file_stamp
from ..files.inside import resolve_inside
from ..images.sources import RegionImage
from ..images.texels import premultiply, unpremultiply
from ..pack.png import profile_misfit


@lru_cache(maxsize=8)
def _colour_of(source: str, stamp: tuple) -> tuple:
    """The colour chunks of the page ``source`` (:func:`spinemesh.pack.page_colours.page_colour`), read once
    for all of its regions; ``stamp`` (:func:`~spinemesh.files.disk.file_stamp`) reads a changed page again."""
    from ..pack.page_colours import page_colour

    return page_colour(Path(source).read_bytes())


def write_editor_image(frame: RegionImage, folder: Path) -> None:
    """``<folder>/<path>.png``, the original-size image the editor re-imports.

    Atlas images exported at a scale other than 1 are resized back to skeleton size. The image
    carries the colour chunks of the page it was cut from (a colour profile, sRGB, gamma), as a
    page ``--repack`` adds does: without them, an editor or an engine that manages colour shows
    the texels of a page in Display P3 or of gamma 1.0 in other colours.
    """
    from .repack import page_png

    rgba = frame.rgba
    if frame.scale != 1:
        import cv2

        from ..limits import check_image_size

        h, w = rgba.shape[:2]
        size = (max(1, round(w / frame.scale)), max(1, round(h / frame.scale)))
        # the size the page's scale implies, checked before it is allocated
        check_image_size(*size, f"editor image {frame.name!r} at atlas scale {frame.scale:g}", frame.source)
        # resized premultiplied: interpolated straight, the colour of transparent texels (black,
        # or whatever a packer left) ran into the edge's texels, a dark fringe in the editor
        rgba = unpremultiply(cv2.resize(premultiply(rgba), size, interpolation=cv2.INTER_CUBIC))
    target = resolve_inside(folder, frame.name + ".png", folder, "--images folder")
    source = Path(frame.source)
    colour = _colour_of(str(source), file_stamp(source))
    data = page_png(rgba, source, colour)
    if misfit := profile_misfit(data):
        # a grey page's (grey) profile fits grey texels only: such an image is written grey
        grey = bool((rgba[..., 0] == rgba[..., 1]).all() and (rgba[..., 1] == rgba[..., 2]).all())
        data = page_png(np.ascontiguousarray(rgba[..., ::3]), source, colour) if grey else data
        if not grey or profile_misfit(data):
            raise SpineMeshError(f"its page's colour profile cannot be carried: {misfit}", frame.source)
    atomic_write_bytes(target, data)

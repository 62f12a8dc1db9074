"""``--images``: the original-size image of each region, for the editor to re-import.

Written to a folder of its own as the planning stage meets each image
(:func:`write_editor_image`).
"""

from __future__ import annotations

from pathlib import Path

from ..fsutil import atomic_write_png, resolve_inside
from ..images import RegionImage


def write_editor_image(frame: RegionImage, folder: Path) -> None:
    """``<folder>/<path>.png``, the original-size image the editor re-imports.

    Atlas images exported at a scale other than 1 are resized back to skeleton size.
    """
    rgba = frame.rgba
    if frame.scale != 1:
        import cv2

        from ..limits import check_image_size

        h, w = rgba.shape[:2]
        size = (max(1, round(w / frame.scale)), max(1, round(h / frame.scale)))
        # the size the page's scale implies, checked before it is allocated
        check_image_size(*size, f"editor image {frame.name!r} at atlas scale {frame.scale:g}", frame.source)
        rgba = cv2.resize(rgba, size, interpolation=cv2.INTER_CUBIC)
    atomic_write_png(resolve_inside(folder, frame.name + ".png", folder, "--images folder"), rgba)

"""A small Spine 4.2 project drawn by code: the bundled demo and a test fixture.

``make_demo_project(folder)`` draws a few sprites (a two-colour body, a head, a ring with a
hole, two separate blobs, a three-frame spark sequence), packs them into a 4.x atlas the
way packers do (whitespace stripped, one region rotated by 90 degrees), and writes a
skeleton JSON with bones, slots, a skin and a short animation. Everything is drawn from
numbers, so the project is ours to ship.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from .files.atomic import atomic_write_png, atomic_write_text


def _canvas(w: int, h: int) -> tuple[Image.Image, ImageDraw.ImageDraw]:
    im = Image.new("RGBA", (w, h), (0, 0, 0, 0))
    return im, ImageDraw.Draw(im)


def demo_images() -> dict[str, np.ndarray]:
    """The demo's sprites at original size, by image path."""
    out = {}
    im, d = _canvas(120, 160)
    d.ellipse((10, 10, 110, 150), fill=(70, 110, 200, 255))
    d.ellipse((30, 60, 90, 140), fill=(240, 200, 60, 255))  # a belly: an interior boundary
    out["demo-body"] = np.asarray(im)
    im, d = _canvas(90, 90)
    d.ellipse((5, 5, 85, 85), fill=(250, 210, 170, 255))
    d.ellipse((25, 30, 38, 43), fill=(30, 30, 30, 255))
    d.ellipse((52, 30, 65, 43), fill=(30, 30, 30, 255))
    out["demo-head"] = np.asarray(im)
    im, d = _canvas(100, 100)
    d.ellipse((4, 4, 96, 96), fill=(200, 60, 60, 255))
    d.ellipse((30, 30, 70, 70), fill=(0, 0, 0, 0))  # the hole
    out["demo-ring"] = np.asarray(im)
    im, d = _canvas(140, 60)
    d.ellipse((5, 5, 55, 55), fill=(60, 180, 90, 255))
    d.rectangle((85, 10, 135, 50), fill=(60, 180, 90, 255))
    out["demo-blobs"] = np.asarray(im)
    im, d = _canvas(40, 120)
    d.rounded_rectangle((8, 4, 32, 116), radius=10, fill=(250, 210, 170, 255))
    out["demo-arm"] = np.asarray(im)
    for i in range(3):
        im, d = _canvas(64, 64)
        r = 12 + 8 * i
        d.regular_polygon((32, 32, r), 5, rotation=20 * i, fill=(255, 240, 120, 255))
        out[f"demo-spark/frame{i + 1}"] = np.asarray(im)
    return out


def _trim(rgba: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Crop to the opaque box; returns the crop and its left and bottom whitespace."""
    ys, xs = np.nonzero(rgba[..., 3])
    top, bottom, left, right = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    return rgba[top:bottom, left:right], int(left), int(rgba.shape[0] - bottom)


def pack_atlas(images: dict[str, np.ndarray], page_name: str, rotate: set[str] = frozenset(),
               keep_whitespace: tuple[str, ...] = (), padding: int = 2) -> tuple[str, np.ndarray]:
    """Pack images on one page, shelf by shelf; returns the 4.x atlas text and the page.

    Images named in ``rotate`` are stored turned 90 degrees counter-clockwise, as packers do.
    Images whose names start with one of ``keep_whitespace`` are stored whole, as packers are
    told to do for sequences, whose frames must share one rectangle.
    """
    placed = []
    x = y = shelf = 0
    width = 512
    for name, rgba in images.items():
        crop, off_x, off_y = (rgba, 0, 0) if name.startswith(tuple(keep_whitespace)) else _trim(rgba)
        stored = np.rot90(crop, 1) if name in rotate else crop
        h, w = stored.shape[:2]
        if x + w + padding > width:
            x, y, shelf = 0, y + shelf + padding, 0
        placed.append((name, rgba, crop, stored, x + padding, y + padding, off_x, off_y))
        x += w + padding
        shelf = max(shelf, h)
    height = int(2 ** np.ceil(np.log2(y + shelf + 2 * padding)))
    page = np.zeros((height, width, 4), np.uint8)
    lines = [page_name, f"\tsize: {width}, {height}", "\tfilter: Linear, Linear"]
    for name, rgba, crop, stored, px, py, off_x, off_y in placed:
        page[py:py + stored.shape[0], px:px + stored.shape[1]] = stored
        lines += [name, f"\tbounds: {px}, {py}, {crop.shape[1]}, {crop.shape[0]}"]
        if crop.shape != rgba.shape:
            lines.append(f"\toffsets: {off_x}, {off_y}, {rgba.shape[1]}, {rgba.shape[0]}")
        if name in rotate:
            lines.append("\trotate: 90")
    return "\n".join(lines) + "\n", page


def demo_skeleton(images: dict[str, np.ndarray]) -> dict:
    """A 4.2 skeleton using every demo image as a region attachment."""
    size = {k: (int(v.shape[1]), int(v.shape[0])) for k, v in images.items()}

    def region(path, x=0.0, y=0.0, rotation=0.0, **extra):
        w, h = size[path]
        att = {"x": x, "y": y}
        if rotation:
            att["rotation"] = rotation
        att.update(extra)
        att.update({"width": w, "height": h})
        return att

    return {
        "skeleton": {"hash": "c3BpbmVtc2g", "spine": "4.2.40", "x": -150, "y": -20,
                     "width": 400, "height": 330, "images": "./images/", "audio": ""},
        "bones": [
            {"name": "root"},
            {"name": "body", "parent": "root", "y": 90},
            {"name": "head", "parent": "body", "y": 120},
            {"name": "arm", "parent": "body", "x": 55, "y": 40, "rotation": -20},
            {"name": "props", "parent": "root", "x": 170, "y": 60},
        ],
        "slots": [
            {"name": "arm", "bone": "arm", "attachment": "demo-arm"},
            {"name": "body", "bone": "body", "attachment": "demo-body"},
            {"name": "head", "bone": "head", "attachment": "demo-head"},
            {"name": "ring", "bone": "props", "attachment": "demo-ring"},
            {"name": "blobs", "bone": "props", "attachment": "demo-blobs"},
            {"name": "spark", "bone": "head", "attachment": "spark", "color": "ffffffc0"},
        ],
        "skins": [{"name": "default", "attachments": {
            "arm": {"demo-arm": region("demo-arm", y=-50, rotation=90, scaleX=0.9)},
            "body": {"demo-body": region("demo-body")},
            "head": {"demo-head": region("demo-head", y=10)},
            "ring": {"demo-ring": region("demo-ring", y=120, scaleX=0.8, scaleY=0.8)},
            "blobs": {"demo-blobs": region("demo-blobs", x=10, y=-10, rotation=15)},
            "spark": {"spark": region("demo-spark/frame1", x=40, y=50, color="ffe0a0ff",
                                      sequence={"count": 3, "setup": 0})
                      | {"path": "demo-spark/frame"}},
        }}],
        "animations": {"wave": {
            "bones": {"arm": {"rotate": [{"value": 0}, {"time": 0.5, "value": 40}, {"time": 1, "value": 0}]},
                      "head": {"rotate": [{"value": 0}, {"time": 0.5, "value": -10}, {"time": 1, "value": 0}]}},
            "attachments": {"default": {"spark": {"spark": {"sequence": [{"mode": "loop", "delay": 0.1}]}}}},
        }},
    }


def make_demo_project(folder: str | Path, with_images_folder: bool = True) -> Path:
    """Write the demo project (``demo.json``, ``demo.atlas``, ``demo.png``, ``images/``) to ``folder``."""
    folder = Path(folder)
    images = demo_images()
    atlas_text, page = pack_atlas(images, "demo.png", rotate={"demo-arm"}, keep_whitespace=("demo-spark/",))
    atomic_write_text(folder / "demo.atlas", atlas_text)
    atomic_write_png(folder / "demo.png", page)
    doc = demo_skeleton(images)
    # The spark's region key is its sequence's base path; its frames are spark/frame1..3.
    atomic_write_text(folder / "demo.json", json.dumps(doc, indent="\t") + "\n")
    from .files.atomic import atomic_write_bytes
    from .skeleton_binary import encode_skel

    atomic_write_bytes(folder / "demo-binary.skel", encode_skel(doc))
    if with_images_folder:
        for name, rgba in images.items():
            atomic_write_png(folder / "images" / f"{name}.png", rgba)
    return folder

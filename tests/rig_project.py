"""A small bendy project drawn by our own code: a worm on a chain of three bones.

One 240x60 image (a striped capsule) in a one-page atlas; bones ``root`` -> ``seg1`` ->
``seg2`` -> ``seg3``, each 80 units long along the worm; the region hangs on ``seg1``; the
animation ``wiggle`` turns ``seg2`` and ``seg3``. Used by the rig tests and by
``scripts/make_weights_figure.py`` for the README picture.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image

WIDTH, HEIGHT = 240, 60


def worm_image() -> np.ndarray:
    """RGBA (60, 240, 4): a striped body tapering to both ends, transparent around it."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    half = 4 + 24 * np.sin(np.pi * (x + 0.5) / WIDTH) ** 0.7
    inside = np.abs(y + 0.5 - HEIGHT / 2) <= half
    rgba = np.zeros((HEIGHT, WIDTH, 4), np.uint8)
    stripe = (x // 20) % 2 == 0
    rgba[..., 0] = np.where(stripe, 220, 90)
    rgba[..., 1] = np.where(stripe, 120, 200)
    rgba[..., 2] = 80
    rgba[..., 3] = np.where(inside, 255, 0)
    return rgba


def worm_skeleton(version: str = "4.2.22") -> dict:
    return {
        "skeleton": {"hash": "d29ybXdvcm0", "spine": version, "x": -130, "y": -40, "width": 260, "height": 80},
        "bones": [
            {"name": "root"},
            {"name": "seg1", "parent": "root", "length": 80, "x": -120},
            {"name": "seg2", "parent": "seg1", "length": 80, "x": 80},
            {"name": "seg3", "parent": "seg2", "length": 80, "x": 80},
        ],
        "slots": [{"name": "worm", "bone": "seg1", "attachment": "worm"}],
        "skins": [{"name": "default", "attachments": {
            "worm": {"worm": {"x": 120, "width": WIDTH, "height": HEIGHT}}}}],
        "animations": {"wiggle": {"bones": {
            "seg2": {"rotate": [{"value": 0}, {"time": 0.5, "value": 35}, {"time": 1, "value": 0}]},
            "seg3": {"rotate": [{"value": 0}, {"time": 0.5, "value": 40}, {"time": 1, "value": 0}]},
        }}},
    }


def make_worm_project(folder: str | Path) -> Path:
    """Write ``worm.json``, ``worm.atlas`` and ``worm.png`` into ``folder``; returns the skeleton path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    page = np.zeros((64, 256, 4), np.uint8)
    page[2:2 + HEIGHT, 2:2 + WIDTH] = worm_image()
    Image.fromarray(page).save(folder / "worm.png")
    (folder / "worm.atlas").write_text(
        "worm.png\n\tsize: 256, 64\n\tfilter: Linear, Linear\nworm\n\tbounds: 2, 2, 240, 60\n")
    path = folder / "worm.json"
    path.write_text(json.dumps(worm_skeleton(), indent=1))
    return path

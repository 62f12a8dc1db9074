"""Driving ``../shared/tools/spine-runtime`` (the official Spine runtime in Node) from tests."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
from PIL import Image

from conftest import SHARED

TOOL = SHARED / "tools" / "spine-runtime"


def install(dest: Path) -> Path | None:
    """Copy the tool (``../shared`` is read-only) and ``npm ci`` it; None if Node is missing."""
    if not TOOL.is_dir() or not shutil.which("node") or not shutil.which("npm"):
        return None
    shutil.copytree(TOOL, dest, ignore=shutil.ignore_patterns("node_modules"))
    r = subprocess.run(["npm", "ci", "--no-audit", "--no-fund"], cwd=dest, capture_output=True, text=True)
    return dest if r.returncode == 0 else None


def node(tool: Path, *args) -> subprocess.CompletedProcess:
    return subprocess.run(["node", *map(str, args)], cwd=tool, capture_output=True, text=True, timeout=300)


def render(tool: Path, atlas: Path, skeleton: Path, anim: str | None, times: str, prefix: Path,
           frame_from: Path | None = None) -> list[Path]:
    args = ["render.mjs", atlas, skeleton, "--out", prefix]
    if anim:
        args += ["--anim", anim, "--times", times]
    if frame_from:
        args += ["--frame-from", frame_from]
    r = node(tool, *args)
    assert r.returncode == 0, f"render of {skeleton} failed: {r.stderr[-2000:]}"
    return sorted(prefix.parent.glob(prefix.name + ".*.png"))


def dump(tool: Path, atlas: Path, skeleton: Path, anim: str | None, times: str, out: Path) -> None:
    args = ["dump.mjs", atlas, skeleton, "--out", out]
    if anim:
        args += ["--anim", anim, "--times", times]
    r = node(tool, *args)
    assert r.returncode == 0, f"dump of {skeleton} failed: {r.stderr[-2000:]}"


def compare_dumps(tool: Path, a: Path, b: Path) -> tuple[bool, str]:
    r = node(tool, "compare.mjs", a, b, "--quiet")
    return r.returncode == 0, (r.stdout + r.stderr)[-3000:]


def render_difference(a: Path, b: Path, tol: int = 2) -> dict:
    """Share of pixels off by more than ``tol``/255, and pixels visible in ``a`` (alpha >= 8) lost in ``b``.

    Colours are compared premultiplied by alpha, as they are composited: the PNGs store
    straight colour, and a pixel with alpha 0 may carry any colour there (a mesh drawn over
    transparent texels leaves their colour in it) while it shows nothing.
    """
    pa = _premultiplied(np.asarray(Image.open(a).convert("RGBA")).astype(int))
    pb = _premultiplied(np.asarray(Image.open(b).convert("RGBA")).astype(int))
    off = np.abs(pa - pb).max(-1) > tol
    lost = (pa[..., 3] >= 8) & (pb[..., 3] == 0)
    return {"off_share": float(off.mean()), "lost": int(lost.sum()), "visible": int((pa[..., 3] >= 8).sum()),
            "lost_where": [tuple(map(int, p)) for p in np.argwhere(lost)[:5]]}


def _premultiplied(rgba: np.ndarray) -> np.ndarray:
    """RGBA (H, W, 4) ints 0..255 with colour multiplied by alpha, rounded."""
    out = rgba.copy()
    out[..., :3] = (rgba[..., :3] * rgba[..., 3:] + 127) // 255
    return out


def first_animation(skeleton_json_or_doc) -> str | None:
    doc = skeleton_json_or_doc
    if isinstance(doc, Path):
        doc = json.loads(doc.read_text(encoding="utf-8-sig"))
    anims = doc.get("animations") or {}
    return next(iter(anims), None)

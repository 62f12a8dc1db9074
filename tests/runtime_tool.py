"""Driving ``../shared/tools/spine-runtime`` (the official Spine runtime in Node) from tests."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from conftest import SHARED

TOOL = SHARED / "tools" / "spine-runtime"


class ToolUnavailable(Exception):
    """The runtime tool cannot be set up here; the message says why."""


#: ``npm ci`` fetches nothing when the npm cache has the packages, but a cold cache on a
#: slow network can take minutes; past this it is reported rather than waited for.
NPM_CI_TIMEOUT_S = 600


def install(dest: Path) -> Path:
    """Copy the tool (``../shared`` is read-only) to ``dest`` and ``npm ci`` it, once.

    A later call with the same ``dest`` (another pytest-xdist worker) reuses a finished
    install. Raises :class:`ToolUnavailable` with the cause, and npm's own error output
    when ``npm ci`` fails or times out.
    """
    done = dest / ".installed"
    if done.is_file():
        return dest
    if not (TOOL / "package.json").is_file():
        raise ToolUnavailable(f"{TOOL} is absent")
    for program in ("node", "npm"):
        if not shutil.which(program):
            raise ToolUnavailable(f"{program} is not installed (the official Spine runtime runs on Node)")
    if dest.exists():
        shutil.rmtree(dest)  # a half-done install of an interrupted run
    shutil.copytree(TOOL, dest, ignore=shutil.ignore_patterns("node_modules"))
    try:
        r = subprocess.run(["npm", "ci", "--no-audit", "--no-fund"], cwd=dest, capture_output=True, text=True,
                           timeout=NPM_CI_TIMEOUT_S)
    except subprocess.TimeoutExpired as e:
        err = e.stderr.decode(errors="replace") if isinstance(e.stderr, bytes) else e.stderr or ""
        raise ToolUnavailable(f"npm ci in {dest} took over {NPM_CI_TIMEOUT_S} s: {err[-2000:]}") from None
    if r.returncode != 0:
        raise ToolUnavailable(f"npm ci in {dest} failed ({r.returncode}):\n{(r.stdout + r.stderr)[-3000:]}")
    done.write_text("ok\n")
    return dest


def install43(dest: Path) -> Path:
    """``tests/runtime43`` (the official spine-core 4.3) copied to ``dest`` and ``npm ci``-ed, once.

    Raises :class:`ToolUnavailable` with the cause."""
    if (dest / "node_modules").is_dir():
        return dest
    for program in ("node", "npm"):
        if not shutil.which(program):
            raise ToolUnavailable(f"{program} is not installed (the official Spine runtime runs on Node)")
    shutil.rmtree(dest, ignore_errors=True)
    shutil.copytree(Path(__file__).parent / "runtime43", dest, ignore=shutil.ignore_patterns("node_modules"))
    r = subprocess.run(["npm", "ci", "--no-audit", "--no-fund"], cwd=dest, capture_output=True, text=True,
                       timeout=NPM_CI_TIMEOUT_S)
    if r.returncode:
        shutil.rmtree(dest / "node_modules", ignore_errors=True)
        raise ToolUnavailable(f"npm ci in {dest} failed ({r.returncode}):\n{(r.stdout + r.stderr)[-3000:]}")
    return dest


def node(tool: Path, *args) -> subprocess.CompletedProcess:
    return subprocess.run(["node", *map(str, args)], cwd=tool, capture_output=True, text=True, timeout=300)


def _pose_args(anim: str | None, times: str, poses: str | None, skin: str | None) -> list:
    """Harness options for one animation at ``times``, a ``--poses`` list, a skin."""
    args = []
    if anim:
        args += ["--anim", anim, "--times", times]
    if poses:
        args += ["--poses", poses]
    if skin:
        args += ["--skin", skin]
    return args


def render(tool: Path, atlas: Path, skeleton: Path, anim: str | None, times: str, prefix: Path,
           frame_from: Path | None = None, poses: str | None = None, skin: str | None = None,
           frame: tuple[float, float, float, float] | None = None) -> list[Path]:
    """Render ``anim`` at ``times``; the frame is the file's bounds, ``frame_from``'s frame, or
    ``frame`` (x, y, width, height in world units)."""
    args = ["render.mjs", atlas, skeleton, "--out", prefix, *_pose_args(anim, times, poses, skin)]
    if frame_from:
        args += ["--frame-from", frame_from]
    elif frame:
        args += ["--frame", ",".join(f"{v:g}" for v in frame)]
    r = node(tool, *args)
    assert r.returncode == 0, f"render of {skeleton} failed: {r.stderr[-2000:]}"
    return sorted(prefix.parent.glob(prefix.name + ".*.png"))


def dump(tool: Path, atlas: Path, skeleton: Path, anim: str | None, times: str, out: Path,
         poses: str | None = None, skin: str | None = None) -> None:
    args = ["dump.mjs", atlas, skeleton, "--out", out, *_pose_args(anim, times, poses, skin)]
    r = node(tool, *args)
    assert r.returncode == 0, f"dump of {skeleton} failed: {r.stderr[-2000:]}"


def pose_dump(tool: Path, atlas: Path, skeleton: Path, out: Path, anim: str, times: str = "0,0.5") -> dict:
    """:func:`dump` of one animation at ``times``, loaded."""
    dump(tool, atlas, skeleton, anim, times, out)
    return json.loads(out.read_text())


def max_difference(a, b, path: str = "") -> float:
    """Largest difference between the numbers of two dumps of one skeleton; everything else
    (keys, lengths, strings) must be equal. The input files, timings and hash are not compared."""
    if isinstance(a, dict):
        keys = set(a) - {"input", "timing_ms", "hash"}
        assert keys == set(b) - {"input", "timing_ms", "hash"}, path
        return max([max_difference(a[k], b[k], f"{path}/{k}") for k in keys] + [0.0])
    if isinstance(a, list):
        assert len(a) == len(b), path
        return max([max_difference(x, y, path) for x, y in zip(a, b)] + [0.0])
    if isinstance(a, (int, float)) and not isinstance(a, bool):
        return abs(a - b)
    assert a == b, (path, a, b)
    return 0.0


def compare_dumps(tool: Path, a: Path, b: Path) -> tuple[bool, str]:
    r = node(tool, "compare.mjs", a, b, "--quiet")
    return r.returncode == 0, (r.stdout + r.stderr)[-3000:]


def render_difference(a: Path, b: Path, tol: int = 2, where: int = 5) -> dict:
    """Share of pixels off by more than ``tol``/255, and pixels visible in ``a`` (alpha >= 8) lost in ``b``.

    Also: ``worst``, the largest difference in /255; ``off``, how many pixels are off;
    ``added``, pixels visible in ``b`` where ``a`` draws nothing (alpha 0). ``lost_where`` and
    ``added_where`` list the first ``where`` of those pixels as (row, column).

    Colours are compared premultiplied by alpha, as they are composited: the PNGs store
    straight colour, and a pixel with alpha 0 may carry any colour there (a mesh drawn over
    transparent texels leaves their colour in it) while it shows nothing.
    """
    # uint8 throughout (premultiplied colour fits in it): renders of large skeletons hold
    # tens of millions of pixels, and int64 copies of them took a minute per case.
    pa = _premultiplied(np.asarray(Image.open(a).convert("RGBA")))
    pb = _premultiplied(np.asarray(Image.open(b).convert("RGBA")))
    d = cv2.split(cv2.absdiff(pa, pb))
    delta = cv2.max(cv2.max(d[0], d[1]), cv2.max(d[2], d[3]))
    off = delta > tol
    lost = (pa[..., 3] >= 8) & (pb[..., 3] == 0)
    added = (pb[..., 3] >= 8) & (pa[..., 3] == 0)
    return {"off_share": float(off.mean()), "lost": int(lost.sum()), "visible": int((pa[..., 3] >= 8).sum()),
            "lost_where": [tuple(map(int, p)) for p in np.argwhere(lost)[:where]],
            "worst": int(delta.max(initial=0)), "off": int(off.sum()), "added": int(added.sum()),
            "added_where": [tuple(map(int, p)) for p in np.argwhere(added)[:where]]}


#: A pixel drawn by one side only whose centre lies this close (screen pixels) to an edge of a
#: region's quad is a rasterisation tie, not art added or lost: the mesh's outline runs along
#: the quad's edge wherever the art reaches the border of its stored rectangle (always, for
#: trimmed regions), but between other end points, and the rasteriser snaps end points to a
#: sub-pixel grid, so centres within a small fraction of a pixel of that edge fall either way.
TIE_PX = 1 / 32


def edge_distances(pixels: list[tuple[int, int]], attachments: list[dict], frame: dict, ppu: float) -> np.ndarray:
    """Distance (screen pixels) from each pixel's centre to the nearest edge of a region quad.

    Parameters
    ----------
    pixels : list of (row, column)
    attachments : list of dict
        One pose's draw list from a harness dump of the original.
    frame : dict
        The render's frame (``x``, ``y``, ``width``, ``height``, world units), ``ppu`` its scale.

    Returns
    -------
    ndarray, shape (len(pixels),)
        ``inf`` where the pose draws no region.
    """
    quads = [np.asarray(a["vertices"], float).reshape(4, 2) for a in attachments if a["type"] == "region"]
    if not pixels or not quads:
        return np.full(len(pixels), np.inf)
    q = np.stack(quads)  # (Q, 4, 2) world, y up
    q = np.stack([(q[..., 0] - frame["x"]) * ppu, (frame["y"] + frame["height"] - q[..., 1]) * ppu], -1)
    a, b = q, np.roll(q, -1, axis=1)  # (Q, 4, 2) edges a -> b
    c = np.asarray(pixels, float)[:, ::-1] + 0.5  # (P, 2) centres, x then y
    ab = (b - a)[None]
    t = np.clip(((c[:, None, None] - a[None]) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
    nearest = a[None] + t[..., None] * ab
    return np.linalg.norm(c[:, None, None] - nearest, axis=-1).reshape(len(pixels), -1).min(axis=1)


def _premultiplied(rgba: np.ndarray) -> np.ndarray:
    """RGBA (H, W, 4) uint8 with colour multiplied by alpha, rounded (uint8 out)."""
    r, g, b, a = cv2.split(rgba)
    # OpenCV rounds x * a / 255 to nearest, which equals (x * a + 127) // 255 for every pair
    # of 8-bit values (checked over all 65,536), at a fraction of numpy's cost.
    return cv2.merge([cv2.multiply(c, a, scale=1 / 255) for c in (r, g, b)] + [a])


def first_animation(skeleton_json_or_doc) -> str | None:
    doc = skeleton_json_or_doc
    if isinstance(doc, Path):
        doc = json.loads(doc.read_text(encoding="utf-8-sig"))
    anims = doc.get("animations") or {}
    return next(iter(anims), None)


#: Why a bone of a 3.8 skeleton is not compared with the harness's 3.8 runtime (a port).
PORT_38_PATHS = ("the harness's 3.8 runtime (a port) lays this path constraint's bones unlike the official 3.8 one "
                 "(chain modes never turned to the next point; spacing as before 3.7): proved against the "
                 "official 4.0 runtime instead (tests/test_runtime_edges.py)")


def unlike_official_38(doc: dict, active: set[str] | None = None) -> set[str]:
    """Bones of a 3.8 skeleton that the harness's 3.8 port poses unlike the official 3.8 runtime:
    those of a path constraint the two lay apart (``spinemesh.rig.constraints.solver.lays_apart_38``),
    of the constraints that read them, and every bone below those. Empty for other versions.
    ``active``: the names of the path constraints the skin posed activates (default: all)."""
    from spinemesh.skeleton_version import doc_major_minor

    if doc_major_minor(doc) != (3, 8):
        return set()
    from spinemesh.rig.constraints.solver import lays_apart_38

    affected = {b for c in doc.get("path") or [] if lays_apart_38(c) and (active is None or c.get("name") in active)
                for b in c.get("bones") or []}
    parents = {b.get("name"): b.get("parent") for b in doc.get("bones") or []}
    slot_bones = {s.get("name"): s.get("bone") for s in doc.get("slots") or []}
    # each constraint with the bone it reads: an IK's or transform's target, a path's slot's bone
    readers = [(c, c.get("target")) for kind in ("ik", "transform") for c in doc.get(kind) or []]
    readers += [(c, slot_bones.get(c.get("target"))) for c in doc.get("path") or []]
    while True:
        grown = set(affected)
        for c, read in readers:
            if read in grown:
                grown |= set(c.get("bones") or [])
        for name in parents:
            up = name
            while up is not None and up not in grown:
                up = parents.get(up)
            if up is not None:
                grown.add(name)
        if grown == affected:
            return affected
        affected = grown

"""Sprites with alpha from real Spine projects, split by game, for training and evaluation.

Until ``spinemesh dataset`` (issue 6) lands, this is the small adapter that gathers
samples directly: every atlas region of ``../shared/spine-corpus`` (cut at its original
size by :mod:`spinemesh.images`) and every image of the 4.2 ``spine-examples`` ``images/``
folders (the other versions hold the same art, so they are left out to avoid duplicates).

Data is read at run time and nothing is written: the licence of the corpus forbids copying
it into the repository.

Numpy and OpenCV only: nothing here imports torch.
"""

from __future__ import annotations

import csv
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from ..atlas import read_atlas
from ..errors import SpineMeshError
from ..images import cut_region, load_rgba, premultiply, unpremultiply
from ..fsutil import resolve_inside

#: Percent of games held out for validation (a stable hash of the game's name decides).
#: With the salt below this holds out 8 games (3 corpus repositories, 5 official examples),
#: about 13% of the sprites; the salt was picked among the first 40 so that no single game
#: makes up most of the validation set.
VAL_PERCENT = 15

#: Salt of the split hash; changing it changes which games are held out.
SPLIT_SALT = "spinemesh-segment-v17"


@dataclass
class Sprite:
    """One sprite image with its provenance.

    Attributes
    ----------
    id : str
        ``<project>/<region name>`` (unique after de-duplication).
    project : str
        Project folder, e.g. ``spine-corpus/cat-game`` or ``spine-examples/4.2/owl``.
    game : str
        What the split is keyed on: the source repository for corpus projects (several
        projects can come from one game), the project itself for the official examples.
    rgba : ndarray, shape (H, W, 4), uint8
        Straight alpha, downscaled so that its longer side is at most ``max_side``.
    """

    id: str
    project: str
    game: str
    rgba: np.ndarray


def split_of(game: str, val_percent: int = VAL_PERCENT) -> str:
    """``"val"`` or ``"train"`` for a game: stable across runs and machines (MD5, not ``hash``)."""
    h = int(hashlib.md5(f"{SPLIT_SALT}:{game}".encode()).hexdigest(), 16)
    return "val" if h % 100 < val_percent else "train"


def shrink(rgba: np.ndarray, max_side: int) -> np.ndarray:
    """Downscale so the longer side is at most ``max_side`` (area filter on premultiplied colour,
    so transparent pixels do not bleed their hidden colour into the edges)."""
    h, w = rgba.shape[:2]
    s = max_side / max(h, w)
    if s >= 1:
        return rgba
    size = (max(1, round(w * s)), max(1, round(h * s)))
    return unpremultiply(cv2.resize(premultiply(rgba), size, interpolation=cv2.INTER_AREA))


def useful(rgba: np.ndarray, min_side: int = 16, min_fg: float = 0.02, max_fg: float = 0.98) -> bool:
    """Whether a sprite teaches segmentation anything.

    Tiny images, nearly empty ones and fully opaque rectangles (whose mask is the whole
    image whatever the background) are left out.
    """
    h, w = rgba.shape[:2]
    if min(h, w) < min_side:
        return False
    fg = float((rgba[..., 3] > 128).mean())
    return min_fg <= fg <= max_fg


def _corpus_games(corpus: Path) -> dict[str, str]:
    """short_name -> source repository, from ``MANIFEST.tsv``."""
    manifest = corpus / "MANIFEST.tsv"
    if not manifest.is_file():
        return {}
    with open(manifest, newline="", encoding="utf-8") as f:
        return {row["short_name"]: row["repo"] for row in csv.DictReader(f, delimiter="\t")}


def _atlas_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file()
                  and (p.name.endswith(".atlas") or p.name.endswith(".atlas.txt")))


def _atlas_sprites(atlas_path: Path, root: Path) -> Iterator[tuple[str, np.ndarray]]:
    """(region name, original-size RGBA) for every region of one atlas, one page load each."""
    atlas = read_atlas(atlas_path)
    for pi, page in enumerate(atlas.pages):
        rel = atlas_path.parent.relative_to(root) / page.name
        try:
            pixels = load_rgba(resolve_inside(root, rel.as_posix(), atlas_path))
        except SpineMeshError:
            continue  # a page missing from the collected project: its regions are skipped
        for region in atlas.regions:
            if region.page != pi:
                continue
            try:
                yield region.name, cut_region(pixels, region, page.pma, str(atlas_path))
            except SpineMeshError:
                continue


def iter_corpus(corpus: Path) -> Iterator[tuple[str, str, str, np.ndarray]]:
    """(project, game, name, rgba) for every atlas region of every corpus project."""
    games = _corpus_games(corpus)
    for proj in sorted(p for p in corpus.iterdir() if p.is_dir()):
        game = games.get(proj.name, proj.name)
        for atlas_path in _atlas_files(proj):
            for name, rgba in _atlas_sprites(atlas_path, proj):
                yield f"spine-corpus/{proj.name}", game, name, rgba


def iter_examples(examples: Path, version: str = "4.2") -> Iterator[tuple[str, str, str, np.ndarray]]:
    """(project, game, name, rgba) for every image of the examples' ``images/`` folders."""
    root = examples / version
    if not root.is_dir():
        return
    for proj in sorted(p for p in root.iterdir() if p.is_dir()):
        images = proj / "images"
        for path in sorted(images.rglob("*.png")) if images.is_dir() else []:
            try:
                rgba = load_rgba(path)
            except SpineMeshError:
                continue
            name = path.relative_to(images).with_suffix("").as_posix()
            yield f"spine-examples/{version}/{proj.name}", f"spine-examples/{proj.name}", name, rgba


def gather_sprites(shared: str | Path, max_side: int = 320, split: str | None = None,
                   limit_per_project: int | None = None) -> list[Sprite]:
    """Collect useful, de-duplicated sprites from ``shared/spine-corpus`` and ``shared/spine-examples``.

    Parameters
    ----------
    shared : path
        The ``shared`` folder (``../shared`` beside the repository).
    max_side : int
        Longest side kept in memory, pixels (default 320: above the 256 model input of
        paper section 3.1, so training at 256 still downscales).
    split : {"train", "val", None}
        Keep only that side of :func:`split_of` (``None``: both).
    limit_per_project : int, optional
        At most this many sprites per project, evenly spread (for quick tests and evals).

    Returns
    -------
    list of Sprite
    """
    shared = Path(shared)
    sources = []
    if (shared / "spine-corpus").is_dir():
        sources.append(iter_corpus(shared / "spine-corpus"))
    if (shared / "spine-examples").is_dir():
        sources.append(iter_examples(shared / "spine-examples"))
    seen: set[bytes] = set()
    out: list[Sprite] = []
    by_project: dict[str, list[Sprite]] = {}
    for source in sources:
        for project, game, name, rgba in source:
            if split is not None and split_of(game) != split:
                continue
            if not useful(rgba):
                continue
            small = shrink(rgba, max_side)
            # The same image often sits in several atlases (pma and straight, per-skin copies).
            key = hashlib.md5(small.tobytes()).digest()
            if key in seen:
                continue
            seen.add(key)
            by_project.setdefault(project, []).append(Sprite(f"{project}/{name}", project, game, small))
    for project, sprites in by_project.items():
        if limit_per_project is not None and len(sprites) > limit_per_project:
            idx = np.linspace(0, len(sprites) - 1, limit_per_project).round().astype(int)
            sprites = [sprites[i] for i in idx]
        out.extend(sprites)
    return out

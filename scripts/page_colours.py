"""How many atlases' pages say what colours their texels stand for, and whether ``pack`` can carry it.

A PNG page may carry colour chunks (gamma, chromaticities, sRGB, a colour profile, ...; a WebP
or AVIF page a colour profile): an engine or a browser that manages colour reads them. ``pack``
writes them on every page it packs (:func:`spinemesh.pack.page_colours.page_colour`), and keeps an atlas
whose pages packed together say different things (:func:`spinemesh.pack.page_colours.colours_by_settings`).
This script counts, over every project in the given folders, the atlases whose pages say
something, by what they say, and those whose pages disagree.

Usage::

    .venv/bin/python scripts/page_colours.py FOLDER [FOLDER ...]
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

from spinemesh.errors import SpineMeshError
from spinemesh.images.sources import AtlasImages
from spinemesh.pack.atlas_pack import PackRefused
from spinemesh.pack.page_colours import colour_words, colours_by_settings, page_colour
from spinemesh.project import find_project, find_projects, project_atlases


def atlas_colours(folder: Path) -> list[tuple[str, str]]:
    """Per atlas of every project under ``folder``: its path and what its pages say, in words
    (``disagree: ...`` when pages packed together say different things)."""
    rows = []
    for path in find_projects(folder):
        try:
            project = find_project(path)
            atlases = project_atlases(project)
        except SpineMeshError:
            continue
        for atlas_path, atlas in atlases.items():
            try:
                colours = [page_colour(AtlasImages.page_path(atlas, p.name).read_bytes()) for p in atlas.pages]
            except (OSError, SpineMeshError):
                continue
            try:
                colours_by_settings(atlas, colours)
                said = sorted({colour_words(c) for c in colours})
                rows.append((str(atlas_path), "; ".join(said)))
            except PackRefused as e:
                rows.append((str(atlas_path), f"disagree: {e}"))
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", type=Path)
    args = ap.parse_args(argv)
    rows = [row for folder in args.folders for row in atlas_colours(folder)]
    said = Counter("pages disagree" if what.startswith("disagree") else what for _, what in rows)
    print(f"{len(rows)} atlases; by what their pages say of their colours:")
    print(f"{'atlases':>8}  what")
    for what, n in said.most_common():
        print(f"{n:>8}  {what}")
    for atlas, what in rows:
        if what != "no colour information":
            print(f"  {atlas}: {what}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

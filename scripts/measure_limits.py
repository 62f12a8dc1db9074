"""The largest values real projects use, beside the limits of :mod:`spinemesh.limits`.

Reads every skeleton and atlas under the given folders (default: the official examples and
the game corpus) and prints, per measured quantity, the largest value found, where, and the
limit, with the limit's ratio to it: each limit must lie well above what real projects use.

Usage: python scripts/measure_limits.py [FOLDER ...]
"""

from __future__ import annotations

import sys
from pathlib import Path

from spinemesh import limits
from spinemesh.atlas import read_atlas
from spinemesh.errors import SpineMeshError
from spinemesh.fsutil import walk_files
from spinemesh.project import ATLAS_SUFFIXES, is_skeleton_file
from spinemesh.skeleton import iter_attachments, load_skeleton

DEFAULT = [Path(__file__).resolve().parents[1].parent / "shared" / "spine-examples",
           Path(__file__).resolve().parents[1].parent / "shared" / "spine-corpus"]

#: Attachment and bone fields whose size the document check bounds.
NUMBER_FIELDS = ("x", "y", "width", "height", "scaleX", "scaleY", "rotation", "length", "shearX", "shearY")


def _number(v) -> float:
    return abs(float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else 0.0


def measure(folders: list[Path]) -> dict[str, tuple[float, str]]:
    most: dict[str, tuple[float, str]] = {}

    def note(key: str, value: float, where: str) -> None:
        if value > most.get(key, (-1.0, ""))[0]:
            most[key] = (value, where)

    for folder in folders:
        for path in walk_files(folder):
            name = path.name.lower()
            try:
                if name.endswith(ATLAS_SUFFIXES):
                    atlas = read_atlas(path, strict=False)
                    note("regions per atlas", len(atlas.regions), str(path))
                    for page in atlas.pages:
                        note("1 / atlas page scale", 1 / page.scale if page.scale else 0, str(path))
                elif is_skeleton_file(path):
                    doc = load_skeleton(path)
                    refs = list(iter_attachments(doc))
                    note("attachments per skeleton", len(refs), str(path))
                    for ref in refs:
                        for k in NUMBER_FIELDS:
                            note("attachment number (abs)", _number(ref.attachment.get(k)), str(path))
                        for v in ref.attachment.get("vertices", []) if isinstance(ref.attachment.get("vertices"), list) else []:
                            note("attachment number (abs)", _number(v), str(path))
                    for bone in doc.get("bones", []):
                        for k in NUMBER_FIELDS:
                            note("bone number (abs)", _number(bone.get(k)), str(path))
            except SpineMeshError:
                continue
    return most


LIMITS = {
    "regions per atlas": limits.MAX_ATLAS_REGIONS,
    "attachments per skeleton": limits.MAX_ATTACHMENTS,
    "1 / atlas page scale": 1 / limits.MIN_ATLAS_SCALE,
    "attachment number (abs)": limits.MAX_SKELETON_NUMBER,
    "bone number (abs)": limits.MAX_SKELETON_NUMBER,
}


def main() -> None:
    folders = [Path(a) for a in sys.argv[1:]] or [f for f in DEFAULT if f.is_dir()]
    most = measure(folders)
    print(f"{'quantity':28} {'largest found':>14} {'limit':>14} {'limit/largest':>14}  where")
    for key, limit in LIMITS.items():
        value, where = most.get(key, (0.0, "-"))
        ratio = f"{limit / value:,.0f}x" if value else "-"
        print(f"{key:28} {value:>14,.4g} {limit:>14,.4g} {ratio:>14}  {where}")


if __name__ == "__main__":
    main()

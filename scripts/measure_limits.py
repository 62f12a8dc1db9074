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
from spinemesh.anim import POSE_ERRORS, Sampler
from spinemesh.anim.curves import FLOAT32_MAX
from spinemesh.atlas import read_atlas
from spinemesh.errors import SpineMeshError
from spinemesh.files.strict_json import strict_json
from spinemesh.files.walk import walk_files
from spinemesh.player.frames import MAX_ANIMATIONS, MAX_WORLD
from spinemesh.project import ATLAS_SUFFIXES, is_skeleton_file
from spinemesh.rig.physics import PhysicsSettings
from spinemesh.skeleton import iter_attachments, load_skeleton

DEFAULT = [Path(__file__).resolve().parents[1].parent / "shared" / "spine-examples",
           Path(__file__).resolve().parents[1].parent / "shared" / "spine-corpus"]

#: Attachment and bone fields whose size the document check bounds.
NUMBER_FIELDS = ("x", "y", "width", "height", "scaleX", "scaleY", "rotation", "length", "shearX", "shearY")


def _number(v) -> float:
    return abs(float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else 0.0


def _numbers_and_key_lists(value, numbers: list, lists: list) -> None:
    """Every number under ``value`` into ``numbers`` and the length of every list of keys (a
    list of objects) into ``lists``."""
    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, dict):
            stack += v.values()
        elif isinstance(v, list):
            if v and all(isinstance(k, dict) for k in v):
                lists.append(len(v))
            stack += v
        else:
            numbers.append(_number(v))


def unreadable_draw_order_keys(doc: dict) -> int:
    """Draw order keys whose offsets the runtimes cannot read, which the sampler passes over: a
    slot named out of slot order or twice, moved out of the list or onto another's place."""
    slot_index = {str(s.get("name")): i for i, s in enumerate(doc.get("slots") or []) if isinstance(s, dict)}
    count = 0
    for anim in (doc.get("animations") or {}).values():
        keys = anim.get("drawOrder", anim.get("draworder")) if isinstance(anim, dict) else None
        for key in keys if isinstance(keys, list) else []:
            offsets = key.get("offsets") if isinstance(key, dict) else None
            last, taken = -1, set()
            for o in offsets if isinstance(offsets, list) else []:
                s = slot_index.get(str(o.get("slot"))) if isinstance(o, dict) else None
                if s is None:
                    continue
                offset = o.get("offset", 0)
                at = s + (int(offset) if isinstance(offset, (int, float)) and not isinstance(offset, bool) else 0)
                if s <= last or not 0 <= at < len(slot_index) or at in taken:
                    count += 1
                    break
                last = s
                taken.add(at)
    return count


def measure_animations(doc: dict, where: str, note) -> None:
    """The quantities the animation sampler, ``spinemesh pose`` and the player bound, for one
    skeleton document."""
    numbers: list[float] = []
    key_lists: list[int] = []
    _numbers_and_key_lists(doc.get("animations") or {}, numbers, key_lists)
    note("animations per skeleton", len(doc.get("animations") or {}), where)
    note("keys per timeline", max(key_lists, default=0), where)
    note("animation number (abs)", max(numbers, default=0.0), where)
    note("draw order keys not readable", unreadable_draw_order_keys(doc), where)
    try:
        sampler = Sampler(doc)
        setup = sampler.pose(None)
        note("JSON of one pose (B)", len(strict_json(setup.to_dump(), None, where)), where)
        world = [abs(float(x)) for d in setup.to_dump().get("attachments", []) for x in d.get("vertices") or []]
        note("setup pose coordinate (abs)", max(world, default=0.0), where)
        for c in sampler.rig.constraints:
            if c.kind == "physics":
                note("physics steps a second", 1 / PhysicsSettings.from_json(c.data, doc.get("skeleton") or {}).step,
                     where)
        longest = max((sampler.duration(n) for n in sampler.animation_names()), default=0.0)
        note("game-loop steps of an animation", longest * 60, where)
        if sampler.physics:
            note("steps of a physics animation", longest * 60, where)
    except POSE_ERRORS as e:
        print(f"{where}: not sampled: {e}", file=sys.stderr)


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
                    measure_animations(doc, str(path), note)
            except SpineMeshError:
                continue
    return most


LIMITS = {
    "regions per atlas": limits.MAX_ATLAS_REGIONS,
    "attachments per skeleton": limits.MAX_ATTACHMENTS,
    "1 / atlas page scale": 1 / limits.MIN_ATLAS_SCALE,
    "attachment number (abs)": limits.MAX_SKELETON_NUMBER,
    "bone number (abs)": limits.MAX_SKELETON_NUMBER,
    "animations per skeleton": MAX_ANIMATIONS,
    "keys per timeline": None,
    "animation number (abs)": FLOAT32_MAX,
    "draw order keys not readable": 0,
    "JSON of one pose (B)": limits.MAX_POSE_OUTPUT_BYTES,   # the ratio: poses one call may write
    "setup pose coordinate (abs)": MAX_WORLD,
    "physics steps a second": limits.MAX_PHYSICS_FPS,
    "game-loop steps of an animation": limits.MAX_POSE_STEPS,
    "steps of a physics animation": limits.MAX_POSE_STEPS,
}


def main() -> None:
    folders = [Path(a) for a in sys.argv[1:]] or [f for f in DEFAULT if f.is_dir()]
    most = measure(folders)
    print(f"{'quantity':32} {'largest found':>14} {'limit':>14} {'limit/largest':>14}  where")
    for key, limit in LIMITS.items():
        value, where = most.get(key, (0.0, "-"))
        where = where if value else "-"   # none found anywhere
        ratio = "-" if not (value and limit) else f"{limit / value:,.0f}x" if limit / value < 1e6 else f"{limit / value:.1e}x"
        shown = "none" if limit is None else f"{limit:,.4g}"
        print(f"{key:32} {value:>14,.4g} {shown:>14} {ratio:>14}  {where}")


if __name__ == "__main__":
    main()

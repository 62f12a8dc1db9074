"""What a skeleton's names and animations say about its bones, for the learned bone choice.

Two signs an artist leaves beyond the setup pose:

* **names**: a bone named like the image it carries (``arm_L`` for ``arm_L``, ``hair-front``
  for ``images/hair_front_2``). Names are cut into lowercase tokens at anything that is not a
  letter or a digit, at lower-to-upper case changes and between letters and digits, so the
  comparison does not depend on a language or a naming style; sides (``l``/``left``,
  ``r``/``right``) are read from the tokens.
* **motion**: how far the animations move each bone by its own timelines (rotation range in
  degrees, translation range in world units, scale range), and in how many animations it is
  keyed. A bone no animation moves changes nothing once bound; a bone the animations swing far
  (a look-at handle, a particle) drags whatever is bound to it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

#: Tokens that say a side, normalised.
SIDES = {"l": "l", "left": "l", "r": "r", "right": "r"}

#: Bone timelines read, with the value fields of their keys and the value a missing field means.
_TIMELINES = {
    "rotate": (("angle", "value"), 0.0), "translate": (("x", "y"), 0.0), "translatex": (("value",), 0.0),
    "translatey": (("value",), 0.0), "scale": (("x", "y"), 1.0), "scalex": (("value",), 1.0),
    "scaley": (("value",), 1.0),
}

#: Keys read per timeline (a bound on what a malformed file can cost).
MAX_KEYS = 4096

_SPLIT = re.compile(r"(?<=[^\W\d_])(?=\d)|(?<=\d)(?=[^\W\d_])")


def name_tokens(name: str) -> frozenset[str]:
    """Lowercase tokens of a name (module docstring); sides normalised to ``l`` / ``r``.

    >>> sorted(name_tokens("images/armL_upper2"))
    ['2', 'arm', 'images', 'l', 'upper']
    """
    name = str(name)
    # lower-to-upper case changes cut words ("armLeft"); runs of capitals ("HEAD") stay whole
    text = "".join(" " + c if k and c.isupper() and name[k - 1].islower() else c for k, c in enumerate(name)).lower()
    words = re.split(r"[\W_]+", text)
    out = set()
    for w in words:
        out.update(t for t in _SPLIT.split(w) if t)
    return frozenset(SIDES.get(t, t) for t in out)


def side_of(tokens: frozenset[str]) -> str:
    """``l``, ``r`` or ``""`` (none, or both)."""
    sides = tokens & {"l", "r"}
    return next(iter(sides)) if len(sides) == 1 else ""


@dataclass
class RigSigns:
    """What names and animations say about each bone of a skeleton (computed once per document).

    Attributes
    ----------
    tokens : list of frozenset of str
        Each bone's name tokens (:func:`name_tokens`).
    motion : ndarray, shape (B, 4)
        Per bone: the largest rotation range over the animations (degrees, at most 360), the
        largest translation range (world units of the parent's space, unscaled), the largest
        scale range, and the share of the animations that key it.
    """

    tokens: list[frozenset[str]]
    motion: np.ndarray


def _key_values(keys, fields: tuple[str, ...], default: float) -> np.ndarray:
    """The keys' values (K, len(fields)); missing or non-numeric fields read ``default``."""
    rows = []
    for key in keys[:MAX_KEYS] if isinstance(keys, list) else []:
        if isinstance(key, dict):
            rows.append([_finite(key.get(f), default) for f in fields])
    return np.asarray(rows, float).reshape(-1, len(fields))


def _finite(value, default: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return default
    return float(value)


def _timeline_ranges(timelines: dict) -> np.ndarray:
    """Rotation, translation and scale range (3,) of one bone in one animation."""
    out = np.zeros(3)
    for kind, (fields, default) in _TIMELINES.items():
        values = _key_values(timelines.get(kind), fields, default)
        if not len(values):
            continue
        span = np.ptp(np.vstack([values, np.full((1, len(fields)), default)]), axis=0)
        slot = 0 if kind == "rotate" else 1 if kind.startswith("translate") else 2
        out[slot] = max(out[slot], float(np.linalg.norm(span)) if slot == 1 else float(span.max()))
    out[0] = min(out[0], 360.0)
    return out


def rig_signs(doc: dict, bone_names: list[str]) -> RigSigns:
    """:class:`RigSigns` of a skeleton document whose bones are named ``bone_names`` (in order)."""
    index = {n: i for i, n in enumerate(bone_names)}
    motion = np.zeros((len(bone_names), 4))
    anims = doc.get("animations")
    anims = anims if isinstance(anims, dict) else {}
    for anim in anims.values():
        bones = anim.get("bones") if isinstance(anim, dict) else None
        for name, timelines in (bones.items() if isinstance(bones, dict) else []):
            if name not in index or not isinstance(timelines, dict):
                continue
            i = index[name]
            motion[i, :3] = np.maximum(motion[i, :3], _timeline_ranges(timelines))
            motion[i, 3] += 1
    motion[:, 3] /= max(len(anims), 1)
    return RigSigns([name_tokens(n) for n in bone_names], motion)


def name_overlap(bone: frozenset[str], art: frozenset[str]) -> float:
    """Share of a bone's name tokens that the art's names hold (sides and bare digits aside)."""
    words = {t for t in bone if t not in ("l", "r") and not t.isdigit()}
    return len(words & art) / len(words) if words else 0.0


def side_conflict(bone: frozenset[str], art: frozenset[str]) -> bool:
    """Whether the bone's name says one side and the art's the other."""
    a, b = side_of(bone), side_of(art)
    return bool(a and b and a != b)

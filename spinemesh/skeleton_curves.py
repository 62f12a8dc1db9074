"""How Spine 3.x JSON spells the curve after an animation key, per version, as each version's
runtime reads it: one declaration the pose sampler (:mod:`spinemesh.anim`) and the 3.x binary
reader and writer (:mod:`spinemesh.skeleton_binary.v3`) share.
"""

from __future__ import annotations

from dataclasses import dataclass

from .skeleton_check import is_number
from .skeleton_version import major_minor


@dataclass(frozen=True)
class CurveSpelling:
    """How a 3.x version's JSON spells the curve after a key, as its runtime reads it
    (``SkeletonJson.readCurve`` of spine-libgdx, spine-csharp and spine-ts, 3.5 to 3.8); 4.x
    spells one curve per value, always a list (read where it is used).

    Attributes
    ----------
    any_text_steps : bool
        Any text is stepped (3.8: the reader asks only whether ``curve`` is text); otherwise
        ``"stepped"`` only, other text drawing linear (3.5 to 3.7).
    bezier_in_list : bool
        A Bezier is ``"curve": [c1, c2, c3, c4]`` (3.5 to 3.7: their readers pass a number
        over, drawing linear); otherwise ``"curve": c1`` with ``c2``, ``c3``, ``c4`` beside it,
        defaults 0, 1, 1 (3.8: a list there is refused by its readers, read here as linear).
    """

    any_text_steps: bool
    bezier_in_list: bool

    def kind(self, frame: dict) -> str:
        """``"linear"``, ``"stepped"`` or ``"bezier"``: the curve after the key ``frame``."""
        curve = frame.get("curve")
        if isinstance(curve, str):
            return "stepped" if self.any_text_steps or curve == "stepped" else "linear"
        if self.bezier_in_list:
            return "bezier" if isinstance(curve, list) and len(curve) >= 4 else "linear"
        return "bezier" if is_number(curve) else "linear"

    def controls(self, frame: dict) -> list:
        """A Bezier key's ``[c1, c2, c3, c4]`` as the document holds them (not checked: numbers
        where the document is sound)."""
        curve = frame.get("curve")
        if self.bezier_in_list:
            return list(curve[:4])
        return [curve, frame.get("c2", 0), frame.get("c3", 1), frame.get("c4", 1)]


#: 3.5 to 3.7 (``"curve": [c1, c2, c3, c4]``) and 3.8 (``"curve": c1, "c2": ...``).
CURVES_35 = CurveSpelling(any_text_steps=False, bezier_in_list=True)
CURVES_38 = CurveSpelling(any_text_steps=True, bezier_in_list=False)


def curve_spelling(version: str) -> CurveSpelling:
    """The 3.x curve spelling of a skeleton written by editor ``version`` (``"3.7.94"``):
    3.8's for 3.8 and for a version that names no 3.x minor below 8 (4.x reads its own)."""
    known = major_minor(version)
    return CURVES_35 if known and known[0] == 3 and known[1] < 8 else CURVES_38

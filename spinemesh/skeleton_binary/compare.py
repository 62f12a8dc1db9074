"""Equality of two skeleton documents, as the Spine editor's JSON export defines it.

The editor's JSON rounds numbers (to about two decimals, some to four) and leaves out any
value equal to its default, while a ``.skel`` keeps float32 values and writes (nearly)
every field. :func:`diff_documents` compares two documents modulo both: numbers are equal
within ``abs_tol`` *or* ``rel_tol``, and a key present on one side only is equal when its
value is that key's default in that place of the document.

The defaults follow the JSON loaders of the Spine runtimes (``SkeletonJson``), for 3.6 to
4.2; where they changed between versions, both layouts are listed (e.g. 3.x timeline
``angle`` and 4.x ``value``). The 3.x and 4.x binary readers share this module.

Usage::

    diffs = diff_documents(from_skel, from_json)
    assert not diffs, "\\n".join(map(str, diffs[:20]))
"""

from __future__ import annotations

import fnmatch
import math
from typing import Any, Callable, Iterable, NamedTuple

from ..skeleton_check import is_number
from ..skeleton_version import doc_major_minor
from .v4.constraint_list import implied_mix

#: Tolerances for numbers: the editor writes about 2 decimals (``abs``) and, for large
#: values, about 4 significant digits (``rel``). Issue 3 of the project fixes both.
ABS_TOL = 0.011
REL_TOL = 1e-3

_MISSING = object()


class Difference(NamedTuple):
    """One place where two documents differ: a ``/``-joined path and both values.

    A value that one side lacks (and that has no known default) is ``"<missing>"``.
    """

    path: str
    left: Any
    right: Any

    def __str__(self) -> str:
        return f"{self.path}: {self.left!r} != {self.right!r}"


# -- defaults --------------------------------------------------------------------------
# Each context maps a key to its default: a constant, or a function of the node (the dict
# holding the key) and the node's own key in its parent, for defaults that depend on other
# values (``mixY`` defaults to ``mixX``; an attachment's ``path`` to its name).

def _same_as(other: str, fallback: Any) -> Callable[[dict, Any], Any]:
    return lambda node, name: node.get(other, fallback)


_BONE = {"parent": None, "length": 0, "x": 0, "y": 0, "rotation": 0, "scaleX": 1, "scaleY": 1,
         "shearX": 0, "shearY": 0, "transform": "normal", "inherit": "normal", "skin": False,
         "color": "9b9b9bff", "icon": None, "iconSize": 1, "iconRotation": 0, "visible": True,
         "inheritScale": True, "inheritRotation": True}
_SLOT = {"color": "ffffffff", "dark": None, "attachment": None, "blend": "normal", "visible": True}
_IK = {"order": 0, "skin": False, "bones": [], "mix": 1, "softness": 0, "bendPositive": True,
       "compress": False, "stretch": False, "uniform": False}
_TRANSFORM = {"order": 0, "skin": False, "bones": [], "local": False, "relative": False,
              "rotation": 0, "x": 0, "y": 0, "scaleX": 0, "scaleY": 0, "shearY": 0,
              "mixRotate": 1, "mixX": 1, "mixY": _same_as("mixX", 1), "mixScaleX": 1,
              "mixScaleY": _same_as("mixScaleX", 1), "mixShearY": 1,
              # 3.x names
              "rotateMix": 1, "translateMix": 1, "scaleMix": 1, "shearMix": 1}
_PATH = {"order": 0, "skin": False, "bones": [], "positionMode": "percent", "spacingMode": "length",
         "rotateMode": "tangent", "rotation": 0, "position": 0, "spacing": 0, "mixRotate": 1,
         "mixX": 1, "mixY": _same_as("mixX", 1), "rotateMix": 1, "translateMix": 1}
_PHYSICS = {"order": 0, "skin": False, "x": 0, "y": 0, "rotate": 0, "scaleX": 0, "shearX": 0,
            "limit": 5000, "fps": 60, "inertia": 1, "strength": 100, "damping": 1, "mass": 1,
            "wind": 0, "gravity": 0, "mix": 1, "inertiaGlobal": False, "strengthGlobal": False,
            "dampingGlobal": False, "massGlobal": False, "windGlobal": False,
            "gravityGlobal": False, "mixGlobal": False}
#: 3.x skins, a name-keyed object: a default skin without attachments is no skin at all to the
#: runtimes (their binary loaders return none for a skin of no slots, so a .skel cannot hold it).
_SKINS = {"default": {}}
_SKIN = {"bones": [], "ik": [], "transform": [], "path": [], "physics": [], "slider": [], "attachments": {},
         "color": "fe9e4fff"}


#: 4.3's one constraint list, by "type".
_CONSTRAINTS_43 = {
    "ik": {"skin": False, "bones": [], "mix": 1, "softness": 0, "bendPositive": True, "compress": False,
           "stretch": False, "scaleY": "none"},
    "transform": {"skin": False, "bones": [], "localSource": False, "localTarget": False, "additive": False,
                  "clamp": False, "properties": {}, "rotation": 0, "x": 0, "y": 0, "scaleX": 0, "scaleY": 0,
                  "shearY": 0, **{k: (lambda node, name, k=k: implied_mix(node, k))
                                  for k in ("mixRotate", "mixX", "mixY", "mixScaleX", "mixScaleY", "mixShearY")}},
    "path": {**_PATH, "order": None},
    "physics": {**_PHYSICS, "order": None, "inertia": 0.5, "damping": 0.85, "scaleY": "none"},
    "slider": {"skin": False, "loop": False, "additive": False, "time": 0, "mix": 1, "bone": None,
               "from": 0, "to": 0, "scale": 1, "max": 0, "local": False},
}
_EVENT = {"int": 0, "float": 0, "string": "", "audio": None, "volume": 1, "balance": 0}
_SKELETON = {"hash": None, "spine": None, "x": 0, "y": 0, "width": 0, "height": 0, "fps": 30,
             "images": "", "audio": "", "referenceScale": 100}
_SEQUENCE = {"start": 1, "digits": 0, "setup": 0}


def _name_of(node: dict, name: Any) -> Any:
    return node.get("name", name)


def _path_default(node: dict, name: Any) -> Any:
    return node.get("name", name)


_ATTACHMENT_COMMON = {"type": "region", "name": _name_of, "path": _path_default, "color": None,
                      "sequence": None}
_ATTACHMENT = {
    "region": {"x": 0, "y": 0, "rotation": 0, "scaleX": 1, "scaleY": 1, "color": "ffffffff"},
    "mesh": {"color": "ffffffff", "hull": 0, "edges": None, "width": 0, "height": 0},
    "linkedmesh": {"color": "ffffffff", "skin": None, "timelines": True, "deform": True,
                   "width": 0, "height": 0, "slot": None},
    "boundingbox": {"color": "60f000ff"},
    "path": {"closed": False, "constantSpeed": True, "color": "ff7f00ff"},
    "point": {"x": 0, "y": 0, "rotation": 0, "color": "f1f100ff"},
    "clipping": {"end": None, "color": "ce3a3aff", "convex": False, "inverse": False},
}
_ATTACHMENT["skinnedmesh"] = _ATTACHMENT["weightedmesh"] = _ATTACHMENT["mesh"]

# Keyframes. ``time`` is 0 and ``curve`` linear everywhere; 3.8 spells a bezier as
# ``"curve": cx1`` plus ``c2``, ``c3``, ``c4``.
_KEY = {"time": 0, "curve": "linear", "c2": 0, "c3": 1, "c4": 1}
_KEYFRAMES = {
    "rotate": {"value": 0, "angle": 0},
    "translate": {"x": 0, "y": 0}, "translatex": {"value": 0}, "translatey": {"value": 0},
    "scale": {"x": 1, "y": 1}, "scalex": {"value": 1}, "scaley": {"value": 1},
    "shear": {"x": 0, "y": 0}, "shearx": {"value": 0}, "sheary": {"value": 0},
    "inherit": {"inherit": "normal"},
    "attachment": {"name": None},
    "color": {"color": "ffffffff"}, "rgba": {"color": "ffffffff"}, "rgb": {"color": "ffffff"},
    "alpha": {"value": 0}, "twocolor": {"light": "ffffffff", "dark": "ffffff"},
    "rgba2": {"light": "ffffffff", "dark": "ffffff"}, "rgb2": {"light": "ffffff", "dark": "ffffff"},
    "ik": {"mix": 1, "softness": 0, "bendPositive": True, "compress": False, "stretch": False},
    "transform": {"mixRotate": 1, "mixX": 1, "mixY": _same_as("mixX", 1), "mixScaleX": 1,
                  "mixScaleY": _same_as("mixScaleX", 1), "mixShearY": 1,
                  "rotateMix": 1, "translateMix": 1, "scaleMix": 1, "shearMix": 1},
    "position": {"value": 0, "position": 0}, "spacing": {"value": 0, "spacing": 0},
    "mix": {"mixRotate": 1, "mixX": 1, "mixY": _same_as("mixX", 1), "rotateMix": 1, "translateMix": 1},
    "physics": {"value": 0}, "inertia": {"value": 0}, "strength": {"value": 0}, "damping": {"value": 0},
    "mass": {"value": 0}, "wind": {"value": 0}, "gravity": {"value": 0},
    "physicsmix": {"value": 0}, "reset": {},
    # 4.3: slider timelines, and a physics mix key's value defaults to 1 (see default_for).
    "time": {"value": 1}, "slidermix": {"value": 1}, "physicsmix43": {"value": 1},
    "transform43": {"mixRotate": 1, "mixX": 1, "mixY": _same_as("mixX", 1), "mixScaleX": 1,
                    "mixScaleY": 1, "mixShearY": 1},
    "deform": {"offset": 0, "vertices": []},
    # A sequence key's delay defaults to the previous key's (SkeletonJson's lastDelay).
    "sequence": {"mode": "hold", "index": 0, "delay": lambda node, name, prev=None: (prev or {}).get("delay", 0)},
    "drawOrder": {"offsets": []},
    # An event key's values default to its event's: see default_for.
    "events": {},
}


def _context(path: tuple) -> tuple[str, str | None]:
    """Classify a path to a dict: ``(context, subtype)`` for the defaults tables."""
    n = len(path)
    if n == 0:
        return "root", None
    top = path[0]
    if n == 1 and top == "skeleton":
        return "skeleton", None
    if n == 2 and top in ("bones", "slots", "ik", "transform", "path", "physics"):
        return top, None
    if n == 2 and top == "constraints":
        return "constraint", None
    if n == 2 and top == "events":
        return "event", None
    if top == "skins":
        if n == 1:
            return "skins", None
        if n == 2 and isinstance(path[1], int):
            return "skin", None
        # 4.x: skins[i]/attachments/slot/name ; 3.x: skins/skin/slot/name
        if (n == 5 and path[2] == "attachments") or (n == 4 and not isinstance(path[1], int)):
            return "attachment", None
        if n in (6, 5) and path[-1] == "sequence":
            return "sequence", None
    if top == "animations" and n >= 4:
        group = path[2]
        if group in ("bones", "slots") and n == 6:
            return "key", str(path[4]).lower()
        if group in ("ik", "transform") and n == 5:
            return "key", group
        if group in ("path", "paths") and n == 6:  # 3.6/3.7 call the group "paths"
            return "key", str(path[4])
        if group == "physics" and n == 6:
            kind = str(path[4])
            return "key", "physicsmix" if kind == "mix" else kind
        if group == "slider" and n == 6:
            kind = str(path[4])
            return "key", "slidermix" if kind == "mix" else kind
        if group in ("deform",) and n == 7:
            return "key", "deform"
        if group == "attachments" and n == 8:
            return "key", str(path[6])
        if group in ("drawOrder", "draworder") and n == 4:
            return "key", "drawOrder"
        if group == "events" and n == 4:
            return "key", "events"
        if group in ("drawOrder", "draworder") and n == 6:
            return "offset", None
    return "other", None


_TABLES = {"skeleton": _SKELETON, "bones": _BONE, "slots": _SLOT, "ik": _IK,
           "transform": _TRANSFORM, "path": _PATH, "physics": _PHYSICS, "skins": _SKINS, "skin": _SKIN,
           "event": _EVENT, "sequence": _SEQUENCE}


def default_for(path: tuple, node: dict, key: str, prev: dict | None = None, root: dict | None = None) -> Any:
    """The value ``key`` takes in the dict ``node`` at ``path`` when the key is absent.

    ``prev`` is the previous keyframe, for defaults that carry over from it; ``root`` the
    whole document, for event keys whose values default to their event's.

    Returns a private sentinel when the key has no default there (it is required).
    """
    context, sub = _context(path)
    name = path[-1] if path else None
    if context == "attachment":
        table = _ATTACHMENT.get(node.get("type", "region"), {})
        value = table.get(key, _ATTACHMENT_COMMON.get(key, _MISSING))
    elif context == "key" and sub == "events" and key in _EVENT:
        events = root.get("events", {}) if isinstance(root, dict) else {}
        data = events.get(node.get("name"), {}) if isinstance(events, dict) else {}
        value = data.get(key, _EVENT[key]) if isinstance(data, dict) else _EVENT[key]
    elif context == "constraint":
        value = _CONSTRAINTS_43.get(node.get("type"), {}).get(key, _MISSING)
    elif context == "key":
        if sub in ("physicsmix", "transform") and _is_43(root):
            sub += "43"
        table = _KEYFRAMES.get(sub or "", {})
        value = table.get(key, _KEY.get(key, _MISSING))
    else:
        value = _TABLES.get(context, {}).get(key, _MISSING)
    if callable(value):
        value = value(node, name, prev) if context == "key" and sub == "sequence" else value(node, name)
    return value


def _is_43(root: Any) -> bool:
    return doc_major_minor(root) == (4, 3)


# -- comparison ------------------------------------------------------------------------

def numbers_equal(a: float, b: float, abs_tol: float = ABS_TOL, rel_tol: float = REL_TOL) -> bool:
    """``a`` and ``b`` equal within the editor's rounding: ``abs_tol`` or ``rel_tol``."""
    if a == b:
        return True
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return abs(a - b) <= abs_tol or abs(a - b) <= rel_tol * max(abs(a), abs(b))


def _values_equal(a: Any, b: Any, abs_tol: float, rel_tol: float) -> bool:
    if is_number(a) and is_number(b):
        return numbers_equal(a, b, abs_tol, rel_tol)
    if isinstance(a, str) and isinstance(b, str):
        return a.lower() == b.lower() if _looks_hex(a) and _looks_hex(b) else a == b
    return a == b


def _looks_hex(s: str) -> bool:
    return len(s) in (6, 8) and all(c in "0123456789abcdefABCDEF" for c in s)


def diff_documents(left: Any, right: Any, *, abs_tol: float = ABS_TOL, rel_tol: float = REL_TOL,
                   ignore: Iterable[str] = (), limit: int = 1000) -> list[Difference]:
    """Every difference between two skeleton documents, modulo rounding and defaults.

    Parameters
    ----------
    left, right : dict
        Documents as loaded from JSON or read from ``.skel`` (same Spine version).
    abs_tol, rel_tol : float
        Numbers are equal when within ``abs_tol`` (default 0.011) or within ``rel_tol``
        (default 1e-3) of the larger magnitude.
    ignore : iterable of str
        ``fnmatch`` patterns of ``/``-joined paths to skip, for known differences that
        the caller lists with their reason (e.g. ``"skins/*/attachments/*/*/edges"``).
    limit : int
        Stop after this many differences.

    Returns
    -------
    list of Difference
        Empty when the documents are equal.
    """
    patterns = list(ignore)
    out: list[Difference] = []

    def ignored(path: tuple) -> bool:
        if not patterns:
            return False
        text = "/".join(map(str, path))
        return any(fnmatch.fnmatchcase(text, p) for p in patterns)

    def walk(a: Any, b: Any, path: tuple, prev_a: Any = None, prev_b: Any = None) -> None:
        if len(out) >= limit or ignored(path):
            return
        if isinstance(a, dict) and isinstance(b, dict):
            if ("vertices" in a or "vertices" in b) and _context(path) == ("key", "deform"):
                a, b = _dense_deform(a, b)
            for key in list(a.keys()) + [k for k in b.keys() if k not in a]:
                sub = path + (key,)
                if ignored(sub):
                    continue
                va = a.get(key, _MISSING)
                vb = b.get(key, _MISSING)
                if va is _MISSING:
                    va = default_for(path, a, key, prev_a, left)
                if vb is _MISSING:
                    vb = default_for(path, b, key, prev_b, right)
                if va is _MISSING or vb is _MISSING:
                    out.append(Difference("/".join(map(str, sub)),
                                          "<missing>" if va is _MISSING else va,
                                          "<missing>" if vb is _MISSING else vb))
                    continue
                walk(va, vb, sub)
        elif isinstance(a, list) and isinstance(b, list):
            if _context(path[:-1]) == ("skin", None) and path[-1] in _SKIN and all(isinstance(x, str) for x in a + b):
                # A skin's bones and constraints are a set; exports list them in any order.
                a, b = sorted(a), sorted(b)
            if len(a) != len(b):
                out.append(Difference("/".join(map(str, path)), f"<{len(a)} items>", f"<{len(b)} items>"))
                return
            for i, (x, y) in enumerate(zip(a, b)):
                walk(x, y, path + (i,), a[i - 1] if i else None, b[i - 1] if i else None)
        elif isinstance(a, dict) and isinstance(b, list) or isinstance(a, list) and isinstance(b, dict):
            out.append(Difference("/".join(map(str, path)), type(a).__name__, type(b).__name__))
        elif not _values_equal(a, b, abs_tol, rel_tol):
            out.append(Difference("/".join(map(str, path)), a, b))

    walk(left, right, ())
    return out


def _dense_deform(a: dict, b: dict) -> tuple[dict, dict]:
    """Deform keys with ``offset`` folded into ``vertices``, both padded to one length.

    The editor trims leading and trailing zeros of a deform key; where its rounding made a
    tiny offset zero, it trims more than the binary. Both spell the same offsets.
    """
    da = [0] * int(a.get("offset", 0)) + list(a.get("vertices", []))
    db = [0] * int(b.get("offset", 0)) + list(b.get("vertices", []))
    n = max(len(da), len(db))
    a = {k: v for k, v in a.items() if k not in ("offset", "vertices")}
    b = {k: v for k, v in b.items() if k not in ("offset", "vertices")}
    a["vertices"] = da + [0] * (n - len(da))
    b["vertices"] = db + [0] * (n - len(db))
    return a, b

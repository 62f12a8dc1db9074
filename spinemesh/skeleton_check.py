"""One check of a skeleton document's shape, made once at load, for every field the program reads.

A skeleton JSON can hold anything: a slot's ``bone`` given as a list, a bone ``x`` of 400
digits, ``width: 1e300``. Code that reads the document trusts what this module checked, so
wrong types and huge numbers end as one line naming the file and the JSON path
(``slots[3].bone: expected a name, found a list``), never as a traceback deep inside.

- :func:`check_document` checks the skeleton-wide parts (bones, slots, constraints, the
  skins' layout, the number of attachments): a problem there refuses the skeleton
  (:class:`~spinemesh.errors.SkeletonError`), since bones and slots are what every attachment
  hangs on.
- :func:`bone_tree_problem` checks the bone tree as the official runtimes build it: every bone
  named once, every parent a bone listed before its child (so no bone is its own parent and no
  parents run in a cycle), every slot on a bone that exists. A skeleton whose tree breaks this
  is refused whole, as the runtimes refuse to load it.
- :func:`attachment_problem` checks one attachment, with the weighted ``vertices`` walked
  against the bone count (:func:`vertices_problem`): a bad one is passed over with its reason
  (:func:`spinemesh.skeleton.checked_attachments`), never its skeleton.

Lenient where the official runtimes are lenient: fields the program does not read are not
looked at; optional fields may be absent or ``null`` (the runtimes' defaults apply); a name
may be a number (the runtimes read it as text); a number may be numeric text (the runtimes
parse it). Numbers must be finite and at most :data:`~spinemesh.limits.MAX_SKELETON_NUMBER`
in size, so that nothing computed from them overflows.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from .errors import LimitError, SkeletonError
from .limits import MAX_ATTACHMENTS, MAX_SKELETON_NUMBER

# -- what a value is -------------------------------------------------------------------------------


def found(value) -> str:
    """Words for what ``value`` is, for an error line (``"a list"``, ``"an integer of 401 digits"``)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, int):
        digits = len(str(abs(value))) if abs(value) < 10**4000 else "thousands of"
        return f"an integer of {digits} digits" if abs(value) > MAX_SKELETON_NUMBER else f"the number {value}"
    if isinstance(value, float):
        return f"the number {value!r}"
    if isinstance(value, str):
        return "text" if len(value) > 40 else f"the text {value!r}"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def is_int(value) -> bool:
    """Whether ``value`` is an integer and not true or false (Python's ``bool`` is an ``int``; a
    JSON ``true`` is no number to any runtime): the one test for a count, a size or an index read
    from a file.

    Examples
    --------
    >>> is_int(3), is_int(True), is_int(3.0)
    (True, False, False)
    """
    return isinstance(value, int) and not isinstance(value, bool)


def is_number(value) -> bool:
    """Whether ``value`` is an integer or a float and not true or false (see :func:`is_int`).

    Examples
    --------
    >>> is_number(2.5), is_number(False), is_number("2")
    (True, False, False)
    """
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _number_ok(value) -> bool:
    if isinstance(value, str):  # the runtimes parse numeric text
        try:
            value = float(value)
        except ValueError:
            return False
    if not is_number(value):
        return False
    # abs() of an int is exact: a 400-digit integer compares without overflow
    return abs(value) <= MAX_SKELETON_NUMBER if isinstance(value, int) else (
        math.isfinite(value) and abs(value) <= MAX_SKELETON_NUMBER)


def _numbers_ok(values) -> bool:
    """A list of numbers, each within the limit (checked in C for long vertex lists)."""
    if not isinstance(values, list):
        return False
    try:
        # abs() refuses text, lists and objects (TypeError) but takes true/false: those are
        # looked for by type, in C ("in" over the types), not in a Python loop
        return max(map(abs, values), default=0) <= MAX_SKELETON_NUMBER and bool not in map(type, values)
    except TypeError:  # a string, list or object among them
        return False


def _name_ok(value) -> bool:
    # text, or a scalar the runtimes read as text; never a list or object (unhashable)
    return isinstance(value, (str, int, float)) and not (isinstance(value, float) and not math.isfinite(value))


def _names_ok(values) -> bool:
    return isinstance(values, list) and all(_name_ok(v) for v in values)


#: Kinds of field: (test, what is expected). ``None`` passes every optional field.
NAME = (_name_ok, "a name")
NAMES = (_names_ok, "a list of names")
NUMBER = (_number_ok, f"a finite number of at most {MAX_SKELETON_NUMBER:g} in size")
NUMBERS = (_numbers_ok, f"a list of finite numbers of at most {MAX_SKELETON_NUMBER:g} in size")
OBJECT = (lambda v: isinstance(v, dict), "an object")
LIST = (lambda v: isinstance(v, list), "a list")


def _fields(kind, *names: str) -> dict:
    return dict.fromkeys(names, kind)


BONE = {"name": NAME, "parent": NAME, "inherit": NAME, "transform": NAME,
        **_fields(NUMBER, "length", "x", "y", "rotation", "scaleX", "scaleY", "shearX", "shearY")}
SLOT = {"name": NAME, "bone": NAME, "attachment": NAME, "blend": NAME, "color": NAME, "dark": NAME}
_CONSTRAINT = {"name": NAME, "bones": NAMES, "bone": NAME, "target": NAME, "source": NAME, "slot": NAME,
               "type": NAME, "order": NUMBER}
IK = {**_CONSTRAINT, **_fields(NUMBER, "mix", "softness")}
TRANSFORM = {**_CONSTRAINT, **_fields(NUMBER, "rotation", "x", "y", "scaleX", "scaleY", "shearY", "mixRotate",
                                      "mixX", "mixY", "mixScaleX", "mixScaleY", "mixShearY", "rotateMix",
                                      "translateMix", "scaleMix", "shearMix")}
PATH = {**_CONSTRAINT, "positionMode": NAME, "spacingMode": NAME, "rotateMode": NAME,
        **_fields(NUMBER, "position", "spacing", "rotation", "mixRotate", "mixX", "mixY", "rotateMix",
                  "translateMix")}
PHYSICS = {**_CONSTRAINT, **_fields(NUMBER, "x", "y", "rotate", "scaleX", "shearX", "limit", "fps", "inertia",
                                    "strength", "damping", "mass", "wind", "gravity", "mix")}
#: A 4.3 slider's names (its numbers are clamped where they are played, as round six's 1e300 showed).
SLIDER = {**_CONSTRAINT, "animation": NAME, "property": NAME}
CONSTRAINTS = {"ik": IK, "transform": TRANSFORM, "path": PATH, "physics": PHYSICS, "slider": SLIDER}

#: The fields of an attachment that the program reads (meshing, weighting, writing .skel).
ATTACHMENT = {"type": NAME, "name": NAME, "path": NAME, "parent": NAME, "source": NAME, "skin": NAME,
              "slot": NAME, "color": NAME, "sequence": OBJECT,
              **_fields(NUMBER, "x", "y", "width", "height", "rotation", "scaleX", "scaleY", "hull", "vertexCount"),
              **_fields(NUMBERS, "vertices", "uvs", "triangles", "edges", "lengths")}

#: Top-level fields and what they hold.
TOP = {"skeleton": OBJECT, "bones": LIST, "slots": LIST, "constraints": LIST, "animations": OBJECT,
       **_fields(LIST, *CONSTRAINTS)}

# -- JSON paths ------------------------------------------------------------------------------------

_PLAIN_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*\Z")


def json_path(*parts) -> str:
    """``slots[3].bone`` from ``("slots", 3, "bone")``; odd keys quoted (``attachments["a b"]``)."""
    out = ""
    for part in parts:
        if isinstance(part, int):
            out += f"[{part}]"
        elif _PLAIN_KEY.match(part):
            out += f".{part}" if out else part
        else:
            out += f"[{json.dumps(part, ensure_ascii=False)}]"
    return out


def _field_problem(node: dict, spec: dict, *where) -> str:
    """The first field of ``node`` that is not what ``spec`` expects, or that ``node`` names twice
    (:class:`KeyedTwice`), as an error line, or ``""``."""
    twice = getattr(node, "twice", None)
    if twice:
        read = {k.casefold() for k in spec}
        key = next((k for k in node if k.casefold() in twice and k.casefold() in read), None)
        if key is not None:
            return (f"{json_path(*where, key)}: written twice (or twice but for case); the Spine runtimes read "
                    "different ones (spine-ts the last, spine-c, spine-cpp and libGDX the first)")
    folded = None
    for key, value in node.items():
        kind = spec.get(key)
        if kind is None and value is not None:
            # spine-c, spine-cpp and libGDX match a field's name ignoring case: "X" is their x
            folded = folded or {k.casefold(): k for k in spec}
            meant = folded.get(key.casefold())
            if meant is not None and meant not in node:
                return (f"{json_path(*where, key)}: read as {meant!r} by spine-c, spine-cpp and libGDX (they match "
                        "names ignoring case), not by spine-ts")
        if kind is None or value is None:  # not read by the program / absent in the runtimes' eyes
            continue
        test, expected = kind
        if not test(value):
            return f"{json_path(*where, key)}: expected {expected}, found {found(value)}"
    return ""


def _list_of_objects(doc: dict, key: str, spec: dict | None) -> str:
    """The first problem of the objects listed under ``key``; ``spec`` None: each entry's fields
    by its ``type`` (4.3's one ``constraints`` list, where a field name means different things in
    different kinds: an IK constraint's ``scaleY`` is a mode name, a transform's a number)."""
    for i, node in enumerate(doc.get(key) or []):
        if not isinstance(node, dict):
            return f"{json_path(key, i)}: expected an object, found {found(node)}"
        kind = node.get("type")
        fields = spec if spec is not None else CONSTRAINTS.get(kind if isinstance(kind, str) else "", _CONSTRAINT)
        problem = _field_problem(node, fields, key, i)
        if problem:
            return problem
    return ""


def _skins_problem(skins) -> tuple[str, int]:
    """The skins' layout (3.8+: a list of objects; before: an object of skins) and its attachment count."""
    count = 0
    if isinstance(skins, list):
        items = []
        for i, skin in enumerate(skins):
            if not isinstance(skin, dict):
                return f"{json_path('skins', i)}: expected an object, found {found(skin)}", 0
            problem = _field_problem(skin, {"name": NAME, "attachments": OBJECT, "bones": NAMES, "ik": NAMES,
                                            "transform": NAMES, "path": NAMES, "physics": NAMES}, "skins", i)
            if problem:
                return problem, 0
            items.append((("skins", i, "attachments"), skin.get("attachments") or {}))
    elif isinstance(skins, dict):
        items = [(("skins", name), slots) for name, slots in skins.items()]
    elif skins is None:
        return "", 0
    else:
        return f"skins: expected a list or an object, found {found(skins)}", 0
    for where, slots in items:
        if not isinstance(slots, dict):
            return f"{json_path(*where)}: expected an object, found {found(slots)}", 0
        for slot, attachments in slots.items():
            if not isinstance(attachments, dict):
                return f"{json_path(*where, slot)}: expected an object, found {found(attachments)}", 0
            count += len(attachments)
    return "", count


def document_problem(doc) -> str:
    """The first problem of a skeleton document's shape outside its attachments, or ``""``."""
    if not isinstance(doc, dict):
        return f"the top level: expected an object, found {found(doc)}"
    problem = _field_problem(doc, {**TOP, "skins": None})  # skins: checked below, named twice here
    if problem:
        return problem
    if isinstance(doc.get("skeleton"), dict):
        problem = _field_problem(doc["skeleton"], {"spine": NAME}, "skeleton")
    problem = problem or _list_of_objects(doc, "bones", BONE) or _list_of_objects(doc, "slots", SLOT)
    for kind, spec in CONSTRAINTS.items():
        problem = problem or _list_of_objects(doc, kind, spec)
    return problem or _list_of_objects(doc, "constraints", None)


def _bone_name(bone: dict) -> str:
    return str(bone.get("name"))


def bone_tree_problem(doc: dict) -> str:
    """The first break of the bone tree (names, parents, slots' bones), or ``""``.

    The runtimes read bones in order and look each parent up among the bones read before it,
    so a parent listed after its child, a bone that is its own parent and parents in a cycle
    are all refused there; so are a slot on a bone that does not exist and a constraint or skin
    naming a bone or slot that does not exist (:data:`REFERENCES`). Code that walks up the
    tree (weights, bone chains, world transforms) relies on this to end. ``doc`` has passed
    :func:`document_problem` (bones and slots are lists of objects with names where named).
    """
    bones = doc.get("bones") or []
    index: dict[str, int] = {}
    for i, bone in enumerate(bones):
        if bone.get("name") is None:
            return f"{json_path('bones', i)}: a bone needs a name"
        name = _bone_name(bone)
        if name in index:
            return f"{json_path('bones', i, 'name')}: {name!r} names two bones (bones[{index[name]}] and bones[{i}])"
        index[name] = i
    for i, bone in enumerate(bones):
        parent = bone.get("parent")
        if parent is None:
            continue
        name, parent = _bone_name(bone), str(parent)
        where = json_path("bones", i, "parent")
        if parent == name:
            return f"{where}: bone {name!r} is its own parent"
        if parent not in index:
            return f"{where}: bone {name!r} names parent {parent!r}, which is not a bone of this skeleton"
        if index[parent] > i:
            # a cycle, or only the order: say which, since the fix differs
            path, at = [i], index[parent]
            while at not in path:
                path.append(at)
                up = bones[at].get("parent")
                if up is None or str(up) not in index:
                    break
                at = index[str(up)]
            else:
                cycle = path[path.index(at):] + [at]
                return f"{where}: the parents of bones {' -> '.join(repr(_bone_name(bones[k])) for k in cycle)} " \
                       "run in a cycle"
            return (f"{where}: parent {parent!r} of bone {name!r} is listed after it (bones[{index[parent]}]); "
                    "a parent must come before its children")
    for i, slot in enumerate(doc.get("slots") or []):
        bone = slot.get("bone")
        if bone is None or str(bone) not in index:
            on = "no bone" if bone is None else f"bone {str(bone)!r}, which is not a bone of this skeleton"
            return f"{json_path('slots', i, 'bone')}: slot {str(slot.get('name'))!r} is on {on}"
    return _references_problem(doc, {"bone": index, "slot": {str(s.get("name")) for s in doc.get("slots") or []}})


#: What the names in a constraint's fields stand for, per kind (3.x to 4.2 field names, and 4.3's
#: ``source`` and ``slot``); fields left out are not names of bones or slots.
REFERENCES = {"ik": {"bones": "bone", "target": "bone"},
              "transform": {"bones": "bone", "target": "bone", "source": "bone"},
              "path": {"bones": "bone", "target": "slot", "slot": "slot"},
              "physics": {"bone": "bone"}}


def _references_problem(doc: dict, known: dict) -> str:
    """The first constraint or skin naming a bone or slot the skeleton lacks (which the runtimes
    refuse to load), or ``""``. ``known``: names of the bones and of the slots."""
    lists = [((kind, i), kind, node) for kind in REFERENCES for i, node in enumerate(doc.get(kind) or [])]
    lists += [(("constraints", i), node.get("type"), node) for i, node in enumerate(doc.get("constraints") or [])]
    skins = doc.get("skins")
    if isinstance(skins, list):
        lists += [(("skins", i), "skin", skin) for i, skin in enumerate(skins) if isinstance(skin, dict)]
    for where, kind, node in lists:
        fields = {"bones": "bone"} if kind == "skin" else REFERENCES.get(kind if isinstance(kind, str) else "", {})
        for key, what in fields.items():
            value = node.get(key)
            for name in value if isinstance(value, list) else [] if value is None else [value]:
                if str(name) not in known[what]:
                    return (f"{json_path(*where, key)}: {str(node.get('name', kind))!r} names {what} {str(name)!r}, "
                            f"which is not a {what} of this skeleton")
    return ""


def vertices_problem(vertices: list, count: int, bone_count: int) -> str:
    """Why a ``vertices`` list cannot hold ``count`` vertices over ``bone_count`` bones, or ``""``.

    Unweighted: ``2 * count`` numbers. Weighted (any other length): per vertex, its number of
    bones ``k``, then ``k`` times (bone index, x, y, weight), ending exactly at the list's end;
    every bone index below ``bone_count``. The numbers themselves were checked (finite, at most
    :data:`~spinemesh.limits.MAX_SKELETON_NUMBER` in size, no text), so ``int()`` cannot fail.
    """
    if len(vertices) == 2 * count:
        return ""
    i, n = 0, len(vertices)
    for v in range(count):
        if i >= n:
            return f"the weighted list ends after {v} of {count} vertices"
        k = vertices[i]
        if k != int(k) or not 0 <= k <= bone_count:
            return f"vertex {v} gives {k!r} as its number of bones (the skeleton has {bone_count})"
        k = int(k)
        if i + 1 + 4 * k > n:
            return f"the weighted list ends inside vertex {v} of {count}"
        for j in range(k):
            b = vertices[i + 1 + 4 * j]
            if b != int(b) or not 0 <= b < bone_count:
                return f"vertex {v} is bound to bone index {b!r}, the skeleton has {bone_count} bones"
        i += 1 + 4 * k
    if i != n:
        return f"{n - i} numbers follow the {count} weighted vertices"
    return ""


def _vertex_count(attachment: dict) -> int | None:
    """How many vertices an attachment's ``vertices`` hold: half its ``uvs`` for a mesh, else its
    ``vertexCount``; None when that cannot be told (checked elsewhere, or nothing to check)."""
    uvs = attachment.get("uvs")
    if isinstance(uvs, list):
        return len(uvs) // 2
    count = attachment.get("vertexCount")
    if is_number(count) and count == int(count) and count >= 0:
        return int(count)
    return None


def check_document(doc, source: str | Path | None = None) -> None:
    """Refuse a skeleton document whose bones, slots, constraints or skins have the wrong shape,
    or whose bone tree is broken (:func:`bone_tree_problem`).

    Attachments are checked one by one where they are read (:func:`attachment_problem`).

    Raises
    ------
    SkeletonError
        ``FILE: slots[3].bone: expected a name, found a list``.
    LimitError
        More than :data:`~spinemesh.limits.MAX_ATTACHMENTS` attachments.
    """
    problem = document_problem(doc) or bone_tree_problem(doc)
    if problem:
        raise SkeletonError(problem, source)
    problem, count = _skins_problem(doc.get("skins"))
    if problem:
        raise SkeletonError(problem, source)
    if count > MAX_ATTACHMENTS:
        raise LimitError(f"{count:,} attachments exceed the limit of {MAX_ATTACHMENTS:,} per skeleton", source)


class KeyedTwice(dict):
    """A JSON object that names a key twice, or twice but for case (``{"x": 0, "X": 50}``).

    Python's JSON, like spine-ts (``JSON.parse``), keeps the last value of a key; spine-c,
    spine-cpp and libGDX read the first whose name matches ignoring case. ``twice`` holds those
    keys, case-folded; ``repeated`` those written twice alike, as written (``x`` of ``x``, ``X``,
    ``x`` too); :func:`spinemesh.skeleton.parse_skeleton_json` makes such objects.
    """

    twice: frozenset = frozenset()
    repeated: frozenset = frozenset()

    @classmethod
    def of(cls, pairs: list) -> dict:
        """The object of JSON ``pairs``: a plain dict, or a :class:`KeyedTwice` where a key repeats."""
        obj = dict(pairs)
        if len(obj) == len(pairs) and (len(obj) < 2 or len({k.casefold() for k in obj}) == len(obj)):
            return obj
        seen: set = set()
        twice = {k for k in (key.casefold() for key, _ in pairs) if k in seen or seen.add(k)}
        written: set = set()
        marked = cls(obj)
        marked.twice = frozenset(twice)
        marked.repeated = frozenset(key for key, _ in pairs if key in written or written.add(key))
        return marked


#: Most lines :func:`animations_keyed_twice` gives, one per animation: a file of thousands says the first.
MAX_KEYED_TWICE_LINES = 10


def animations_keyed_twice(doc) -> list[str]:
    """One warning line per animation that names a key twice in one of its objects (a slot's
    ``"attachment"`` timeline written twice, as an exporter left it in a game's skeleton), naming the animation and the JSON paths, up to :data:`MAX_KEYED_TWICE_LINES`
    lines (then one saying how many more).

    The runtimes read such an animation differently: spine-c, spine-cpp and libGDX go through
    every entry (both timelines are applied, the later over the earlier), spine-ts
    (``JSON.parse``) and Python keep the last alone, and so does every skeleton spinemesh writes
    (JSON or ``.skel``). Animations are passed through, not read: not refused, said.
    """
    animations = doc.get("animations") if isinstance(doc, dict) else None
    if not isinstance(animations, dict):
        return []
    lines = [f"animation {name!r}: named twice; {_KEYED_TWICE_READ}" for name in _written_twice(animations)]
    for name in animations:
        paths = []
        stack = [((), animations[name])]
        while stack:
            where, node = stack.pop()
            if isinstance(node, dict):
                if isinstance(node, KeyedTwice):
                    paths += [json_path(*where, key) for key in _written_twice(node)]
                stack += [((*where, key), value) for key, value in node.items() if isinstance(value, (dict, list))]
            elif isinstance(node, list):
                stack += [((*where, i), value) for i, value in enumerate(node) if isinstance(value, (dict, list))]
        if paths:
            paths.sort()
            more = f" and {len(paths) - 3} more" if len(paths) > 3 else ""
            lines.append(f"animation {name!r}: {', '.join(paths[:3])}{more} written twice; "
                         + _KEYED_TWICE_READ)
    if len(lines) > MAX_KEYED_TWICE_LINES:
        more = len(lines) - MAX_KEYED_TWICE_LINES
        lines = [*lines[:MAX_KEYED_TWICE_LINES], f"and {more} more animations naming a key twice"]
    return lines


def _written_twice(node: dict) -> list[str]:
    """The keys a :class:`KeyedTwice` holds once for two written alike (the first's value lost
    here), beside another case of it or not (``x`` of ``x``, ``X``, ``x``); keys that differ but
    for case alone are both held, and not among them."""
    repeated = getattr(node, "repeated", ())
    return [key for key in node if key in repeated]


_KEYED_TWICE_READ = ("spine-c, spine-cpp and libGDX read each (a timeline written twice is applied twice), spine-ts "
                     "the last only, as a skeleton spinemesh writes keeps it: remove one to play the same everywhere")


def attachment_problem(attachment, where: tuple = (), bone_count: int | None = None) -> str:
    """Why one attachment cannot be used (``"x: expected a finite number ..., found ..."``), or ``""``.

    ``where`` is the attachment's JSON path, put before the field in the answer. With
    ``bone_count`` (the skeleton's number of bones), weighted ``vertices`` are walked too
    (:func:`vertices_problem`).
    """
    if not isinstance(attachment, dict):
        return f"{json_path(*where) or 'attachment'}: expected an object, found {found(attachment)}"
    problem = _field_problem(attachment, ATTACHMENT, *where)
    vertices = attachment.get("vertices")
    if problem or bone_count is None or not isinstance(vertices, list):
        return problem
    count = _vertex_count(attachment)
    if count is None:
        return ""
    problem = vertices_problem(vertices, count, bone_count)
    return f"{json_path(*where, 'vertices')}: {problem}" if problem else ""


__all__ = [
    "KeyedTwice",
    "animations_keyed_twice",
    "attachment_problem",
    "bone_tree_problem",
    "check_document",
    "document_problem",
    "found",
    "json_path",
    "vertices_problem",
]

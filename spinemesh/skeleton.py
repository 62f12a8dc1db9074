"""Skeleton documents: lossless JSON I/O and one walk over every attachment.

A skeleton document is the plain ``dict`` that the Spine editor's JSON export holds. The
binary reader (:mod:`spinemesh.skeleton_binary`) produces the same document, so everything
downstream works on one model whatever the input format was.

Spine changed the skin layout in 3.8: before, ``"skins"`` is a dict of skin name to slots;
from 3.8 on, a list of ``{"name", "attachments", ...}``. :func:`iter_attachments` hides
the difference.
"""

from __future__ import annotations

import json
import math
import re
import sys
from collections import namedtuple
from collections.abc import Iterator
from pathlib import Path

from .errors import LimitError, SkeletonError, SpineMeshError
from .files.atomic import atomic_write_text
from .limits import (
    MAX_JSON_DEPTH,
    MAX_SEQUENCE_DIGITS,
    MAX_SEQUENCE_FRAMES,
    check_file_size,
)
from .skeleton_check import KeyedTwice, check_document, is_int, is_number
from .skeleton_names import first_of_each_name  # noqa: F401 (re-exported: where anim finds it)

#: Attachment types that draw an image from the atlas.
IMAGE_TYPES = ("region", "mesh", "linkedmesh")


class AttachmentRef(namedtuple("AttachmentRef", "skin slot name attachment")):
    """One attachment of one skin: ``(skin, slot, name, attachment)``, three ``str`` and a ``dict``.

    ``attachment`` is the document's own dict: changing it changes the document. (A
    collections.namedtuple: `spinemesh convert` does not import typing.)
    """

    __slots__ = ()

    @property
    def type(self) -> str:
        return self.attachment.get("type", "region")


def load_skeleton(path: str | Path) -> dict:
    """Load a skeleton ``.json`` (or ``.skel``, through the binary reader).

    JSON keeps key order and every field, known or not, so that :func:`save_skeleton`
    writes back an equal document.

    The document's shape is checked once here (:func:`spinemesh.skeleton_check.check_document`):
    code that reads it may trust the types of bones, slots, constraints and skins.

    Parameters
    ----------
    path : path
        A skeleton file of Spine 3.5 to 4.3: JSON, or binary by its name or first byte
        (:func:`is_binary_skeleton`); its size is bounded (:mod:`spinemesh.limits`).

    Returns
    -------
    dict
        The document in the layout of Spine's JSON export, whichever format it came in.

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> folder = make_demo_project("demo")
    >>> doc = load_skeleton(folder / "demo.json")
    >>> doc["skeleton"]["spine"], [b["name"] for b in doc["bones"]][:2]
    ('4.2.40', ['root', 'body'])
    >>> load_skeleton(folder / "demo-binary.skel")["skeleton"]["spine"]
    '4.2.40'

    Raises
    ------
    SkeletonError
        With the file and line, for unreadable or non-skeleton JSON; with the file and the JSON
        path for a field of the wrong shape (``slots[3].bone: expected a name, found a list``).
    SkelFormatError
        With the byte offset, for a broken ``.skel``.
    """
    path = Path(path)
    try:  # a file it may not read (permission denied) is that skeleton's line, never the run's end
        check_file_size(path, "skeleton")
        wide = _wide_text(path)
        binary = not wide and is_binary_skeleton(path)
    except OSError as e:
        raise SkeletonError(f"cannot read skeleton: {e.strerror}", path) from None
    if wide:
        raise SkeletonError(f"skeleton is {wide} text; the Spine runtimes read JSON as UTF-8 only", path)
    if binary:
        from .skeleton_binary import read_skel_finite

        doc, finite = read_skel_finite(path)
        where = None if finite else first_non_finite(doc)
        if where is not None:
            raise SkeletonError(f"holds a non-finite number (NaN or infinity) at {where}; refused, "
                                "since it could not be written back as valid JSON or meshed", path)
        check_document(doc, path)
        return doc
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise SkeletonError(f"cannot read skeleton: {e.strerror}", path) from None
    except UnicodeDecodeError as e:
        raise SkeletonError(f"skeleton is not UTF-8 text (byte {e.start})", path) from None
    doc = parse_skeleton_json(text, path)
    if not isinstance(doc, dict) or not isinstance(doc.get("bones", []), list):
        raise SkeletonError("not a Spine skeleton (no top-level object with 'bones')", path)
    check_document(doc, path)
    return doc


def first_non_finite(doc) -> str | None:
    """Where the first NaN or infinity in a document is (``"skins/0/attachments/..."``), or None.

    JSON input refuses them while parsing; a binary ``.skel`` stores raw floats, so its
    document is checked once after reading.
    """
    try:
        json.dumps(doc, allow_nan=False)  # the fast answer, in C; the walk below only says where
        return None
    except ValueError:
        pass
    stack = [("", doc)]
    while stack:
        where, node = stack.pop()
        if isinstance(node, float):
            if not math.isfinite(node):
                return where or "the top level"
        elif isinstance(node, dict):
            stack.extend((f"{where}/{k}", v) for k, v in node.items())
        elif isinstance(node, list):
            stack.extend((f"{where}/{i}", v) for i, v in enumerate(node))
    return None


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):  # 1e999 parses as inf
        raise ValueError(f"{text} is beyond the range of a number")
    return value


def _whole_number(text: str) -> int:
    """A JSON integer, refused in words where it has more digits than Python turns into a number
    (4,300 by default): its own error says to call ``sys.set_int_max_str_digits``."""
    digits = len(text.lstrip("-"))
    if digits > sys.get_int_max_str_digits() > 0:
        raise ValueError(f"a number of {digits:,} digits is beyond the range of a number")
    return int(text)


#: Digits to 0 and ``E`` to ``e``, for :func:`_may_overflow`'s search.
_NUMBER_SHAPES = str.maketrans("123456789E", "000000000e")


def _may_overflow(text: str) -> bool:
    """Whether JSON ``text`` may hold a number beyond float range (``1e999``, ``-2E+308``, or
    three hundred digits): False means none can overflow, so floats parse without a hook.

    A JSON number overflows only with an exponent of three digits or more, or, with one of
    at most two (below 10^100), an integer part of over 200 digits: digits mapped to ``0``,
    either shows as ``0e000``, ``0e+000`` or a run of 210 zeros. Names and hex colours
    (``"10e323ff"``) can match too; they only send the text through the checking parse.
    """
    shapes = text.translate(_NUMBER_SHAPES)
    return "0e000" in shapes or "0e+000" in shapes or "0" * 210 in shapes


def _bracket_depth(text: str) -> int:
    """Deepest running count of ``[{`` minus ``]}`` in ``text``."""
    # numpy is imported here, not at the top: `spinemesh convert` of a .skel never needs it.
    import numpy as np

    step = np.zeros(256, np.int8)
    step[[0x5B, 0x7B]] = 1   # [ {
    step[[0x5D, 0x7D]] = -1  # ] }
    raw = np.frombuffer(text.encode("utf-8", "surrogatepass"), np.uint8)
    return int(np.cumsum(step[raw], dtype=np.int32).max(initial=0))


def _json_depth(text: str) -> int:
    """How deep arrays and objects nest in JSON ``text``.

    Counted on the raw characters first (fast); brackets inside strings can make that count
    too high, so a high count is counted again with strings blanked out. (Strings full of
    closing brackets can make it too low; the parser's own recursion check backs this up.)
    """
    depth = _bracket_depth(text)
    if depth <= MAX_JSON_DEPTH:
        return depth
    return _bracket_depth(re.sub(r'"(?:[^"\\]|\\.)*"', '""', text))


#: A ``\\uD800``-``\\uDFFF`` escape (a UTF-16 surrogate) not escaped itself.
_SURROGATE = re.compile(r'(?<!\\)(?:\\\\)*\\u[dD][89a-fA-F][0-9a-fA-F]{2}')


def _lone_surrogate(text: str) -> bool:
    """Whether ``text`` escapes a UTF-16 surrogate that is not half of a valid pair."""
    if "\\ud" not in text and "\\uD" not in text:
        return False
    for m in _SURROGATE.finditer(text):
        code = int(m.group()[-4:], 16)
        if code >= 0xDC00:
            before = text[max(0, m.end() - 12):m.end() - 6]
            if not re.fullmatch(r"\\u[dD][89abAB][0-9a-fA-F]{2}", before):
                return True
        else:
            after = text[m.end():m.end() + 6]
            if not re.fullmatch(r"\\u[dD][c-fC-F][0-9a-fA-F]{2}", after):
                return True
    return False


def parse_skeleton_json(text: str, source: str | Path | None = None):
    """Parse skeleton JSON strictly: what could not be written back, or would exhaust memory, is refused.

    Refused, each with a :class:`SkeletonError` naming ``source``: invalid JSON (with line and
    column), ``NaN``/``Infinity`` and numbers beyond float range (never meshed, never written),
    nesting deeper than :data:`~spinemesh.limits.MAX_JSON_DEPTH`, integers longer than Python
    parses, and escaped lone UTF-16 surrogates (no UTF-8 file can hold them). An object that
    names a key twice, or twice but for case, is a :class:`~spinemesh.skeleton_check.KeyedTwice`
    (the runtimes read different ones; an attachment so written is not used).
    """
    depth = _json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise LimitError(f"JSON nests {depth} levels deep, more than the limit of {MAX_JSON_DEPTH}", source)
    if _lone_surrogate(text):
        raise SkeletonError("JSON holds an escaped lone UTF-16 surrogate (\\ud800-\\udfff), "
                            "which is not text", source)
    try:
        # objects that name a key twice are marked (KeyedTwice): the runtimes read different ones
        if not _may_overflow(text):  # no number can be beyond float range: no hook per float
            return json.loads(text, parse_constant=_refuse_constant, object_pairs_hook=KeyedTwice.of)
        return json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float,
                          parse_int=_whole_number, object_pairs_hook=KeyedTwice.of)
    except json.JSONDecodeError as e:
        raise SkeletonError(f"invalid JSON: {e.msg} (column {e.colno})", source, line=e.lineno) from None
    except (ValueError, RecursionError) as e:
        raise SkeletonError(f"invalid JSON: {e}", source) from None


def dumps_skeleton(doc: dict, path: str | Path | None = None, like: str | None = None, numbers=None) -> str:
    """The document as JSON text in the editor's export style, or in the style of ``like``.

    Parameters
    ----------
    doc : dict
    path : path, optional
        The file the text is meant for, named in errors.
    like : str, optional
        The JSON text ``doc`` was read from. Only the values that changed are rewritten (in
        the style detected from ``like``) and every other byte is kept, so that a
        version-control diff shows only what changed (see :mod:`spinemesh.json_style`).
    numbers : type, optional
        How numbers are written when ``like`` is not given: a
        :class:`~spinemesh.json_style.NumberText` class, by default that one;
        :class:`~spinemesh.skeleton_binary.Float32Text` for a document read from a ``.skel``.

    Raises
    ------
    SpineMeshError
        If the document holds NaN or Infinity (strict JSON and the runtimes reject them),
        naming ``path``, the file it was meant for.
    """
    from .json_style import EDITOR_STYLE, NumberText, dumps, splice

    try:
        if like is not None:
            return splice(like, doc)
        return dumps(doc, EDITOR_STYLE, numbers=numbers or NumberText) + "\n"
    except ValueError as e:
        raise SpineMeshError(f"not written: it would hold a non-finite number ({e})", path) from None


def save_skeleton(doc: dict, path: str | Path) -> None:
    """Write ``doc`` atomically, as ``.skel`` if ``path`` is binary, else as JSON.

    Parameters
    ----------
    doc : dict
        A document as :func:`load_skeleton` gives it; written for the version it names.
    path : path
        The file to write; binary by its name (:func:`is_binary_skeleton`). An existing
        file is replaced whole or not at all.

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> doc = load_skeleton(make_demo_project("demo") / "demo.json")
    >>> save_skeleton(doc, "copy.skel")
    >>> load_skeleton("copy.skel")["slots"] == doc["slots"]
    True
    """
    path = Path(path)
    if is_binary_skeleton(path):
        from .files.atomic import atomic_write_bytes
        from .skeleton_binary import encode_skel

        atomic_write_bytes(path, encode_skel(doc, path))
    else:
        atomic_write_text(path, dumps_skeleton(doc, path))


#: Skeleton file names: the editor's, Unity's (``.json.txt``, ``.skel.bytes``) and Godot's
#: (``.spine-json``).
SKELETON_SUFFIXES = (".json", ".skel", ".json.txt", ".skel.bytes", ".spine-json")

#: Byte-order marks and first characters (``{`` or ``[``) of JSON saved as UTF-16 or UTF-32
#: (Windows editors' "Unicode"), longest first.
_WIDE_TEXT = ((b"\xff\xfe\x00\x00", "UTF-32"), (b"\x00\x00\xfe\xff", "UTF-32"), (b"{\x00\x00\x00", "UTF-32"),
              (b"[\x00\x00\x00", "UTF-32"), (b"\xff\xfe", "UTF-16"), (b"\xfe\xff", "UTF-16"),
              (b"{\x00", "UTF-16"), (b"[\x00", "UTF-16"), (b"\x00{", "UTF-16"), (b"\x00[", "UTF-16"))


def _wide_text(path: Path) -> str:
    """``"UTF-16"`` or ``"UTF-32"`` for a skeleton named ``.json`` saved so, else ``""`` (a
    binary read as one said only "expected a Spine version string")."""
    if path.name.lower().endswith((".skel", ".skel.bytes", ".skel.txt")) or not path.is_file():
        return ""
    with open(path, "rb") as f:
        head = f.read(4)
    return next((name for start, name in _WIDE_TEXT if head.startswith(start)), "")


def is_binary_skeleton(path: str | Path) -> bool:
    """Whether a skeleton file is binary: ``.skel``, ``.skel.bytes``, or a ``.json`` that is not text.

    Real projects ship binaries under JSON names (Unity), so the first byte decides when
    the extension says JSON.
    """
    p = Path(path)
    name = p.name.lower()
    if name.endswith((".skel", ".skel.bytes", ".skel.txt")):
        return True
    if p.is_file():
        with open(p, "rb") as f:
            head = f.read(64).lstrip(b"\xef\xbb\xbf \t\r\n")
        return not head.startswith((b"{", b"["))
    return False


def spine_version(doc: dict) -> str:
    """The editor version that wrote the document, e.g. ``"4.2.22"`` (``""`` if absent)."""
    skel = doc.get("skeleton")
    return str(skel.get("spine", "")) if isinstance(skel, dict) else ""


def _skins(doc: dict) -> Iterator[tuple[str, dict, tuple]]:
    """``(skin name, {slot: {name: attachment}}, JSON path of that mapping)`` for both layouts."""
    skins = doc.get("skins")
    if isinstance(skins, dict):  # 3.6 / 3.7
        for name, slots in skins.items():
            if isinstance(slots, dict):
                yield name, slots, ("skins", name)
    elif isinstance(skins, list):  # 3.8+
        for i, skin in enumerate(skins):
            if isinstance(skin, dict) and isinstance(skin.get("attachments", {}), dict):
                yield str(skin.get("name", "")), skin.get("attachments", {}), ("skins", i, "attachments")


def iter_skins(doc: dict) -> Iterator[tuple[str, dict]]:
    """``(skin name, {slot: {attachment name: attachment}})`` for both skin layouts."""
    for name, slots, _ in _skins(doc):
        yield name, slots


def skins_by_name(doc: dict) -> dict[str, dict]:
    """``{skin name: {slot: {attachment name: attachment}}}`` as the runtimes find a skin when
    two share a name (no editor writes that; a merge of two skeletons can): by name, the first
    (``findSkin``); the default skin, the last named ``default`` (the JSON readers set it at each).
    """
    out: dict[str, dict] = {}
    for name, slots in iter_skins(doc):
        if name == "default":
            out[name] = slots
        else:
            out.setdefault(name, slots)
    return out


def checked_attachments(doc: dict) -> Iterator[tuple[AttachmentRef, str]]:
    """Every attachment of every skin, in document order, with why it cannot be used (or ``""``).

    The reason names the attachment's JSON path and the field
    (``skins[0].attachments.head.head.x: expected a finite number ..., found ...``), weighted
    vertices included (a bone index beyond the skeleton's bones, a list cut short); see
    :func:`spinemesh.skeleton_check.attachment_problem`.
    """
    from .skeleton_check import attachment_problem

    bone_count = len(doc.get("bones") or [])
    for skin, slots, where in _skins(doc):
        for slot, attachments in slots.items():
            if not isinstance(attachments, dict):
                continue
            for name, att in attachments.items():
                if isinstance(att, dict):
                    yield AttachmentRef(skin, slot, name, att), attachment_problem(att, (*where, slot, name), bone_count)


def iter_attachments(doc: dict) -> Iterator[AttachmentRef]:
    """Every usable attachment of every skin, in document order.

    An attachment whose fields have the wrong type or an unusable number is passed over (left
    as it is in the document); :func:`checked_attachments` says why.

    Parameters
    ----------
    doc : dict
        A document as :func:`load_skeleton` gives it.

    Yields
    ------
    AttachmentRef
        ``(skin, slot, name, attachment)``, the attachment the document's own dict (changing
        it changes the document); ``type`` is its type (``region`` when the JSON names none).

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> doc = load_skeleton(make_demo_project("demo") / "demo.json")
    >>> [(ref.slot, ref.name, ref.type) for ref in iter_attachments(doc)][:2]
    [('arm', 'demo-arm', 'region'), ('body', 'demo-body', 'region')]
    """
    for ref, problem in checked_attachments(doc):
        if not problem:
            yield ref


def attachment_path(ref: AttachmentRef) -> str:
    """The image path an attachment draws: ``path``, else ``name``, else its key."""
    att = ref.attachment
    return str(att.get("path") or att.get("name") or ref.name)


def linked_source(ref: AttachmentRef) -> tuple[str, str, str]:
    """``(skin, slot, name)`` of the mesh whose geometry a linked mesh reuses.

    Before 4.3 the JSON names it ``"parent"``, in the linked mesh's own slot; 4.3 names it
    ``"source"`` and, when it sits in another slot, that ``"slot"``. The skin is ``"skin"``,
    else the default skin.
    """
    att = ref.attachment
    name = att.get("source", att.get("parent"))
    return str(att.get("skin") or "default"), str(att.get("slot") or ref.slot), str(name)


#: Constraint kinds, as 4.3's ``"type"`` and as the list keys of earlier versions.
CONSTRAINT_KINDS = ("ik", "transform", "path", "physics", "slider")


def iter_constraints(doc: dict, kind: str) -> Iterator[dict]:
    """The constraints of one kind (one of :data:`CONSTRAINT_KINDS`), in document order.

    4.3 keeps every constraint in one ``"constraints"`` list, each with its ``"type"``;
    earlier versions keep one list per kind under the kind's name. Note that 4.3 also renamed
    fields: a transform constraint's ``"target"`` bone became ``"source"`` (what it reads)
    and a path constraint's ``"target"`` slot became ``"slot"``.
    """
    items = doc.get("constraints")
    if isinstance(items, list):
        yield from (c for c in items if isinstance(c, dict) and c.get("type") == kind)
        return
    items = doc.get(kind)
    if isinstance(items, list):
        yield from (c for c in items if isinstance(c, dict))


def sequence_paths(path: str, sequence: dict) -> list[str]:
    """Frame image paths of a sequence: ``path`` + frame number, zero-padded to ``digits``.

    Defaults as in the editor's export: ``start`` 1, ``digits`` 0.

    Raises
    ------
    SkeletonError
        When ``count``, ``start`` or ``digits`` is not a whole number, or ``count`` or
        ``digits`` is negative or exceeds :mod:`spinemesh.limits` (a tiny file could
        otherwise ask for billions of frames).
    """
    def whole(key: str, default: int, low: int, high: int) -> int:
        value = sequence.get(key, default)
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not is_int(value):
            raise SkeletonError(f"sequence of {path!r}: {key!r} must be a whole number, found {value!r}")
        if not low <= value <= high:
            raise LimitError(f"sequence of {path!r}: {key!r} is {value}, outside {low} to {high}")
        return value

    count = whole("count", 0, 0, MAX_SEQUENCE_FRAMES)
    start = whole("start", 1, -2**31, 2**31 - 1)
    digits = whole("digits", 0, 0, MAX_SEQUENCE_DIGITS)
    return [path + str(start + i).zfill(digits) for i in range(count)]


def image_paths(ref: AttachmentRef) -> list[str]:
    """Every image an attachment may draw: one path, or a sequence's frames.

    Empty for attachment types that draw no image (bounding boxes, paths, points, clipping).
    """
    if ref.type not in IMAGE_TYPES:
        return []
    path = attachment_path(ref)
    seq = ref.attachment.get("sequence")
    if isinstance(seq, dict):
        return sequence_paths(path, seq)
    return [path]


def number(att: dict, key: str, default: float, source: str | Path | None = None, what: str = "") -> float:
    """A numeric field of an attachment, with a clear error when it is not a finite number.

    NaN and infinities (a binary ``.skel`` can hold them) are refused: a mesh built from them
    would be written with non-finite vertices that the runtimes reject.
    """
    value = att.get(key, default)
    if not is_number(value) or not math.isfinite(value):
        raise SkeletonError(f"{what or 'attachment'}: {key!r} must be a finite number, found {value!r}", source)
    return float(value)

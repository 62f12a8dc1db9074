"""Field helpers shared by every version's declarations (:mod:`.v3`, :mod:`.v4`).

Each reads a value into ``node[key]``, leaving it out when it is the JSON default, or
writes ``node.get(key, default)``; one call serves both directions (see :mod:`.stream`).
``-0.0`` is always kept: it packs to other bytes than ``0.0``.
"""

from __future__ import annotations

import math

from ..errors import SkelFormatError
from ..skeleton_colours import read_colour
from ..skeleton_names import first_of_each_name


def put(node: dict, key: str, v, default) -> None:
    """Set ``node[key] = v`` unless ``v`` is the JSON default (``-0.0`` is kept)."""
    if v != default:
        node[key] = v
    elif type(v) is float and v == 0 and math.copysign(1.0, v) < 0:
        node[key] = v


def fld(s, node: dict, key: str, default=0.0):
    """A float32 that is always stored."""
    if s.reading:
        v = s.f32(what=key)
        put(node, key, v, default)
        return v
    return s.f32(node.get(key, default), what=key)


def boolean(s, node: dict, key: str, default: bool = False) -> bool:
    """A boolean byte."""
    if s.reading:
        v = s.bool(what=key)
        put(node, key, v, default)
        return v
    return s.bool(node.get(key, default))


def color(s, node: dict, key: str, default: str | None):
    """An RGBA8888 colour as ``rrggbbaa``."""
    if s.reading:
        v = s.color(what=key)
        put(node, key, v, default)
        return v
    return s.color(node.get(key, default), what=key)


def dark_color(s, node: dict, key: str) -> None:
    """A dark colour (two-colour tint) as an RGB888 int, ``-1`` for none (a slot without one).

    The runtimes read the low 24 bits as red, green and blue, and a JSON's ``rrggbb[aa]`` as
    its first six digits: a high byte (no editor sets it) is read as two more digits,
    ``rrggbbaa``, and written back there, never in the colour's bits. Where it would make the
    int -1 (``"ffffffff"``), it is left out: -1 would say the slot has no dark colour.
    """
    if s.reading:
        v = s.i32(what=key)
        if v != -1:
            node[key] = "%06x" % (v & 0xFFFFFF) + ("%02x" % (v >> 24 & 0xFF) if v >> 24 & 0xFF else "")
        return
    v = node.get(key)
    if v is None:
        s.i32(-1)
        return
    try:  # no colour a runtime reads ("ff" would be 0000ff, a blue) is refused
        r, g, b, high = read_colour(v)
        n = r << 16 | g << 8 | b | (high or 0) << 24
    except ValueError:
        raise s.fail(f"a hex dark colour of six digits for {key!r}, got {v!r}") from None
    n = n & 0xFFFFFF if n == 0xFFFFFFFF else n
    s.i32(n - (1 << 32) if n & 0x80000000 else n)


def text(s, node: dict, key: str):
    """An inline string; null means the key is absent."""
    return _string_or_absent(s, s.string, node, key)


def _string_or_absent(s, io, node: dict, key: str):
    """``io`` (the stream's ``string`` or ``string_ref``) of ``node[key]``; null is the key absent."""
    if s.reading:
        v = io(what=key)
        if v is not None:
            node[key] = v
        return v
    return io(node.get(key), what=key)


def index_value(s, value, table: tuple, what: str, key: str, offset: int = 0):
    """A varint index into a name table (``(names, lookup)``, :func:`name_table`), the name itself
    in the document: read, the name at that index; written, ``value``'s index (``key`` names the
    field in the error). Read or written, one wording for every field and list of every version."""
    names, lookup = table
    if s.reading:
        at = s.pos
        i = s.varint(what=f"{what} index") - offset
        if not 0 <= i < len(names) or names[i] is None:
            # None: in 4.3's one constraint list, a constraint of another type.
            raise s.fail(f"a {what} index below {len(names)}, found {i}", at)
        return names[i]
    if value not in lookup:
        raise s.fail(f"a known {what} for {key!r}, got {value!r}")
    s.varint(lookup[value] + offset)
    return value


def index(s, node: dict, key: str, names: list, lookup: dict, what: str, offset: int = 0):
    """:func:`index_value` of ``node[key]``."""
    name = index_value(s, None if s.reading else node.get(key), (names, lookup), what, key, offset)
    if s.reading:
        node[key] = name
    return name


def index_list(s, node: dict, key: str, table: tuple, what: str, keep_empty: bool = True) -> None:
    """A varint count, then that many :func:`index_value` indices into ``table``: a list of names
    under ``key`` (a constraint's bones, a skin's constraints). Read, an empty list is left out
    unless ``keep_empty``. ``what`` names an item in the errors (``bone``; the count: ``bone count``)."""
    if s.reading:
        items = [index_value(s, None, table, what, key) for _ in range(s.count(what=f"{what} count"))]
        if items or keep_empty:
            node[key] = items
        return
    items = node.get(key, [])
    s.count(len(items), what=f"{what} count")
    for name in items:
        index_value(s, name, table, what, key)


def bend(s, node: dict, key: str = "bendPositive") -> None:
    """A bend direction byte (3.5 to 4.1; 4.2 keeps it in a flag bit) as the JSON's ``bendPositive``.

    Every runtime of these versions (spine-libgdx, spine-csharp, spine-c, spine-cpp, spine-ts)
    reads the byte as a signed byte and multiplies the two-bone IK's angles by it, and their JSON
    loaders give it 1 or -1 (``bendPositive``): a file with another byte (0 straightens the
    chain, 2 doubles its bend) poses in the game as no document says, so it is refused, in
    every version alike, rather than read as one of the two.
    """
    if s.reading:
        at = s.pos
        v = s.i8(what="bend direction")
        if v not in (1, -1):
            raise s.fail(f"a bend direction of 1 or -1, found {v} (the runtimes multiply the IK's angles by it, "
                         "and a JSON holds no other)", at)
        put(node, key, v > 0, True)
    else:
        s.i8(1 if node.get(key, True) else -1)


def enum(s, node: dict, key: str, names: tuple, default: str | None, as_byte: bool = False) -> str:
    """An index into a fixed tuple of names, a varint (a byte, ``as_byte``: 4.x's inherit modes,
    properties and scale modes), as the name in the document."""
    if s.reading:
        at = s.pos
        i = s.u8(what=key) if as_byte else s.varint(what=key)
        if not 0 <= i < len(names):
            raise s.fail(f"{key} between 0 and {len(names) - 1}, found {i}", at)
        put(node, key, names[i], default)
        return names[i]
    v = node.get(key, default)
    if v not in names:
        raise s.fail(f"{key} one of {', '.join(names)}, got {v!r}")
    if as_byte:
        s.u8(names.index(v), what=key)
    else:
        s.varint(names.index(v), what=key)
    return v


def ref(s, node: dict, key: str):
    """A string-table reference (3.8 and 4.x); null means the key is absent."""
    return _string_or_absent(s, s.string_ref, node, key)


def first_use_table(strings: list[str], refs: list[int]) -> bool:
    """Whether numbering strings in first-use order gives this string table and these
    references (the writer's own table): no duplicate, and the references, in file order,
    first use index 1, then 2, and so on."""
    if len(set(strings)) != len(strings):
        return False
    expected = 1
    for k in refs:
        if k == expected:
            expected += 1
        elif k > expected:
            return False
    return expected - 1 == len(strings)


def name_table(names) -> tuple[list, dict]:
    """``(names, name -> index of the first of that name)``: a table that indices in the binary
    point into (read: index to name; written: name to index, the first, as the runtimes'
    ``findSlot`` and their JSON readers find a name, :func:`~spinemesh.skeleton_names.first_of_each_name`)."""
    return list(names), first_of_each_name(names)


#: What each constraint list (or, in 4.3, each type of its one list) holds, in :func:`names_once`'s line.
CONSTRAINT_WORDS = {"ik": "IK constraints", "transform": "transform constraints", "path": "path constraints",
                    "physics": "physics constraints", "slider": "sliders"}


def names_once(s, names, key: str, kind: str) -> None:
    """Refuse a list read from a ``.skel``, or to be written to one, that names two items alike,
    where the file refers to them by place.

    A ``.skel`` refers to slots, constraints, events, skins and animations by index; the
    document read from it (the JSON's layout) by name, so a timeline, skin entry or linked mesh
    aimed at the later of two items of one name would be posed as aimed at the first and written
    back so (a changed animation), and a name-keyed list (events; skins before 3.8; animations)
    would lose one. No editor writes such a file (two bones of one name are refused alike,
    :func:`spinemesh.skeleton_check.bone_tree_problem`). Writing, a JSON's two slots (constraints,
    skins) of one name are refused in the same words before any file is written: the ``.skel``
    made of them would be one that this reader refuses.

    Parameters
    ----------
    s : SkelReader or SkelWriter
        The reader, just past the list (the offset said), or the writer.
    names : list
        The items' names in file order (``None`` where an item of another type sits, in 4.3's
        one constraint list).
    key : str
        The list as the JSON names it (``"slots"``, ``"ik"``, ``"constraints"``...).
    kind : str
        What an item is, plural (``"slots"``, ``"IK constraints"``).

    Raises
    ------
    SkelFormatError
        ``expected slots named once each, found 'head' naming two (slots[2] and slots[4]): ...``.
    """
    first: dict = {}
    for i, n in enumerate(names):
        if n is None:
            continue
        if n in first:
            raise SkelFormatError(
                f"expected {kind} named once each, found {n!r} naming two ({key}[{first[n]}] and {key}[{i}]): a .skel "
                "refers to them by place, spinemesh by name, so one would be read and written back as the other; "
                "refused",
                s.path, offset=s.pos)
        first[n] = i

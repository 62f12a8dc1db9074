r"""JSON written in the style it came in, with unchanged parts kept byte for byte.

The Spine editor exports skeleton JSON in a compact pretty style: top-level keys are not
indented, nesting is indented with tabs, a flat object (one holding no object or array) is
written on one line when it is short, and a flat array (say a mesh's ``uvs``) always on one
line. A tool that rewrites a whole skeleton in another style turns a version-control diff
of a few changed attachments into a diff of the whole file.

:func:`detect_style` reads the style of a JSON text, :func:`dumps` writes a value in a
style, and :func:`splice` writes a changed document into the text it was read from,
re-writing only the values that changed (each in the detected style) and keeping every
other byte.

Examples
--------
>>> text = '{\n"bones": [\n\t{ "name": "root", "x": 10, "y": 20 }\n],\n"skins": {\n\t"a": { "x": 1 }\n}\n}\n'
>>> doc = {"bones": [{"name": "root", "x": 10, "y": 20}], "skins": {"a": {"x": 1, "type": "mesh"}}}
>>> print(splice(text, doc), end="")  # doctest: +NORMALIZE_WHITESPACE
{
"bones": [
	{ "name": "root", "x": 10, "y": 20 }
],
"skins": {
	"a": { "x": 1, "type": "mesh" }
}
}
"""

from __future__ import annotations

import json
import math
import pickle
import re
from collections import namedtuple
from itertools import repeat
from json.decoder import scanstring

__all__ = ["JsonStyle", "EDITOR_STYLE", "NumberText", "detect_style", "dumps", "splice"]


# A collections.namedtuple, not typing's: `spinemesh convert` does not import typing.
_STYLE_FIELDS = {"indent": "\t", "top_level_indented": False, "object_columns": 100, "object_items": 6,
                 "array_columns": math.inf, "pad": " ", "colon": ": ", "java_exponents": True,
                 "minified": False, "newline": "\n"}


class JsonStyle(namedtuple("JsonStyle", _STYLE_FIELDS, defaults=_STYLE_FIELDS.values())):
    """How a JSON text is laid out (defaults: the editor's export style).

    Attributes
    ----------
    indent : str
        One level of indentation (``"\\t"`` in the editor's exports); ignored when ``minified``.
    top_level_indented : bool
        Whether the keys of the top-level object are indented (False in the editor's exports).
    object_columns : float
        A flat, non-empty object whose one-line form is at most this many characters long
        is written on one line; ``-1`` never, ``inf`` always.
    object_items : float
        ... and holds at most this many items (the editor breaks bones of seven fields
        even when they are short).
    array_columns : float
        The same for flat arrays (``inf`` in the editor's exports: ``uvs`` stay on one line).
    pad : str
        Inside the brackets of a one-line object or array: ``" "`` gives ``{ "x": 1 }``.
    colon : str
        Between a key and its value: ``": "`` or ``":"``.
    java_exponents : bool
        Numbers below 0.001 or from 10^7 up written as Java writes them (``1.0E-5``), as the
        editor does; otherwise as Python does (``1e-05``).
    minified : bool
        Everything on one line, no spaces (the editor's "pretty print" switched off).
    newline : str
        ``"\\n"`` or ``"\\r\\n"``.
    """

    __slots__ = ()


#: The Spine editor's export style, for JSON written from a ``.skel`` or from scratch.
EDITOR_STYLE = JsonStyle()

_MINIFIED = JsonStyle(indent="", pad="", colon=":", minified=True)


# -- writing ---------------------------------------------------------------------------------

#: What ``json.dumps(value, ensure_ascii=False)`` writes for a string and for the literals,
#: without building an encoder per value (``spinemesh convert`` writes ~100,000 of them).
_quote = json.encoder.encode_basestring
_LITERALS = {None: "null", True: "true", False: "false"}
#: Exact types of the values a flat line may hold, and of those written through ``NumberText``.
_SCALAR_TYPES = frozenset((str, int, float, bool, type(None)))
_NUMBER_TYPES = frozenset((int, float))


def _scalar(value, java_exponents: bool = False) -> str:
    """A string, number, boolean or null as JSON; integral floats as integers, like the editor."""
    if isinstance(value, float):  # first: a new mesh's every coordinate (the kinds do not overlap)
        if not math.isfinite(value):
            raise ValueError(f"{value!r} cannot be written as JSON")
        if value.is_integer() and abs(value) < 1e15:
            return str(int(value))
        if java_exponents and not 1e-3 <= abs(value) < 1e7:
            return _java_double(value)
        return repr(value)
    if isinstance(value, str):
        return _quote(value)
    if value is None or isinstance(value, bool):
        return _LITERALS[value]
    if isinstance(value, int):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not a JSON value")


def _java_double(value: float) -> str:
    """The shortest digits of ``value`` (Python's ``repr``) in Java's scientific form:
    ``1.0E-5``, ``-2.5E8``, ``5.0E-4``."""
    text = repr(value)
    sign = "-" if text.startswith("-") else ""
    mantissa, _, exponent = text.lstrip("-").partition("e")
    whole, _, fraction = mantissa.partition(".")
    digits = whole + fraction
    significant = digits.lstrip("0")
    power = int(exponent or 0) + len(whole) - 1 - (len(digits) - len(significant))
    significant = significant.rstrip("0") or "0"
    return f"{sign}{significant[0]}.{significant[1:] or '0'}E{power}"


class NumberText(dict):
    """How numbers are written: ``numbers[value]`` is the JSON text of an ``int`` or ``float``.

    Each text is made once and remembered (a skeleton repeats its values: keys, weights,
    uvs), and lines of numbers are joined from it. Subclasses change :meth:`text`, say to
    write float32 values as their shortest decimals (:class:`spinemesh.skeleton_binary.Float32Text`).
    Only exact ``int`` and ``float`` values are looked up (``True == 1`` as a key), and none of
    magnitude 1e15 or more is remembered: there ``int`` and ``float`` keys that compare equal
    are written differently.

    Parameters
    ----------
    java_exponents : bool, default True
        See :attr:`JsonStyle.java_exponents`.
    """

    __slots__ = ("java_exponents",)

    def __init__(self, java_exponents: bool = True):
        super().__init__()
        self.java_exponents = java_exponents

    def __missing__(self, value) -> str:
        text = self.text(value)  # raises ValueError for NaN and infinities
        if -1e15 < value < 1e15:
            self[value] = text
        return text

    def text(self, value) -> str:
        """The JSON text of one number, as :func:`dumps` writes it by default."""
        return _scalar(value, self.java_exponents)


def _writer(style: JsonStyle, numbers: NumberText, out: list[str]):
    """The function that appends a value to ``out`` in ``style``: ``write(value, close, inner)``,
    where ``close`` indents the value's closing bracket and ``inner`` its items; and the one to
    call when done, ``release()``.

    The style's settings are bound once here rather than looked up for each of the ~10,000
    containers of a large skeleton; flat values are told by the set of their items' exact types,
    and lines of numbers are joined from ``numbers`` without a call per value.
    """
    java = style.java_exponents
    minified = style.minified
    sep = "," if minified else ", "
    colon, pad, step = style.colon, style.pad, style.indent
    nl = "" if minified else style.newline
    object_columns = math.inf if minified else style.object_columns
    array_columns = math.inf if minified else style.array_columns
    object_items = math.inf if minified else style.object_items
    number = numbers.__getitem__
    append = out.append

    def scalar(value) -> str:
        return number(value) if type(value) in _NUMBER_TYPES else _scalar(value, java)

    def one_line(value, is_dict: bool) -> str | None:
        types = set(map(type, value.values() if is_dict else value))
        if not types <= _SCALAR_TYPES and any(issubclass(t, (dict, list)) for t in types):
            return None
        if is_dict:
            return "{" + pad + sep.join([_quote(str(k)) + colon + scalar(v) for k, v in value.items()]) + pad + "}"
        if types <= _NUMBER_TYPES:
            return "[" + pad + sep.join(map(number, value)) + pad + "]"
        return "[" + pad + sep.join(map(scalar, value)) + pad + "]"

    def write(value, close: str, inner: str) -> None:
        is_dict = isinstance(value, dict)
        if not is_dict and not isinstance(value, list):
            append(scalar(value))
            return
        if not value:
            append("{}" if is_dict else "[]")
            return
        if not is_dict or len(value) <= object_items:
            line = one_line(value, is_dict)
            if line is not None and len(line) <= (object_columns if is_dict else array_columns):
                append(line)
                return
        deeper = inner + step
        last = len(value) - 1
        append(("{" if is_dict else "[") + nl)
        for i, (key, item) in enumerate(value.items() if is_dict else zip(repeat(None), value)):
            head = inner if key is None else inner + _quote(str(key)) + colon
            end = ("," if i < last else "") + nl
            if type(item) in _SCALAR_TYPES:
                append(head + scalar(item) + end)
            else:
                append(head)
                write(item, inner, deeper)
                append(end)
        append(close + ("}" if is_dict else "]"))

    def release() -> None:
        # A closure that calls itself is a reference cycle: without this, `out` and `numbers`
        # would live until the cyclic collector runs (at exit for `spinemesh convert`).
        nonlocal write
        write = None

    return write, release


def dumps(value, style: JsonStyle = EDITOR_STYLE, indent: str = "", numbers: type[NumberText] = NumberText) -> str:
    """``value`` as JSON text in ``style``.

    Parameters
    ----------
    value : dict, list, str, int, float, bool or None
        Non-finite numbers are refused (``ValueError``): strict parsers and the Spine
        runtimes reject them.
    style : JsonStyle, default EDITOR_STYLE
    indent : str, default ""
        Indentation of the line the value starts on; its closing bracket gets the same.
    numbers : type, default NumberText
        How numbers are written (a :class:`NumberText` class, made with ``style.java_exponents``).

    Examples
    --------
    >>> print(dumps({"skeleton": {"spine": "4.2.22"}, "bones": [{"name": "root"}]}))
    ... # doctest: +NORMALIZE_WHITESPACE
    {
    "skeleton": { "spine": "4.2.22" },
    "bones": [
    	{ "name": "root" }
    ]
    }
    """
    out: list[str] = []
    top = indent == "" and isinstance(value, dict)
    inner = indent + (style.indent if (style.top_level_indented or not top) else "")
    write, release = _writer(style, numbers(style.java_exponents), out)
    try:
        write(value, indent, inner)
    finally:
        release()
    return "".join(out)


# -- reading the style of a text -------------------------------------------------------------

_WS = re.compile(r"[ \t\n\r]*")
#: One flat object or array alone on its line (after an optional key), as the pretty styles write them.
_INLINE_OBJECT = re.compile(r'^[ \t]*(?:"(?:[^"\\]|\\.)*"[ \t]*:[ \t]*)?(\{[^\n{}\[\]]*\})[ \t]*,?[ \t]*\r?$', re.M)
_INLINE_ARRAY = re.compile(r'^[ \t]*(?:"(?:[^"\\]|\\.)*"[ \t]*:[ \t]*)?(\[[^\n{}\[\]]*\])[ \t]*,?[ \t]*\r?$', re.M)
#: A non-empty array whose first item, a number or string, opens the next line.
_BROKEN_ARRAY = re.compile(r'\[[ \t]*\r?\n[ \t]*[-\d"]')
_KEY = re.compile(r'"(?:[^"\\]|\\.)*"[ \t]*:')


def _line_indent(text: str, pos: int) -> str:
    """The whitespace that starts the line holding ``pos``."""
    line_start = text.rfind("\n", 0, pos) + 1
    return _WS.match(text, line_start).group().lstrip("\r\n")


def detect_style(text: str) -> JsonStyle:
    """The layout of a JSON text, read from the text itself.

    The one-line limits are the longest flat object and array the text holds on one line
    (``-1`` when it holds every such value over several lines; ``inf`` for arrays when it
    never breaks one).

    Examples
    --------
    >>> detect_style('{\\n"a": { "x": 1 },\\n"b": [ 1, 2 ]\\n}').indent == "\\t"
    True
    >>> detect_style('{"a":{"x":1}}').minified
    True
    """
    body = text.lstrip("\ufeff").strip()
    if "\n" not in body:
        return _MINIFIED
    newline = "\r\n" if "\r\n" in body else "\n"
    indents = re.findall(r"\n([ \t]+)[\"{\[]", body)
    unit = min(indents, key=len) if indents else "\t"
    if unit.startswith(" "):
        unit = " " * min(len(i) for i in indents if i.startswith(" "))
    second_line = body.split("\n", 2)[1] if body.count("\n") >= 1 else ""
    top_indented = second_line[:1] in (" ", "\t")
    # "{ " and "[ " as counted one by one: two characters, the second no bracket, never overlap
    pad = " " if body.count("{ ") + body.count("[ ") >= len(re.findall(r"[{\[][^\s\]}]", body)) else ""
    colon = ": " if body.count('": ') >= body.count('":') - body.count('": ') else ":"
    objects = [o for o in _INLINE_OBJECT.findall(body) if o != "{}"]
    object_columns = max(map(len, objects)) if objects else -1
    object_items = _most_keys(objects) if objects else EDITOR_STYLE.object_items
    if _BROKEN_ARRAY.search(body):  # never in the editor's exports: one-line arrays need not be scanned
        arrays = [len(a) for a in _INLINE_ARRAY.findall(body) if a != "[]"]
        array_columns = max(arrays) if arrays else -1
    else:
        array_columns = math.inf
    python_exponents = re.search(r"\de-\d", body) is not None
    java_exponents = re.search(r"\d\.\dE-?\d", body) is not None or not python_exponents
    return JsonStyle(indent=unit, top_level_indented=top_indented, object_columns=object_columns,
                     object_items=object_items, java_exponents=java_exponents,
                     array_columns=array_columns, pad=pad, colon=colon, newline=newline)


def _most_keys(objects: list[str]) -> int:
    """The most keys (:data:`_KEY`) any of ``objects`` (one-line object texts) holds.

    Each key ends in a colon, so an object holds at most as many keys as colons: only
    objects with more colons than the most keys counted so far are counted (a large
    skeleton holds tens of thousands of one-line objects, nearly all alike).
    """
    most = 0
    for o in objects:
        if o.count(":") > most:
            most = max(most, len(_KEY.findall(o)))
    return most


# -- writing a changed document into its original text ------------------------------------------

_DECODER = json.JSONDecoder()


def _pickled(value) -> bytes:
    """``value`` as pickle writes it: types and float bits exact, key order kept, in C."""
    return pickle.dumps(value, pickle.HIGHEST_PROTOCOL)


def _same(a, b, known: set | None = None) -> bool:
    """Equal as JSON text would be: 1 and 1.0 alike, but not True and 1.

    Containers equal in Python's own comparison that pickle to the same bytes (the same
    types, float bits and key order: ``True`` apart from ``1``, ``1.0`` apart from ``1``) are
    the same without a walk here: both tests run in C, many times faster on the large
    unchanged parts of a skeleton. Others (``1`` against ``1.0``, NaN, which Python's
    comparison finds unequal, objects shared differently) are walked. ``known`` holds the ``id`` pairs of containers already found the same (kept
    alive by the caller): :func:`_changes` asks again about every container on the way down
    to a change, and each is then compared once however deep it lies.
    """
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return a == b or (a != a and b != b)
    if isinstance(a, dict) and isinstance(b, dict):
        pair = (id(a), id(b))
        if known is not None and pair in known:
            return True
        same = (a == b and _pickled(a) == _pickled(b)) or (
            list(a) == list(b) and all(_same(a[k], b[k], known) for k in a))
    elif isinstance(a, list) and isinstance(b, list):
        pair = (id(a), id(b))
        if known is not None and pair in known:
            return True
        same = (a == b and _pickled(a) == _pickled(b)) or (
            len(a) == len(b) and all(_same(x, y, known) for x, y in zip(a, b)))
    else:
        return type(a) is type(b) and a == b
    if same and known is not None:
        known.add(pair)
    return same


def _skip(text: str, pos: int) -> int:
    """The end of the JSON value that starts at ``pos`` (read by the C decoder)."""
    return _DECODER.raw_decode(text, pos)[1]


def _items(text: str, pos: int, is_object: bool):
    """Walk the items of the object or array opening at ``pos``: yield ``(key, value_start)``;
    the caller sends back each value's end. Returns the position after the closing bracket."""
    closer = "}" if is_object else "]"
    pos = _WS.match(text, pos + 1).end()
    if text.startswith(closer, pos):
        return pos + 1
    while True:
        key = None
        if is_object:
            key, pos = scanstring(text, pos + 1)
            pos = _WS.match(text, pos).end() + 1          # past the colon
        pos = _WS.match(text, pos).end()
        end = yield key, pos
        pos = _WS.match(text, end).end()
        if text.startswith(",", pos):
            pos = _WS.match(text, pos + 1).end()
            continue
        return pos + 1


def _changes(text: str, pos: int, old, new, style: JsonStyle, out: list, known: set,
             known_end: int | None = None) -> int:
    """Collect (start, end, replacement) for the smallest values of ``old`` that differ in
    ``new``; ``pos`` is where ``old`` starts in ``text``. Returns where it ends.

    Unchanged values are stepped over by the C decoder; only the path down to each change
    is walked here. ``known``: see :func:`_same`. ``known_end``: where ``old`` ends, when the
    caller knows it (then it is not read again).
    """
    if _same(old, new, known):
        return _skip(text, pos) if known_end is None else known_end
    same_keys = isinstance(old, dict) and isinstance(new, dict) and list(old) == list(new)
    same_length = isinstance(old, list) and isinstance(new, list) and len(old) == len(new)
    if same_keys or same_length:
        found: list = []
        walker = _items(text, pos, same_keys)
        keys = iter(old) if same_keys else iter(range(len(old)))
        try:
            key, start = next(walker)
            while True:
                expected = next(keys, None)
                if same_keys and key != expected:
                    break  # a key written twice: rewrite the whole object below
                end = _changes(text, start, old[expected], new[expected], style, found, known)
                key, start = walker.send(end)
        except StopIteration as stop:
            if next(keys, None) is None:
                out += found
                return stop.value
    end = _skip(text, pos) if known_end is None else known_end
    out.append((pos, end, dumps(new, style, _line_indent(text, pos))))
    return end


def _top_level(text: str, pos: int) -> tuple[dict, list[tuple[str, int, int]], int] | None:
    """The object whose text starts at ``pos``, read value by value: ``(object, items, end)``
    with each item's ``(key, start, end)`` in ``text``; None when ``text`` is anything else
    (not an object, a key written twice, not JSON, more than the object): then the caller
    reads it whole.

    Each value is read by the C decoder as ``json.loads`` reads it, so the object is the
    same; knowing where each value ends spares :func:`_changes` reading the unchanged ones
    (a skeleton's animations, most of its text) a second time to find their ends.
    """
    if not text.startswith("{", pos):
        return None
    obj: dict = {}
    items = []
    pos = _WS.match(text, pos + 1).end()
    try:
        if text.startswith("}", pos):
            pos += 1
        else:
            while True:
                if not text.startswith('"', pos):
                    return None
                key, pos = scanstring(text, pos + 1)
                pos = _WS.match(text, pos).end()
                if not text.startswith(":", pos) or key in obj:
                    return None
                start = _WS.match(text, pos + 1).end()
                obj[key], pos = _DECODER.raw_decode(text, start)
                items.append((key, start, pos))
                pos = _WS.match(text, pos).end()
                if text.startswith(",", pos):
                    pos = _WS.match(text, pos + 1).end()
                    continue
                if not text.startswith("}", pos):
                    return None
                pos += 1
                break
    except ValueError:  # not JSON: the caller's json.loads says so
        return None
    if _WS.match(text, pos).end() != len(text):
        return None
    return obj, items, pos


def splice(text: str, new, style: JsonStyle | None = None) -> str:
    """``new`` written into ``text`` (the JSON it was read from): only changed values are rewritten.

    Parameters
    ----------
    text : str
        The original JSON text, as read (a byte-order mark is kept).
    new : dict or list
        The changed document.
    style : JsonStyle, optional
        Style of the rewritten values; by default :func:`detect_style` of ``text``.

    Returns
    -------
    str
        ``text`` with each changed value replaced. Values added to or removed from an object
        rewrite that object; everything else keeps its exact text. If ``text`` is not JSON,
        the whole document is written in ``style``.
    """
    style = style or detect_style(text)
    offset = _WS.match(text, 1 if text.startswith("\ufeff") else 0).end()
    edits: list = []
    top = _top_level(text, offset)
    if top is not None and isinstance(new, dict) and list(top[0]) == list(new):
        # as _changes walks an object of the same keys, each value's end known already
        old, items, _ = top
        known: set = set()
        for key, start, end in items:
            _changes(text, start, old[key], new[key], style, edits, known, end)
    else:
        if top is not None:
            old = top[0]
        else:
            try:
                old = json.loads(text[offset:])
            except ValueError:
                return dumps(new, style) + style.newline
        _changes(text, offset, old, new, style, edits, set(), None if top is None else top[2])
    # One pass over the text: unchanged stretches and replacements joined once (rebuilding the
    # whole text per edit was quadratic: 109 s for 20,000 changed attachments in a 1.1 MB file).
    pieces, pos = [], 0
    for start, end, replacement in sorted(edits):
        pieces += (text[pos:start], replacement)
        pos = end
    pieces.append(text[pos:])
    return "".join(pieces)

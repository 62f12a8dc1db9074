"""Spine's binary skeleton format (``.skel``), versions 3.6 to 4.3, read and written.

:func:`read_skel` turns a ``.skel`` into the same document that the Spine editor's JSON
export of that version holds; :func:`write_skel` turns such a document back into bytes.
Each major version's structures are declared once, in :mod:`.v3` and :mod:`.v4`, as
functions of a :mod:`.stream` that serve both directions.
"""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path

from ..errors import SkelFormatError
from .stream import SkelReader, SkelWriter


_VERSION = re.compile(r"\d{1,2}\.\d{1,2}(\.\d{1,3})?([-.][\w.-]{1,20})?")


def sniff_version(data: bytes) -> str:
    """The editor version string stored in a ``.skel`` header, e.g. ``"4.2.43"``.

    4.x files start with an 8-byte hash and then the version string; 3.x files start with
    the hash as a string. Both are tried.
    """
    for layout in ("v4", "v3"):
        r = SkelReader(data)
        try:
            if layout == "v4":
                r.i64()
            else:
                r.string()
            version = r.string()
        except SkelFormatError:
            continue
        # A real version ("4.2.22", "3.8.99", "4.3.39-beta"), not base64 hash characters
        # that a wrong guess of the layout happened to read as a string.
        if version and _VERSION.fullmatch(version):
            return version
    raise SkelFormatError("expected a Spine version string in the header", offset=0)


def _codec(version: str, path: str | Path | None = None):
    """The module that declares this version's structures: :mod:`.v3` or :mod:`.v4`.

    ``path`` is the file read or written, for the error message.
    """
    major = version.split(".")[0]
    if major == "3":
        from . import v3 as codec
    elif major == "4":
        from . import v4 as codec
    else:
        raise SkelFormatError(f"expected Spine 3.6 to 4.3, found version {version!r}", path, offset=0)
    return codec


def read_skel(source: str | Path | bytes, path: str | Path | None = None) -> dict:
    """Read a ``.skel`` into a JSON-equivalent skeleton document.

    Raises
    ------
    SkelFormatError
        For truncated, corrupted or unsupported input; it carries the byte offset and what
        was expected. No other exception escapes.
    """
    if isinstance(source, (str, Path)):
        path = path or source
        data = Path(source).read_bytes()
    else:
        data = bytes(source)
    try:
        version = sniff_version(data)
        reader = SkelReader(data, path)
        return _codec(version).read(reader)
    except SkelFormatError as e:
        if e.path is None and path is not None:
            e.path = str(path)
        raise
    except (ValueError, TypeError, KeyError, IndexError, OverflowError, RecursionError, MemoryError) as e:
        off = reader.pos if "reader" in locals() else 0
        raise SkelFormatError(f"expected valid skeleton data ({type(e).__name__}: {e})", path, offset=off) from None


def write_skel(doc: dict, path: str | Path | None = None) -> bytes:
    """Encode a skeleton document as ``.skel`` bytes of the version in ``doc["skeleton"]["spine"]``."""
    skeleton = doc.get("skeleton") if isinstance(doc, dict) else None
    if not isinstance(skeleton, dict):
        raise SkelFormatError("cannot write: expected a document with a 'skeleton' object", path)
    version = str(skeleton.get("spine", ""))
    writer = SkelWriter(path)
    _codec(version, path).write(writer, doc)
    return writer.getvalue()


def tidy_floats(node):
    """A copy of a document with every float written as the shortest decimal that is still
    the same float32 (``-188.6337890625`` becomes ``-188.63379``, ``100.0`` becomes ``100``).

    For JSON text meant for people: writing the copy as ``.skel`` gives the same bytes.
    """
    return _tidy(node, {})


def _tidy(node, done: dict):
    # ``done`` remembers each value's result: animations repeat values (a quarter of them are
    # repeats in mix-and-match-pro), which halves the time. Zeros are not remembered, since
    # 0.0 == -0.0 as a key but they are written differently.
    if isinstance(node, float):
        tidy = done.get(node)
        if tidy is None:
            if node != node or node in (math.inf, -math.inf):
                return node
            if node.is_integer() and math.copysign(1.0, node) > 0:
                tidy = int(node)
            else:
                tidy = shortest_float32(node)
            if node:
                done[node] = tidy
        return tidy
    if isinstance(node, dict):
        return {k: _tidy(v, done) for k, v in node.items()}
    if isinstance(node, list):
        return [_tidy(v, done) for v in node]
    return node


_FLOAT32 = struct.Struct("<f")
_FLOAT32_SMALLEST_NORMAL = 1.1754943508222875e-38


def shortest_float32(value: float) -> float:
    """The decimal with the fewest significant digits that rounds to the same float32 as ``value``.

    Pure Python on purpose: importing numpy for ``str(np.float32(x))`` costs ``spinemesh
    convert`` about 100 ms of start-up, more than this takes on a large skeleton. The correctly
    rounded 6-digit decimal is tried first: any float32 (not subnormal) whose shortest decimal
    has 6 digits or fewer rounds to exactly that one, since float32 spacing is finer than 6
    digits; subnormals, coarser, try every length. Same results as numpy on every example and
    corpus ``.skel`` and on 500,000 random float32 values.
    """
    pack, unpack = _FLOAT32.pack, _FLOAT32.unpack
    target = unpack(pack(value))[0]
    digits = (6, 7, 8, 9) if abs(target) >= _FLOAT32_SMALLEST_NORMAL else range(1, 10)
    for n in digits:
        candidate = float("%.*g" % (n, target))
        if unpack(pack(candidate))[0] == target:
            return candidate
    return target

"""Spine's binary skeleton format (``.skel``), versions 3.5 to 4.3, read and written.

:func:`read_skel` turns a ``.skel`` into the same document that the Spine editor's JSON
export of that version holds; :func:`encode_skel` turns such a document back into bytes.
Each major version's structures are declared once, in :mod:`.v3` and :mod:`.v4`, as
functions of a :mod:`.stream` that serve both directions.
"""

from __future__ import annotations

import math
import re
import struct
from bisect import bisect_right
from pathlib import Path

from ..errors import SkelFormatError
from ..json_style import NumberText
from ..skeleton_version import major_minor
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
    major = (major_minor(version) or (None,))[0]
    if major == 3:
        from . import v3 as codec
    elif major == 4:
        from . import v4 as codec
    else:
        raise SkelFormatError(f"expected Spine 3.5 to 4.3, found version {version!r}", path, offset=0)
    return codec


def read_skel(source: str | Path | bytes, path: str | Path | None = None) -> dict:
    """Read a ``.skel`` into a JSON-equivalent skeleton document.

    Parameters
    ----------
    source : path or bytes
        The file, or its bytes; Spine 3.5 to 4.3, the version read from its header.
    path : path, optional
        The file's name for error messages when ``source`` is bytes.

    Returns
    -------
    dict
        The document the editor's JSON export of the same skeleton holds (:mod:`.compare`).

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> doc = read_skel(make_demo_project("demo") / "demo-binary.skel")
    >>> doc["skeleton"]["spine"], read_skel(encode_skel(doc)) == doc
    ('4.2.40', True)

    Raises
    ------
    SkelFormatError
        For truncated, corrupted or unsupported input; it carries the byte offset and what
        was expected. No other exception escapes.
    """
    return read_skel_finite(source, path)[0]


def read_skel_finite(source: str | Path | bytes, path: str | Path | None = None) -> tuple[dict, bool]:
    """:func:`read_skel`, and whether every number it read is finite (no NaN, no infinity).

    Told by the sum the reader keeps of the floats it reads (``SkelReader.float_sum``), which
    costs next to nothing, where a walk over the document cost ``spinemesh convert`` a third of
    its time on a large skeleton.
    """
    if isinstance(source, (str, Path)):
        path = path or source
        data = Path(source).read_bytes()
    else:
        data = bytes(source)
    try:
        version = sniff_version(data)
        reader = SkelReader(data, path)
        doc = _codec(version).read(reader)
        return doc, math.isfinite(reader.float_sum)
    except SkelFormatError as e:
        if e.path is None and path is not None:
            e.path = str(path)
        raise
    except (ValueError, TypeError, KeyError, IndexError, OverflowError, RecursionError, MemoryError) as e:
        off = reader.pos if "reader" in locals() else 0
        raise SkelFormatError(f"expected valid skeleton data ({type(e).__name__}: {e})", path, offset=off) from None


def encode_skel(doc: dict, path: str | Path | None = None) -> bytes:
    """Encode a skeleton document as ``.skel`` bytes of the version in ``doc["skeleton"]["spine"]``.

    Nothing is written: :func:`spinemesh.skeleton.save_skeleton` writes the file.

    Parameters
    ----------
    doc : dict
        A document as :func:`read_skel` or :func:`spinemesh.skeleton.load_skeleton` gives it.
    path : path, optional
        The file's name for error messages.

    Returns
    -------
    bytes
        The binary skeleton; :func:`read_skel` of it gives ``doc`` back.

    Raises
    ------
    SkelFormatError
        For a document that the version's format cannot hold.
    """
    skeleton = doc.get("skeleton") if isinstance(doc, dict) else None
    if not isinstance(skeleton, dict):
        raise SkelFormatError("cannot write: expected a document with a 'skeleton' object", path)
    version = str(skeleton.get("spine", ""))
    writer = SkelWriter(path)
    _codec(version, path).write(writer, doc)
    return writer.getvalue()


class Float32Text(NumberText):
    """Numbers written as JSON with every float as the shortest decimal that is still the same
    float32 (``-188.6337890625`` becomes ``-188.63379``, ``100.0`` becomes ``100``): a ``.skel``
    stores float32 values, and the editor's JSON export writes them so.

    Pass it to :func:`spinemesh.skeleton.dumps_skeleton` (``numbers=Float32Text``) for a document
    read from a ``.skel``; reading the JSON back and writing it as ``.skel`` gives the same bytes.
    Each value's text is made once (a quarter of mix-and-match-pro's values are repeats), but
    for zeros: ``-0.0`` is written ``-0.0`` (the editor never writes one, but a ``.skel`` may hold
    one: 6 of the 129 official 3.6 to 4.2 examples do, and the 3.5 raptor), and as a key of this
    table it would be the same as ``0``.

    The common case, a value of magnitude 1e-3 to 1e7 that is not a whole number, is done in
    exact arithmetic: with ``n`` significant digits (6 to 9) and ``k = n - 1 - floor(log10|x|)``
    between 0 and 11, the float32 ``x`` times ``10**k`` is exact in float64 (24 bits times
    5**11's 26), so ``round`` gives the correctly rounded digits, ties to even, as ``"%.*g"``
    does, and their quotient by ``10**k`` is the float those digits parse to. That takes three
    quarters of the time of formatting and parsing every candidate (:func:`shortest_float32`,
    17 against 23 ms for mix-and-match-pro's 11,655 such values), which the other values take,
    with the same result.
    """

    __slots__ = ()

    def __missing__(self, value) -> str:
        if value == 0:
            return self.text(value)  # not remembered: 0 and -0.0 are one key
        if type(value) is float and -_FLOAT32_MAX <= value <= _FLOAT32_MAX:
            target = _FLOAT32.unpack(_FLOAT32.pack(value))[0]
            magnitude = target if target > 0 else -target
            if 1e-3 <= magnitude < 1e7 and not target.is_integer():
                pack, unpack = _FLOAT32.pack, _FLOAT32.unpack
                for digits, scale in _TRIES[bisect_right(_DECADES, magnitude)]:
                    if unpack(pack(round(target * scale) / scale))[0] == target:
                        text = self[value] = digits % target
                        return text
        return super().__missing__(value)

    def text(self, value) -> str:
        if value == 0 and type(value) is float and math.copysign(1.0, value) < 0:
            return "-0.0"  # reads back as -0.0, which packs to other bytes than 0
        if type(value) is float and value > 0 and value.is_integer():
            return str(int(value))  # as an int, whatever its size, as JSON from a .skel always was
        if type(value) is int or abs(value) > _FLOAT32_MAX:
            # Beyond float32 (a physics mass read as the inverse of a tiny float32): as it is.
            return super().text(value)
        return super().text(shortest_float32(value))


#: Decade boundaries from 1e-2 to 1e6: ``bisect_right`` of a magnitude of 1e-3 to 1e7 gives its
#: decimal exponent plus 3. (A float32 never lies between a power of ten and the float64 nearest it.)
_DECADES = tuple(10.0 ** e for e in range(-2, 7))
#: Per decade: (format, 10**k) for 6 to 9 significant digits. Six digits from 1e6 up would be a
#: whole number, which a value that is not cannot round to: left out.
_TRIES = tuple(tuple(("%%.%dg" % n, 10.0 ** (n - 1 - e)) for n in (6, 7, 8, 9) if n - 1 - e >= 0)
               for e in range(-3, 7))


_FLOAT32 = struct.Struct("<f")
_FLOAT32_SMALLEST_NORMAL = 1.1754943508222875e-38
_FLOAT32_MAX = 3.4028234663852886e38


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

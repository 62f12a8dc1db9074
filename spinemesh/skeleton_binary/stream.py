"""Symmetric primitives for Spine's binary skeleton format.

A structure of the ``.skel`` format is declared once, as a function of a *stream* and a
document node, and the same function serves reading and writing::

    def bone_transform(s, bone):
        bone["rotation"] = s.f32(bone.get("rotation", 0.0))
        bone["x"] = s.f32(bone.get("x", 0.0))

With a :class:`SkelReader`, every primitive ignores the value it is given and returns the
value it read; with a :class:`SkelWriter`, it writes the value it is given and returns it.
Counts and flags read or written this way drive loops and branches identically in both
directions, so a round trip is exact by construction.

Byte order and encodings follow the Spine runtimes' ``SkeletonBinary`` input: big-endian
32-bit ints and floats, 7-bit variable-length ints (optionally zig-zag), strings prefixed
by ``byte length + 1`` (0 means null), colours as RGBA8888 ints.
"""

from __future__ import annotations

import struct
from pathlib import Path

from ..errors import SkelFormatError
from ..limits import MAX_SKELETON_ITEMS
from ..skeleton_colours import read_colour

_F32 = struct.Struct(">f")
_I32 = struct.Struct(">i")
_U32 = struct.Struct(">I")
_I64 = struct.Struct(">q")
#: A weighted vertex's x, y and weight for one bone.
XYW = struct.Struct(">3f")

#: Largest string the reader accepts, as a guard against corrupted length prefixes.
MAX_STRING_BYTES = 1 << 20
#: Largest element count the reader accepts for any list.
MAX_COUNT = 1 << 22


def string_too_long(s, n: int, what: str, at: int | None = None):
    """The refusal, read or written, of a string whose length prefix ``n`` (its bytes + 1, as the
    format stores it) is below 1 or says more than :data:`MAX_STRING_BYTES` bytes (a Java int
    past 2^31 reads negative)."""
    written = "" if s.reading else " (as a .skel is read back)"
    return s.fail(f"a {what} of at most {MAX_STRING_BYTES:,} bytes{written}, found a length of {n - 1:,}", at)


def items_beyond_limit(reading: bool) -> str:
    """What a reader or writer expected when the lengths of a skeleton's lists sum past
    :data:`MAX_SKELETON_ITEMS`."""
    written = "" if reading else " (as a .skel is read back)"
    return (f"at most {MAX_SKELETON_ITEMS:,} items in one skeleton (bones, slots, skins, attachments, vertices, "
            f"animations, keys), found more{written}")


class SkelReader:
    """Reads primitives from ``data``; every method's value argument is ignored.

    Parameters
    ----------
    data : bytes
        The whole file.
    path : str, optional
        File name used in error messages.
    """

    reading = True

    def __init__(self, data: bytes, path: str | Path | None = None):
        self.data = memoryview(data)
        self.pos = 0
        self.path = str(path) if path is not None else None
        #: The shared string table of 3.8+ files (``readStringRef``).
        self.strings: list[str] = []
        #: The sum of every float read, as a float64: finite exactly when each one was, since
        #: float32 values cannot overflow it and a NaN or infinity makes it NaN or infinite.
        #: One addition per value (or per bulk read) instead of a walk over the document.
        self.float_sum = 0.0
        #: The sum of every list length read, held to :data:`MAX_SKELETON_ITEMS`.
        self.items = 0

    # -- errors ---------------------------------------------------------------------
    def fail(self, expected: str, at: int | None = None) -> SkelFormatError:
        """Build the error for ``expected`` at the current (or given) offset."""
        return SkelFormatError(f"expected {expected}", self.path, offset=self.pos if at is None else at)

    def _take(self, n: int, what: str) -> memoryview:
        end = self.pos + n
        if end > len(self.data):
            raise self.fail(f"{what} ({n} bytes), found end of file after {len(self.data) - self.pos}")
        chunk = self.data[self.pos:end]
        self.pos = end
        return chunk

    @property
    def at_end(self) -> bool:
        return self.pos >= len(self.data)

    # -- primitives -----------------------------------------------------------------
    def u8(self, value=None, what: str = "byte") -> int:
        return self._take(1, what)[0]

    def i8(self, value=None, what: str = "signed byte") -> int:
        b = self._take(1, what)[0]
        return b - 256 if b > 127 else b

    def bool(self, value=None, what: str = "boolean") -> bool:
        return self._take(1, what)[0] != 0

    def i32(self, value=None, what: str = "int") -> int:
        return _I32.unpack(self._take(4, what))[0]

    def i64(self, value=None, what: str = "long") -> int:
        return _I64.unpack(self._take(8, what))[0]

    def f32(self, value=None, what: str = "float") -> float:
        v = _F32.unpack(self._take(4, what))[0]
        self.float_sum += v
        return v

    def varint(self, value=None, positive: bool = True, what: str = "varint") -> int:
        result = 0
        # At most five bytes; the runtimes ignore the fifth byte's continuation bit.
        for shift in (0, 7, 14, 21, 28):
            b = self._take(1, what)[0]
            result |= (b & 0x7F) << shift
            if not b & 0x80:
                break
        result &= 0xFFFFFFFF
        if positive:
            # Java ints are signed: a varint over 2^31 is negative there.
            return result - (1 << 32) if result & 0x80000000 else result
        return (result >> 1) ^ -(result & 1)

    def count(self, value=None, what: str = "count") -> int:
        """A non-negative varint used as a list length, checked against :data:`MAX_COUNT`."""
        at = self.pos
        n = self.varint(what=what)
        if n < 0 or n > MAX_COUNT:
            raise self.fail(f"{what} between 0 and {MAX_COUNT}, found {n}", at)
        return self.counted(n, at)

    def counted(self, n: int, at: int) -> int:
        """``n``, a list length read at offset ``at``, once the lengths read so far stay within
        :data:`MAX_SKELETON_ITEMS` (what the document will hold bounds its memory)."""
        self.items += n
        if self.items > MAX_SKELETON_ITEMS:
            raise self.fail(items_beyond_limit(self.reading), at)
        return n

    def string(self, value=None, what: str = "string") -> str | None:
        at = self.pos
        n = self.varint(what=f"{what} length")
        if n == 0:
            return None
        if n < 0 or n - 1 > MAX_STRING_BYTES:
            raise string_too_long(self, n, what, at)
        raw = self._take(n - 1, what)
        try:
            return bytes(raw).decode("utf-8")
        except UnicodeDecodeError as e:
            raise self.fail(f"UTF-8 {what}: {e.reason}", at) from None

    def string_ref(self, value=None, what: str = "string reference") -> str | None:
        at = self.pos
        i = self.varint(what=what)
        if i == 0:
            return None
        if not 0 < i <= len(self.strings):
            raise self.fail(f"{what} into a table of {len(self.strings)} strings, found {i}", at)
        return self.strings[i - 1]

    def color(self, value=None, what: str = "colour") -> str:
        """RGBA8888 colour as the JSON's lowercase ``rrggbbaa`` hex string."""
        return "%08x" % _U32.unpack(self._take(4, what))[0]

    def raw(self, value=None, n: int = 0, what: str = "bytes") -> bytes:
        return bytes(self._take(n, what))


def colour_bytes(text: str, channels: int) -> bytes:
    """A JSON colour ``[#]rrggbb[aa]`` as ``channels`` (3 or 4) bytes, read as the runtimes read it
    (:func:`spinemesh.skeleton_colours.read_colour`): alpha from the 7th and 8th digits only
    where there are exactly eight (else 1: ``"ff804000ab"`` is opaque orange). A ValueError for
    fewer than six digits or any read that is not hex: no colour a runtime reads.

    Examples
    --------
    >>> colour_bytes("ff8040", 4).hex(), colour_bytes("ff80401", 4).hex(), colour_bytes("#12345680", 3).hex()
    ('ff8040ff', 'ff8040ff', '123456')
    """
    r, g, b, a = read_colour(text)
    return bytes((r, g, b, 255 if a is None else a))[:channels]


class SkelWriter:
    """Writes primitives; every method writes its value argument and returns it."""

    reading = False

    def __init__(self, path: str | Path | None = None):
        self.out = bytearray()
        self.path = str(path) if path is not None else None
        self.strings: list[str] = []
        self._string_index: dict[str, int] = {}
        #: The sum of every list length written, held to what :meth:`SkelReader.count` reads back.
        self.items = 0

    @property
    def pos(self) -> int:
        return len(self.out)

    def fail(self, expected: str, at: int | None = None) -> SkelFormatError:
        return SkelFormatError(f"cannot write: expected {expected}", self.path, offset=self.pos if at is None else at)

    def set_strings(self, strings: list[str]) -> None:
        """Install the string table that :meth:`string_ref` indexes into."""
        self.strings = list(strings)
        self._string_index = {}
        for i, s in enumerate(self.strings):
            self._string_index.setdefault(s, i)

    def getvalue(self) -> bytes:
        return bytes(self.out)

    def whole(self, value, what: str) -> int:
        """``value`` as the whole number a binary integer field stores, refused in one line where it
        is not one: cut to its whole part (an event's ``int`` of 2.5 written 2), the ``.skel``
        would say another number than the JSON, which spine-ts plays as it is. A whole float
        (``4.0``, as some tools write) is that number."""
        try:
            v = int(value)
        except (TypeError, ValueError, OverflowError):
            raise self.fail(f"a whole number for {what}, got {value!r}") from None
        if isinstance(value, float) and v != value:
            raise self.fail(f"a whole number for {what} (the binary format stores an integer), got {value!r}")
        return v

    def _integer(self, value, low: int, high: int, what: str) -> int:
        """``value`` as an integer the field holds, refused in one line where it does not: cut to
        the field's bits it was written as another number (an event's int of 2**40 read back 256)."""
        v = self.whole(value, what)
        if not low <= v <= high:
            raise self.fail(f"an integer from {low:,} to {high:,} for {what} (the binary format's range), "
                            f"got {value!r}")
        return v

    def u8(self, value, what: str = "byte") -> int:
        self.out.append(self._integer(value, 0, 0xFF, what))
        return value

    def i8(self, value, what: str = "signed byte") -> int:
        self.out.append(self._integer(value, -0x80, 0x7F, what) & 0xFF)
        return value

    def bool(self, value, what: str = "boolean") -> bool:
        self.out.append(1 if value else 0)
        return bool(value)

    def i32(self, value, what: str = "int") -> int:
        self.out += _I32.pack(self._integer(value, -1 << 31, (1 << 31) - 1, what))
        return value

    def i64(self, value, what: str = "long") -> int:
        self.out += _I64.pack(self._integer(value, -1 << 63, (1 << 63) - 1, what))
        return value

    def f32(self, value, what: str = "float") -> float:
        try:
            self.out += _F32.pack(float(value))
        except OverflowError:  # a number all the same: what it lacks is a float32's range
            raise self.fail(f"a number a 32-bit float holds (at most 3.4e+38 in size) for {what}, got {value!r}") from None
        except (TypeError, ValueError):
            raise self.fail(f"a number for {what}, got {value!r}") from None
        return value

    def varint(self, value, positive: bool = True, what: str = "varint") -> int:
        # Read back as a 32-bit int (the runtimes' readInt(optimizePositive)), whichever the sign
        v = self._integer(value, -1 << 31, (1 << 31) - 1, what)
        if not positive:
            v = ((v << 1) ^ (v >> 31)) & 0xFFFFFFFF
        else:
            v &= 0xFFFFFFFF
        while True:
            if v < 0x80:
                self.out.append(v)
                break
            self.out.append((v & 0x7F) | 0x80)
            v >>= 7
        return value

    def weighted(self, values, n: int = 0, nbones: int = 0) -> list:
        """``n`` weighted vertices, flat as in the JSON (per vertex a bone count, then
        ``(bone, x, y, weight)`` per bone), each bone an index below ``nbones``: a file whose
        bone the reader would refuse is refused here, before it is written."""
        i = 0
        try:
            for _ in range(n):
                k = self.count(values[i], what="weighted vertex bone count")
                i += 1
                for _ in range(k):
                    b = self.whole(values[i], "weighted vertex bone")
                    if not 0 <= b < nbones:
                        raise self.fail(f"bone index below {nbones} in weighted vertices, got {b}")
                    self.varint(b)
                    self.out += XYW.pack(values[i + 1], values[i + 2], values[i + 3])
                    i += 4
        except (IndexError, ValueError, TypeError, struct.error):
            raise self.fail("weighted vertices [boneCount, (bone, x, y, weight)...]") from None
        if i != len(values):
            raise self.fail(f"{i} numbers of weighted vertices, got {len(values)}")
        return values

    def count(self, value, what: str = "count") -> int:
        """A list length, refused where :meth:`SkelReader.count` would refuse to read it back
        (below 0, above :data:`MAX_COUNT`): a ``_skel`` timeline count edited by hand is written
        as given, and libGDX and spine-csharp reserve that many timelines (a negative one stops
        their load, a huge one takes the memory); the other runtimes skip it."""
        v = self.whole(value, what)
        if not 0 <= v <= MAX_COUNT:
            raise self.fail(f"a count from 0 to {MAX_COUNT:,} for {what} (as a .skel is read back), got {value!r}")
        self.items += v
        if self.items > MAX_SKELETON_ITEMS:
            raise self.fail(items_beyond_limit(False))
        return self.varint(v, what=what)

    def string(self, value, what: str = "string") -> str | None:
        if value is None:
            self.varint(0)
            return None
        raw = str(value).encode("utf-8")
        if len(raw) > MAX_STRING_BYTES:
            raise string_too_long(self, len(raw) + 1, what)
        self.varint(len(raw) + 1)
        self.out += raw
        return value

    def string_ref(self, value, what: str = "string reference") -> str | None:
        if value is None:
            self.varint(0)
            return None
        i = self._string_index.get(value)
        if i is None:
            raise self.fail(f"{what} {value!r} to be in the string table")
        self.varint(i + 1)
        return value

    def color(self, value, what: str = "colour") -> str:
        try:
            self.out += colour_bytes(str(value), 4)
        except ValueError:
            raise self.fail(f"a hex colour of six or eight digits for {what}, got {value!r}") from None
        return value

    def raw(self, value, n: int = 0, what: str = "bytes") -> bytes:
        self.out += bytes(value)
        return value


class RecordedRefs:
    """Writer mixin: string references written with the table indices a read recorded.

    The editor's string table may hold a string twice, and only the indices tell which copy
    a reference used; so each recorded index is written again while it still names the same
    string (``refs[i]`` for the ``i``-th reference). Other references follow the writer's
    own rule (the next class in the method resolution order).
    """

    def replay(self, refs: list[int] | None) -> None:
        self.refs = refs or []
        self._next = 0

    def string_ref(self, value, what: str = "string reference"):
        i = self._next
        self._next += 1
        if i < len(self.refs):
            k = self.refs[i]
            if (k == 0 and value is None) or (0 < k <= len(self.strings) and self.strings[k - 1] == value):
                self.varint(k)
                return value
        return super().string_ref(value, what)

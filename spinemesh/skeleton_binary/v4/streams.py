"""The reader and writer the 4.x declarations run on: string-reference indices kept, bulk reads."""

from __future__ import annotations

import math
import struct

from ..enums import CURVE_BEZIER, CURVE_LINEAR, CURVE_STEPPED
from ..stream import MAX_COUNT, MAX_STRING_BYTES, XYW, RecordedRefs, SkelReader, SkelWriter, string_too_long
from .fields import _floats_struct
from .timelines import _FrameSpec

_F32 = struct.Struct(">f")
_I32 = struct.Struct(">i")


class _RefReader(SkelReader):
    """A reader that also records which table index every string reference used.

    The editor's string table may hold a string more than once and references pick any
    copy, so the indices themselves are needed to write the same bytes again.

    It also reads the hottest primitives straight from a ``bytes`` copy of the file and
    adds bulk reads (:meth:`varints`, :meth:`weighted`): meshes are most of a file.
    """

    def __init__(self, data, path=None):
        super().__init__(data, path)
        self.buf = bytes(self.data)
        self.end = len(self.buf)
        self.refs: list[int] = []

    def _eof(self, what: str):
        return self.fail(f"{what}, found end of file after {len(self.buf) - self.pos} bytes")

    def u8(self, value=None, what: str = "byte") -> int:
        pos = self.pos
        try:
            b = self.buf[pos]
        except IndexError:
            raise self._eof(what) from None
        self.pos = pos + 1
        return b

    def bool(self, value=None, what: str = "boolean") -> bool:
        return self.u8(what=what) != 0

    def raw(self, value=None, n: int = 0, what: str = "bytes") -> bytes:
        pos = self.pos
        end = pos + n
        if end > self.end or n < 0:
            raise self._eof(f"{what} ({n} bytes)")
        self.pos = end
        return self.buf[pos:end]

    def color(self, value=None, what: str = "colour") -> str:
        return self.raw(n=4, what=what).hex()

    def i32(self, value=None, what: str = "int") -> int:
        pos = self.pos
        if pos + 4 > self.end:
            raise self._eof(what)
        self.pos = pos + 4
        return _I32.unpack_from(self.buf, pos)[0]

    def string(self, value=None, what: str = "string") -> str | None:
        at = pos = self.pos
        if pos < self.end and 1 < self.buf[pos] < 0x80:
            # The common case: a short string, its length in one byte.
            end = pos + self.buf[pos]
            if end <= self.end:
                try:
                    text = self.buf[pos + 1:end].decode("utf-8")
                except UnicodeDecodeError as e:
                    raise self.fail(f"UTF-8 {what}: {e.reason}", at) from None
                self.pos = end
                return text
        n = self.varint(what=f"{what} length")
        if n == 0:
            return None
        if n < 0 or n - 1 > MAX_STRING_BYTES:
            raise string_too_long(self, n, what, at)
        raw = self.raw(n=n - 1, what=what)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise self.fail(f"UTF-8 {what}: {e.reason}", at) from None

    def f32(self, value=None, what: str = "float") -> float:
        pos = self.pos
        try:
            v = _F32.unpack_from(self.buf, pos)[0]
        except struct.error:
            raise self._eof(what) from None
        self.pos = pos + 4
        self.float_sum += v
        return v

    def varint(self, value=None, positive: bool = True, what: str = "varint") -> int:
        buf, pos = self.buf, self.pos
        try:
            b = buf[pos]
            if b < 0x80 and positive:
                self.pos = pos + 1
                return b
            result, shift = 0, 0
            while True:
                b = buf[pos]
                pos += 1
                result |= (b & 0x7F) << shift
                if not b & 0x80 or shift == 28:
                    break
                shift += 7
        except IndexError:
            raise self._eof(what) from None
        self.pos = pos
        result &= 0xFFFFFFFF
        if positive:
            return result - (1 << 32) if result & 0x80000000 else result
        return (result >> 1) ^ -(result & 1)

    def plain_frames(self, n: int, spec: _FrameSpec) -> list[dict]:
        """Frames of a timeline whose values are float32s or colour bytes, the hot loop of
        animations: the same result as :func:`.timelines.curve_timeline`, in fewer steps."""
        buf = self.buf
        layout = spec.layout
        unpack, size = spec.unpack, spec.size
        curve_unpack, curve_size = spec.curve_unpack, spec.curve_size
        single, key0, d0 = spec.single, spec.key0, spec.d0
        frames = []
        prev = None
        copysign = math.copysign
        pos = self.pos
        total = 0.0  # of the floats read, for float_sum
        try:
            for _ in range(n):
                vals = unpack(buf, pos)
                pos += size
                f = {}
                t = vals[0]
                total += t
                if t != 0 or copysign(1.0, t) < 0:
                    f["time"] = t
                if single:
                    v = vals[1]
                    total += v
                    if v != d0 or (v == 0 and copysign(1.0, v) < 0):
                        f[key0] = v
                else:
                    for (key, kind, d), v in zip(layout, vals[1:]):
                        if kind != "f":
                            f[key] = v.hex()
                            continue
                        total += v
                        if v != d or (v == 0 and copysign(1.0, v) < 0):
                            f[key] = v
                if prev is not None:
                    kind = buf[pos]
                    pos += 1
                    if kind == CURVE_BEZIER:
                        prev["curve"] = bezier = list(curve_unpack(buf, pos))
                        total += sum(bezier)
                        pos += curve_size
                    elif kind == CURVE_STEPPED:
                        prev["curve"] = "stepped"
                    elif kind != CURVE_LINEAR:
                        self.pos = pos - 1
                        raise self.fail(f"a curve type 0, 1 or 2, found {kind}")
                frames.append(f)
                prev = f
        except (struct.error, IndexError):
            self.pos = pos
            raise self._eof("timeline frames") from None
        self.pos = pos
        self.float_sum += total
        return frames

    def count(self, value=None, what: str = "count") -> int:
        at = self.pos
        if at < self.end and self.buf[at] < 0x80:
            self.pos = at + 1
            return self.counted(self.buf[at], at)
        n = self.varint(what=what)
        if n < 0 or n > MAX_COUNT:
            raise self.fail(f"{what} between 0 and {MAX_COUNT}, found {n}", at)
        return self.counted(n, at)

    def f32s(self, n: int, what: str = "floats") -> list[float]:
        """``n`` float32s as a list (bulk arrays and runs of fields)."""
        pos = self.pos
        if n < 0 or pos + 4 * n > self.end:
            raise self._eof(f"{what} ({n} floats)")
        unpack, size = _floats_struct(n)
        self.pos = pos + size
        values = list(unpack(self.buf, pos))
        self.float_sum += sum(values)
        return values

    def varints(self, values=None, n: int = 0, what: str = "indices") -> list[int]:
        """``n`` non-negative varints (triangles, edges of 4.2 meshes)."""
        buf, pos = self.buf, self.pos
        head = buf[pos:pos + n]
        if len(head) == n and (not n or max(head) < 0x80):
            # The common case (meshes of under 128 vertices): n one-byte varints, read at once.
            self.pos = pos + n
            return list(head)
        out = []
        append = out.append
        try:
            for _ in range(n):
                b = buf[pos]
                pos += 1
                if b < 0x80:
                    append(b)
                    continue
                result, shift = b & 0x7F, 7
                while True:
                    b = buf[pos]
                    pos += 1
                    result |= (b & 0x7F) << shift
                    if not b & 0x80 or shift == 28:
                        break
                    shift += 7
                append(result & 0xFFFFFFFF)
        except IndexError:
            self.pos = pos
            raise self._eof(what) from None
        self.pos = pos
        return out

    def weighted(self, values=None, n: int = 0, nbones: int = 0) -> list:
        """``n`` weighted vertices as the JSON's flat ``[count, (bone, x, y, weight)*]``."""
        buf, pos = self.buf, self.pos
        out = []
        append, extend = out.append, out.extend
        unpack = XYW.unpack_from
        # A vertex's bones in one unpack, (bone, x, y, weight) per bone, when every bone index is
        # one byte and names a bone; else bone by bone below. Half the time of a mesh-heavy file.
        fast_below = min(nbones, 0x80)
        structs = _BONES_XYW
        try:
            for _ in range(n):
                k = buf[pos]
                pos += 1
                if 0 < k < 0x80:
                    try:
                        st = structs[k]
                    except IndexError:
                        st = None
                    if st is not None:
                        group = st.unpack_from(buf, pos)
                        if max(group[::4]) < fast_below:
                            append(k)
                            extend(group)
                            pos += st.size
                            continue
                if k >= 0x80:  # over 127 bones on one vertex: the long varint path
                    self.pos = pos - 1
                    k = self.count(what="bones per vertex")
                    pos = self.pos
                append(k)
                for _ in range(k):
                    b = buf[pos]
                    pos += 1
                    if b >= 0x80:
                        self.pos = pos - 1
                        b = self.varint()
                        pos = self.pos
                    if not 0 <= b < nbones:
                        raise self.fail(f"bone index below {nbones}, found {b}", pos - 1)
                    append(b)
                    extend(unpack(buf, pos))
                    pos += 12
        except (IndexError, struct.error):
            self.pos = pos
            raise self._eof("weighted vertices") from None
        self.pos = pos
        self.float_sum += sum(out)  # its counts and bone indices are small ints
        return out

    def string_ref(self, value=None, what: str = "string reference"):
        at = pos = self.pos
        if pos < self.end and self.buf[pos] < 0x80:
            i = self.buf[pos]
            self.pos = pos + 1
        else:
            i = self.varint(what=what)
        self.refs.append(i)
        if i == 0:
            return None
        if i < 0 or i > len(self.strings):
            raise self.fail(f"{what} into a table of {len(self.strings)} strings, found {i}", at)
        return self.strings[i - 1]


#: By bone count k (1 to 8): k times a one-byte bone index and x, y, weight as float32.
_BONES_XYW = (None, *(struct.Struct(">" + "B3f" * k) for k in range(1, 9)))


class _RefWriter(RecordedRefs, SkelWriter):
    """A writer that reuses recorded string-reference indices where they still fit.

    It has the reader's bulk methods, so that declarations stay symmetric.
    """

    def varints(self, values, n: int = 0, what: str = "indices") -> list[int]:
        for v in values:
            self.varint(v, what=what)
        return values

    def __init__(self, path=None, refs: list[int] | None = None):
        super().__init__(path)
        self.replay(refs)

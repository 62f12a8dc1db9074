"""Keyed values and the curves between keys, evaluated as the official runtimes evaluate them.

A timeline holds keys (a time and one or more values each) and, for every key but the last,
the curve to the next key: linear, stepped or a cubic Bezier. The runtimes do not solve the
Bezier at each time: when they read a skeleton they sample it at nine points by forward
differences and interpolate linearly between those; they store keys and samples as float32.
This module does the same, so that sampled values agree with the runtimes' to float32
precision rather than to the (larger) difference between a curve and its nine-point outline.

Two layouts:

* 3.x: one curve per key over normalised time and value; it turns the elapsed fraction of
  the segment into a *percent* that every value of the key moves by. 3.5 to 3.7 spell it
  ``"curve": [c1, c2, c3, c4]``, 3.8 ``"curve": c1, "c2": ..., "c3": ..., "c4": ...``, and
  each version's runtime reads its own spelling only
  (:class:`spinemesh.skeleton_curves.CurveSpelling`).
* 4.x: one curve per value, in the timeline's own time and value units
  (``"curve": [cx1, cy1, cx2, cy2]`` per value, one after the other).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..rig.transform import float_divide, wrap_turns
from ..skeleton_check import is_number
from ..skeleton_curves import CURVES_38, CurveSpelling

LINEAR, STEPPED, BEZIER = 0, 1, 2


def f32(values) -> np.ndarray:
    """``values`` rounded to float32 (as the runtimes store keys), as float64."""
    return np.asarray(values, np.float64).astype(np.float32).astype(np.float64)


class UnorderedTimes(np.ndarray):
    """Key times that do not ascend (a file written by hand or by a tool, never by the editor),
    marked so that :func:`search` finds a key among them as the version's runtime does.

    ``reach``: for 4.x, the running maximum of the times after the first (a key is found by the
    first later key past the time, :func:`search`); None for 3.x, whose runtimes bisect.
    """

    reach: np.ndarray | None = None


def key_times(times: np.ndarray, four: bool) -> np.ndarray:
    """``times`` (float64, shape (n,)) as :func:`search` searches them: the array itself where
    they ascend, as every editor writes them, else an :class:`UnorderedTimes` view."""
    if len(times) < 2 or bool(np.all(times[1:] >= times[:-1])):
        return times
    out = times.view(UnorderedTimes)
    out.reach = np.maximum.accumulate(times[1:]) if four else None
    return out


def search(times: np.ndarray, time: float) -> int:
    """The key a runtime applies at ``time``: the last at or before it where the times ascend;
    -1 before the first key.

    Where they do not (:func:`key_times`), the runtimes disagree, and each version's is taken:
    4.x (spine-core, spine-c, spine-cpp) scans from the second key for the first later than
    ``time`` and takes the one before it; 3.x takes the last key from its time on, else bisects
    the keys between, as 3.8's ``Animation.binarySearch`` does. numpy's bisection of keys out of
    order found yet another key (a pose no runtime showed).
    """
    if not isinstance(times, UnorderedTimes):
        return int(np.searchsorted(times, time, side="right")) - 1
    n = len(times)
    if time < times[0]:
        return -1
    if times.reach is not None:
        return int(np.searchsorted(times.reach, time, side="right"))
    if time >= times[n - 1]:
        return n - 1
    low, high = 0, n - 2
    current = high >> 1
    while low != high:
        if times[current + 1] <= time:
            low = current + 1
        else:
            high = current
        current = (low + high) >> 1
    return low


def _forward_differences(x1, y1, cx1, cy1, cx2, cy2, x2, y2) -> np.ndarray:
    """Nine points of a cubic Bezier from ``(x1, y1)`` to ``(x2, y2)``, shape (9, 2), at
    parameters 0.1 to 0.9, by forward differences in the runtimes' order of operations."""
    tmpx, tmpy = (x1 - cx1 * 2 + cx2) * 0.03, (y1 - cy1 * 2 + cy2) * 0.03
    dddx, dddy = ((cx1 - cx2) * 3 - x1 + x2) * 0.006, ((cy1 - cy2) * 3 - y1 + y2) * 0.006
    ddx, ddy = tmpx * 2 + dddx, tmpy * 2 + dddy
    dx = (cx1 - x1) * 0.3 + tmpx + dddx * 0.16666667
    dy = (cy1 - y1) * 0.3 + tmpy + dddy * 0.16666667
    x, y = x1 + dx, y1 + dy
    out = np.empty((9, 2))
    for i in range(9):
        out[i] = x, y
        dx += ddx
        dy += ddy
        ddx += dddx
        ddy += dddy
        x += dx
        y += dy
    return f32(out)


def bezier_points_3(c1: float, c2: float, c3: float, c4: float) -> np.ndarray:
    """3.x: the nine points of a key's percent curve (normalised: from (0, 0) to (1, 1))."""
    return _forward_differences(0.0, 0.0, c1, c2, c3, c4, 1.0, 1.0)


def bezier_points_4(time1, value1, cx1, cy1, cx2, cy2, time2, value2) -> np.ndarray:
    """4.x: the nine points of one value's curve, in time and value units."""
    return _forward_differences(time1, value1, cx1, cy1, cx2, cy2, time2, value2)


def percent_3(points, percent: float) -> float:
    """3.x ``getCurvePercent``: the curve's value at ``percent`` of the segment's time.

    ``points``: the nine points (9, 2), an array or nested lists of float. Divisions as the
    runtimes' floats make them (:func:`~spinemesh.rig.transform.float_divide`: two points at
    the same time divide by zero and give a NaN or an infinity, as numpy's floats did, where
    Python's would raise)."""
    percent = min(1.0, max(0.0, percent))
    px, py = 0.0, 0.0
    for x, y in points:
        if x >= percent:
            return py + float_divide((y - py) * (percent - px), x - px)
        px, py = x, y
    return py + float_divide((1 - py) * (percent - px), 1 - px)


def value_4(points, time: float, time1: float, value1: float, time2: float, value2: float) -> float:
    """4.x ``getBezierValue``: a value's curve at ``time`` (``time1 <= time < time2``); ``points``
    and divisions as :func:`percent_3` has them."""
    px, py = time1, value1
    for x, y in points:
        if x >= time:
            return py + float_divide(time - px, x - px) * (y - py)
        px, py = x, y
    return py + float_divide(time - px, time2 - px) * (value2 - py)


def percent_between_3(time: float, t1: float, t2: float) -> float:
    """How far ``time`` lies from key time ``t1`` to the next, ``t2``, as the 3.x runtimes work
    it out: from the next key back, ``1 - (time - t2) / (t1 - t2)``. The same number but for its
    last bit, which an angle of 1e12 degrees makes a difference of 1e-5 degrees."""
    return 1 - (time - t2) / (t1 - t2)


@dataclass
class Keys:
    """The keys of one timeline: ``times`` (n,), ``values`` (n, k) and the curve after each key.

    ``kinds`` (n,) holds LINEAR, STEPPED or BEZIER per key (the last key is STEPPED, as the
    runtimes set it). ``bezier``: per BEZIER key's index, its curve: 3.x, (9, 2) percent points;
    4.x, (k, 9, 2) per value (only those keys: a million linear keys hold no curve).
    ``angle``: a 3.x rotate timeline, whose keys turn the shorter way round.

    A player asks for time after time a frame apart, most of them between the same two keys:
    the span last found is kept, its keys and curve as Python floats (the same float64
    arithmetic as numpy's, without numpy's cost per call on a few numbers).
    """

    times: np.ndarray
    values: np.ndarray
    kinds: np.ndarray
    bezier: dict
    four: bool
    angle: bool = False
    #: 4.x: the first curve no runtime plays (a list too short for the timeline's values, or
    #: holding what is not a number), said as text; "" when none. It is posed linear here.
    unplayable: str = ""
    _span: tuple | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def duration(self) -> float:
        return float(self.times[-1]) if len(self.times) else 0.0

    def index(self, time: float) -> int:
        """The last key at or before ``time`` (-1 before the first key)."""
        return self._find(time)[0]

    def _find(self, time: float) -> tuple:
        """``(i, t1, t2, kind, a, b, curve)``: the key at or before ``time`` (:meth:`index`), the
        span ``t1 <= time < t2`` in which that is the answer (-inf before the first key, inf
        from the last on), the key's kind, its values and the next key's (tuples of float)
        and its curve (nested lists of float; None unless BEZIER). The span last found is
        kept and answers while ``time`` stays within it, where the times ascend (a file's
        keys out of order are searched each time, as the runtimes search them: :func:`search`)."""
        span = self._span
        if span is not None and span[1] <= time < span[2]:
            return span
        i = search(self.times, time)
        n = len(self.times)
        if i < 0:
            span = (-1, -math.inf, float(self.times[0]), STEPPED, (), (), None)
        elif i == n - 1:
            row = tuple(self.values[i].tolist())
            span = (i, float(self.times[i]), math.inf, STEPPED, row, row, None)
        else:
            kind = int(self.kinds[i])
            curve = self.bezier[i].tolist() if kind == BEZIER else None
            span = (i, float(self.times[i]), float(self.times[i + 1]), kind, tuple(self.values[i].tolist()),
                    tuple(self.values[i + 1].tolist()), curve)
        if not isinstance(self.times, UnorderedTimes):
            self._span = span
        return span

    def at(self, time: float) -> tuple[float, ...] | None:
        """The values (k floats) at ``time``; None before the first key (the setup values apply)."""
        i, t1, t2, kind, a, b, curve = self._find(time)
        if i < 0:
            return None
        if kind == STEPPED:
            return a
        # one value (rotate, and every timeline of one value) written out: a bone's timelines
        # are asked at every step of every pose, and a generator costs more than the sums
        one = len(a) == 1
        if self.four:
            if kind == LINEAR:
                f = (time - t1) / (t2 - t1)
                if one:
                    return (a[0] + f * (b[0] - a[0]),)
                return tuple([x + f * (y - x) for x, y in zip(a, b)])
            if one:
                return (value_4(curve[0], time, t1, a[0], t2, b[0]),)
            return tuple([value_4(curve[c], time, t1, a[c], t2, b[c]) for c in range(len(a))])
        p = percent_between_3(time, t1, t2)
        if kind == BEZIER:
            p = percent_3(curve, p)
        else:
            p = min(1.0, max(0.0, p))
        if self.angle:
            return (a[0] + wrap_turns(b[0] - a[0]) * p,) if one else tuple(
                [x + wrap_turns(y - x) * p for x, y in zip(a, b)])
        return (a[0] + (b[0] - a[0]) * p,) if one else tuple([x + (y - x) * p for x, y in zip(a, b)])

    def percent(self, time: float) -> tuple[int, float]:
        """For deform timelines: the key at or before ``time`` and how far (0..1) the value has
        moved towards the next key; ``(-1, 0)`` before the first key."""
        i, t1, t2, kind, _, _, curve = self._find(time)
        if i < 0:
            return -1, 0.0
        if kind == STEPPED:
            return i, 0.0
        if self.four:
            if kind == LINEAR:
                return i, (time - t1) / (t2 - t1)
            return i, value_4(curve[0], time, t1, 0.0, t2, 1.0)
        p = percent_between_3(time, t1, t2)
        return i, percent_3(curve, p) if kind == BEZIER else min(1.0, max(0.0, p))


#: The largest magnitude a float32 holds: the runtimes store keys as float32, so a key beyond
#: it (``1e300``, an integer of 400 digits) is not a number they can hold.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def _number(value, default: float) -> float:
    """``value`` as a float; ``default`` for what is not a number a float32 holds (text, a
    boolean, ``1e300``, an integer too large for a float)."""
    if not is_number(value):
        return float(default)
    try:
        v = float(value)
    except OverflowError:  # an integer of hundreds of digits
        return float(default)
    return v if abs(v) <= FLOAT32_MAX else float(default)



def read_keys(frames: list, values, four: bool, angle: bool = False, percent: bool = False,
              spelling: CurveSpelling = CURVES_38) -> Keys | None:
    """Keys from a timeline's JSON frames.

    Parameters
    ----------
    frames : list of dict
        The timeline's keys (``time``, values, ``curve``...), as the JSON (or the binary reader) has them.
    values : callable
        ``values(frame) -> list of float``: the key's values, defaults filled in.
    four : bool
        4.x curves (per value, absolute) rather than 3.x (per key, normalised).
    angle : bool
        A 3.x rotate timeline.
    percent : bool
        A 4.x deform timeline: one curve from 0 to 1 (the values are not read here).
    spelling : CurveSpelling
        3.x: how the version spells a key's curve (:func:`spinemesh.skeleton_curves.curve_spelling`);
        default 3.8's.

    Returns
    -------
    Keys or None
        None for a timeline without keys.
    """
    frames = [f for f in frames if isinstance(f, dict)] if isinstance(frames, list) else []
    if not frames:
        return None
    n = len(frames)
    times = key_times(f32([_number(f.get("time", 0), 0) for f in frames]), four)
    vals = f32([[0.0] if percent else values(f) for f in frames]).reshape(n, -1)
    k = vals.shape[1]
    kinds = np.full(n, LINEAR, np.int8)
    kinds[-1] = STEPPED
    bezier: dict[int, np.ndarray] = {}
    unplayable = ""
    for i, f in enumerate(frames[:-1]):
        if not four:
            kind = spelling.kind(f)
            if kind == "stepped":
                kinds[i] = STEPPED
            elif kind == "bezier":
                kinds[i] = BEZIER
                bezier[i] = bezier_points_3(*(_number(v, d) for v, d in zip(spelling.controls(f), (0, 0, 1, 1))))
            continue
        curve = f.get("curve")
        if curve == "stepped":
            kinds[i] = STEPPED
            continue
        if not unplayable and not curve_4_playable(curve, k):
            unplayable = (f"the curve of the key at {float(times[i]):g} s is {_shown(curve)}, where its "
                          f"{k} value{'s' if k > 1 else ''} need{'' if k > 1 else 's'} a list of {4 * k} numbers")
        if not isinstance(curve, list) or len(curve) < 4 * k:
            continue
        kinds[i] = BEZIER
        t1, t2 = float(times[i]), float(times[i + 1])
        bezier[i] = np.zeros((k, 9, 2))
        for c in range(k):
            cx1, cy1, cx2, cy2 = (_number(v, 0) for v in curve[4 * c:4 * c + 4])
            v1, v2 = (0.0, 1.0) if percent else (float(vals[i, c]), float(vals[i + 1, c]))
            bezier[i][c] = bezier_points_4(t1, v1, cx1, cy1, cx2, cy2, t2, v2)
    return Keys(times, vals, kinds, bezier, four, angle, unplayable)


#: What is said of a curve :func:`curve_4_playable` refuses (by ``pose`` and the preview).
UNPLAYABLE_SAID = ("the runtimes play it apart or not at all (spine-ts poses most such curves as not a number, the "
                   "others fail to load them or read other numbers)")


def unplayable_said(animation: str, problem: str, drawn: str) -> str:
    """The words for a curve :func:`curve_4_playable` refuses in ``animation``: ``problem`` (the
    timeline and key, :attr:`Keys.unplayable`), what the runtimes do, and how it was read here
    (``drawn``: ``"shown linear here"``); the preview, the motion guard and the bending checks
    say it so, as ``pose`` does."""
    return f"animation {animation!r}: {problem}; {UNPLAYABLE_SAID}: {drawn}"


def curve_4_playable(curve, values: int) -> bool:
    """Whether the 4.x runtimes play a key's ``curve`` for ``values`` values alike: absent or falsy
    (linear), ``"stepped"``, or a list of at least ``4 * values`` numbers. Anything else (a list
    cut short, text, ``true``) is not a number to spine-ts, which poses the values as NaN (the
    bone drawn nowhere; a number written as text it reads as the number); spine-c and spine-cpp
    read past the list or read text as 0, and libGDX refuses the file."""
    if curve is None or curve is False or curve == 0 or curve == "" or curve == "stepped":
        return True
    return (isinstance(curve, list) and len(curve) >= 4 * values
            and all(map(is_number, curve[:4 * values])))


def _shown(value) -> str:
    """A JSON value as a short text for a message."""
    import json

    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."

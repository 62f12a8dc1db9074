"""Path constraints (4.0-4.2, and 4.3 with its changes): position, spacing and rotate modes,
constant speed or not, open or closed paths; the target slot's path in world space and the bones
laid along it.
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import SpineMeshError
from ...skeleton_check import is_int
from ..binding import deformed, parse_vertices, setup_world
from ..transform import _num, wrap_pi
from .pose_bone import RAD, PoseBone

#: Below this setup length a bone has no direction of its own for path spacing.
_EPSILON = 0.00001


_NONE, _BEFORE, _AFTER = -1, -2, -3


def path_world_vertices(att: dict, slot_bone: PoseBone, bones: list[PoseBone],
                        deform: list[float] | None = None) -> list[float] | None:
    """A path attachment's vertices in world space, flat ``[x0, y0, x1, y1, ...]``, or None when
    its vertices do not parse. Weighted when ``vertices`` is longer than ``2 * vertexCount``.
    ``deform``: an animation's deform of it (the runtime's layout: positions when unweighted,
    offsets per bone influence when weighted), used instead of the setup values."""
    count = att.get("vertexCount")
    verts = att.get("vertices")
    if not is_int(count) or count <= 0 or not isinstance(verts, list):
        return None
    try:  # the mesh reader's layout; a path has no uvs, only its vertex count
        mesh = parse_vertices({"uvs": [0.0] * (2 * count), "vertices": verts}, len(bones))
    except SpineMeshError:
        return None
    if deform is not None:
        mesh = deformed(mesh, deform)
    world = setup_world(mesh, [b.world for b in bones], slot_bone.index)
    return [float(v) for v in world.reshape(-1)]


def _curve_position(p, x1, y1, cx1, cy1, cx2, cy2, x2, y2, tangents, family) -> tuple[float, float, float | None]:
    """Point (and with ``tangents`` its direction, radians) at parameter ``p`` of a cubic Bezier.

    At the very start 4.x returns the first point and its handle's direction; 3.8 evaluates
    the curve a little further (p = 1e-4) and takes the tangent there."""
    if p == 0 or math.isnan(p):
        if family == "3.8":
            p = 1e-4
        else:
            return x1, y1, math.atan2(cy1 - y1, cx1 - x1)
    tt, u = p * p, 1 - p
    ttt, uu = tt * p, u * u
    uuu, ut = uu * u, u * p
    ut3 = ut * 3
    uut3, utt3 = u * ut3, ut3 * p
    x = x1 * uuu + cx1 * uut3 + cx2 * utt3 + x2 * ttt
    y = y1 * uuu + cy1 * uut3 + cy2 * utt3 + y2 * ttt
    if not tangents:
        return x, y, None
    if p < 0.001 and family != "3.8":
        return x, y, math.atan2(cy1 - y1, cx1 - x1)
    return x, y, math.atan2(y - (y1 * uu + cy1 * ut * 2 + cy2 * tt), x - (x1 * uu + cx1 * ut * 2 + cx2 * tt))


def _beyond(p: float, x1: float, y1: float, x2: float, y2: float, at_end: bool) -> tuple[float, float, float]:
    """A position ``p`` past either end of an open path, along its first or last segment."""
    r = math.atan2(y2 - y1, x2 - x1)
    x, y = (x2, y2) if at_end else (x1, y1)
    return x + p * math.cos(r), y + p * math.sin(r), r


def _put(out: list, o: int, xyr: tuple) -> None:
    out[o], out[o + 1] = xyr[0], xyr[1]
    if xyr[2] is not None:
        out[o + 2] = xyr[2]


def _seek(lengths, start: int, p: float) -> tuple[int, float]:
    """The index of the first cumulative length at or past ``p`` from ``start``, and ``p``
    made relative to that piece (0..1)."""
    i = start
    while i < len(lengths) - 1 and p > lengths[i]:
        i += 1
    if i == 0:
        return i, p / lengths[i]
    prev = lengths[i - 1]
    return i, (p - prev) / (lengths[i] - prev)


def path_positions(att: dict, world: list[float], spaces: list[float], tangents: bool, position: float,
                   position_mode: str, spacing_mode: str, family: str, v43: bool = False) -> list[float]:
    """``computeWorldPositions``: ``[x, y, r]`` per space along the path, flat, plus two.

    A path whose ``constantSpeed`` is off places its points by the curve lengths the editor
    stored; otherwise the lengths are measured here along the world vertices, as the runtime
    does, and each curve is walked in ten segments of about equal length (4.3, ``v43``: on a
    closed path, each point's segment sought from the curve's first)."""
    out = [0.0] * (len(spaces) * 3 + 2)
    if not att.get("constantSpeed", True):
        return _positions_by_stored_lengths(att, world, spaces, tangents, position, position_mode, spacing_mode,
                                            family, out)
    return _positions_at_constant_speed(att, world, spaces, tangents, position, position_mode, spacing_mode,
                                        family, out, v43)


def _start_and_multiplier(position: float, position_mode: str, spacing_mode: str, path_length: float,
                          spaces_count: int) -> tuple[float, float]:
    """The path position in path units, and the factor that turns spaces into path units."""
    if position_mode == "percent":
        position *= path_length
    multiplier = {"percent": path_length, "proportional": path_length / spaces_count}.get(spacing_mode, 1)
    return position, multiplier


def _on_path(spaces: list[float], multiplier: float, position: float, path_length: float, closed: bool,
             first: list[float], last: list[float], out: list[float]):
    """The runtime's walk over the spaces: yields ``(i, o, p, space)`` for each point that falls
    on the path (``p`` its distance along it, wrapped on a closed path; ``o`` its offset in
    ``out``). A point before or past the ends of an open path is written to ``out`` here, along
    the line through the first or last two points (``first``, ``last``: ``[x1, y1, x2, y2]``)."""
    for i in range(len(spaces)):
        o = 3 * i
        space = spaces[i] * multiplier
        position += space
        p = position
        if closed:
            p = math.fmod(p, path_length)
            if p < 0:
                p += path_length
        elif p < 0:
            _put(out, o, _beyond(p, *first, at_end=False))
            continue
        elif p > path_length:
            _put(out, o, _beyond(p - path_length, *last, at_end=True))
            continue
        yield i, o, p, space


def _positions_by_stored_lengths(att: dict, world: list[float], spaces: list[float], tangents: bool,
                                 position: float, position_mode: str, spacing_mode: str, family: str,
                                 out: list[float]) -> list[float]:
    """:func:`path_positions` with ``constantSpeed`` off: the attachment's ``lengths``."""
    closed = bool(att.get("closed", False))
    vertices_length = len(world)
    curve_count = vertices_length // 6
    lengths = [float(v) for v in att.get("lengths", [])]
    curve_count -= 1 if closed else 2
    path_length = lengths[curve_count]
    position, multiplier = _start_and_multiplier(position, position_mode, spacing_mode, path_length, len(spaces))
    w = world
    curve = 0
    for i, o, p, space in _on_path(spaces, multiplier, position, path_length, closed, w[2:6],
                                   w[vertices_length - 6:vertices_length - 2], out):
        curve, p = _seek(lengths, 0 if closed else curve, p)
        if closed and curve == curve_count:
            pts = w[vertices_length - 4:vertices_length] + w[0:4]
        else:
            pts = w[curve * 6 + 2:curve * 6 + 10]
        _put(out, o, _curve_position(p, *pts, tangents or (i > 0 and space == 0), family))
    return out


def _positions_at_constant_speed(att: dict, world: list[float], spaces: list[float], tangents: bool,
                                 position: float, position_mode: str, spacing_mode: str, family: str,
                                 out: list[float], v43: bool = False) -> list[float]:
    """:func:`path_positions` with ``constantSpeed`` on: lengths measured along the world vertices."""
    closed = bool(att.get("closed", False))
    vertices_length = len(world)
    curve_count = vertices_length // 6
    if closed:
        vertices_length += 2
        w = world[2:] + world[0:2]
        w = w + w[0:2]
    else:
        curve_count -= 1
        vertices_length -= 4
        w = world[2:2 + vertices_length]
    curves, path_length = _curve_lengths(w, curve_count)
    position, multiplier = _start_and_multiplier(position, position_mode, spacing_mode, path_length, len(spaces))
    segments: list[float] = []
    curve_length = 0.0
    curve = segment = 0
    prev_curve = _NONE
    pts = None
    for i, o, p, space in _on_path(spaces, multiplier, position, path_length, closed, w[0:4],
                                   w[vertices_length - 4:vertices_length], out):
        curve, p = _seek(curves, 0 if closed else curve, p)
        if curve != prev_curve:
            prev_curve = curve
            pts = w[curve * 6:curve * 6 + 8]
            segments = _segment_lengths(pts)
            curve_length = segments[9]
            segment = 0
        p *= curve_length
        segment, frac = _seek(segments, 0 if closed and v43 else segment, p)
        p = frac if segment == 0 else segment + frac
        _put(out, o, _curve_position(p * 0.1, *pts, tangents or (i > 0 and space == 0), family))
    return out


def _curve_lengths(w: list[float], curve_count: int) -> tuple[list[float], float]:
    """Cumulative lengths of the path's curves, each estimated from four forward differences
    as the runtime does, and the whole path's length (``w``: the curves' points, flat)."""
    curves = []
    path_length = 0.0
    x1, y1 = w[0], w[1]
    for i in range(curve_count):
        cx1, cy1, cx2, cy2, x2, y2 = w[2 + 6 * i:8 + 6 * i]
        tmpx, tmpy = (x1 - cx1 * 2 + cx2) * 0.1875, (y1 - cy1 * 2 + cy2) * 0.1875
        dddfx, dddfy = ((cx1 - cx2) * 3 - x1 + x2) * 0.09375, ((cy1 - cy2) * 3 - y1 + y2) * 0.09375
        ddfx, ddfy = tmpx * 2 + dddfx, tmpy * 2 + dddfy
        dfx = (cx1 - x1) * 0.75 + tmpx + dddfx * 0.16666667
        dfy = (cy1 - y1) * 0.75 + tmpy + dddfy * 0.16666667
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        dfx += ddfx
        dfy += ddfy
        ddfx += dddfx
        ddfy += dddfy
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        dfx += ddfx
        dfy += ddfy
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        dfx += ddfx + dddfx
        dfy += ddfy + dddfy
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        curves.append(path_length)
        x1, y1 = x2, y2
    return curves, path_length


def _segment_lengths(pts: list[float]) -> list[float]:
    """Cumulative lengths of one curve's ten segments, by forward differences as the runtime
    does (``pts``: its four points, flat)."""
    x1, y1, cx1, cy1, cx2, cy2, x2, y2 = pts
    segments = [0.0] * 10
    tmpx, tmpy = (x1 - cx1 * 2 + cx2) * 0.03, (y1 - cy1 * 2 + cy2) * 0.03
    dddfx, dddfy = ((cx1 - cx2) * 3 - x1 + x2) * 0.006, ((cy1 - cy2) * 3 - y1 + y2) * 0.006
    ddfx, ddfy = tmpx * 2 + dddfx, tmpy * 2 + dddfy
    dfx = (cx1 - x1) * 0.3 + tmpx + dddfx * 0.16666667
    dfy = (cy1 - y1) * 0.3 + tmpy + dddfy * 0.16666667
    curve_length = math.sqrt(dfx * dfx + dfy * dfy)
    segments[0] = curve_length
    for ii in range(1, 8):
        dfx += ddfx
        dfy += ddfy
        ddfx += dddfx
        ddfy += dddfy
        curve_length += math.sqrt(dfx * dfx + dfy * dfy)
        segments[ii] = curve_length
    dfx += ddfx
    dfy += ddfy
    curve_length += math.sqrt(dfx * dfx + dfy * dfy)
    segments[8] = curve_length
    dfx += ddfx + dddfx
    dfy += ddfy + dddfy
    curve_length += math.sqrt(dfx * dfx + dfy * dfy)
    segments[9] = curve_length
    return segments


def path_apply(d: dict, att: dict, world: list[float], target_bone: PoseBone, bones: list[PoseBone],
               family: str) -> bool:
    """A path constraint's update: bones placed along the path, turned along it; False when
    every mix is 0 (the runtime returns first). 3.8 reads ``rotateMix``/``translateMix`` and
    gives a bone shorter than the epsilon no space (4.x gives it the spacing)."""
    mixes = _path_mixes(d, family)
    if mixes is None:
        return False
    rotate_mode, spacing_mode = d.get("rotateMode", "tangent"), d.get("spacingMode", "length")
    tangents, scale = rotate_mode == "tangent", rotate_mode == "chainScale"
    v43 = bones[0].v43
    spaces, lengths = _path_spaces(bones, _num(d, "spacing", 0), spacing_mode, tangents, scale, family)
    positions = path_positions(att, world, spaces, tangents, _num(d, "position", 0),
                               d.get("positionMode", "percent"), spacing_mode, family, v43)
    offset = _num(d, "rotation", 0)
    if offset == 0:
        tip = rotate_mode == "chain"
    else:
        tip = False
        pa, pb, _, pc, pd, _ = target_bone.m
        offset *= RAD if pa * pd - pb * pc > 0 else -RAD
    _lay_bones(bones, positions, spaces, lengths, mixes, tangents, scale, tip, offset, family)
    return True


def _path_mixes(d: dict, family: str) -> tuple[float, float, float] | None:
    """A path constraint's ``(rotate, x, y)`` mixes; None when the runtime would do nothing
    (3.8: rotate and translate mixes not above 0; 4.x: all three 0)."""
    if family == "3.8":
        mix_rotate, mix_x = _num(d, "rotateMix", 1), _num(d, "translateMix", 1)
        mix_y = mix_x
        if mix_rotate <= 0 and mix_x <= 0:
            return None
    else:
        mix_rotate, mix_x = _num(d, "mixRotate", 1), _num(d, "mixX", 1)
        mix_y = _num(d, "mixY", mix_x)
        if mix_rotate == 0 and mix_x == 0 and mix_y == 0:
            return None
    return mix_rotate, mix_x, mix_y


def _path_spaces(bones: list[PoseBone], spacing: float, spacing_mode: str, tangents: bool, scale: bool,
                 family: str) -> tuple[list[float], list[float]]:
    """The spaces between the bones along the path (one more than the bones unless the rotate
    mode is tangent) and each bone's world length (for chain scale), by the spacing mode."""
    count = len(bones)
    spaces_count = count if tangents else count + 1
    spaces = [0.0] * spaces_count
    lengths = [0.0] * count
    if family == "3.8" and spacing_mode == "percent":
        # 3.8 (since 3.7): a percent spacing is the spacing, whatever the bones' scale; in chain
        # scale, a bone shorter than the epsilon is given none
        for i in range(spaces_count - 1):
            short = bones[i].length < _EPSILON
            if scale and not short:
                a, _, _, c, _, _ = bones[i].m
                lengths[i] = math.hypot(bones[i].length * a, bones[i].length * c)
            spaces[i + 1] = 0.0 if short and scale else spacing
    elif spacing_mode == "percent":
        for i in range(spaces_count - 1) if scale else ():
            a, _, _, c, _, _ = bones[i].m
            short = family != "4.2" and bones[i].length < _EPSILON  # 4.0-4.1 give short bones no length
            lengths[i] = 0.0 if short else math.hypot(bones[i].length * a, bones[i].length * c)
        spaces[1:] = [spacing] * (spaces_count - 1)
    else:
        total = 0.0
        for i in range(spaces_count - 1):
            bone = bones[i]
            setup = bone.length
            if setup < _EPSILON:
                lengths[i] = 0.0
                spaces[i + 1] = 0.0 if family == "3.8" else spacing
                continue
            a, _, _, c, _, _ = bone.m
            length = math.hypot(setup * a, setup * c)
            lengths[i] = length
            if spacing_mode == "proportional" and family != "3.8":
                spaces[i + 1] = length
                total += length
            else:
                # 4.3 gives a bone no negative length spacing
                ahead = (max(0.0, setup + spacing) if bone.v43 else setup + spacing) if spacing_mode == "length" \
                    else spacing
                spaces[i + 1] = ahead * length / setup
        if spacing_mode == "proportional" and total > 0:
            k = spaces_count / total * spacing
            spaces[1:] = [v * k for v in spaces[1:]]
    return spaces, lengths


def _lay_bones(bones: list[PoseBone], positions: list[float], spaces: list[float], lengths: list[float],
               mixes: tuple[float, float, float], tangents: bool, scale: bool, tip: bool, offset: float,
               family: str) -> None:
    """Each bone moved to its point on the path, scaled (chain scale) and turned along it, by the mixes."""
    mix_rotate, mix_x, mix_y = mixes
    bone_x, bone_y = positions[0], positions[1]
    for i, bone in enumerate(bones):
        p = 3 * (i + 1)
        if bone.v43:
            bone.modify_world()
        a, b, wx, c, dd, wy = bone.m
        wx += (bone_x - wx) * mix_x
        wy += (bone_y - wy) * mix_y
        x, y = positions[p], positions[p + 1]
        dx, dy = x - bone_x, y - bone_y
        if scale and lengths[i] != 0:
            s = (math.hypot(dx, dy) / lengths[i] - 1) * mix_rotate + 1
            a, c = a * s, c * s
        bone_x, bone_y = x, y
        if mix_rotate > 0:
            if tangents:
                r = positions[p - 1]
            elif spaces[i + 1] == 0:
                r = positions[p + 2]
            else:
                r = math.atan2(dy, dx)
            r -= math.atan2(c, a)
            if tip:
                cos, sin = math.cos(r), math.sin(r)
                bone_x += (bone.length * (cos * a - sin * c) - dx) * mix_rotate
                bone_y += (bone.length * (sin * a + cos * c) - dy) * mix_rotate
            else:
                r += offset
            r = wrap_pi(r) * mix_rotate
            cos, sin = math.cos(r), math.sin(r)
            a, b, c, dd = cos * a - sin * c, cos * b - sin * dd, sin * a + cos * c, sin * b + cos * dd
        bone.world = np.array([[a, b, wx], [c, dd, wy]])
        if family == "3.8":
            bone.applied_valid = False
        else:
            bone.update_applied()

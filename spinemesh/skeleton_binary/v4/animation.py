"""Animations: every timeline group in file order, and the stored timeline count."""

from __future__ import annotations

from ..symmetric import color, fld, index, put as _put, text
from .fields import seq
from .layout import Context, Layout
from .timelines import (_bone_body, _deform_values, _path_body, _physics_body, _physics_body_43,
                        _sequence_frames, _slider_body, _time, _transform_values,
                        _transform_values_43, _typed_groups, curve_timeline, ik_timeline, slot_body)


def attachment_timelines(s, anim: dict, c: Context) -> None:
    """Deform (4.0: ``"deform"``) and sequence timelines (4.1+: ``"attachments"``), by skin, slot, attachment."""
    key = "attachments" if c.L.attachment_timelines else "deform"
    skin_names, skin_lookup = c.skins
    slot_names, slot_lookup = c.slots
    if s.reading:
        n = s.count(what="skin count")
        if not n:
            return
        out = anim[key] = {}
        for _ in range(n):
            tmp = {}
            index(s, tmp, "k", skin_names, skin_lookup, "skin")
            by_slot = out.setdefault(tmp["k"], {})
            for _ in range(s.count(what="slot count")):
                index(s, tmp, "k", slot_names, slot_lookup, "slot")
                by_att = by_slot.setdefault(tmp["k"], {})
                for _ in range(s.count(what="attachment count")):
                    name = s.string_ref()
                    if c.L.attachment_timelines:
                        at = s.pos
                        t = s.u8()
                        holder = by_att.setdefault(name, {})
                        if t == 0:
                            holder["deform"] = curve_timeline(s, None, _deform_values, 1, curve_first=True)
                        elif t == 1:
                            holder["sequence"] = _sequence_frames(s, None)
                        else:
                            raise s.fail(f"an attachment timeline type 0 or 1, found {t}", at)
                    else:
                        by_att[name] = curve_timeline(s, None, _deform_values, 1, curve_first=True)
        return
    group = anim.get(key, {})
    s.count(len(group))
    for skin_name, by_slot in group.items():
        index(s, {"k": skin_name}, "k", skin_names, skin_lookup, "skin")
        s.count(len(by_slot))
        for slot_name, by_att in by_slot.items():
            index(s, {"k": slot_name}, "k", slot_names, slot_lookup, "slot")
            if c.L.attachment_timelines:
                s.count(sum(len(h) for h in by_att.values()))
                for name, holder in by_att.items():
                    for kind, frames in holder.items():
                        s.string_ref(name)
                        if kind == "deform":
                            s.u8(0)
                            curve_timeline(s, frames, _deform_values, 1, curve_first=True)
                        elif kind == "sequence":
                            s.u8(1)
                            _sequence_frames(s, frames)
                        else:
                            raise s.fail(f"a deform or sequence timeline, got {kind!r}")
            else:
                s.count(len(by_att))
                for name, frames in by_att.items():
                    s.string_ref(name)
                    curve_timeline(s, frames, _deform_values, 1, curve_first=True)


def _draw_order_key(s, f: dict, table: tuple) -> None:
    """Time, then the slots that move and by how much; ``table`` names the slots (all of
    them, or a 4.3 folder's)."""
    names, lookup = table
    _time(s, f)
    if s.reading:
        k = s.count(what="offset count")
        if k:
            offsets = f["offsets"] = []
            for _ in range(k):
                o = {}
                index(s, o, "slot", names, lookup, "slot")
                o["offset"] = s.varint()
                offsets.append(o)
        return
    offsets = f.get("offsets") or []
    s.count(len(offsets))
    for o in offsets:
        index(s, o, "slot", names, lookup, "slot")
        s.varint(o.get("offset", 0), what="draw order offset")


def draw_order(s, anim: dict, c: Context) -> None:
    if s.reading:
        frames = seq(s, None, _draw_order_key, c.slots, what="draw order count")
        if frames:
            anim["drawOrder"] = frames
        return
    seq(s, anim.get("drawOrder", anim.get("draworder", [])), _draw_order_key, c.slots)


def _folder(s, folder: dict, c: Context) -> None:
    """4.3: a draw order timeline over some slots only; its keys index those slots."""
    if s.reading:
        slots = folder["slots"] = []
        for _ in range(s.count(what="folder slot count")):
            tmp: dict = {}
            index(s, tmp, "k", *c.slots, "slot")
            slots.append(tmp["k"])
    else:
        slots = folder.get("slots", [])
        s.count(len(slots))
        for name in slots:
            index(s, {"k": name}, "k", *c.slots, "slot")
    table = (slots, {n: i for i, n in reversed(list(enumerate(slots)))})
    keys = seq(s, None if s.reading else folder.get("keys", []), _draw_order_key, table, what="folder key count")
    if s.reading:
        folder["keys"] = keys


def draw_order_folders(s, anim: dict, c: Context) -> None:
    folders = seq(s, None if s.reading else anim.get("drawOrderFolder", []), _folder, c,
                  what="draw order folder count")
    if s.reading and folders:
        anim["drawOrderFolder"] = folders


def events_timeline(s, anim: dict, c: Context) -> None:
    names, lookup = c.event_names
    if s.reading:
        n = s.count(what="event count")
        if not n:
            return
        frames = anim["events"] = []
        for _ in range(n):
            f = {}
            _time(s, f)
            index(s, f, "name", names, lookup, "event")
            data = c.events[lookup[f["name"]]]
            _event_key(s, f, data, c)
            frames.append(f)
        return
    frames = anim.get("events", [])
    s.count(len(frames))
    for f in frames:
        _time(s, f)
        index(s, f, "name", names, lookup, "event")
        _event_key(s, f, c.events[lookup[f["name"]]], c)


def _event_key(s, f: dict, data: dict, c: Context) -> None:
    # A key's values default to its event's; the JSON leaves out equal ones.
    if s.reading:
        _put(f, "int", s.varint(positive=False), data.get("int", 0))
    else:
        s.varint(f.get("int", data.get("int", 0)), positive=False, what="an event key's int")
    fld(s, f, "float", data.get("float", 0))
    if c.L.flags:
        text(s, f, "string")
    elif s.bool("string" in f):
        text(s, f, "string")
    if data.get("audio") is not None:
        fld(s, f, "volume", data.get("volume", 1))
        fld(s, f, "balance", data.get("balance", 0))


def timeline_count(anim: dict, L: Layout) -> int:
    """How many runtime timelines an animation makes: the count stored before it."""
    n = 0
    for group in ("slots", "bones", "path", "physics", "slider"):
        for timelines in anim.get(group, {}).values():
            n += len(timelines)
    n += len(anim.get("ik", {})) + len(anim.get("transform", {}))
    if L.attachment_timelines:
        for by_slot in anim.get("attachments", {}).values():
            for by_att in by_slot.values():
                n += sum(len(h) for h in by_att.values())
    else:
        for by_slot in anim.get("deform", {}).values():
            for by_att in by_slot.values():
                n += len(by_att)
    n += 1 if anim.get("drawOrder") else 0
    n += len(anim.get("drawOrderFolder", []))
    n += 1 if anim.get("events") else 0
    return n


def animation(s, anim: dict, c: Context, extra_counts: dict, name: str) -> None:
    if s.reading:
        count = s.count(what="timeline count")
    else:
        count = s.count(extra_counts.get(name, timeline_count(anim, c.L)), what=f"animation {name!r}'s timeline count")
    for key, names_lookup, body, offset in (
            ("slots", c.slots, slot_body(c.L), 0), ("bones", c.bones, _bone_body, 0)):
        got = _typed_groups(s, None if s.reading else anim.get(key, {}), *names_lookup, key[:-1], body, offset)
        if s.reading and got:
            anim[key] = got
    # IK and transform constraints: one timeline each.
    transform_values = _transform_values_43 if c.L.constraint_list else _transform_values
    for key, table in (("ik", c.ik), ("transform", c.transform)):
        names, lookup = table
        if s.reading:
            n = s.count(what=f"{key} timeline count")
            if n:
                out = anim[key] = {}
                for _ in range(n):
                    tmp = {}
                    index(s, tmp, "k", names, lookup, key)
                    if key == "ik":
                        out[tmp["k"]] = ik_timeline(s, None, c)
                    else:
                        out[tmp["k"]] = curve_timeline(s, None, transform_values, 6)
        else:
            group = anim.get(key, {})
            s.count(len(group))
            for cname, frames in group.items():
                index(s, {"k": cname}, "k", names, lookup, key)
                if key == "ik":
                    ik_timeline(s, frames, c)
                else:
                    curve_timeline(s, frames, transform_values, 6)
    got = _typed_groups(s, None if s.reading else anim.get("path", {}), *c.path, "path", _path_body)
    if s.reading and got:
        anim["path"] = got
    if c.L.physics:
        # Index 0 means every physics constraint: the JSON's "" key.
        names = [""] + c.physics[0]
        lookup = {n: i for i, n in reversed(list(enumerate(names)))}
        got = _typed_groups(s, None if s.reading else anim.get("physics", {}), names, lookup, "physics",
                            _physics_body_43 if c.L.constraint_list else _physics_body)
        if s.reading and got:
            anim["physics"] = got
    if c.L.constraint_list:
        got = _typed_groups(s, None if s.reading else anim.get("slider", {}), *c.sliders, "slider", _slider_body)
        if s.reading and got:
            anim["slider"] = got
    attachment_timelines(s, anim, c)
    draw_order(s, anim, c)
    if c.L.constraint_list:
        draw_order_folders(s, anim, c)
    events_timeline(s, anim, c)
    if c.L.constraint_list and c.nonessential:
        color(s, anim, "color", "ffffffff")
    if s.reading and count != timeline_count(anim, c.L):
        extra_counts[name] = count

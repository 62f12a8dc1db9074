"""The skeleton header: hash, version, bounds, reference scale, nonessential data."""

from __future__ import annotations

import base64
import struct

from ..symmetric import fld, text
from .layout import Layout, _layout


def header(s, doc: dict, extra: dict) -> tuple[Layout, bool]:
    sk = doc.setdefault("skeleton", {}) if s.reading else doc.get("skeleton", {})
    if s.reading:
        h = s.i64(what="hash")
        sk["hash"] = base64.b64encode(struct.pack(">q", h)).decode("ascii").rstrip("=")
        version = s.string(what="version")
        if version is None:
            raise s.fail("a version string", 8)
        sk["spine"] = version
    else:
        h = sk.get("hash")
        raw = base64.b64decode(h + "=" * (-len(h) % 4)) if h else b"\0" * 8
        if len(raw) != 8:
            raise s.fail(f"an 8-byte base64 hash, got {h!r}")
        s.raw(raw)
        version = s.string(str(sk.get("spine", "")))
    layout = _layout(s, version)
    for key in ("x", "y", "width", "height"):
        if s.reading:
            sk[key] = s.f32()
        else:
            s.f32(sk.get(key, 0.0))
    if layout.reference_scale:
        fld(s, sk, "referenceScale", 100)
    nonessential = s.bool(extra.get("nonessential", True))
    if nonessential:
        fld(s, sk, "fps", 30)
        text(s, sk, "images")
        text(s, sk, "audio")
    if s.reading and not nonessential:
        extra["nonessential"] = False
    return layout, nonessential

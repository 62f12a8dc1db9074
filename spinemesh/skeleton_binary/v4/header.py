"""The skeleton header: hash, version, bounds, reference scale, nonessential data."""

from __future__ import annotations

import base64
import binascii
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
        s.raw(_hash_bytes(s, sk.get("hash")))
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


def _hash_bytes(s, h) -> bytes:
    """The 8 bytes a 4.x ``.skel`` holds for the JSON's ``hash`` (their base64); zeros for none.

    Tools besides the editor write other hashes (``"gen-h1-1784752710547"``): a ``.skel`` has no
    room for them, and dropping one would not be the skeleton as written, so it is refused in
    words that say what to do (``base64`` alone skipped the ``-`` and said "Incorrect padding").
    """
    if not h:
        return b"\0" * 8
    try:
        raw = base64.b64decode(h + "=" * (-len(h) % 4), validate=True) if isinstance(h, str) else b""
    except (binascii.Error, ValueError):
        raw = b""
    if len(raw) != 8:
        raise s.fail(f"a skeleton hash of 8 bytes in base64 as the Spine editor writes, got {h!r}"
                     " (a .skel has room for no other: remove the hash from the JSON to convert it)")
    return raw

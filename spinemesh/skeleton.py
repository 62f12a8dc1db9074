"""Skeleton documents: lossless JSON I/O and one walk over every attachment.

A skeleton document is the plain ``dict`` that the Spine editor's JSON export holds. The
binary reader (:mod:`spinemesh.skeleton_binary`) produces the same document, so everything
downstream works on one model whatever the input format was.

Spine changed the skin layout in 3.8: before, ``"skins"`` is a dict of skin name to slots;
from 3.8 on, a list of ``{"name", "attachments", ...}``. :func:`iter_attachments` hides
the difference.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterator, NamedTuple

from .errors import SkeletonError
from .fsutil import atomic_write_text

#: Attachment types that draw an image from the atlas.
IMAGE_TYPES = ("region", "mesh", "linkedmesh")


class AttachmentRef(NamedTuple):
    """One attachment of one skin: ``(skin, slot, name, attachment)``.

    ``attachment`` is the document's own dict: changing it changes the document.
    """

    skin: str
    slot: str
    name: str
    attachment: dict

    @property
    def type(self) -> str:
        return self.attachment.get("type", "region")


def load_skeleton(path: str | Path) -> dict:
    """Load a skeleton ``.json`` (or ``.skel``, through the binary reader).

    JSON keeps key order and every field, known or not, so that :func:`save_skeleton`
    writes back an equal document.

    Raises
    ------
    SkeletonError
        With the file and line, for unreadable or non-skeleton JSON.
    SkelFormatError
        With the byte offset, for a broken ``.skel``.
    """
    path = Path(path)
    if is_binary_skeleton(path):
        from .skeleton_binary import read_skel

        return read_skel(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise SkeletonError(f"cannot read skeleton: {e.strerror}", path) from None
    except UnicodeDecodeError as e:
        raise SkeletonError(f"skeleton is not UTF-8 text (byte {e.start})", path) from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise SkeletonError(f"invalid JSON: {e.msg} (column {e.colno})", path, line=e.lineno) from None
    if not isinstance(doc, dict) or not isinstance(doc.get("bones", []), list):
        raise SkeletonError("not a Spine skeleton (no top-level object with 'bones')", path)
    return doc


def dumps_skeleton(doc: dict) -> str:
    """The document as JSON text, tab-indented like the editor's export."""
    return json.dumps(doc, indent="\t", ensure_ascii=False) + "\n"


def save_skeleton(doc: dict, path: str | Path) -> None:
    """Write ``doc`` atomically, as ``.skel`` if ``path`` is binary, else as JSON."""
    path = Path(path)
    if is_binary_skeleton(path):
        from .fsutil import atomic_write_bytes
        from .skeleton_binary import write_skel

        atomic_write_bytes(path, write_skel(doc, path))
    else:
        atomic_write_text(path, dumps_skeleton(doc))


def is_binary_skeleton(path: str | Path) -> bool:
    """Whether a skeleton file is binary: ``.skel``, ``.skel.bytes``, or a ``.json`` that is not text.

    Real projects ship binaries under JSON names (Unity), so the first byte decides when
    the extension says JSON.
    """
    p = Path(path)
    name = p.name.lower()
    if name.endswith((".skel", ".skel.bytes", ".skel.txt")):
        return True
    if p.is_file():
        with open(p, "rb") as f:
            head = f.read(64).lstrip(b"\xef\xbb\xbf \t\r\n")
        return not head.startswith((b"{", b"["))
    return False


def spine_version(doc: dict) -> str:
    """The editor version that wrote the document, e.g. ``"4.2.22"`` (``""`` if absent)."""
    skel = doc.get("skeleton")
    return str(skel.get("spine", "")) if isinstance(skel, dict) else ""


def iter_skins(doc: dict) -> Iterator[tuple[str, dict]]:
    """``(skin name, {slot: {attachment name: attachment}})`` for both skin layouts."""
    skins = doc.get("skins")
    if isinstance(skins, dict):  # 3.6 / 3.7
        for name, slots in skins.items():
            if isinstance(slots, dict):
                yield name, slots
    elif isinstance(skins, list):  # 3.8+
        for skin in skins:
            if isinstance(skin, dict) and isinstance(skin.get("attachments", {}), dict):
                yield str(skin.get("name", "")), skin.get("attachments", {})


def iter_attachments(doc: dict) -> Iterator[AttachmentRef]:
    """Every attachment of every skin, in document order."""
    for skin, slots in iter_skins(doc):
        for slot, attachments in slots.items():
            if not isinstance(attachments, dict):
                continue
            for name, att in attachments.items():
                if isinstance(att, dict):
                    yield AttachmentRef(skin, slot, name, att)


def attachment_path(ref: AttachmentRef) -> str:
    """The image path an attachment draws: ``path``, else ``name``, else its key."""
    att = ref.attachment
    return str(att.get("path") or att.get("name") or ref.name)


def sequence_paths(path: str, sequence: dict) -> list[str]:
    """Frame image paths of a sequence: ``path`` + frame number, zero-padded to ``digits``.

    Defaults as in the editor's export: ``start`` 1, ``digits`` 0.
    """
    count = int(sequence.get("count", 0))
    start = int(sequence.get("start", 1))
    digits = int(sequence.get("digits", 0))
    return [path + str(start + i).zfill(digits) for i in range(count)]


def image_paths(ref: AttachmentRef) -> list[str]:
    """Every image an attachment may draw: one path, or a sequence's frames.

    Empty for attachment types that draw no image (bounding boxes, paths, points, clipping).
    """
    if ref.type not in IMAGE_TYPES:
        return []
    path = attachment_path(ref)
    seq = ref.attachment.get("sequence")
    if isinstance(seq, dict):
        return sequence_paths(path, seq)
    return [path]


def number(att: dict, key: str, default: float, source: str | Path | None = None, what: str = "") -> float:
    """A numeric field of an attachment, with a clear error when it is not a number."""
    value = att.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SkeletonError(f"{what or 'attachment'}: {key!r} must be a number, found {value!r}", source)
    return float(value)

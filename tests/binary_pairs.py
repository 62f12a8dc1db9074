"""The checks every ``.skel`` of the examples passes against its ``.json`` twin, for the 3.x
and 4.x binary tests alike (each names its pairs and its known differences).

A known difference is ``(version, file, path pattern, condition on the .skel document, reason)``:
a place where the two exports really hold different information.
"""

from __future__ import annotations

import fnmatch
import json
from pathlib import Path

import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version
from spinemesh.skeleton_binary.compare import diff_documents
from spinemesh.skeleton_binary.enums import EXTRA


def editor_json(js: Path) -> dict:
    return json.loads(js.read_text(encoding="utf-8-sig"))


_NOT_VALUES = {"time", "curve", "c2", "c3", "c4"}


def frames_at(doc: dict, path: str) -> tuple[dict, dict] | None:
    """The key at ``path`` (``.../<i>/curve``) and the one after it, from ``doc``."""
    parts = path.split("/")[:-1]
    node = doc
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    i = int(parts[-1])
    return (node[i], node[i + 1]) if i + 1 < len(node) else None


def no_motion(doc: dict, path: str) -> bool:
    """The key and the next hold the same values, so a stepped and a linear curve
    between them give the same motion."""
    pair = frames_at(doc, path)
    if pair is None:
        return False
    a, b = ({k: v for k, v in f.items() if k not in _NOT_VALUES} for f in pair)
    return a == b


def is_known(known: list, version: str, name: str, doc: dict, path: str) -> bool:
    """Whether the difference at ``path`` is one of ``known``."""
    for v, f, pattern, condition, _reason in known:
        if fnmatch.fnmatchcase(version, v) and fnmatch.fnmatchcase(name, f) \
                and fnmatch.fnmatchcase(path, pattern) and (condition is None or condition(doc, path)):
            return True
    return False


def check_round_trip(skel: Path) -> None:
    """Reading the ``.skel`` and writing it back gives the same bytes."""
    data = skel.read_bytes()
    assert encode_skel(read_skel(data, skel)) == data


def check_document_equals_editor_json(skel: Path, js: Path, known: list) -> None:
    """The document read from the ``.skel`` equals the editor's JSON but for ``known``, and
    every entry of ``known`` tied to this very file is still needed (the list does not rot)."""
    doc = read_skel(skel)
    version = skel.parts[-3]
    diffs = diff_documents(doc, editor_json(js), ignore=[EXTRA], limit=100_000)
    unexplained = [d for d in diffs if not is_known(known, version, skel.name, doc, d.path)]
    assert not unexplained, "\n".join(map(str, unexplained[:30]))
    for v, f, pattern, _c, _r in known:
        if f == skel.name and fnmatch.fnmatchcase(version, v):
            assert any(fnmatch.fnmatchcase(d.path, pattern) for d in diffs), f"{pattern} no longer differs"


def check_json_writes_a_skel_that_reads_back(js: Path, binary_only: frozenset = frozenset()) -> None:
    """The editor's JSON written as ``.skel`` reads back to it (up to float32 rounding), and
    that ``.skel`` is stable; ``binary_only`` are the ``EXTRA`` keys the reader may add."""
    editor = editor_json(js)
    data = encode_skel(editor)
    again = read_skel(data)
    assert EXTRA not in again or set(again[EXTRA]) <= binary_only
    diffs = diff_documents(again, editor, abs_tol=1e-4, rel_tol=1e-6, ignore=[EXTRA])
    assert not diffs, "\n".join(map(str, diffs[:30]))
    assert encode_skel(again) == data
    assert sniff_version(data) == editor["skeleton"]["spine"]


def check_survives_json_text(skel: Path) -> None:
    """A document read from ``.skel``, saved as JSON text with its binary-only data and loaded
    again, still writes the original bytes."""
    data = skel.read_bytes()
    assert encode_skel(json.loads(json.dumps(read_skel(data)))) == data


def check_truncation_says_where_and_what(data: bytes) -> None:
    """A cut file (``data``, a prefix of a real one) is the one format error, naming the file,
    an offset inside what there is, and what was expected there."""
    with pytest.raises(SkelFormatError) as e:
        read_skel(data, "spineboy-pro.skel")
    assert e.value.offset is not None and 0 <= e.value.offset <= len(data)
    assert "expected" in e.value.message and e.value.path == "spineboy-pro.skel"


def check_trailing_bytes_refused(data: bytes) -> None:
    """A byte after a whole file (``data``) is an error at the offset where the file should end."""
    with pytest.raises(SkelFormatError, match="end of file") as e:
        read_skel(data + b"\0")
    assert e.value.offset == len(data)

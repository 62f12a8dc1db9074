"""The binary reader tells a non-finite number by the sum of the floats it reads.

``load_skeleton`` refuses a ``.skel`` holding NaN or an infinity. It no longer walks the whole
document to find out: the reader adds up every float it reads (``SkelReader.float_sum``), and
only a non-finite sum makes it look for where. That is right only if every way a float is read
adds to the sum. This checks it on real files: every kind of float that the example skeletons
hold (grouped by the keys that lead to it) is set to NaN in turn, written as ``.skel`` by our
writer, and read back; the sum must say "not finite" each time.
"""

from __future__ import annotations

import math
import re

import pytest

from spinemesh.errors import SkelFormatError, SkeletonError
from spinemesh.skeleton import load_skeleton
from spinemesh.skeleton_binary import encode_skel, read_skel, read_skel_finite
from spinemesh.skeleton_binary.enums import EXTRA

from conftest import EXAMPLES

#: Keys that are Spine fields or timeline types; any other key above a float is a name (of a
#: bone, slot, skin, attachment, animation...) and is left out of the float's kind.
_FIELDS = {"bones", "slots", "skins", "attachments", "animations", "events", "ik", "transform", "path",
           "physics", "slider", "constraints", "drawOrder", "deform", "sequence", "rotate", "translate",
           "translatex", "translatey", "scale", "scalex", "scaley", "shear", "shearx", "sheary", "inherit",
           "rgba", "rgb", "rgba2", "rgb2", "alpha", "attachment", "position", "spacing", "mix", "inertia",
           "strength", "damping", "mass", "wind", "gravity", "reset", "offsets", "curve", "vertices",
           "skeleton", "uvs", "lengths", "properties", "to", "from"}


def _float_kinds(doc) -> dict[tuple, list]:
    """{kind: path} for the first float of each kind; a path is the keys and indices down to it.

    A kind is the top-level section, the float's key (or its list's), the field above that, the
    attachment type it belongs to, and whether it sits in a list: what picks the reader's path.
    """
    found: dict[tuple, list] = {}
    stack = [([], doc, "")]
    while stack:
        path, node, owner_type = stack.pop()
        if isinstance(node, float):
            keys = [k for k in path if isinstance(k, str)]
            above = keys[-2] if len(keys) > 1 and keys[-2] in _FIELDS else "*"
            found.setdefault((path[0], above, keys[-1], owner_type, isinstance(path[-1], int)), path)
        elif isinstance(node, dict):
            kind = node.get("type") if isinstance(node.get("type"), str) else owner_type
            stack.extend((path + [k], v, kind) for k, v in node.items() if k != EXTRA)
        elif isinstance(node, list):
            stack.extend((path + [i], v, owner_type) for i, v in enumerate(node))
    return found


def _set(doc, path: list, value):
    """Set the value at ``path``; return the one it replaces."""
    for step in path[:-1]:
        doc = doc[step]
    before, doc[path[-1]] = doc[path[-1]], value
    return before


def _families() -> list:
    """Example .skel files, smallest first, one list per reader (3.x, 4.0-4.2)."""
    skels = sorted(EXAMPLES.glob("*/*/*.skel"), key=lambda p: p.stat().st_size) if EXAMPLES.is_dir() else []
    return [pytest.param([p for p in skels if re.match(pattern, p.parent.parent.name)], id=name)
            for name, pattern in (("3.x", r"3\."), ("4.0-4.2", r"4\.[012]$"))]


def _nan_everywhere(sources) -> set[tuple]:
    """Set each kind of float of each ``(path, data)`` .skel to NaN in turn; check the reader sees it."""
    tested: set[tuple] = set()
    for path, data in sources:
        doc, finite = read_skel_finite(data, path)
        assert finite, f"{path}: a clean file reads as non-finite"
        for kind, where in _float_kinds(doc).items():
            if kind in tested:
                continue
            before = _set(doc, where, math.nan)
            try:
                changed = encode_skel(doc, path)
            except SkelFormatError:
                continue  # a field the writer stores as an int: no NaN can be written there
            finally:
                _set(doc, where, before)
            tested.add(kind)
            assert not read_skel_finite(changed, path)[1], f"{path}: NaN at {where} not seen by the reader"
    return tested


@pytest.mark.parametrize("files", _families())
def test_every_kind_of_float_counts_in_the_sum(examples, files):
    assert files, "no example .skel of this version"
    tested = _nan_everywhere((p, p.read_bytes()) for p in files)
    assert len(tested) > 50, sorted(tested)


def test_every_kind_of_4_3_float_counts_in_the_sum():
    """4.3, on the document that holds every structure 4.3 added (no 4.3 .skel is exported)."""
    from skel43_features import features_document

    tested = _nan_everywhere([("features.skel", encode_skel(features_document()))])
    assert len(tested) > 20, sorted(tested)


def test_load_skeleton_still_says_where(examples, tmp_path):
    src = next(EXAMPLES.glob("4.2/spineboy/spineboy-pro.skel"))
    doc = read_skel(src)
    doc["bones"][1]["x"] = math.inf
    bad = tmp_path / "bad.skel"
    bad.write_bytes(encode_skel(doc, bad))
    with pytest.raises(SkeletonError, match=r"non-finite number .* at /bones/1/x"):
        load_skeleton(bad)

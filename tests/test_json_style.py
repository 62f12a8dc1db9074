"""Skeleton JSON written in the style it came in: a version-control diff shows only what changed."""

from __future__ import annotations

import json
import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from spinemesh.json_style import EDITOR_STYLE, JsonStyle, _items, _skip, detect_style, dumps, splice
from spinemesh.skeleton import dumps_skeleton, is_binary_skeleton, iter_attachments
from spinemesh.attachment_geometry import mesh_attachment

from conftest import CORPUS, EXAMPLES

#: Skeleton JSON text (binary skeletons that Unity projects name .json are left out by their bytes).
EXAMPLE_JSON = sorted(p for p in EXAMPLES.glob("*/*/*.json") if not is_binary_skeleton(p))
CORPUS_JSON = sorted(p for p in CORPUS.rglob("*.json")
                     if not p.name.endswith(".source.json") and not is_binary_skeleton(p))


def _skeleton_text(path: Path) -> str | None:
    try:
        text = path.read_bytes().decode("utf-8-sig")
        doc = json.loads(text)
    except (UnicodeDecodeError, ValueError):
        return None  # a binary skeleton under a .json name
    return text if isinstance(doc, dict) and "skeleton" in doc else None


def _removed_lines(before: str, after: str) -> int:
    """Lines of ``before`` that ``after`` no longer holds (counted with repeats): what a
    line diff shows as removed when nothing moved."""
    return sum((Counter(before.splitlines()) - Counter(after.splitlines())).values())


def _spans_of(text: str, doc, wanted: set[int]) -> list[tuple[int, int]]:
    """(start, end) in ``text`` of the objects of ``doc`` whose ``id`` is in ``wanted``."""
    found = []

    def walk(value, pos: int) -> int:
        if isinstance(value, (dict, list)) and value:
            keys = iter(value) if isinstance(value, dict) else iter(range(len(value)))
            walker = _items(text, pos, isinstance(value, dict))
            try:
                _, start = next(walker)
                while True:
                    _, start = walker.send(walk(value[next(keys)], start))
            except StopIteration as stop:
                end = stop.value
        else:
            end = _skip(text, pos)
        if id(value) in wanted:
            found.append((pos, end))
        return end

    walk(doc, len(text) - len(text.lstrip()))
    return found


def _upgrade_regions(doc: dict) -> list[dict]:
    """Turn every region attachment into a 6-vertex mesh with the real mesh writer, in place."""
    upgraded = []
    verts = np.array([[0, 0], [10, 0], [20, 5], [20, 20], [0, 20], [10, 10]], float)
    tris = np.array([[0, 1, 5], [1, 2, 5], [2, 3, 5], [3, 4, 5], [4, 0, 5]])
    for ref in iter_attachments(doc):
        att = ref.attachment
        if att.get("type", "region") != "region" or "width" not in att:
            continue
        mesh = mesh_attachment(att, verts, tris, 5, np.zeros((0, 2), int), 20, 20)
        att.clear()
        att.update(mesh)
        upgraded.append(att)
    return upgraded


@pytest.mark.parametrize("path", EXAMPLE_JSON + CORPUS_JSON, ids=lambda p: str(p.relative_to(p.parents[2])))
def test_unchanged_document_keeps_its_exact_text(path):
    text = _skeleton_text(path)
    assert text is not None, f"{path} is not skeleton JSON text"
    assert splice(text, json.loads(text)) == text


@pytest.mark.parametrize("path", EXAMPLE_JSON, ids=lambda p: str(p.relative_to(p.parents[2])))
def test_upgrade_removes_only_the_lines_of_upgraded_regions(path):
    """For every example JSON: lines removed <= lines of the region attachments upgraded."""
    text = _skeleton_text(path)
    doc = json.loads(text)
    ids = {id(ref.attachment) for ref in iter_attachments(doc)
           if ref.attachment.get("type", "region") == "region" and "width" in ref.attachment}
    region_lines = sum(text.count("\n", start, end) + 1 for start, end in _spans_of(text, doc, ids))
    upgraded = _upgrade_regions(doc)
    assert len(upgraded) == len(ids)
    out = dumps_skeleton(doc, path, like=text)
    assert json.loads(out) == json.loads(json.dumps(doc))
    assert _removed_lines(text, out) <= region_lines


def test_detected_style_rewrites_editor_exports_exactly(examples):
    """Written from scratch in the detected style, the editor's exports come out byte for byte
    (all but a few, whose one-line limits the editor chose differently per object)."""
    texts = [t for t in map(_skeleton_text, EXAMPLE_JSON) if t]
    exact = [dumps(json.loads(t), detect_style(t)) == t.rstrip("\r\n") for t in texts]
    assert len(texts) >= 100 and sum(exact) >= 0.9 * len(texts), (sum(exact), len(texts))


def test_styles_are_detected():
    editor = '{\n"bones": [\n\t{ "name": "root", "x": 1.0E-5 }\n]\n}\n'
    st = detect_style(editor)
    assert (st.indent, st.top_level_indented, st.pad, st.java_exponents, st.minified) == ("\t", False, " ", True, False)
    python = json.dumps({"bones": [{"name": "root", "x": 1e-05}]}, indent=2)
    st = detect_style(python)
    assert (st.indent, st.top_level_indented, st.object_columns, st.java_exponents) == ("  ", True, -1, False)
    assert dumps(json.loads(python), st) == python
    assert detect_style('{"bones":[{"name":"root"}]}').minified
    assert detect_style('{\r\n"a": 1\r\n}').newline == "\r\n"


def test_numbers_as_the_editor_writes_them():
    assert dumps([1.0, 0.5, 1e-05, -2.5e-4, 12345678.5, 3], EDITOR_STYLE) == "[ 1, 0.5, 1.0E-5, -2.5E-4, 1.23456785E7, 3 ]"
    assert dumps([1e-05], JsonStyle(java_exponents=False)) == "[ 1e-05 ]"
    with pytest.raises(ValueError):
        dumps({"x": math.nan})
    with pytest.raises(ValueError):
        dumps([math.inf])


def test_java_exponents_are_the_shortest_digits():
    """Java's form is made from ``repr`` by string steps (no decimal import at start-up); the
    same digits and exponent as Python's ``Decimal`` gives them, on 100,000 random doubles."""
    from decimal import Decimal

    from spinemesh.json_style import _java_double

    def by_decimal(value: float) -> str:
        sign, digits, exponent = Decimal(repr(value)).normalize().as_tuple()
        return f"{'-' if sign else ''}{digits[0]}.{''.join(map(str, digits[1:])) or '0'}E{exponent + len(digits) - 1}"

    rng = np.random.default_rng(4)
    values = [1e-5, -2.5e8, 5e-4, 1.2e-4, 1234567890123456.0, 1e16, 12345678.5, 5e-324, 1.7976931348623157e308,
              *(rng.choice([-1, 1], 50_000) * 10.0 ** rng.uniform(-40, 40, 50_000)),
              *(rng.integers(1, 10 ** 6, 50_000) * 10.0 ** rng.integers(-12, 20, 50_000))]
    for v in map(float, values):
        assert _java_double(v) == by_decimal(v), v


def test_a_changed_value_deep_inside_rewrites_only_its_line():
    text = '{\n"skeleton": { "spine": "4.2.22" },\n"bones": [\n\t{ "name": "root" },\n\t{ "name": "hip", "x": 2 }\n]\n}\n'
    doc = json.loads(text)
    doc["bones"][1]["x"] = 3.5
    assert splice(text, doc) == text.replace('"x": 2', '"x": 3.5')


def test_unreadable_original_falls_back_to_a_full_rewrite():
    doc = {"skeleton": {"spine": "4.2.22"}}
    assert json.loads(splice("{ not json", doc)) == doc


def test_top_level_values_are_read_with_their_ends():
    """The top-level object read value by value is ``json.loads``'s, each value's span its text."""
    from spinemesh.json_style import _top_level

    text = '{\n"a": { "x": 1.5 },\n"b" : [ 1, 2 ] ,\n"c": "s"\n}\n'
    obj, items, end = _top_level(text, 0)
    assert obj == json.loads(text) and list(obj) == ["a", "b", "c"]
    assert [text[s:e] for _, s, e in items] == ['{ "x": 1.5 }', "[ 1, 2 ]", '"s"']
    assert text[:end] == text.rstrip()
    assert _top_level("{}", 0) == ({}, [], 2)
    # anything but one object read whole by the caller: a key twice, not JSON, more after it, a list
    for other in ('{"a": 1, "a": 2}', '{"a": 1,}', '{"a" 1}', '{"a": 1} 2', '[1]', '{"a": nope}'):
        assert _top_level(other, 0) is None, other


def test_a_top_level_key_written_twice_rewrites_the_whole_object():
    """The later value is the one read: a change is written as one object, without the other."""
    text = '{\n"a": 1,\n"b": 2,\n"a": 3\n}\n'
    doc = json.loads(text)
    doc["a"] = 4
    assert json.loads(splice(text, doc)) == {"a": 4, "b": 2}


def test_one_line_objects_count_their_most_keys():
    from spinemesh.json_style import _most_keys

    assert _most_keys(['{ "a": 1 }', '{ "a": 1, "b": "x:y", "c": 2 }', '{ "t": ":::::" }']) == 3
    assert _most_keys(["{ }"]) == 0

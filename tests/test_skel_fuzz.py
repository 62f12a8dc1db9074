"""Fuzzing the ``.skel`` reader with mutations of the real example files, all versions.

Whatever the bytes, :func:`read_skel` either returns a document or raises
:class:`SkelFormatError` carrying a byte offset inside the file and what was expected: no
other exception escapes. The mutation loop has a fixed seed and a time budget
(``SPINEMESH_FUZZ_SECONDS``, default 20 s for the reader, a quarter of it for the writer),
so it is repeatable and bounded. The writer is fuzzed too, with damaged JSON documents.
"""

from __future__ import annotations

import json
import os
import random
import time

import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.skeleton_binary import read_skel

from conftest import VERSIONS, skel_json_pairs, unavailable

BUDGET_S = float(os.environ.get("SPINEMESH_FUZZ_SECONDS", "20"))
#: Bytes that are boundaries of the encodings: varint continuation, sign, null/empty string.
#: Tries each fuzz loop makes even past its time budget, so that a loaded machine still tests.
MIN_TRIES = 20
SPECIAL = (0x00, 0x01, 0x02, 0x7F, 0x80, 0xFF)


def mutate(data: bytes, rng: random.Random) -> tuple[str, bytes]:
    """One random mutation of ``data``: its name and the mutated bytes."""
    n = len(data)
    kind = rng.choice(("flip", "special", "truncate", "insert", "delete", "splice", "bitflip"))
    i = rng.randrange(n)
    if kind == "flip":
        return kind, data[:i] + bytes([rng.randrange(256)]) + data[i + 1:]
    if kind == "bitflip":
        return kind, data[:i] + bytes([data[i] ^ (1 << rng.randrange(8))]) + data[i + 1:]
    if kind == "special":
        return kind, data[:i] + bytes([rng.choice(SPECIAL)]) + data[i + 1:]
    if kind == "truncate":
        return kind, data[:i]
    if kind == "insert":
        k = rng.randint(1, 8)
        return kind, data[:i] + bytes(rng.randrange(256) for _ in range(k)) + data[i:]
    if kind == "delete":
        return kind, data[:i] + data[i + rng.randint(1, 8):]
    # splice: a run of the file copied over another place of it
    j, k = rng.randrange(n), rng.randint(2, 64)
    return kind, data[:i] + data[j:j + k] + data[i + k:]


def _mutate_and_read(files: list[tuple[str, bytes]], seed: str) -> tuple[int, int, dict[str, int]]:
    """Read mutated copies of ``files`` (name, bytes) for this version's share of the time
    budget: each must read or fail with a :class:`SkelFormatError` that names the file, an
    offset within the data and what was expected. Returns how many were tried, how many
    failed, and the failures by kind of mutation."""
    rng = random.Random(seed)
    deadline = time.monotonic() + BUDGET_S / len(VERSIONS)
    tried = failed = 0
    kinds: dict[str, int] = {}
    while time.monotonic() < deadline or tried < MIN_TRIES:
        name, data = rng.choice(files)
        kind, bad = mutate(data, rng)
        tried += 1
        try:
            read_skel(bad, name)
        except SkelFormatError as e:
            failed += 1
            kinds[kind] = kinds.get(kind, 0) + 1
            assert e.offset is not None and 0 <= e.offset <= len(bad), (name, kind, e)
            assert "expected" in e.message, (name, kind, e)
            assert e.path == name, (name, kind, e)
        except Exception as e:  # pragma: no cover - the failure this test exists to find
            pytest.fail(f"{name}, {kind} mutation (seed {seed}, try {tried}): {type(e).__name__}: {e}")
    return tried, failed, kinds


@pytest.mark.parametrize("version", VERSIONS)
def test_mutations_raise_only_skel_format_error(version):
    pairs = skel_json_pairs(version)
    if not pairs:
        unavailable("../shared/spine-examples is absent")
    files = [(s.name, s.read_bytes()) for s, _ in pairs]
    tried, failed, kinds = _mutate_and_read(files, f"spinemesh-fuzz-{version}")
    assert tried >= 20, f"only {tried} mutations ran in the time budget"
    # Most mutations must be caught; a reader that accepts everything would not be tested here.
    assert failed >= tried // 4, (tried, failed, kinds)


def _seeds_43() -> list[tuple[str, bytes]]:
    """4.3 files: no editor export is available, so ours, written from the 4.3 corpus JSON
    and from a document using every 4.3 field (``skel43_features``)."""
    from skel43_features import features_document
    from spinemesh.skeleton_binary import encode_skel

    from conftest import CORPUS

    docs = [("features.skel", features_document())]
    for name in ("tmd-ar15", "tmd-npcportrait"):
        for js in sorted((CORPUS / name).glob("*.json")) if (CORPUS / name).is_dir() else []:
            if not js.name.endswith(".source.json"):
                docs.append((js.stem + ".skel", json.loads(js.read_text(encoding="utf-8-sig"))))
    return [(name, encode_skel(doc)) for name, doc in docs]


def test_mutations_raise_only_skel_format_error_43():
    """The same guarantee for 4.3, whose layout differs most (one typed constraint list,
    sliders, draw order folders)."""
    tried, failed, _ = _mutate_and_read(_seeds_43(), "spinemesh-fuzz-4.3")
    assert tried >= 20 and failed >= tried // 4, (tried, failed)


@pytest.mark.parametrize("version", VERSIONS)
def test_every_truncation_of_a_small_file(version):
    """Every prefix of the smallest file of each version fails with the end-of-file offset."""
    pairs = skel_json_pairs(version)
    if not pairs:
        unavailable("../shared/spine-examples is absent")
    name, data = min(((s.name, s.read_bytes()) for s, _ in pairs), key=lambda x: len(x[1]))
    step = max(1, len(data) // 400)
    for cut in range(0, len(data), step):
        with pytest.raises(SkelFormatError) as e:
            read_skel(data[:cut], name)
        assert e.value.offset is not None and e.value.offset <= cut


# -- the writer, on broken documents ------------------------------------------------------

JUNK = (None, "x", -1, 1e40, [], {}, True, 3.5, 0, "ffffffff", [1, 2], {"a": 1})


def _damage(doc, rng: random.Random) -> str:
    """Delete or replace one value somewhere in ``doc`` (in place); returns what was done."""
    cur, parent = doc, None
    while isinstance(cur, (dict, list)) and cur:
        key = rng.choice(list(cur)) if isinstance(cur, dict) else rng.randrange(len(cur))
        parent, cur = (cur, key), cur[key]
        if rng.random() < 0.15:
            break
    if parent is None:
        return "nothing"
    container, key = parent
    if rng.random() < 0.35:
        del container[key]
        return "delete"
    container[key] = json.loads(json.dumps(rng.choice(JUNK)))
    return "replace"


@pytest.mark.parametrize("version", ["4.0", "4.1", "4.2", "4.3"])
def test_broken_documents_raise_only_skel_format_error(version):
    """Hand-edited JSON may hold anything: the writer either writes a file that reads back,
    or raises SkelFormatError."""
    from spinemesh.skeleton_binary import encode_skel

    if version == "4.3":
        from skel43_features import features_document

        docs = [("features.json", json.dumps(features_document()))]
    else:
        pairs = skel_json_pairs(version)
        if not pairs:
            unavailable("../shared/spine-examples is absent")
        docs = [(js.name, js.read_text(encoding="utf-8")) for _, js in pairs]
    rng = random.Random(f"spinemesh-write-fuzz-{version}")
    deadline = time.monotonic() + BUDGET_S / 12
    tried = written = 0
    while time.monotonic() < deadline or tried < MIN_TRIES:
        name, text = rng.choice(docs)
        doc = json.loads(text)
        what = [_damage(doc, rng) for _ in range(rng.randint(1, 3))]
        tried += 1
        try:
            data = encode_skel(doc)
        except SkelFormatError:
            continue
        except Exception as e:  # pragma: no cover
            pytest.fail(f"{name} after {what}: write raised {type(e).__name__}: {e}")
        written += 1
        try:
            read_skel(data)
        except Exception as e:  # pragma: no cover
            pytest.fail(f"{name} after {what}: the written file does not read: {e}")
    assert tried >= 10 and written >= 1, (tried, written)

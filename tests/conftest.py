"""Shared fixtures: the real Spine data in ../shared, skipped cleanly when absent."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
EXAMPLES = SHARED / "spine-examples"
CORPUS = SHARED / "spine-corpus"
VERSIONS = ["3.6", "3.7", "3.8", "4.0", "4.1", "4.2"]


def _need(path: Path) -> Path:
    if not path.is_dir():
        pytest.skip(f"{path} is absent: real Spine data is needed for this test")
    return path


@pytest.fixture(scope="session")
def examples() -> Path:
    """``../shared/spine-examples``: official projects, 3.6 to 4.2."""
    return _need(EXAMPLES)


@pytest.fixture(scope="session")
def corpus() -> Path:
    """``../shared/spine-corpus``: 61 real game projects."""
    return _need(CORPUS)


def example_projects(version: str) -> list[Path]:
    """Project folders of one version, for parametrising (empty when data is absent)."""
    root = EXAMPLES / version
    return sorted(p for p in root.iterdir() if p.is_dir()) if root.is_dir() else []


def skel_json_pairs(version: str | None = None) -> list[tuple[Path, Path]]:
    """Every ``.skel`` with its ``.json`` twin, for one version or all."""
    out = []
    for v in ([version] if version else VERSIONS):
        for proj in example_projects(v):
            for skel in sorted(proj.glob("*.skel")):
                js = skel.with_suffix(".json")
                if js.exists():
                    out.append((skel, js))
    return out

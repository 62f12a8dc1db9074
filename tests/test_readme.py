"""The README's Python examples run as written (from a checkout's root, in order)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _python_blocks(markdown: str) -> list[str]:
    api = markdown[markdown.index("## Python API"):]
    api = api[:api.index("\n## ", 1)]
    return re.findall(r"```python\n(.*?)```", api, re.S)


def test_python_api_examples_run(tmp_path, monkeypatch, capsys):
    blocks = _python_blocks((REPO / "README.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 3
    shutil.copytree(REPO / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    printed = capsys.readouterr().out
    assert "vertices" in printed and "'meshed':" in printed and "demo-body" in printed
    assert (tmp_path / "meshed-demo" / "demo.json").is_file()
    assert (tmp_path / "demo-from-binary.json").is_file()

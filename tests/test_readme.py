"""The README's examples run as written, on the demo project (the rules of ``doc_examples``).

Its ``spinemesh`` command lines are checked against the application and run in a folder holding
copies of the demo (``project/``, ``examples/demo/``, ``library/``, ...); its Python API blocks
run in order from a checkout-like root. It stays a short front door.
"""

from __future__ import annotations

from doc_examples import REPO, examples_of, make_workspace, run_page

README = REPO / "README.md"


def test_readme_examples_run(tmp_path):
    workspace = make_workspace(tmp_path / "ws")
    ran, checked, printed = run_page(README, workspace)
    assert ran >= 8 and checked == 0
    assert "vertices," in printed and "'meshed':" in printed
    assert (workspace / "meshed-demo" / "demo.json").is_file()
    assert (workspace / "out" / "demo-preview" / "index.html").is_file()
    assert (workspace / "diff-report" / "report.md").is_file()


def test_readme_is_a_short_front_door():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 200
    commands = [e.text for e in examples_of(text) if e.kind == "command"]
    # the two set-up commands, exactly as CI runs the tests (.ci/run -> scripts/test.sh)
    assert "bash scripts/demo.sh" in text and "bash scripts/test.sh" in text
    assert "bash scripts/test.sh" in (REPO / ".ci" / "run").read_text(encoding="utf-8")
    for task in ("upgrade", "weights", "mesh", "diff", "dataset", "info", "convert"):
        assert any(c.startswith(f"spinemesh {task} ") for c in commands), task
    for page in ("getting-started", "guide/upgrade", "reference/cli", "reference/api", "benchmarks/index"):
        assert f"(docs/{page}.md)" in text, page

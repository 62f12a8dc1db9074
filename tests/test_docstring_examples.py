"""Every example in spinemesh's docstrings runs and prints what it shows (``>>>`` lines, run
by :mod:`doctest` in the module's own namespace): an example a reader copies must work.

Modules that need an extra that is not installed (the training code's torch) are skipped
outside CI; under ``CI=true`` every extra is installed, so nothing is skipped.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest
from conftest import unavailable

import spinemesh


def _modules() -> list[str]:
    return sorted(m.name for m in pkgutil.walk_packages(spinemesh.__path__, "spinemesh.")
                  if not m.name.endswith("__main__"))


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    try:
        module = importlib.import_module(name)
    except ImportError as e:  # an extra that is not installed
        unavailable(f"{name} needs {e.name}")
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(module, name) if t.examples and getattr(t, "filename", None)]
    failures = []
    for test in tests:
        if test.filename and not test.filename.startswith(spinemesh.__path__[0]):
            continue  # re-exported from elsewhere: tested there
        result = runner.run(test, out=failures.append, clear_globs=True)
        assert not result.failed, f"{test.name}:\n{''.join(failures)}"

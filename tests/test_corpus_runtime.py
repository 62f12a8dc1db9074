"""The corpus runtime proof (``scripts/prove_corpus.py``) on a representative subset.

Each case is one real skeleton from ``../shared/spine-corpus``, chosen for what trips a mesh
up, upgraded with the default options, rendered with the official runtime (setup pose, two
frames of its first animation) beside the original and compared: at most 0.1% of pixels
off by more than 2/255, no visible pixel (alpha >= 8) lost or added, the dump check passes,
and every region became a mesh. The whole corpus is proved by running the script itself.
"""

from __future__ import annotations

import importlib.util
import os
import sys

import pytest

from spinemesh.upgrade import Options

from conftest import CORPUS, REPO
from runtime_tool import install

#: skeleton -> what it covers.
CASES = {
    "dm-symbols/scatter.json": "4.1, premultiplied WebP page, 8 additive slots, regions rotated 90 degrees "
                               "with whitespace stripped; premultiplied light (alpha 0, colour > 0)",
    "bubble-fx/hop-qua/hop qua-anim.json": "3.8, glows fainter than alpha 8 stacked over each other",
    "dq-symbols/high_payout_4.json": "4.1, sequences (39 and 61 frames), additive slots, rotated regions",
}


def _prove_corpus():
    """``scripts/prove_corpus.py`` as a module (scripts/ is not a package)."""
    if "prove_corpus" not in sys.modules:
        spec = importlib.util.spec_from_file_location("prove_corpus", REPO / "scripts" / "prove_corpus.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules["prove_corpus"] = module  # dataclasses look their module up there
        spec.loader.exec_module(module)
    return sys.modules["prove_corpus"]


@pytest.fixture(scope="module")
def tool(tmp_path_factory):
    found = install(tmp_path_factory.mktemp("spine-runtime") / "tool")
    if found is None:
        if os.environ.get("CI"):
            pytest.fail("CI: Node/npm or ../shared/tools/spine-runtime is unavailable, the proof cannot run")
        pytest.skip("Node/npm or ../shared/tools/spine-runtime unavailable")
    return found


@pytest.mark.parametrize("skeleton", sorted(CASES))
def test_corpus_skeleton_renders_like_the_original(skeleton, tool, tmp_path):
    path = CORPUS / skeleton
    if not path.is_file():
        if os.environ.get("CI"):
            pytest.fail(f"CI: {path} is absent, the proof cannot run")
        pytest.skip(f"{path} is absent: real Spine data is needed for this test")
    prove = _prove_corpus()
    # Every region meshed, even where a mesh would save little (upgrade keeps those regions by
    # default), so that the renders prove meshes.
    rows = prove.prove_project(tool, path, tmp_path, animations=1, options=Options(min_saving=None))
    assert len(rows) == 1
    row = rows[0]
    print(prove.table(rows))
    assert row.status == "pass", (row.cause, row.details)
    assert row.renders >= 2
    assert row.meshed == row.regions > 0, (row.meshed, row.kept, row.regions, row.cause)

"""Shared fixtures: the real Spine data in ../shared and the official runtime tool.

A proof that cannot run is never silently a pass. Outside CI, tests that need
``../shared`` (or Node, npm, Chromium) skip with the reason; in CI (``CI=true``) the same
absence is a failure, with the reason (and a failed install's own error output) shown.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
EXAMPLES = SHARED / "spine-examples"
CORPUS = SHARED / "spine-corpus"
VERSIONS = ["3.6", "3.7", "3.8", "4.0", "4.1", "4.2"]

#: CI sets ``CI=true``: there every proof must run.
IN_CI = os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


def unavailable(reason: str) -> None:
    """A test's proof cannot run: a failure in CI, a skip with ``reason`` elsewhere."""
    if IN_CI:
        pytest.fail(f"{reason} (CI=true: a proof that cannot run fails)", pytrace=False)
    pytest.skip(reason)


def _need(path: Path) -> Path:
    if not path.is_dir():
        unavailable(f"{path} is absent: real Spine data is needed for this test")
    return path


@pytest.fixture(scope="session")
def examples() -> Path:
    """``../shared/spine-examples``: official projects, 3.6 to 4.2."""
    return _need(EXAMPLES)


@pytest.fixture(scope="session")
def corpus() -> Path:
    """``../shared/spine-corpus``: real game projects."""
    return _need(CORPUS)


@pytest.fixture(scope="session")
def spine_runtime(tmp_path_factory, examples) -> Path:
    """``../shared/tools/spine-runtime`` with its packages, installed once per test run.

    Under pytest-xdist every worker is a session of its own; they share one install
    (the first to take the lock runs ``npm ci``, the others reuse its result).
    """
    from runtime_tool import ToolUnavailable, install

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # shared by all workers of this run
    with open(root / "spine-runtime.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            return install(root / "spine-runtime")
        except ToolUnavailable as e:
            unavailable(str(e))


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


#: Test files whose cases are spread one by one over pytest-xdist workers: they hold the
#: slow runtime proofs and build nothing per module. Every other file stays on one worker,
#: so that its module and session fixtures are built once.
SPREAD = {"test_upgrade_runtime", "test_weights_runtime", "test_pack_runtime"}


def pytest_collection_modifyitems(config, items):
    if not config.pluginmanager.hasplugin("xdist"):
        return
    for item in items:
        module = item.module.__name__ if item.module is not None else ""
        if module not in SPREAD:
            item.add_marker(pytest.mark.xdist_group(module or item.nodeid.split("::")[0]))


def memory_files_left() -> list[str]:
    """This process's mappings and open descriptors of anonymous memory files (Linux ``memfd``),
    after a garbage collection: what pages decoded by workers leave behind (nothing, once dropped)."""
    import gc

    gc.collect()
    maps = [line for line in Path("/proc/self/maps").read_text().splitlines() if "memfd:" in line]
    fds = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            link = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:  # the descriptor listdir itself held
            continue
        if "memfd:" in link:
            fds.append(link)
    return maps + fds


def shared_memory_segments() -> set[str]:
    """Named shared memory (``/dev/shm``) but multiprocessing's semaphores (``sem.*``), which the
    locks of every process make and remove, the other test workers running beside this one too."""
    return {name for name in os.listdir("/dev/shm") if not name.startswith("sem.")}


@pytest.fixture(scope="module")
def meshed(tmp_path_factory) -> Path:
    """The demo project upgraded with every region kept a mesh (``min_saving=None``), one per
    test module: what the packing tests pack, move and crop."""
    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import Options, upgrade_project

    base = tmp_path_factory.mktemp("meshed")
    demo = make_demo_project(base / "demo", with_images_folder=False)
    out = base / "meshed"
    upgrade_project(demo, out, Options(min_saving=None, jobs=1))
    return out


@pytest.fixture()
def trimmed_project(tmp_path):
    """The demo sprites packed with every frame of the spark sequence trimmed to its own art
    (frames of growing size, one rotated), drawn by the demo skeleton: a project for ``--repack``."""
    import json

    from spinemesh.demo import demo_images, demo_skeleton, pack_atlas
    from spinemesh.files.atomic import atomic_write_png, atomic_write_text

    images = demo_images()
    text, page = pack_atlas(images, "demo.png", rotate={"demo-arm", "demo-spark/frame2"})
    folder = tmp_path / "project"
    atomic_write_text(folder / "demo.atlas", text)
    atomic_write_png(folder / "demo.png", page)
    atomic_write_text(folder / "demo.json", json.dumps(demo_skeleton(images), indent=1))
    return folder


# --- the data are read, never written -------------------------------------------------------------

def _data_files() -> set[str]:
    """Every file and folder under the real data (none when it is absent)."""
    out: set[str] = set()
    for root in (EXAMPLES, CORPUS):
        for folder, dirs, files in os.walk(root):
            out.update(os.path.join(folder, n) for n in dirs + files)
    return out


def pytest_sessionstart(session):
    if not hasattr(session.config, "workerinput"):  # the controller (or the only process) looks once
        session.config._data_before = _data_files()


def pytest_sessionfinish(session, exitstatus):
    """A test that writes beside the data (a dump next to a corpus skeleton) fails the run: the next
    test reading that folder would take the file for the project's own."""
    before = getattr(session.config, "_data_before", None)
    if before is None:
        return
    added = sorted(_data_files() - before)
    if added:
        session.config.get_terminal_writer().line(
            f"tests wrote {len(added)} files into the real data, e.g. {', '.join(added[:3])}", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED

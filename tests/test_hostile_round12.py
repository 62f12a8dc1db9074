"""Hostile round twelve, first part: the process a command runs as.

Round eleven attacked the environment a command is handed; this one attacks the process itself, as a
build system, a CI job or an impatient user treats it: Ctrl-C the moment it starts, SIGTERM and SIGHUP
in the middle of a run over workers, a umask or a disk that refuses the output, standard output
closed, a worker pool the system refuses a process. Every project is made here by our own code
(``twenty``: the demo with twenty skeletons); each case runs ``python -m spinemesh`` in a subprocess
and checks what docs/safety.md promises.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_hostile_round11b import _as_a_user, _env, _no_traceback, _one_error, twenty  # noqa: F401 (a fixture)

REPO = Path(__file__).resolve().parents[1]


# --- Ctrl-C the moment a command starts -------------------------------------------------------------

#: Run the command line as ``python -m spinemesh`` does, after a finder that sends this process
#: SIGINT when the module named in ``argv[1]`` is first looked for: a Ctrl-C at that very moment
#: of the start-up, whatever the machine's speed.
_INTERRUPTED_AT_IMPORT = """
import os, runpy, signal, sys
AT = sys.argv[1]
class Interrupt:
    def find_spec(self, name, path=None, target=None):
        if name == AT:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, Interrupt())
sys.argv = ["spinemesh", *sys.argv[2:]]
runpy.run_module("spinemesh", run_name="__main__", alter_sys=True)
"""


@pytest.mark.parametrize("module", ["spinemesh.cli", "spinemesh.processes", "spinemesh.errors"])
def test_ctrl_c_while_the_command_is_imported_ends_quietly(tmp_path, twenty, module):  # noqa: F811
    """Ctrl-C in the first ~50 ms of a command, while its modules were imported (before the run's own
    handler was in place): a Python traceback of a dozen frames, exit 1 or killed by SIGINT. It ends
    as a Ctrl-C a moment later does: exit 130, nothing printed."""
    r = subprocess.run([sys.executable, "-c", _INTERRUPTED_AT_IMPORT, module, "info", str(twenty)], cwd=tmp_path,
                       env=_env(), capture_output=True, timeout=120, check=False)
    assert r.returncode == 130 and r.stderr == b"" and r.stdout == b"", (r.returncode, r.stderr.decode()[-2000:])


# --- an output the system refuses: umask 777, a full disk ---------------------------------------------

#: One run of each command that writes into a folder it makes: (arguments, the output folder).
MAKING_FOLDERS = {
    "upgrade": (("upgrade", "p", "--out", "o/up"), "o"),
    "upgrade --preview": (("upgrade", "p", "--out", "o/up", "--preview", "o/pv"), "o"),
    "pack": (("pack", "p", "--out", "o"), "o"),
    "weights": (("weights", "p", "--out", "o"), "o"),
    "mesh DIR": (("mesh", "p", "--out", "o"), "o"),
    "mesh": (("mesh", "p/demo.png", "--out", "o/m.json"), "o"),
    "dataset": (("dataset", "p", "--out", "o"), "o"),
    "convert": (("convert", "p/demo.json", "o/x.skel"), "o"),
    "pose": (("pose", "p/demo.json", "--out", "o/pose.json"), "o"),
    "segment": (("segment", "p/demo.png", "--out", "o/mask.png"), "o"),
}


def _run_limited(args, cwd: Path, umask: int | None = None, file_size: int | None = None,
                 prefix: list[str] = ()) -> subprocess.CompletedProcess:
    """``python -m spinemesh ARGS`` under ``umask`` and a largest file of ``file_size`` bytes
    (``ulimit -f``: a write past it fails with EFBIG, as on a full disk with ENOSPC)."""
    import resource

    def limits():
        if umask is not None:
            os.umask(umask)
        if file_size is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size, file_size))

    return subprocess.run([*prefix, sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=_env(),
                          capture_output=True, timeout=180, check=False, preexec_fn=limits)


@pytest.fixture()
def project_in(tmp_path, twenty):  # noqa: F811
    """``tmp_path/p``: a copy of ``twenty`` with its demo page beside it (``mesh``, ``segment``)."""
    shutil.copytree(twenty, tmp_path / "p")
    return tmp_path


@pytest.mark.skipif(sys.platform != "linux", reason="umask and permissions as Linux reads them")
@pytest.mark.parametrize("command", list(MAKING_FOLDERS))
def test_umask_777_leaves_no_empty_output_folder(project_in, command):
    """``umask 777`` (a misconfigured service account): every command made its output folder (mode
    000), could not write in it, and left it behind, empty, with ``error: o: Permission denied`` or a
    line naming a temporary file (``o/.x.skel.0afae324.tmp: Permission denied``: the cleanup's error
    in place of the write's). One line names the output and the umask; no folder is left."""
    args, out = MAKING_FOLDERS[command]
    r = _run_limited(args, project_in, umask=0o777, prefix=_as_a_user())
    line = _one_error(r)
    assert "cannot write: permission denied: the umask (0777)" in line and ".tmp" not in line, line
    assert not (project_in / out).exists() and not os.path.lexists(project_in / out), line


@pytest.mark.skipif(sys.platform != "linux", reason="the file size limit as Linux applies it")
@pytest.mark.parametrize("command", list(MAKING_FOLDERS))
def test_a_full_disk_leaves_no_empty_output_folder(project_in, command):
    """A disk with no room (``ulimit -f``: no byte may be written): every command ended in one line
    (exit 2) and left its output folder behind, empty. It is removed."""
    args, out = MAKING_FOLDERS[command]
    r = _run_limited(args, project_in, file_size=1)
    line = _one_error(r)
    assert "cannot write: File too large" in line, line
    assert not (project_in / out).exists(), sorted(p.name for p in (project_in / out).rglob("*"))


@pytest.mark.skipif(sys.platform != "linux", reason="the file size limit as Linux applies it")
@pytest.mark.parametrize("command", ["upgrade", "pack", "weights"])
def test_a_disk_that_fills_leaves_no_folder_of_a_marker(project_in, command):
    """A disk that fills as the run writes (room for the folder's marker, none for a skeleton or a
    page): the run said each file it could not write (exit 3) and left OUT holding only its marker,
    listing nothing. Nothing of the run is left."""
    r = _run_limited((command, "p", "--out", "o"), project_in, file_size=1000)
    text = _no_traceback(r)
    assert r.returncode == 3 and "cannot write: File too large" in text, text[-2000:]
    assert not (project_in / "o").exists(), sorted(p.name for p in (project_in / "o").rglob("*"))


def test_mesh_of_a_folder_draws_no_bar_into_a_log(project_in):
    """``mesh DIR 2> build.log``: its bar, alone of every command's, was drawn into the log at its end
    (a line of 300 bar characters); a log gets none, as from the others."""
    r = _run_limited(("mesh", "p", "--out", "o"), project_in)
    assert r.returncode == 0 and r.stderr == b"", r.stderr[-500:]


# --- a closed standard output: one rule for every command ----------------------------------------------

def _closed_stdout(*args, cwd: Path) -> subprocess.CompletedProcess:
    """``spinemesh ARGS >&-`` (a daemon, a service that closes its standard output)."""
    return subprocess.run(["sh", "-c", 'exec "$@" >&-', "sh", sys.executable, "-m", "spinemesh", *map(str, args)],
                          cwd=cwd, env=_env(), capture_output=True, timeout=180, check=False)


@pytest.fixture(scope="module")
def data_set(tmp_path_factory, twenty):  # noqa: F811
    """A data set built from ``twenty`` (``dataset``)."""
    where = tmp_path_factory.mktemp("ds")
    r = subprocess.run([sys.executable, "-m", "spinemesh", "dataset", str(twenty), "--out", "ds"], cwd=where,
                       env=_env(), capture_output=True, timeout=180, check=False)
    assert r.returncode == 0, r.stderr[-2000:]
    return where / "ds"


#: Commands whose standard output is all they make, refused when it is closed: what the line names.
ALL_ON_STANDARD_OUTPUT = {
    "dataset-stats": (("dataset-stats", "{ds}"), "the counts"),
    "segment-eval": (("segment-eval", "--data", "{ds}"), "the scores"),
    "--version": (("--version",), "the version"),
}


@pytest.mark.parametrize("command", list(ALL_ON_STANDARD_OUTPUT))
def test_a_closed_standard_output_is_refused_where_it_is_all_a_command_makes(tmp_path, data_set, command):
    """``dataset-stats`` (its counts, which no plot holds), ``segment-eval`` without ``--json`` or
    ``--card`` (its scores) and ``--version`` wrote their one product to a closed standard output:
    exit 0 with a warning, or in silence. Refused as ``info`` and ``pose`` are, before any work."""
    args, product = ALL_ON_STANDARD_OUTPUT[command]
    r = _closed_stdout(*(a.format(ds=data_set) for a in args), cwd=tmp_path)
    line = _one_error(r)
    assert line == f"error: standard output is closed: {product} would go nowhere; give it a file (> FILE)", line


@pytest.mark.parametrize("plain", [True, False], ids=["plain", "typer"])
def test_convert_to_a_closed_standard_output_says_its_line_is_not_written(tmp_path, twenty, plain):  # noqa: F811
    """``convert`` with standard output closed dropped its ``wrote ...`` line in silence (exit 0), on
    both of its paths (plain, and parsed by typer); its file is what it makes: it is written, and the
    run says once that its words are not, as every command making files does."""
    extra = () if plain else ("--",)  # `--` sends it to typer
    r = _closed_stdout("convert", twenty / "demo.json", "c.skel", *extra, cwd=tmp_path)
    text = _no_traceback(r)
    assert r.returncode == 0 and (tmp_path / "c.skel").stat().st_size > 0, text
    assert text.count("warning: standard output is closed: this command's table is not written (its files are)") == 1, text


# --- a worker the system refuses once ------------------------------------------------------------------

def test_a_worker_refused_once_is_started_when_the_system_allows(monkeypatch):
    """One start refused (``ulimit -n`` reached for a moment, while a stage held files open): the pool
    ran the rest of the run on the workers it had, one of ``--jobs 3`` here, however many
    descriptors were freed. It tries again a moment later (``START_RETRY_SECONDS``) and runs on three."""
    import errno
    import time

    from spinemesh.cluster import ProcessWorkers

    starts = []
    real_start = ProcessWorkers._start_worker

    def second_refused_once(self):
        starts.append(True)
        if len(starts) == 2:
            raise OSError(errno.EMFILE, "Too many open files")
        return real_start(self)

    monkeypatch.setattr(ProcessWorkers, "_start_worker", second_refused_once)
    most = 0
    with ProcessWorkers(3) as w:
        futures = [w.submit(time.sleep, 0.2) for _ in range(10 * 3)]
        deadline = time.monotonic() + 60
        while not all(f.done() for f in futures) and time.monotonic() < deadline:
            most = max(most, len(w.pids))
            time.sleep(0.02)
        assert all(f.done() and f.exception() is None for f in futures)
    assert most == 3, most


# --- two runs into one OUT ---------------------------------------------------------------------------

@pytest.mark.skipif(sys.platform == "win32", reason="flock: POSIX")
def test_a_run_waiting_for_out_locks_the_folder_its_files_go_to(tmp_path):
    """Two ``upgrade`` runs into one new OUT: the second waits for the first's lock. The first fails
    (Ctrl-C before it wrote anything) and removes the folder it made; the second then held the lock
    of that folder, gone, while its files went into a new one of the same name, unlocked (a third
    run could enter it). It locks the folder its files go to."""
    import fcntl
    import threading
    import time

    from spinemesh.output import output_folder

    out = tmp_path / "o"
    out.mkdir()
    first = os.open(out, os.O_RDONLY)
    fcntl.flock(first, fcntl.LOCK_EX)
    locked = []

    def second():
        with output_folder(out, overwrite=False):
            probe = os.open(out, os.O_RDONLY)
            try:
                fcntl.flock(probe, fcntl.LOCK_EX | fcntl.LOCK_NB)
                locked.append(False)
            except BlockingIOError:
                locked.append(True)
            finally:
                os.close(probe)

    waiting = threading.Thread(target=second)
    waiting.start()
    time.sleep(0.5)
    os.rmdir(out)  # the first run ends, failed: the folder it made goes, empty
    os.close(first)
    waiting.join(30)
    assert locked == [True]


def test_a_failed_run_leaves_the_folder_another_run_holds(tmp_path):
    """The first of two runs into one new OUT fails as the second takes the folder over (its running
    marker written, nothing else yet): the first's cleanup removed that marker and the folder under
    the second. A folder whose marker says a run holds it is kept."""
    from spinemesh.files.atomic import make_folder
    from spinemesh.written_folder import OUTPUT_MARKER, remove_made_folders_left_empty, write_marker

    out = make_folder(tmp_path / "o")  # made by this process: the failed run
    write_marker(out, OUTPUT_MARKER, "output folder", {"running": True, "kept": [], "folder": [1, 2]})
    remove_made_folders_left_empty()
    assert (out / OUTPUT_MARKER).is_file()


@pytest.mark.parametrize("command", ["upgrade", "mesh DIR"])
def test_an_output_below_a_file_names_the_file(project_in, command):
    """``--out build/x`` where ``build`` is a file: ``upgrade`` and ``mesh DIR`` said ``build/x:
    cannot write: Not a directory``; ``convert`` and ``pose`` named the file in the way. Every
    command names it, in the same words."""
    (project_in / "build").write_text("a file")
    args = {"upgrade": ("upgrade", "p"), "mesh DIR": ("mesh", "p")}[command]
    line = _one_error(_run_limited((*args, "--out", "build/x/y"), project_in))
    assert line == "error: build: cannot create folder: a file of that name exists", line


# --- a home of its own ---------------------------------------------------------------------------------

def test_dataset_stats_writes_nothing_at_home(tmp_path, data_set):
    """``dataset-stats``: matplotlib, which draws its plots, made ``~/.config/matplotlib`` and
    ``~/.cache/matplotlib`` (its font list) in the user's home, where no other command writes, and
    where home is read-only printed four lines of warning. Nothing is made at home."""
    pytest.importorskip("matplotlib")
    home = tmp_path / "home"
    home.mkdir()
    env = _env(HOME=str(home))
    for name in ("MPLCONFIGDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME"):
        env.pop(name, None)
    r = subprocess.run([sys.executable, "-m", "spinemesh", "dataset-stats", str(data_set), "--plots", "plots"],
                       cwd=tmp_path, env=env, capture_output=True, timeout=180, check=False)
    assert r.returncode == 0 and r.stderr == b"", r.stderr[-2000:]
    assert len(list((tmp_path / "plots").glob("*.png"))) == 4 and list(home.iterdir()) == []


# --- a disk that fills mid-run: said once, the run ended there -------------------------------------------

#: Runs that write many files into OUT: their arguments (``lib``: a library of three projects).
FILLING = {
    "upgrade": ("upgrade", "p", "--out", "o"),
    "upgrade --pack": ("upgrade", "p", "--out", "o", "--pack"),
    "pack": ("pack", "p", "--out", "o"),
    "weights": ("weights", "p", "--out", "o"),
    "upgrade LIBRARY": ("upgrade", "lib", "--out", "o"),
    "mesh DIR": ("mesh", "lib", "--out", "o"),
}


@pytest.mark.skipif(sys.platform != "linux", reason="the file size limit as Linux applies it")
@pytest.mark.parametrize("command", list(FILLING))
def test_a_disk_that_fills_is_said_once_and_ends_the_run(project_in, command):
    """A disk that fills as the run writes (``ulimit -f``: room for the folder's marker, none for a
    skeleton): one ``cannot write`` line per skeleton and per file copied, 23 lines for twenty
    skeletons and hundreds for a library, each run on to the end. A refusal that holds for every later
    write (full, size limit, read-only, quota) is said once, naming the file and the condition, and the
    run ends there (exit 3); no temporary file, no atlas without its page."""
    library = project_in / "lib"
    for name in ("a", "b", "c"):
        shutil.copytree(project_in / "p", library / name)
    r = _run_limited(FILLING[command], project_in, file_size=1000)
    text = _no_traceback(r)
    lines = [line for line in text.splitlines() if line.startswith("error:")]
    assert r.returncode == 3 and len(lines) == 1 and "skipped:" not in text, text[-3000:]
    assert "o/" in lines[0] and "cannot write: File too large" in lines[0] and "the run stopped" in lines[0], lines
    left = [p for p in project_in.rglob("*") if p.is_file()]
    assert not [p for p in left if p.name.endswith(".tmp")], left
    for atlas in (p for p in left if p.suffix == ".atlas" and "o" in p.relative_to(project_in).parts[:1]):
        assert (atlas.parent / "demo.png").exists(), sorted(map(str, left))


def test_a_page_cut_short_mid_run_is_said_of_the_input(tmp_path, monkeypatch):
    """A page the export replaced or cut short after the upgrade read it, before its copy into OUT:
    ``upgrade --pack`` decoded the copy and said ``o/demo.png: cannot decode image``, a file of its
    own output the user cannot fix. It names the project's page, which the copy's bytes came from."""
    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import write
    from spinemesh.upgrade.options import Options
    from spinemesh.upgrade.run import upgrade_project

    make_demo_project(tmp_path / "p", with_images_folder=False)
    copy = write.atomic_copy

    def cut_short_first(source, dest):  # the half-written export a game's build replaces it with
        if Path(source).suffix == ".png":
            Path(source).write_bytes(Path(source).read_bytes()[:100])
        return copy(source, dest)

    monkeypatch.setattr(write, "atomic_copy", cut_short_first)
    monkeypatch.chdir(tmp_path)
    result = upgrade_project(Path("p"), Path("o"), Options(pack=True))
    (row,) = result.atlases
    assert row.status == "failed" and row.reason.startswith("p/demo.png: cannot decode image"), row.reason
    assert any(line.startswith("demo.atlas: not packed: p/demo.png: cannot decode image") for line in result.errors), \
        result.errors

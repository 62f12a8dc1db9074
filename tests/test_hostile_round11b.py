"""Hostile round eleven, second half: the environment a command runs in.

Ten rounds attacked the files; this one attacks what build servers, CI runners, Windows shells and
Docker images hand a command besides its arguments: the console's encoding, its width, standard
streams that are full or closed, the temporary folder, the umask, a current folder removed, an
output on another file system. Every project is made here by our own code; each case runs
``python -m spinemesh`` in a subprocess with that environment and checks what docs/safety.md
promises: one clear line naming the file, never a traceback, the run's work never stopped by its
words, inputs unchanged.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import unavailable
from test_hostile import snapshot

REPO = Path(__file__).resolve().parents[1]

#: A word no 8-bit code page writes whole (``é`` is latin-1, the snowman is not).
WORD = "démo☃"


def _env(**extra: str) -> dict[str, str]:
    # No empty PYTHONPATH entry: Python reads one as the current folder and cannot even start
    # where that folder is gone (test_a_current_folder_removed_is_named).
    env = {**os.environ, "COLUMNS": "100", "NO_COLOR": "1", "OMP_NUM_THREADS": "1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}
    for name in ("PYTHONIOENCODING", "FORCE_COLOR", "TTY_COMPATIBLE", "TTY_INTERACTIVE"):
        env.pop(name, None)
    env.update(extra)
    return env


def _run(*args, cwd: Path, env: dict | None = None, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
         umask: int | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    """``python -m spinemesh ARGS`` with the environment and standard streams given; bytes out."""
    return subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=env or _env(),
                          stdout=stdout, stderr=stderr, timeout=timeout, check=False,
                          preexec_fn=(lambda: os.umask(umask)) if umask is not None else None)


def _no_traceback(r: subprocess.CompletedProcess) -> str:
    text = (r.stdout or b"").decode("utf-8", "replace") + (r.stderr or b"").decode("utf-8", "replace")
    assert "Traceback" not in text and "Exception ignored" not in text, text[-3000:]
    return text


def _one_error(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr)
    text = _no_traceback(r)
    lines = [line for line in text.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, text
    return lines[0]


@pytest.fixture(scope="module")
def named(tmp_path_factory) -> Path:
    """The demo project with every name non-ASCII: its folder, files, regions, slots and animation."""
    from spinemesh.demo import demo_images, demo_skeleton, pack_atlas
    from spinemesh.files.atomic import atomic_write_png, atomic_write_text

    folder = tmp_path_factory.mktemp("env") / "projé"
    images = {k.replace("demo", WORD): v for k, v in demo_images().items()}
    atlas, page = pack_atlas(images, f"{WORD}.png", keep_whitespace=(f"{WORD}-spark/",))
    atomic_write_text(folder / f"{WORD}.atlas", atlas)
    atomic_write_png(folder / f"{WORD}.png", page)
    doc = json.loads(json.dumps(demo_skeleton(demo_images())).replace("demo", WORD))
    doc["animations"] = {"vague☃": doc["animations"]["wave"]}
    atomic_write_text(folder / f"{WORD}.json", json.dumps(doc, ensure_ascii=False))
    return folder


@pytest.fixture(scope="module")
def twenty(tmp_path_factory) -> Path:
    """The demo project with twenty skeletons on its one atlas."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path_factory.mktemp("env") / "p20", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    for k in range(19):
        shutil.copy(project / "demo.json", project / f"demo{k:02d}.json")
    return project


# --- the console's encoding -------------------------------------------------------------------------

@pytest.mark.parametrize("encoding", ["ascii", "latin-1"])
def test_names_the_console_cannot_encode_are_escaped(tmp_path, named, encoding):
    """``PYTHONIOENCODING=ascii`` (or latin-1: a Windows code page, a Docker image's locale) with a
    project named ``projé/démo☃``: every command's table on standard output ended in a
    UnicodeEncodeError traceback, exit 1, after its files were written. Names the console cannot
    write are written as Python escapes, as standard error writes them."""
    before = snapshot(named)
    env = _env(PYTHONIOENCODING=encoding)
    skeleton = named / f"{WORD}.json"
    runs = {
        "upgrade": ("upgrade", named, "--out", "up", "--pack", "--weights", "auto", "--preview", "prev"),
        "info": ("info", named),
        "mesh": ("mesh", named / f"{WORD}.png", "--out", "m.json"),
        "convert": ("convert", skeleton, "c.skel"),
    }
    if encoding == "ascii":  # the other commands print through the same console
        runs |= {"pack": ("pack", named, "--out", "pk"), "weights": ("weights", "up", "--out", "w")}
    shown = {}
    for name, args in runs.items():
        r = _run(*args, cwd=tmp_path, env=env)
        text = _no_traceback(r)
        assert r.returncode == 0, (name, text[-2000:])
        shown[name] = r.stdout.decode(encoding)  # all of it in the console's encoding
    assert ("d\\xe9mo\\u2603" if encoding == "ascii" else "démo\\u2603") in shown["upgrade"], shown["upgrade"]
    assert snapshot(named) == before


def test_pose_writes_utf8_json_whatever_the_console_encoding(tmp_path, named):
    """``pose`` to standard output with an ASCII console: its JSON (names ``démo☃``, ``vague☃``)
    ended in a traceback; it is UTF-8 bytes, what JSON is, and the same bytes as ``--out``."""
    args = ("pose", named / f"{WORD}.json", "-a", "vague☃", "--times", "0,0.5")
    r = _run(*args, cwd=tmp_path, env=_env(PYTHONIOENCODING="ascii"))
    _no_traceback(r)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout.decode("utf-8"))
    assert doc["input"]["skeleton"] == f"{WORD}.json" and len(doc["poses"]) == 3
    assert _run(*args, "--out", "pose.json", cwd=tmp_path).returncode == 0
    assert (tmp_path / "pose.json").read_bytes() == r.stdout


@pytest.mark.parametrize("locale", ["C", "POSIX"])
def test_the_c_locale_reads_and_writes_non_ascii_names(tmp_path, named, locale):
    """``LANG=C``/``LC_ALL=C`` (a bare Docker image): Python reads file names as UTF-8 there, so a
    project of non-ASCII names upgrades, whole, as in a UTF-8 locale."""
    env = _env(LC_ALL=locale, LANG=locale)
    env.pop("PYTHONUTF8", None)
    r = _run("upgrade", named, "--out", "up", "--pack", cwd=tmp_path, env=env)
    _no_traceback(r)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "up" / f"{WORD}.json").is_file() and (tmp_path / "up" / f"{WORD}.atlas").is_file()


@pytest.mark.skipif(sys.platform != "linux", reason="file names in the locale's encoding: a POSIX system's")
def test_a_locale_whose_file_names_cannot_hold_a_projects_names(tmp_path, named):
    """The C locale with UTF-8 mode turned off (``PYTHONUTF8=0 PYTHONCOERCECLOCALE=0``, as a
    non-UTF-8 locale such as latin-1 does to letters outside it): Python's file names are ASCII
    there, and the atlas's page ``démo☃.png`` ended ``upgrade``, ``pack``, ``info`` and ``pose``
    in a UnicodeEncodeError traceback. One line names the file and the way out."""
    env = _env(LC_ALL="C", LANG="C", PYTHONUTF8="0", PYTHONCOERCECLOCALE="0")
    before = snapshot(named)
    for args in (("upgrade", named, "--out", "up"), ("pack", named, "--out", "pk"), ("info", named),
                 ("pose", named / f"{WORD}.json")):
        r = _run(*args, cwd=tmp_path, env=env)
        line = _one_error(r)
        assert "mo\\u2603.png: this name cannot be a file name here" in line and "PYTHONUTF8=1" in line, line
    assert snapshot(named) == before
    assert not (tmp_path / "up").exists() or not any((tmp_path / "up").glob("*.json"))


# --- the console's width ----------------------------------------------------------------------------

def test_a_width_of_zero_columns_still_prints_the_table_and_the_errors(tmp_path, twenty):
    """``COLUMNS=0`` (set by build servers that have no terminal): rich drew at width 0 and
    nothing came out, neither ``upgrade``'s table nor an error line, the run exiting 2 in
    silence. It is taken as no width given; a width too narrow for a number is widened."""
    r = _run("upgrade", tmp_path / "missing", "--out", "x", cwd=tmp_path, env=_env(COLUMNS="0"))
    assert "missing: no such file or folder" in _one_error(r)
    r = _run("upgrade", twenty, "--out", "up", cwd=tmp_path, env=_env(COLUMNS="0"))
    out = r.stdout.decode()
    assert r.returncode == 0 and "demo07.json" in out and "kept as region" in out, out
    for columns in ("1", "10"):
        r = _run("upgrade", twenty, "--out", f"up{columns}", cwd=tmp_path, env=_env(COLUMNS=columns))
        rows = [line for line in r.stdout.decode().splitlines() if line.startswith("│")]
        assert r.returncode == 0 and len(rows) == 20 and all("19" in row for row in rows), r.stdout.decode()


@pytest.mark.parametrize("columns", ["100000", "-5", "abc"])
def test_odd_widths_print_the_table_whole(tmp_path, twenty, columns):
    """A huge or unreadable ``COLUMNS`` prints the table as at 80 columns or wider, one row a
    skeleton."""
    r = _run("upgrade", twenty, "--out", "up", cwd=tmp_path, env=_env(COLUMNS=columns))
    rows = [line for line in r.stdout.decode().splitlines() if line.startswith("│")]
    assert r.returncode == 0 and len(rows) == 20, r.stdout.decode()


def test_bars_never_flood_a_log(tmp_path, twenty):
    """Standard error that is no terminal (a CI log): ``upgrade --pack --preview`` of twenty
    skeletons writes no progress bar there, not one byte (rich draws bars on terminals only)."""
    r = _run("upgrade", twenty, "--out", "up", "--pack", "--preview", "prev", "--jobs", "2", cwd=tmp_path,
             env=_env(TERM="dumb"))
    assert r.returncode == 0 and r.stderr == b"", r.stderr[-2000:]


# --- standard streams full, closed, cut -------------------------------------------------------------

def _files(folder: Path) -> set[str]:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full on this system")
def test_a_full_log_never_stops_the_run(tmp_path, twenty):
    """Standard error on a full disk (``2> build.log`` on a build server whose disk filled): the
    first progress bar's end raised, and the run stopped there, exit 1, the preview and the table
    never written. Words that cannot be written are dropped: the run is whole, exit 0, its files
    those of a run with a log; a run that fails still exits 2."""
    args = ("--pack", "--weights", "auto", "--preview")
    ok = _run("upgrade", twenty, "--out", "a", *args, "pa", cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
    with open("/dev/full", "wb") as full:
        r = _run("upgrade", twenty, "--out", "b", *args, "pb", cwd=tmp_path, stderr=full)
        assert r.returncode == 0 and b"demo07.json" in r.stdout
        assert _files(tmp_path / "b") == _files(tmp_path / "a") and _files(tmp_path / "pb") == _files(tmp_path / "pa")
        assert _run("upgrade", tmp_path / "missing", "--out", "x", cwd=tmp_path, stderr=full).returncode == 2


def test_a_log_pipe_its_reader_closed_never_stops_the_run(tmp_path, twenty):
    """``2>&1 | tee log`` where the reader of standard error is gone: the same, as a closed pipe."""
    read, write = os.pipe()
    os.close(read)
    try:
        r = _run("upgrade", twenty, "--out", "b", "--pack", "--preview", "pb", cwd=tmp_path, stderr=write)
    finally:
        os.close(write)
    assert r.returncode == 0 and b"demo07.json" in r.stdout
    assert (tmp_path / "pb" / "index.html").is_file() and len(list((tmp_path / "b").glob("*.json"))) == 20


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full on this system")
@pytest.mark.parametrize("command", ["info", "upgrade"])
def test_a_full_standard_output_is_named(tmp_path, twenty, command):
    """Standard output on a full disk said only ``error: No space left on device``; it names
    standard output, as ``pose`` does. (``upgrade``'s files are written before its table.)"""
    args = ("info", twenty) if command == "info" else ("upgrade", twenty, "--out", "up")
    with open("/dev/full", "wb") as full:
        r = _run(*args, cwd=tmp_path, stdout=full)
    assert "standard output: cannot write: No space left on device" in _one_error(r)


@pytest.mark.skipif(sys.platform != "linux", reason="the file behind standard output is named on Linux")
@pytest.mark.parametrize("command", ["upgrade", "info", "pack", "weights", "convert", "mesh", "dataset", "diff"])
def test_standard_output_redirected_into_the_project_is_refused(tmp_path, command):
    """``spinemesh upgrade hero/ --out out/ >> hero/hero.json``: every command but ``pose``
    appended its table to the skeleton (exit 0), changing its input; ``> hero/log.txt`` wrote
    inside it. Standard output redirected into an input is refused as such an output file is,
    before any work, in one line naming it."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    before = snapshot(project)
    args = {"upgrade": ("upgrade", "p", "--out", "o"), "info": ("info", "p"), "pack": ("pack", "p", "--out", "o"),
            "weights": ("weights", "p", "--out", "o"), "convert": ("convert", "p/demo-binary.skel", "o.json"),
            "mesh": ("mesh", "p", "--out", "o"), "dataset": ("dataset", "p", "--out", "o"),
            "diff": ("diff", "p/demo.json", "p/demo-binary.skel", "--out", "o")}[command]
    target = project / ("demo-binary.skel" if command == "convert" else "demo.json")
    with open(target, "ab") as appended:
        r = _run(*args, cwd=tmp_path, stdout=appended)
    line = _one_error(r)
    assert f"{target}: standard output " in line and "input" in line, line
    assert snapshot(project) == before and not (tmp_path / "o").exists() and not (tmp_path / "o.json").exists()


def test_standard_output_cut_by_its_reader_ends_quietly(tmp_path, twenty):
    """``spinemesh info PROJECT | head -1``: the run ends at its next write, status 1, no traceback."""
    run = subprocess.Popen([sys.executable, "-m", "spinemesh", "upgrade", str(twenty), "--out", "up"], cwd=tmp_path,
                           env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    run.stdout.close()
    stderr = run.stderr.read().decode()
    assert run.wait(120) in (0, 1) and "Traceback" not in stderr and "Exception" not in stderr, stderr
    assert len(list((tmp_path / "up").glob("*.json"))) == 20


def test_closed_standard_input_and_output(tmp_path, twenty):
    """Standard input closed (``<&-``, a daemon), and standard output closed: the run is whole."""
    r = subprocess.run(["sh", "-c", 'exec "$@" <&- >&-', "sh", sys.executable, "-m", "spinemesh", "upgrade",
                        str(twenty), "--out", "up", "--pack"], cwd=tmp_path, env=_env(), capture_output=True,
                       timeout=120, check=False)
    _no_traceback(r)
    assert r.returncode == 0 and len(list((tmp_path / "up").glob("*.json"))) == 20


# --- files the user running it may not read --------------------------------------------------------

def _as_a_user() -> list[str]:
    """The command prefix that runs as a user whom file modes bind: none for one; for root, the
    capabilities that pass over them dropped (``setpriv``), or a skip where that cannot be done."""
    if os.geteuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    if setpriv is None or subprocess.run([setpriv, "--bounding-set", "-dac_override", "true"],
                                         capture_output=True, check=False).returncode != 0:
        pytest.skip("running as root, with no way to drop the capabilities that pass over file modes")
    return [setpriv, "--bounding-set", "-dac_override,-dac_read_search,-fowner"]


def _run_as_a_user(*args, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*_as_a_user(), sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=_env(),
                          capture_output=True, timeout=120, check=False)


def test_a_skeleton_the_user_may_not_read_is_that_skeletons_line(tmp_path, twenty):
    """One skeleton of twenty the user may not read (mode 000: copied from another account, a
    build cache): project discovery opened it and the ``PermissionError`` ended ``upgrade``,
    ``info``, ``pack`` and ``weights`` on the whole project (exit 2, nothing written). It is that
    skeleton's line now, as a broken one is, and the other nineteen are written (exit 3)."""
    project = tmp_path / "p"
    shutil.copytree(twenty, project)
    (project / "demo05.json").chmod(0)
    try:
        for args in (("upgrade", "p", "--out", "up"), ("info", "p"), ("pack", "p", "--out", "pk"),
                     ("weights", "p", "--out", "w")):
            r = _run_as_a_user(*args, cwd=tmp_path)
            text = _no_traceback(r)
            assert r.returncode == 3, (args, text[-2000:])
            assert "demo05.json: cannot read skeleton: Permission denied" in text, text[-2000:]
        assert len(list((tmp_path / "up").glob("*.json"))) == 19
    finally:
        (project / "demo05.json").chmod(0o644)


def test_a_page_the_user_may_not_read_is_said_of_the_page(tmp_path, twenty):
    """A page the user may not read: ``pack`` and ``upgrade`` said ``not copied:
    OUT/demo.png: cannot write: permission denied (read-only?)``, of the output, sending the
    user to fix a folder that was writable. The line names the page read, and why."""
    project = tmp_path / "p"
    shutil.copytree(twenty, project)
    (project / "demo.png").chmod(0)
    try:
        for args in (("pack", "p", "--out", "pk"), ("upgrade", "p", "--out", "up", "--pack")):
            r = _run_as_a_user(*args, cwd=tmp_path)
            text = _no_traceback(r)
            assert r.returncode == 3, (args, text[-2000:])
            assert "not copied: p/demo.png: cannot read: Permission denied" in text, text[-2000:]
            assert "cannot write" not in text, text[-2000:]
        assert "demo.png: cannot read image: Permission denied" in text, text[-2000:]
    finally:
        (project / "demo.png").chmod(0o644)


def test_a_folder_the_user_may_not_list_is_said(tmp_path):
    """A subfolder of the project the user may not list (mode 000), holding a skeleton: the
    walk every command makes left it out without a word (``info`` exit 0, the skeleton in it
    never upgraded). Each command says it, one line naming the folder (exit 3)."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p")
    (project / "sub").mkdir()
    shutil.copy(project / "demo.json", project / "sub" / "hidden.json")
    (project / "sub").chmod(0)
    try:
        for args in (("upgrade", "p", "--out", "up"), ("info", "p"), ("pack", "p", "--out", "pk"),
                     ("weights", "p", "--out", "w"), ("mesh", "p", "--out", "m")):
            r = _run_as_a_user(*args, cwd=tmp_path)
            text = _no_traceback(r)
            assert r.returncode == 3, (args, text[-2000:])
            assert "p/sub: folder not read (Permission denied); the files in it were left out" in text, text[-2000:]
    finally:
        (project / "sub").chmod(0o755)


def test_workers_the_system_refuses_to_start_never_hang_the_run(monkeypatch):
    """``ulimit -n`` low (or a container's pids limit): starting a worker process raised
    ``Too many open files`` in the thread that hands out tasks, which ended in a traceback while
    the run waited for its answers for ever (``upgrade --jobs 2`` under ``ulimit -n 12``). The
    pool goes on with the workers it has; with none, every queued task fails saying why."""
    import errno
    from concurrent.futures import wait as wait_all

    from spinemesh.cluster import ProcessWorkers
    from spinemesh.errors import SpineMeshError

    started = []
    real_start = ProcessWorkers._start_worker

    def second_refused(self):
        if started:
            raise OSError(errno.EMFILE, "Too many open files")
        started.append(True)
        return real_start(self)

    monkeypatch.setattr(ProcessWorkers, "_start_worker", second_refused)
    with ProcessWorkers(2) as w:  # one worker starts, the second is refused: the one does the work
        assert sorted(f.result(timeout=60) for f in [w.submit(abs, -i) for i in range(8)]) == list(range(8))

    def refused(self):
        raise OSError(errno.EMFILE, "Too many open files")

    monkeypatch.setattr(ProcessWorkers, "_start_worker", refused)
    with ProcessWorkers(2) as w:
        futures = [w.submit(abs, -i) for i in range(4)]
        _, waiting = wait_all(futures, timeout=30)
        assert not waiting, "the run waits for ever"
        for future in futures:
            with pytest.raises(SpineMeshError, match="cannot start a worker process: Too many open files"):
                future.result()


@pytest.mark.skipif(sys.platform != "linux", reason="descriptor limits as Linux counts them")
def test_upgrade_under_a_low_descriptor_limit_ends(tmp_path, twenty):
    """``upgrade --pack --jobs 2`` under ``ulimit -n 12`` and a few more: it ends within its time
    (it hung), in one line or with every file written, never a traceback."""
    import resource

    for limit in (12, 14, 16):
        def low(limit=limit):
            resource.setrlimit(resource.RLIMIT_NOFILE, (limit, limit))

        r = subprocess.run([sys.executable, "-m", "spinemesh", "upgrade", str(twenty), "--out", f"up{limit}",
                            "--pack", "--preview", f"pv{limit}", "--jobs", "2"], cwd=tmp_path, env=_env(),
                           capture_output=True, timeout=120, check=False, preexec_fn=low)
        text = _no_traceback(r)
        assert r.returncode in (0, 2, 3), (limit, text[-2000:])
        if r.returncode == 2:
            assert len([line for line in text.splitlines() if line.startswith("error:")]) == 1, text


# --- the process: its folder, its temporary folder, its umask, another file system -------------------

def test_a_current_folder_removed_is_named(tmp_path, twenty):
    """A build step's scratch folder removed under it: a relative ``--out`` ended in a bare
    ``error: No such file or directory``; the line says the current folder is gone."""
    gone = tmp_path / "gone"
    gone.mkdir()
    r = subprocess.run(["sh", "-c", 'cd "$1" && rmdir "$1" && shift && exec "$@"', "sh", str(gone), sys.executable,
                        "-m", "spinemesh", "upgrade", str(twenty), "--out", "rel"], env=_env(PWD=str(gone)),
                       capture_output=True, timeout=120, check=False)
    line = _one_error(r)
    assert "the current folder no longer exists" in line, line


@pytest.mark.parametrize("tmpdir", ["missing", "a-file"])
def test_a_temporary_folder_that_is_no_folder(tmp_path, twenty, tmpdir):
    """``TMPDIR`` missing or a file: ``pose`` holds its stream in the system's temporary folder
    (Python falls back to /tmp), ``upgrade --pack`` writes its pages; both succeed."""
    (tmp_path / "a-file").write_text("x")
    env = _env(TMPDIR=str(tmp_path / tmpdir))
    r = _run("pose", twenty / "demo.json", "-a", "wave", "--times", "0,0.5", cwd=tmp_path, env=env)
    assert r.returncode == 0 and len(json.loads(r.stdout)["poses"]) == 3, r.stderr
    r = _run("upgrade", twenty / "demo.json", "--out", "up", "--pack", cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("home", ["unset", "missing"])
def test_no_home_is_needed_and_nothing_is_written_there(tmp_path, twenty, home):
    """``HOME`` unset (a service account, ``env -i``) or naming a folder that does not exist: every
    command that could keep a cache runs (the preview, the learned bone choice, the shipped
    segmentation model), and nothing is made at ``HOME``."""
    env = _env(HOME=str(tmp_path / "home"))
    if home == "unset":
        env.pop("HOME")
    for args in (("upgrade", twenty, "--out", "up", "--pack", "--weights", "auto", "--preview", "prev"),
                 ("segment", twenty / "demo.png", "--out", "mask.png", "--mask", "model")):
        r = _run(*args, cwd=tmp_path, env=env)
        _no_traceback(r)
        assert r.returncode == 0, r.stderr[-2000:]
    assert not (tmp_path / "home").exists()


@pytest.mark.parametrize("umask", [0o077, 0o000, 0o022])
def test_written_files_follow_the_umask(tmp_path, twenty, umask):
    """Every file and folder written (skeletons, atlases, pages, preview, report, poses, converted
    skeletons) has the modes an ordinary ``open()``/``mkdir`` gives under the umask: 0600 under
    077 (a temporary renamed into place is never left 0600 under 022, nor 0666 under 077)."""
    steps = [("upgrade", twenty, "--out", "up", "--pack", "--preview", "prev", "--report", "r.json"),
             ("pose", twenty / "demo.json", "-a", "wave", "--times", "0", "--out", "pose.json"),
             ("convert", twenty / "demo.json", "c.skel")]
    for args in steps:
        r = _run(*args, cwd=tmp_path, umask=umask)
        assert r.returncode == 0, r.stderr
    modes = {stat.S_IMODE(p.stat().st_mode) for p in tmp_path.rglob("*") if p.is_file()}
    folders = {stat.S_IMODE(p.stat().st_mode) for p in tmp_path.rglob("*") if p.is_dir()}
    assert modes == {0o666 & ~umask} and folders == {0o777 & ~umask}, (sorted(map(oct, modes)), sorted(map(oct, folders)))


def test_outputs_on_another_file_system_than_the_temporary_folder(tmp_path, twenty):
    """``--out`` on /dev/shm, the temporary folder on disk: every write is made beside its target
    and renamed there (never across devices); no temporary file stays."""
    shm = Path("/dev/shm")
    if not shm.is_dir() or not os.access(shm, os.W_OK) or shm.stat().st_dev == tmp_path.stat().st_dev:
        pytest.skip("no second file system to write to")
    out = Path(os.path.realpath(shm)) / f"spinemesh-env-{os.getpid()}"
    try:
        steps = [("upgrade", twenty, "--out", out / "up", "--pack", "--preview", out / "prev", "--report",
                  out / "r.json"),
                 ("pack", twenty, "--out", out / "pk"),
                 ("pose", twenty / "demo.json", "-a", "wave", "--times", "0", "--out", out / "pose.json"),
                 ("convert", twenty / "demo.json", out / "c.skel")]
        for args in steps:
            r = _run(*args, cwd=tmp_path, env=_env(TMPDIR=str(tmp_path)))
            assert r.returncode == 0, r.stderr
        left = [p.name for p in out.rglob("*") if p.name.endswith(".tmp") or ".tmp" in p.name]
        assert not left and len(list((out / "up").glob("*.json"))) == 20
    finally:
        shutil.rmtree(out, ignore_errors=True)


def test_forced_colours_never_animate_the_bars_into_a_log(tmp_path, twenty):
    """``FORCE_COLOR=1`` (which CI logs are often given, for colours) made rich take the log for a
    terminal and redraw every bar into it ten times a second: 45 KB of redraws for 10 s of
    ``upgrade`` on a corpus project, megabytes for a long run. A stream that is no terminal gets
    the colours and each bar once, at its end; ``TTY_INTERACTIVE=1`` still asks for the drawing."""
    r = _run("upgrade", twenty, "--out", "up", "--pack", "--preview", "prev", "--weights", "auto", cwd=tmp_path,
             env=_env(FORCE_COLOR="1"))
    assert r.returncode == 0, r.stderr
    assert b"\x1b[1A" not in r.stderr and len(r.stderr) < 2000, (len(r.stderr), r.stderr[-500:])
    assert b"\x1b[" in r.stdout  # the colours stay
    r = _run("upgrade", twenty, "--out", "up2", "--pack", cwd=tmp_path, env=_env(FORCE_COLOR="1", TTY_INTERACTIVE="1"))
    assert r.returncode == 0 and b"\x1b[1A" in r.stderr


# --- determinism on a real project ------------------------------------------------------------------

def test_a_game_project_upgrades_to_the_same_bytes_in_any_environment(tmp_path, corpus):
    """A game's binary project (``.skel.bytes``, two skeletons), ``upgrade --pack --weights auto``
    by relative paths with ``--jobs 1``, hash seed 0, UTC, then by absolute paths from another
    folder with ``--jobs 2``, hash seed 77, another time zone and the C locale: every file written
    is the same bytes (tests/test_pipeline.py proves it on the demo)."""
    project = corpus / "chyo-sd"
    if not project.is_dir():
        unavailable("chyo-sd is not in this corpus")
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    args = ("upgrade", project, "--pack", "--weights", "auto")
    r = _run(*args, "--out", "out", "--jobs", "1", cwd=tmp_path / "a", env=_env(PYTHONHASHSEED="0", TZ="UTC"))
    assert r.returncode == 0, r.stderr[-2000:]
    r = _run(*args, "--out", tmp_path / "b" / "out", "--jobs", "2", cwd=tmp_path,
             env=_env(PYTHONHASHSEED="77", TZ="Asia/Kathmandu", LC_ALL="C", LANG="C"))
    assert r.returncode == 0, r.stderr[-2000:]
    a, b = (snapshot(tmp_path / side / "out") for side in "ab")
    assert a == b and any(name.endswith((".skel", ".skel.bytes")) for name in a), sorted(set(a) ^ set(b))


@pytest.mark.skipif(sys.platform != "linux", reason="the file behind standard output is named on Linux")
def test_standard_output_into_the_project_says_to_redirect_it(tmp_path):
    """``spinemesh info p > p/log.txt``: the user gave no path, they redirected standard output;
    the line says what to do in those words (it said "give a path outside it")."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p", with_images_folder=False)
    with open(tmp_path / "p" / "log.txt", "wb") as log:
        r = _run("info", "p", cwd=tmp_path, stdout=log)
    line = _one_error(r)
    assert "standard output lies inside the input" in line and line.endswith("redirect it outside it"), line

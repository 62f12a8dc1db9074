"""``spinemesh pose`` writes its JSON as a stream: the same bytes as the whole document
serialised at once, each pose on disk before the next is made, nothing left where a pose
fails mid-way (no file, nothing on standard output), and bounds that fit a stream (a cap and the space free where --out is)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_anim import _doc

from spinemesh.anim import Sampler
from spinemesh.anim.dump import dump
from spinemesh.errors import SpineMeshError
from spinemesh.files.strict_json import strict_json

REPO = Path(__file__).resolve().parents[1]


def _many(slots: int) -> dict:
    """The test skeleton with ``slots`` more region slots: about 320 bytes of pose JSON each."""
    doc = _doc()
    doc["slots"] += [{"name": f"s{i}", "bone": "arm", "attachment": "a"} for i in range(slots)]
    doc["skins"][0]["attachments"].update({f"s{i}": {"a": {"width": 10, "height": 4}} for i in range(slots)})
    return doc


def _project(tmp_path: Path, doc: dict, name: str = "arm.json") -> Path:
    project = tmp_path / "project"
    project.mkdir(exist_ok=True)
    (project / name).write_text(json.dumps(doc, ensure_ascii=False), encoding="utf-8")
    return project / name


def _pose(*args, patch: str = "") -> subprocess.CompletedProcess:
    """``spinemesh pose ARGS`` in a fresh interpreter, after the Python ``patch`` (which may
    replace a function, to fail a pose on purpose), through the console entry point."""
    code = f"import sys\n{patch}\nfrom spinemesh.cli import main\nsys.argv = ['spinemesh', 'pose', *sys.argv[1:]]\nmain()\n"
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", "PYTHONPATH": os.pathsep.join(
        filter(None, [str(REPO), str(REPO / "tests"), os.environ.get("PYTHONPATH")]))}
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, env=env,
                          check=False)


def _expected(doc: dict, times: list[float], skeleton: Path) -> bytes:
    """The document serialised at once, as the command wrote it before it streamed (the skeleton by its name)."""
    return (strict_json(dump(Sampler(doc), "turn", times, skeleton.name), None) + "\n").encode("utf-8")


def test_pieces_join_to_the_whole_text():
    from spinemesh.files.strict_json import strict_json_pieces

    head = {"input": {"skeleton": "bras·é.json", "skin": None, "fps": 60.0}, "skeleton": {"bones": [1, 2.5]}}
    for items in ([], [{"a": 1}], [{"a": [1.5, None]}, {"é": "x"}, {}], [1, "two", [3]]):
        assert "".join(strict_json_pieces(head, "poses", iter(items))) == strict_json({**head, "poses": items})
    assert "".join(strict_json_pieces({}, "poses", [{"a": 1}])) == strict_json({"poses": [{"a": 1}]})
    with pytest.raises(ValueError):
        list(strict_json_pieces({"poses": 1}, "poses", []))
    # A non-finite number is refused when its item is reached, naming the file, as strict_json does.
    pieces = strict_json_pieces(head, "poses", [{"a": 1}, {"a": float("nan")}], "out.json")
    assert next(pieces) and next(pieces) == '{"a": 1}'
    with pytest.raises(SpineMeshError, match="out.json.*non-finite"):
        next(pieces)


def test_stream_is_the_whole_document_to_the_byte(tmp_path):
    """--out and standard output are the bytes of the whole document serialised at once
    (separators, numbers, non-ASCII names kept, the final newline)."""
    doc = _doc()
    doc["bones"][1]["name"] = "bras·é"
    for slot in doc["slots"]:
        slot["bone"] = "bras·é" if slot["bone"] == "arm" else slot["bone"]
    doc["animations"]["turn"]["bones"] = {"bras·é": doc["animations"]["turn"]["bones"]["arm"]}
    skeleton = _project(tmp_path, doc)
    times = [0.25, 0.8, 0.25, 1.7]
    r = _pose(skeleton, "-a", "turn", "--times", "0.25,0.8,0.25,1.7", "--out", tmp_path / "pose.json")
    assert r.returncode == 0, r.stderr
    expected = _expected(doc, times, skeleton)
    assert (tmp_path / "pose.json").read_bytes() == expected
    assert b"bras\xc2\xb7\xc3\xa9" in expected and b"turn@1.7" in expected
    assert r.stderr.decode().strip().endswith("4 poses")
    r = _pose(skeleton, "-a", "turn", "--times", "0.25,0.8,0.25,1.7")
    assert r.returncode == 0 and r.stdout == expected, r.stderr


#: Replaces Sampler.pose: before each pose, notes the bytes of every temporary file beside
#: --out (the stream's) in ``sizes.json``; the call numbered FAIL (0: the bounds' look at the
#: setup pose, 1: the setup pose written) fails as KIND says: "raise" (what the sampler cannot
#: play), "nan" (a number not finite in what the pose gives to be written) or "interrupt" (Ctrl-C).
_PATCH = """
import json, math
from spinemesh.anim import pose as pose_module
made = []
real_pose = pose_module.Sampler.pose
def noted_pose(self, *args, **kwargs):
    made.append(sum(p.stat().st_size for p in folder.glob(".*.tmp")))
    (folder / "sizes.json").write_text(json.dumps(made))
    if len(made) - 1 == fail and kind == "raise":
        raise ValueError("a key this sampler cannot read")
    if len(made) - 1 == fail and kind == "interrupt":
        import os, signal
        os.kill(os.getpid(), signal.SIGINT)
    pose = real_pose(self, *args, **kwargs)
    if len(made) - 1 == fail and kind == "nan":
        whole = pose.to_dump()
        pose.to_dump = lambda: {**whole, "bones": {**whole["bones"], "root": [math.nan] * 6}}
    return pose
pose_module.Sampler.pose = noted_pose
"""


@pytest.mark.parametrize("kind, words", [("raise", "cannot be posed"), ("nan", "non-finite"), ("interrupt", None)])
def test_a_pose_failing_mid_stream_leaves_no_file(tmp_path, kind, words):
    """Poses are on disk (in the temporary file) before the next is made; when one fails, the
    run ends in one line (Ctrl-C: in none, exit 130), the temporary file is removed and --out
    keeps what it held."""
    skeleton = _project(tmp_path, _many(200))
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    (out_dir / "pose.json").write_text("what was there")
    patch = f"from pathlib import Path\nfolder, fail, kind = Path({str(out_dir)!r}), 4, {kind!r}\n{_PATCH}"
    r = _pose(skeleton, "-a", "turn", "--times", "0.1,0.2,0.3,0.4,0.5", "--out", out_dir / "pose.json", patch=patch)
    stderr = r.stderr.decode()
    assert r.returncode == (130 if words is None else 2) and "Traceback" not in stderr, stderr
    lines = [x for x in stderr.splitlines() if x.startswith("error:")]
    if words is None:
        assert not lines, stderr
    else:
        (line,) = lines
        assert words in line and str(skeleton if kind == "raise" else out_dir / "pose.json") in line, line
    assert sorted(p.name for p in out_dir.iterdir()) == ["pose.json", "sizes.json"]
    assert (out_dir / "pose.json").read_text() == "what was there"
    sizes = json.loads((out_dir / "sizes.json").read_text())
    # the setup pose and two more written (each over 50 kB) before the one that fails was made
    assert len(sizes) == 5 and sizes[2] > 50_000, sizes
    assert sizes[3] > sizes[2] + 50_000 and sizes[4] > sizes[3] + 50_000, sizes


@pytest.mark.parametrize("kind, words", [("raise", "cannot be posed"), ("nan", "non-finite")])
def test_a_pose_failing_on_standard_output_leaves_nothing_there(tmp_path, kind, words):
    """On standard output the document comes whole or not at all: a pose that fails part way
    (here the fourth, after three of over 50 kB each) leaves no byte there, a script reading it
    gets nothing to mistake for poses; the error is one line on stderr, exit status 2."""
    skeleton = _project(tmp_path, _many(200))
    notes = tmp_path / "notes"
    notes.mkdir()
    patch = f"from pathlib import Path\nfolder, fail, kind = Path({str(notes)!r}), 4, {kind!r}\n{_PATCH}"
    r = _pose(skeleton, "-a", "turn", "--times", "0.1,0.2,0.3,0.4,0.5", patch=patch)
    stderr = r.stderr.decode()
    assert r.returncode == 2 and "Traceback" not in stderr, stderr
    (line,) = [x for x in stderr.splitlines() if x.startswith("error:")]
    assert words in line, line
    assert len(json.loads((notes / "sizes.json").read_text())) == 5  # it failed where asked, poses made before
    assert r.stdout == b"", r.stdout[:200]
    # and with nothing failing, the same run prints the whole document
    r = _pose(skeleton, "-a", "turn", "--times", "0.1,0.2,0.3,0.4,0.5")
    assert r.returncode == 0 and len(json.loads(r.stdout)["poses"]) == 6, r.stderr


def test_output_bound_fits_a_stream(tmp_path):
    """The estimate (setup pose × poses) is bounded by a cap far above 256 MiB, which refused
    10,000 times of a skeleton of 300 regions while the output is now a stream; and to a file,
    by the space free where it is written."""
    from spinemesh.cli.pose import _check_pose_bounds
    from spinemesh.limits import MAX_POSE_OUTPUT_BYTES

    times = [i / 100 for i in range(10_000)]
    skeleton = tmp_path / "many.json"
    _check_pose_bounds(Sampler(_many(300)), "turn", times, 60.0, skeleton)  # about 960 MB: written
    huge = Sampler(_many(6_000))  # about 1.9 MB a pose
    assert 10_000 * len(strict_json(huge.pose(None).to_dump())) > MAX_POSE_OUTPUT_BYTES
    with pytest.raises(SpineMeshError, match=r"many\.json: --times: 10,001 poses .* over the limit of 16 GiB"):
        _check_pose_bounds(huge, "turn", times, 60.0, skeleton)


def test_output_must_fit_in_the_space_free(tmp_path):
    """Refused up front in one line naming the skeleton when the estimate is more than the disk
    holding --out has free (here made to look 5 MiB); nothing is written."""
    skeleton = _project(tmp_path, _many(300))
    times = ",".join(f"{i / 100:g}" for i in range(100))      # about 9.6 MB of JSON
    patch = ("import shutil, collections\nshutil.disk_usage = lambda p: "
             "collections.namedtuple('u', 'total used free')(1 << 40, 0, 5 << 20)")
    r = _pose(skeleton, "-a", "turn", "--times", times, "--out", tmp_path / "new" / "pose.json", patch=patch)
    stderr = r.stderr.decode()
    assert r.returncode == 2 and "Traceback" not in stderr, stderr
    (line,) = [x for x in stderr.splitlines() if x.startswith("error:")]
    assert str(skeleton) in line and "MiB of JSON, more than the 5 MiB free" in line, line
    assert not (tmp_path / "new").exists()
    # standard output has no such check, and with room the same run writes
    r = _pose(skeleton, "-a", "turn", "--times", times, "--out", tmp_path / "new" / "pose.json")
    assert r.returncode == 0 and (tmp_path / "new" / "pose.json").stat().st_size > 9_000_000, r.stderr


def test_standard_output_streams_past_the_progress_bar(tmp_path):
    """With stderr a terminal the progress bar takes over ``sys.stdout`` while it is drawn (rich
    sends what is printed there to the terminal, above the bar, a line at a time): the stream
    goes to the real standard output all the same, the same bytes as --out."""
    import pty
    import threading

    skeleton = _project(tmp_path, _many(50))
    times = ",".join(f"{i / 60:g}" for i in range(40))
    r = _pose(skeleton, "-a", "turn", "--times", times, "--out", tmp_path / "pose.json")
    assert r.returncode == 0, r.stderr
    master, slave = pty.openpty()
    seen = []
    drain = threading.Thread(target=lambda: _drain(master, seen), daemon=True)
    drain.start()
    env = {**os.environ, "COLUMNS": "100", "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}
    env.pop("NO_COLOR", None)
    with open(tmp_path / "stdout.json", "wb") as stdout:
        done = subprocess.run([sys.executable, "-m", "spinemesh", "pose", str(skeleton), "-a", "turn", "--times", times],
                              stdout=stdout, stderr=slave, env=env, timeout=120, check=False)
    os.close(slave)
    drain.join(10)
    assert done.returncode == 0, b"".join(seen)[-2000:]
    assert (tmp_path / "stdout.json").read_bytes() == (tmp_path / "pose.json").read_bytes()
    assert b'"poses"' not in b"".join(seen)           # none of it on the terminal


def _drain(fd: int, into: list) -> None:
    """Read the terminal's side of a pseudo-terminal until it closes (so that the child never blocks)."""
    while True:
        try:
            data = os.read(fd, 65536)
        except OSError:
            return
        if not data:
            return
        into.append(data)


def test_the_cap_holds_where_the_setup_pose_draws_nothing(tmp_path):
    """The estimate measures the setup pose; a skeleton whose setup pose draws nothing and whose
    animation shows hundreds of regions passed it and wrote without a bound. The stream itself
    now stops at the cap (here made 1 MiB), in one line naming the skeleton, no file written."""
    doc = _many(300)
    for slot in doc["slots"][3:]:
        del slot["attachment"]
    doc["animations"]["turn"]["slots"].update({s["name"]: {"attachment": [{"name": "a"}]} for s in doc["slots"][3:]})
    skeleton = _project(tmp_path, doc)
    times = ",".join(f"{i / 100:g}" for i in range(100))  # about 10 MB of JSON, estimated at 0.2 MB
    patch = "import spinemesh.limits\nspinemesh.limits.MAX_POSE_OUTPUT_BYTES = 1 << 20"
    r = _pose(skeleton, "-a", "turn", "--times", times, "--out", tmp_path / "new" / "pose.json", patch=patch)
    stderr = r.stderr.decode()
    assert r.returncode == 2 and "Traceback" not in stderr, stderr
    (line,) = [x for x in stderr.splitlines() if x.startswith("error:")]
    assert str(skeleton) in line and "passed 0.0009766 GiB of JSON" in line, line
    assert not (tmp_path / "new" / "pose.json").exists() and not list((tmp_path / "new").glob("*"))
    r = _pose(skeleton, "-a", "turn", "--times", times, "--out", tmp_path / "new" / "pose.json")
    assert r.returncode == 0 and (tmp_path / "new" / "pose.json").stat().st_size > 5_000_000, r.stderr


@pytest.mark.parametrize("atlas_text, words", [
    (b"arm.png\n\tsize: 4, 4\na\xff\n", "atlas is not UTF-8 text"),  # broken text
    (b"gone.png\n\tsize: 4, 4\na\n\tbounds: 0, 0, 1, 1\n", "page image 'gone.png' not found"),
])
def test_an_unreadable_atlas_is_named_not_called_missing(tmp_path, atlas_text, words):
    """An atlas beside the skeleton that cannot be used is named, with what is wrong, in one line."""
    import io

    from PIL import Image

    skeleton = _project(tmp_path, _doc())
    buf = io.BytesIO()
    Image.new("RGBA", (4, 4)).save(buf, format="PNG")
    (skeleton.parent / "arm.png").write_bytes(buf.getvalue())
    (skeleton.parent / "arm.atlas").write_bytes(atlas_text)
    r = _pose(skeleton, "--out", tmp_path / "pose.json")
    err = r.stderr.decode()
    assert r.returncode == 0, err
    line = next(x for x in err.splitlines() if "warning" in x)
    assert "no atlas found" not in err and "arm.atlas" in line and words in line, err

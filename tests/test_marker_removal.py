"""What a folder's marker may remove when spinemesh writes the folder again: the very files the
earlier run wrote, unchanged since, and nothing else (a marker is a file anyone can edit, copy or
write into a project; a user edits and replaces files in an output folder)."""

from __future__ import annotations

import json
import os
import shutil

import pytest

from spinemesh.errors import OutputError
from spinemesh.output import OUTPUT_MARKER, output_folder
from spinemesh.written_folder import (
    WRITTEN_MARKER,
    mark_written_files,
    remove_listed_files,
    rewriting_folder,
    written_files,
)


def _listing(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def test_a_file_replaced_after_the_run_is_kept_by_overwrite(tmp_path):
    """The user replaced a file the run wrote (an edited page): the next --overwrite, which does not
    write that name again, keeps it; an unchanged file of the run is removed."""
    out = tmp_path / "out"
    with output_folder(out, False):
        (out / "hero.png").write_bytes(b"the run's page")
        (out / "old.atlas").write_text("the run's atlas")
    (out / "hero.png").unlink()
    (out / "hero.png").write_bytes(b"the artist's retouched page")
    with output_folder(out, True):
        (out / "new.atlas").write_text("this run")
    assert (out / "hero.png").read_bytes() == b"the artist's retouched page"
    assert _listing(out) == [OUTPUT_MARKER, "hero.png", "new.atlas"]


def test_a_marker_copied_into_another_folder_removes_nothing_there(tmp_path):
    """A studio copies an output folder's marker into its art folder, whose files of the same names
    are its sources (hero.json before the upgrade, another page): none is a file the run wrote."""
    out, art = tmp_path / "out", tmp_path / "art"
    with output_folder(out, False):
        (out / "hero.json").write_text('{"upgraded": true}')
        (out / "hero.png").write_bytes(b"page")
    art.mkdir()
    (art / "hero.json").write_text('{"source": true}')
    (art / "hero.png").write_bytes(b"the artist's page")
    shutil.copy(out / OUTPUT_MARKER, art / OUTPUT_MARKER)
    with output_folder(art, True):
        pass
    assert _listing(art) == [OUTPUT_MARKER, "hero.json", "hero.png"]
    with output_folder(out, True):
        pass
    assert _listing(out) == [OUTPUT_MARKER]  # the run's own files, unchanged: removed


def test_a_preview_folder_keeps_a_file_replaced_after_its_run(tmp_path):
    """The same for a folder of pictures written again (rewriting_folder), and its marker copied."""
    folder = tmp_path / "preview"
    folder.mkdir()
    with rewriting_folder(folder):
        (folder / "a.png").write_bytes(b"run one")
        (folder / "b.png").write_bytes(b"run one")
    (folder / "b.png").unlink()
    (folder / "b.png").write_bytes(b"mine")
    with rewriting_folder(folder):
        (folder / "c.png").write_bytes(b"run two")
    assert _listing(folder) == [WRITTEN_MARKER, "b.png", "c.png"]
    assert sorted(written_files(folder)) == ["c.png"]


def test_a_run_that_ends_early_keeps_the_earlier_files_with_their_stamps(tmp_path):
    """A run that writes nothing lists the earlier run's files as that run left them: a file the user
    replaced in between is not taken for the run's own."""
    folder = tmp_path / "preview"
    folder.mkdir()
    with rewriting_folder(folder):
        (folder / "a.png").write_bytes(b"run one")
    (folder / "a.png").unlink()
    (folder / "a.png").write_bytes(b"mine")
    with rewriting_folder(folder):
        pass  # nothing written: nothing removed
    with rewriting_folder(folder):
        (folder / "b.png").write_bytes(b"run three")
    assert (folder / "a.png").read_bytes() == b"mine"


def test_a_marker_name_with_a_nul_or_no_encoding_removes_nothing_and_raises_nothing(tmp_path):
    """A hand-written marker's names are text anyone wrote: a NUL or an unpaired surrogate in a
    folder's name is no path; the run goes on."""
    folder = tmp_path / "f"
    (folder / "sub").mkdir(parents=True)
    (folder / "sub" / "x").write_text("x")
    remove_listed_files(folder, {"sub\x00/x": None, "\ud800/x": None, "sub/\ud800": None})
    marker = {"spinemesh": "written", "written": ["sub\u0000/x", "sub/x"]}
    (folder / WRITTEN_MARKER).write_text(json.dumps(marker))
    with rewriting_folder(folder):
        (folder / "new.png").write_bytes(b"new")
    assert (folder / "sub" / "x").exists()  # listed without the stamp the run gave it: not the run's


@pytest.mark.parametrize("text", ["", "marker\n", "{not json", "[]", '{"spinemesh": "written"}', "\xff\xfe"])
def test_an_output_marker_spinemesh_never_wrote_refuses_overwrite(tmp_path, text):
    """Only the marker an older spinemesh wrote (one line, known) empties the folder as a whole; a
    marker edited by hand into anything else is refused in one line, every file kept."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("mine")
    (out / OUTPUT_MARKER).write_bytes(text.encode("utf-8", "surrogateescape"))
    with pytest.raises(OutputError, match="spinemesh-output"), output_folder(out, True):
        pass
    assert (out / "mine.txt").read_text() == "mine"


def test_the_older_spinemeshs_marker_still_empties_its_folder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "stale.atlas").write_text("stale")
    (out / OUTPUT_MARKER).write_text("written by spinemesh upgrade; --overwrite may replace this folder\n")
    with output_folder(out, True):
        pass
    assert _listing(out) == [OUTPUT_MARKER]


def test_listed_files_are_removed_only_as_the_run_left_them(tmp_path):
    """mark_written_files: the earlier files this one did not write go when their stamps still hold."""
    folder = tmp_path / "f"
    folder.mkdir()
    (folder / "a").write_text("a")
    mark_written_files(folder, ["a"])
    earlier = written_files(folder)
    with open(folder / "a", "r+") as f:  # edited in place since (an editor saving over it)
        f.write("b")
    mark_written_files(folder, [], earlier)
    assert (folder / "a").exists()


@pytest.mark.parametrize("marker", [{"spinemesh": "output folder"}, {"spinemesh": "output folder", "kept": []},
                                    {"spinemesh": "output folder", "running": True, "kept": "mine.txt"}])
def test_an_output_marker_listing_nothing_it_wrote_refuses_overwrite(tmp_path, marker):
    """A marker of spinemesh's shape but neither a run's list nor a running run's (edited by hand)
    was read as a run that found nothing, and every file removed."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("mine")
    (out / OUTPUT_MARKER).write_text(json.dumps(marker))
    with pytest.raises(OutputError, match="marker|spinemesh-output"), output_folder(out, True):
        pass
    assert (out / "mine.txt").read_text() == "mine"


def test_a_name_listed_without_a_digest_is_never_taken_for_the_runs(tmp_path):
    """A hand-written marker's name without a digest stays listed so through a run that writes
    nothing, never digested then as if the run had written it, and is kept by the next."""
    folder = tmp_path / "preview"
    folder.mkdir()
    (folder / "mine.txt").write_text("mine")
    (folder / WRITTEN_MARKER).write_text(json.dumps({"spinemesh": "written", "written": ["mine.txt"]}))
    with rewriting_folder(folder):
        pass
    assert written_files(folder) == {"mine.txt": None}
    with rewriting_folder(folder):
        (folder / "a.png").write_bytes(b"a")
    assert (folder / "mine.txt").read_text() == "mine"


def test_the_marker_is_the_same_bytes_for_the_same_files_anywhere(tmp_path):
    """A build's folders are the same bytes from any folder: its marker too (digests, not inodes)."""
    texts = []
    for name in ("a", "b"):
        out = tmp_path / name / "out"
        with output_folder(out, False):
            (out / "hero.png").write_bytes(b"page")
        texts.append((out / OUTPUT_MARKER).read_bytes())
    assert texts[0] == texts[1] and b"sha256" in texts[0]


def test_a_marker_of_a_run_that_did_not_end_copied_elsewhere_removes_nothing(tmp_path):
    """A run killed half-way leaves a marker of the files it found (all others its own): copied into
    a studio's folder, it named every file there as the run's. It names its folder now; the copy
    is refused, every file kept, and the folder it came from is cleaned as before."""
    import subprocess
    import sys
    from pathlib import Path

    out, art = tmp_path / "out", tmp_path / "art"
    code = ("import os, sys\nfrom pathlib import Path\nfrom spinemesh.output import output_folder\n"
            "out = Path(sys.argv[1])\n"
            "with output_folder(out, False):\n"
            "    (out / 'half.skel').write_bytes(b'half')\n"
            "    os._exit(9)\n")
    repo = Path(__file__).resolve().parents[1]
    r = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(repo)), check=False)
    assert r.returncode == 9, r.stderr
    art.mkdir()
    (art / "hero.png").write_bytes(b"the artist's page")
    shutil.copy(out / OUTPUT_MARKER, art / OUTPUT_MARKER)
    with pytest.raises(OutputError, match="spinemesh-output"), output_folder(art, True):
        pass
    assert (art / "hero.png").read_bytes() == b"the artist's page"
    with output_folder(out, True):
        pass
    assert _listing(out) == [OUTPUT_MARKER]

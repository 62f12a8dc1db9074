"""Hostile round thirteen: what one skeleton may cost, and hostile animation data.

Each case is made here by our own code (the demo skeleton, its ``.skel`` written by our writer
and, where the writer cannot hold the case, spliced by hand), run through the library or through
``python -m spinemesh`` in a subprocess, and checked against what docs/safety.md promises.
"""

from __future__ import annotations

import resource
import struct
import subprocess
import sys

import numpy as np
import pytest
from test_hostile_round11b import _env, _no_traceback

from spinemesh.demo import demo_images, demo_skeleton, make_demo_project
from spinemesh.errors import SkelFormatError
from spinemesh.limits import MAX_SKELETON_ITEMS
from spinemesh.skeleton_binary import encode_skel, read_skel

#: A float32 no real key holds, written as one key's time and found again in the bytes.
_SENTINEL = struct.pack(">f", 12345.5)


def _varint(n: int) -> bytes:
    """``n`` as the format's unsigned varint."""
    out = bytearray()
    while n >= 0x80:
        out.append(n & 0x7F | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def _attachment_keys_skel(keys: int) -> bytes:
    """The demo's ``.skel`` with one attachment timeline of ``keys`` keys, 5 bytes each.

    Our writer makes the timeline with one key at :data:`_SENTINEL`'s time; its frame count, that
    key and its name (none: string reference 0) are spliced into ``keys`` such keys, since the
    writer itself refuses the count.
    """
    doc = demo_skeleton(demo_images())
    doc["animations"]["many"] = {"slots": {"head": {"attachment": [{"time": 12345.5, "name": None}]}}}
    data = encode_skel(doc)
    one = b"\x01" + _SENTINEL + b"\x00"
    assert data.count(one) == 1
    return data.replace(one, _varint(keys) + (b"\x00\x00\x00\x00\x00" * keys))


# --- what one skeleton may cost ---------------------------------------------------------------------

def test_a_skel_of_more_items_than_the_limit_is_refused_where_it_is_read():
    """A 5 MB ``.skel`` of a million attachment keys was read into 250 MB of dicts (50 times its
    size; the 256 MB file limit allowed over 12 GB); the lengths it lists are summed as they are
    read, and the file is refused at the count that passes the limit, naming the file and byte."""
    data = _attachment_keys_skel(MAX_SKELETON_ITEMS + 1)
    with pytest.raises(SkelFormatError, match=r"at most 1,000,000 items in one skeleton") as refused:
        read_skel(data, "many.skel")
    assert "many.skel (byte " in str(refused.value)


def test_a_skel_at_the_limit_is_read():
    """Just under the limit, the same timeline is read whole (the limit is a sum of lengths, not a
    count of something else)."""
    data = _attachment_keys_skel(MAX_SKELETON_ITEMS // 2)
    doc = read_skel(data, "half.skel")
    assert len(doc["animations"]["many"]["slots"]["head"]["attachment"]) == MAX_SKELETON_ITEMS // 2


def test_the_writer_refuses_a_skel_its_reader_would_refuse():
    """``convert x.json x.skel`` of a skeleton listing more than the limit says so, naming what the
    reader would refuse, instead of writing a ``.skel`` no command reads back."""
    doc = demo_skeleton(demo_images())
    doc["animations"]["many"] = {"slots": {"head": {"attachment": [{"time": 0, "name": None}] * MAX_SKELETON_ITEMS}}}
    with pytest.raises(SkelFormatError, match=r"items in one skeleton.*as a \.skel is read back"):
        encode_skel(doc, "many.json")


def _limit_memory(megabytes: int):
    """A ``preexec_fn`` holding the child's address space to ``megabytes``."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (megabytes << 20, megabytes << 20))
    return limit


def test_info_of_a_skel_of_too_many_keys_is_one_line_in_little_memory(tmp_path):
    """``info`` of the project: one line naming the skeleton, within 1 GB of address space and seconds
    (the whole document was built before anything looked at it)."""
    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo.json").unlink()
    (project / "demo-binary.skel").write_bytes(_attachment_keys_skel(MAX_SKELETON_ITEMS + 1))
    r = subprocess.run([sys.executable, "-m", "spinemesh", "info", str(project)], capture_output=True,
                       env=_env(), timeout=60, preexec_fn=_limit_memory(1024))
    text = _no_traceback(r)
    lines = [line for line in text.splitlines() if "items in one skeleton" in line]
    assert len(lines) == 1 and "demo-binary.skel (byte " in lines[0], text
    assert r.returncode == 3, text


def test_diff_measures_an_artist_mesh_of_many_vertices_in_little_memory():
    """``diff``'s distance from each of our vertices to the nearest of the artist's was a matrix of
    256 of ours times every one of theirs: an artist mesh of 90,000 vertices (a 10 MB JSON) took
    ``diff`` 25 s and 1.2 GB. Nearest vertices come from a k-d tree now, the same distances."""
    import tracemalloc

    from spinemesh.diff.compare import chamfer_distance, directed_mean_distance

    rng = np.random.default_rng(13)
    theirs = rng.uniform(0, 1000, (50_000, 2))
    ours = rng.uniform(0, 1000, (64, 2))
    tracemalloc.start()
    try:
        near = directed_mean_distance(ours, theirs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 << 20, f"{peak / 2**20:.0f} MB"
    exact = np.mean([np.min(np.hypot(*(theirs - p).T)) for p in ours])
    assert near == pytest.approx(exact, rel=1e-12)
    assert chamfer_distance(ours, ours[::-1]) == 0.0


# --- the command line -------------------------------------------------------------------------------

def test_upgrade_of_a_project_already_upgraded_says_so_without_a_traceback(meshed, tmp_path):
    """Upgrading a project whose attachments are all meshes already (a build step run twice) ends
    with one warning and exit 0: the warning's printer was not imported where the run says it, and
    such a run ended in a NameError traceback after writing its output."""
    r = subprocess.run([sys.executable, "-m", "spinemesh", "upgrade", str(meshed), "--out", str(tmp_path / "again")],
                       capture_output=True, env=_env(), timeout=120)
    text = _no_traceback(r)
    assert r.returncode == 0, text
    assert [line for line in text.splitlines() if line.startswith("warning:")], text


def test_an_interior_chain_is_split_no_finer_than_its_pixels():
    """A contour's points lie a pixel apart: splitting its segments finer picks the same points
    again. ``--density 1e9`` divided the split length by a billion, and ``upgrade`` of the demo ran
    past 300 s and 3.8 GB (``--density 1e300``: a ValueError traceback)."""
    from spinemesh.mesher.interior import simplify_chain

    c = np.array([(x, 0) for x in range(60)] + [(59, y) for y in range(1, 60)], np.float64)
    fine = simplify_chain(c, 0.012, 1e-4)
    assert len(fine) <= len(c)
    assert np.array_equal(fine, simplify_chain(c, 0.012, 1.0))


@pytest.mark.parametrize("density", ["1e9", "1e300"])
def test_mesh_at_an_enormous_density_is_the_finest_mesh(tmp_path, density):
    """``mesh --density`` of any finite number meshes, within seconds, the mesh density 1000 gives."""
    image = make_demo_project(tmp_path / "p") / "images" / "demo-head.png"
    meshes = {}
    for d in (density, "1000"):
        out = tmp_path / f"d{d}.json"
        r = subprocess.run([sys.executable, "-m", "spinemesh", "mesh", str(image), "--out", str(out), "--density", d],
                           capture_output=True, env=_env(), timeout=60, preexec_fn=_limit_memory(2048))
        assert r.returncode == 0, _no_traceback(r)
        meshes[d] = out.read_bytes()
    assert meshes[density] == meshes["1000"]


def test_diff_methods_naming_none_is_refused(tmp_path):
    """``diff --methods ,`` (a list of none, a script's empty variable joined) compared no method and
    wrote a report of the artists' meshes alone, exit 0; it is refused in one line now."""
    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    r = subprocess.run([sys.executable, "-m", "spinemesh", "diff", str(project), "--out", str(tmp_path / "d"),
                        "--methods", " , "], capture_output=True, env=_env(), timeout=60)
    text = _no_traceback(r)
    assert r.returncode == 2, text
    assert "error: no method named in ' , '; choose from default, paper" in text
    assert not (tmp_path / "d" / "report.json").exists()


@pytest.mark.parametrize("times", ["", " , "])
def test_pose_times_naming_none_is_refused(tmp_path, times):
    """``pose -a wave --times "$T"`` with ``T`` empty wrote the setup pose alone, exit 0, the
    animation never posed; a list naming no time is refused in the option's one line."""
    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    out = tmp_path / "pose.json"
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", str(project / "demo.json"), "-a", "wave",
                        "--times", times, "--out", str(out)], capture_output=True, env=_env(), timeout=60)
    text = _no_traceback(r)
    assert r.returncode == 2, text
    assert "names no time" in text and not out.exists()

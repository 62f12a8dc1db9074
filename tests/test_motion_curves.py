"""The bone choice's samplers say a 4.x curve the runtimes play apart, as ``pose`` does (hostile round ten).

The motion guard and the bending checks (``weights``, ``upgrade --weights auto``) sample the
skeleton's animations to choose bones; a 4.x curve that is a list too short, text or ``true``
(spine-ts poses it as not a number, libGDX refuses the file) they read as a straight line
without a word, where ``pose`` and the preview warn. Now each run says it in one warning line
naming the skeleton, the animation, the timeline and the key, in ``pose``'s words.
"""

from __future__ import annotations

import json

import pytest
from test_hostile import check_run, run_cli, snapshot


def _worm(tmp, curve) -> None:
    """The worm project (three bones along its art, ``wiggle`` bending it) in ``tmp/p``, the first
    key of ``wiggle``'s seg2 rotate given ``curve``."""
    from rig_project import make_worm_project

    path = make_worm_project(tmp / "p")
    doc = json.loads(path.read_text())
    doc["animations"]["wiggle"]["bones"]["seg2"]["rotate"][0]["curve"] = curve
    path.write_text(json.dumps(doc))


@pytest.mark.parametrize("curve", [[0.25, 0, 0.75], "linear", True], ids=["3 numbers", "text", "true"])
def test_the_motion_guard_says_a_curve_it_samples_linear(tmp_path, curve):
    _worm(tmp_path, curve)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--weights", "auto", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(0,))
    said = [line for line in r.stderr.splitlines() if "bones.seg2.rotate" in line]
    shown = json.dumps(curve)
    assert said == [(f"warning: worm.json: animation 'wiggle': bones.seg2.rotate: the curve of the key at 0 s is {shown}, "
                     "where its 1 value needs a list of 4 numbers; the runtimes play it apart or not at all (spine-ts "
                     "poses most such curves as not a number, the others fail to load them or read other numbers): "
                     "sampled linear where the bones are chosen")], r.stderr
    # weights on what upgrade wrote (its meshes bound again) samples the same animation: said alike
    before = snapshot(tmp_path)
    r = run_cli("weights", "o", "--out", "w", "--replace", cwd=tmp_path)
    check_run(r, before, tmp_path, ["w/"], codes=(0,))
    assert [line for line in r.stderr.splitlines() if "bones.seg2.rotate" in line] == said, r.stderr


def test_a_curve_the_runtimes_play_is_not_said_and_nothing_unsampled_is(tmp_path):
    """A 4-number curve is played alike: nothing said. A skeleton whose choices never needed
    the animations (upgrade without --weights auto) says nothing of them either."""
    _worm(tmp_path, [0.25, 0, 0.75, 1])
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--weights", "auto", cwd=tmp_path)
    assert r.returncode == 0 and "curve" not in r.stderr, r.stderr
    _worm(tmp_path / "b", True)
    r = run_cli("upgrade", "b/p", "--out", "b/o", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0 and "curve" not in r.stderr, r.stderr

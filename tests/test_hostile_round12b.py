"""Hostile round twelve, part three: the ``.skel`` readers and writers.

The IK bend byte read as the runtimes read it, one index-list reading for every version, and the
runtimes' pi at the one spot each uses it; then hostile files (claimed lengths, long varints,
truncations, counts past the end, bad text) and round trips of every real skeleton.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from spinemesh.errors import SkelFormatError
from spinemesh.rig.bones import skeleton_bones
from spinemesh.skeleton_binary import encode_skel, read_skel

from rig_project import make_worm_project
from runtime_tool import node
from test_ik_chain_runtime import ATLAS


def _ik_document(version: str, bend_positive: bool) -> dict:
    """Two bones bent by one IK constraint, and one IK key: a bend byte in the constraint and one in the key."""
    return {
        "skeleton": {"spine": version},
        "bones": [{"name": "root"}, {"name": "upper", "parent": "root", "length": 10},
                  {"name": "lower", "parent": "upper", "x": 10, "length": 10}, {"name": "aim", "parent": "root"}],
        "ik": [{"name": "reach", "bones": ["upper", "lower"], "target": "aim", "bendPositive": bend_positive}],
        "animations": {"bend": {"ik": {"reach": [{"bendPositive": bend_positive}]}}},
    }


def _bend_offsets(version: str) -> tuple[bytes, list[int]]:
    """The ``.skel`` of :func:`_ik_document` bending negatively, and the offsets of its bend bytes
    (where it differs from the one bending positively: -1 against 1)."""
    negative = encode_skel(_ik_document(version, False))
    positive = encode_skel(_ik_document(version, True))
    assert len(negative) == len(positive)
    offsets = [i for i, (a, b) in enumerate(zip(negative, positive)) if a != b]
    assert [negative[i] for i in offsets] == [0xFF] * len(offsets) and [positive[i] for i in offsets] == [1] * 2
    return negative, offsets


@pytest.mark.parametrize("version", ["3.5.51", "3.7.94", "3.8.99", "4.0.64", "4.1.24"])
@pytest.mark.parametrize("byte", [0, 2, 0x80])
@pytest.mark.parametrize("where", [0, 1], ids=["constraint", "key"])
def test_a_bend_byte_other_than_one_or_minus_one_is_refused_in_every_version(version, byte, where):
    """Every runtime of 3.5 to 4.1 reads the bend as a signed byte and multiplies the IK's angles
    by it (0 straightens the chain, 2 doubles the bend); the JSON says 1 or -1 only. 4.0 and 4.1
    read any byte but -1 as bending positively: a chain the game straightens was posed and
    written back bent."""
    data, offsets = _bend_offsets(version)
    assert read_skel(data)["ik"][0]["bendPositive"] is False
    hostile = bytearray(data)
    hostile[offsets[where]] = byte
    with pytest.raises(SkelFormatError, match="bend direction of 1 or -1") as e:
        read_skel(bytes(hostile), "bent.skel")
    assert e.value.offset == offsets[where] and "bent.skel" in str(e.value) and "\n" not in str(e.value)


VERSIONS = ["3.5.51", "3.8.99", "4.0.64", "4.2.40"]


def _index_offset(version: str) -> tuple[bytes, int]:
    """The ``.skel`` of :func:`_ik_document` and the offset of the IK constraint's first bone index
    (where it differs from the one naming the bone ``aim``)."""
    data = encode_skel(_ik_document(version, True))
    other = _ik_document(version, True)
    other["ik"][0]["bones"] = ["aim", "lower"]
    changed = [i for i, (a, b) in enumerate(zip(data, encode_skel(other))) if a != b]
    assert len(changed) == 1 and data[changed[0]] == 1
    return data, changed[0]


@pytest.mark.parametrize("version", VERSIONS)
def test_a_bone_index_past_the_last_is_refused_in_the_same_words_in_every_version(version):
    """One reading of a list of indices serves 3.x and 4.x (it was three near-copies: 4.x said
    ``bone index below 4``, 3.x and single indices ``a bone index below 4``)."""
    data, at = _index_offset(version)
    hostile = bytearray(data)
    hostile[at] = 9
    with pytest.raises(SkelFormatError) as e:
        read_skel(bytes(hostile), "far.skel")
    assert str(e.value) == f"far.skel (byte {at}): expected a bone index below 4, found 9"


@pytest.mark.parametrize("version", VERSIONS)
def test_writing_a_constraint_naming_no_bone_is_refused_in_the_same_words_in_every_version(version):
    """Writing, the list says which field names the unknown bone, as a single index (``target``)
    does: 3.x said ``for 'v'``, 4.x named no field."""
    doc = _ik_document(version, True)
    doc["ik"][0]["bones"] = ["ghost", "lower"]
    with pytest.raises(SkelFormatError) as e:
        encode_skel(doc, "ghost.skel")
    assert str(e.value).split("): ", 1)[1] == "cannot write: expected a known bone for 'bones', got 'ghost'"


@pytest.mark.parametrize("version", ["3.8.99", "4.1.24", "4.2.40"])
def test_a_skin_naming_no_ik_constraint_is_refused_in_the_same_words_in_every_version(version):
    doc = _ik_document(version, True)
    doc["skins"] = [{"name": "default"}, {"name": "armour", "ik": ["missing"]}]
    with pytest.raises(SkelFormatError) as e:
        encode_skel(doc, "skin.skel")
    assert str(e.value).split("): ", 1)[1] == "cannot write: expected a known IK constraint for 'ik', got 'missing'"


def _no_scale_reach(version: str) -> dict:
    """A ``noScale`` bone under a turned, sheared, unevenly scaled parent, moved by a transform
    constraint and then by a one-bone IK (which starts from the applied values the transform
    constraint left: 4.2 takes them back from the world through ``updateAppliedTransform``), with
    a child 100,000 units out along both of its axes, where the pi of 3.1415927 against
    ``Math.PI`` moves it by a thousandth of a unit."""
    inherit = "inherit" if version.startswith("4.2") else "transform"
    bones = [{"name": "root"},
             {"name": "parent", "parent": "root", "x": 5, "y": 3, "rotation": 37, "scaleX": 2.5, "scaleY": 0.4,
              "shearY": 11},
             {"name": "free", "parent": "parent", "x": 300, "y": 120, "rotation": 29, "length": 400,
              inherit: "noScale", "scaleX": 1.7, "scaleY": 0.8},
             {"name": "far", "parent": "free", "x": 100000, "y": 100000},
             {"name": "aim", "parent": "root", "x": -200, "y": 500},
             {"name": "pull", "parent": "root", "x": 100, "y": 50, "rotation": 71, "scaleX": 1.3}]
    mixes = ({"mixRotate": 0.5, "mixX": 0.3, "mixY": 0.3, "mixScaleX": 0, "mixScaleY": 0, "mixShearY": 0}
             if version.startswith("4.") else
             {"rotateMix": 0.5, "translateMix": 0.3, "scaleMix": 0, "shearMix": 0})
    return {"skeleton": {"spine": version}, "bones": bones,
            "slots": [{"name": "worm", "bone": "far", "attachment": "worm"}],
            "skins": [{"name": "default", "attachments": {"worm": {"worm": {"width": 240, "height": 60}}}}],
            "transform": [{"name": "pulled", "order": 0, "bones": ["free"], "target": "pull", **mixes}],
            "ik": [{"name": "reach", "order": 1, "bones": ["free"], "target": "aim", "mix": 0.7}],
            "animations": {}}


@pytest.mark.parametrize("version", ["3.8.99", "4.0.64", "4.1.24", "4.2.22"])
def test_no_scale_bones_use_the_pi_each_runtime_uses_there(version, spine_runtime, tmp_path):
    """``Bone.updateWorldTransform``'s noScale maths use ``Math.PI`` (pixi-spine 3.8, spine-core
    4.0 to 4.2: ``rig.transform``), 4.2's ``updateAppliedTransform`` ``MathUtils.PI`` = 3.1415927
    (``rig.constraints``). Either one swapped for the other moves ``far`` by 8e-4 (3.8 to 4.1)
    and 2e-3 to 3e-3 (4.2) units; as they are, ours and the runtime's dump (6 decimals) agree
    within 5e-7."""
    make_worm_project(tmp_path)
    (tmp_path / "worm.atlas").write_text(ATLAS)
    doc = _no_scale_reach(version)
    path = tmp_path / "reach.json"
    path.write_text(json.dumps(doc))
    r = node(spine_runtime, "dump.mjs", tmp_path / "worm.atlas", path, "--out", tmp_path / "d.json")
    assert r.returncode == 0, r.stderr[-2000:]
    theirs = json.loads((tmp_path / "d.json").read_text())["poses"][0]["bones"]
    for bone in skeleton_bones(doc):
        assert bone.exact, (bone.name, bone.why)
        a, b, c, d, x, y = theirs[bone.name]
        assert np.abs(np.array([[a, b, x], [c, d, y]]) - bone.world).max() < 1e-5, bone.name


@pytest.mark.parametrize("sign", ["", "-"])
def test_a_json_integer_of_thousands_of_digits_is_refused_in_words(tmp_path, sign):
    """Python turns at most 4,300 digits into an integer; its own error told the user to call
    ``sys.set_int_max_str_digits()``."""
    from spinemesh.errors import SkeletonError
    from spinemesh.skeleton import load_skeleton

    path = tmp_path / "long.json"
    path.write_text('{"skeleton": {"spine": "4.2.40"}, "bones": [{"name": "root", "x": ' + sign + "9" * 5000 + "}]}")
    with pytest.raises(SkeletonError) as e:
        load_skeleton(path)
    assert str(e.value) == f"{path}: invalid JSON: a number of 5,000 digits is beyond the range of a number"


@pytest.mark.parametrize("version", ["3.5.51", "3.8.99", "4.2.40"])
def test_a_string_the_reader_refuses_is_refused_before_it_is_written(version):
    """``convert`` wrote a JSON's 2 MB event string into a ``.skel`` (exit 0) that it then refused
    to read: the writer refuses what the reader refuses, in the reader's words."""
    doc = {"skeleton": {"spine": version}, "bones": [{"name": "root"}],
           "events": {"long": {"string": "x" * (2 << 20)}}, "animations": {}}
    with pytest.raises(SkelFormatError) as e:
        encode_skel(doc, "long.skel")
    assert str(e.value).split("): ", 1)[1] == ("cannot write: expected a string of at most 1,048,576 bytes "
                                               "(as a .skel is read back), found a length of 2,097,152")
    doc["events"]["long"]["string"] = "x" * (1 << 20)
    assert read_skel(encode_skel(doc))["events"]["long"]["string"] == doc["events"]["long"]["string"]


@pytest.mark.parametrize("version", ["3.8.99", "4.2.40"])
@pytest.mark.parametrize("length,said", [(b"\xff\xff\xff\xff\x07", "2,147,483,646"),
                                         (b"\x80\x80\x80\x80\x08", "-2,147,483,649")])
def test_a_claimed_string_of_two_gigabytes_is_refused_before_it_is_allocated(version, length, said):
    """A bone name claiming 2 GB (or, past 2^31, a negative length as the runtimes' ints read it)
    is refused at its length, saying the bound."""
    doc = {"skeleton": {"spine": version}, "bones": [{"name": "root"}, {"name": "MARKER", "parent": "root"}]}
    data = encode_skel(doc)
    at = data.index(b"MARKER") - 1
    with pytest.raises(SkelFormatError) as e:
        read_skel(data[:at] + length + data[at + 1:], "big.skel")
    assert e.value.offset == at
    assert str(e.value).split("): ", 1)[1].endswith(f"name of at most 1,048,576 bytes, found a length of {said}")

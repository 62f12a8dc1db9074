"""Hostile input, sixth round: what the last round of work added (``pose``'s stream, the preview's
animations sampled over ``--jobs``, 3.x curves read per version, 4.3 physics).

As in round five (tests/test_hostile_wave4.py), every skeleton and project is made here by our
own code; each case checks what docs/safety.md promises: no traceback, one line naming the file,
nothing non-finite written, one bad animation never stopping the others, bounded time, and no
process or temporary file left behind.
"""

from __future__ import annotations

import copy
import json

import pytest
from test_anim43 import physics_doc
from test_hostile_wave4 import within

from spinemesh.anim import Sampler
from spinemesh.anim.dump import dump


def _strict(obj) -> dict:
    return json.loads(json.dumps(obj, allow_nan=False))


# --- physics (4.2 and 4.3) driven past what a float holds -------------------------------------

def _as_42(doc: dict) -> dict:
    """A 4.3 physics document as 4.2 writes it (a ``physics`` list, no ``type``)."""
    doc = copy.deepcopy(doc)
    doc["skeleton"]["spine"] = "4.2.11"
    doc["physics"] = [{k: v for k, v in c.items() if k not in ("type", "scaleY")} for c in doc.pop("constraints")]
    return doc


def _diverging(version: str, where: str) -> dict:
    """Physics whose springs blow up to infinity within a few steps: values the document's check
    lets through (strength 1e9, mass 1e-9 on one bone, five times), or animated to 1e30."""
    doc = physics_doc()
    if where == "setup":
        doc["constraints"] += [{"type": "physics", "name": f"stiff{i}", "bone": "tail", "x": 1, "rotate": 1,
                                "strength": 1e9, "mass": 1e-9} for i in range(5)]
        doc["animations"]["h"] = copy.deepcopy(doc["animations"]["sway"])
    else:
        doc["animations"]["h"] = {"physics": {"tail": {where: [{"value": 1e30}]}},
                                  "bones": {"body": {"rotate": [{"value": 0}, {"time": 1, "value": 90}]}}}
    return doc if version == "4.3" else _as_42(doc)


@pytest.mark.parametrize("version, where", [("4.2", "strength"), ("4.2", "damping"), ("4.2", "mix"),
                                            ("4.3", "strength"), ("4.3", "damping"), ("4.3", "setup")])
def test_physics_whose_springs_diverge_flags_its_bones_instead_of_refusing_the_animation(version, where):
    """The runtimes draw such a bone nowhere (NaN); the sampler once raised a math domain error
    and refused the whole animation. Now the bone and those below it are flagged (null in the
    dump), every other bone posed."""
    sampler = Sampler(_diverging(version, where))
    with within(30):
        out = _strict(dump(sampler, "h", [0.05, 0.5, 1.5]))
    last = out["poses"][-1]
    assert "tail" in last["inexact"] and "tip" in last["inexact"]
    assert last["bones"]["chin"] is not None and "chin" not in last["inexact"]

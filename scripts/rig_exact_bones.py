"""Setup-pose bones and meshes that ``spinemesh weights`` can bind, over folders of projects.

    .venv/bin/python scripts/rig_exact_bones.py ROOT... [--tool DIR] [--meshes]

For every skeleton file (``.json`` and ``.skel``) under the given folders, counts the bones
whose setup world transform :mod:`spinemesh.rig.bones` reproduces (``exact``), by folder.

- ``--tool DIR``: an ``npm ci``'d copy of the Spine runtime harness. Skeletons of 3.8-4.2 are
  dumped in the setup pose, and every exact bone is compared with the runtime's world
  transform (mismatches over 1e-3 are listed; bones only some skins activate are skipped).
- ``--meshes``: also runs ``weight_document`` (``--replace --bones auto``, harmonic weights)
  on each skeleton and counts the meshes weighted and those left because one of their bones
  is not exact (a constraint that is not solved), as ``spinemesh weights --report`` tells.

Run it on two commits (``git worktree add``) to compare before and after a change.
"""

from __future__ import annotations

import argparse
import collections
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.project import find_project, image_source_for  # noqa: E402
from spinemesh.rig.bones import skeleton_bones  # noqa: E402
from spinemesh.rig.document import WeightOptions, weight_document  # noqa: E402
from spinemesh.skeleton import load_skeleton, spine_version  # noqa: E402

RUNTIME_VERSIONS = ("3.8", "4.0", "4.1", "4.2")


def runtime_mismatches(tool: Path, skeleton: Path, doc: dict, bones) -> list[str] | None:
    """Exact bones whose transform differs from the runtime's; None when it cannot be dumped."""
    source = image_source_for(doc, skeleton, find_project(skeleton.parent))
    atlases = getattr(source, "atlases", None) if source is not None else None
    if not atlases:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "dump.json"
        r = subprocess.run(["node", "dump.mjs", str(atlases[0].path), str(skeleton), "--out", str(out)],
                           cwd=tool, capture_output=True, text=True)
        if r.returncode:
            return None
        pose = json.loads(out.read_text())["poses"][0]["bones"]
    bad = []
    for bone in bones:
        chain, b = [], bone.index
        while b is not None:
            chain.append(bones[b])
            b = bones[b].parent
        if bone.exact and not any(x.skin_required for x in chain):
            m = pose[bone.name]
            runtime = np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]])
            if np.abs(runtime - bone.world).max() >= 1e-3:
                bad.append(bone.name)
    return bad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("roots", nargs="+", type=Path)
    ap.add_argument("--tool", type=Path, help="npm ci'd copy of the runtime harness: compare with its dumps")
    ap.add_argument("--meshes", action="store_true", help="also count meshes weighted / left for constraints")
    args = ap.parse_args()
    rows: dict[str, collections.Counter] = {}
    for root in args.roots:
        row = rows.setdefault(str(root), collections.Counter())
        for f in sorted(p for p in root.rglob("*") if p.suffix in (".json", ".skel")):
            try:
                doc = load_skeleton(f)
            except SpineMeshError:
                continue  # not a skeleton, or one the readers refuse
            if not isinstance(doc, dict) or not isinstance(doc.get("bones"), list):
                continue
            bones = skeleton_bones(doc)
            row["skeletons"] += 1
            row["bones"] += len(bones)
            row["exact"] += sum(b.exact for b in bones)
            if args.tool and spine_version(doc)[:3] in RUNTIME_VERSIONS:
                bad = runtime_mismatches(args.tool.resolve(), f.resolve(), doc, bones)
                if bad is None:
                    row["not dumped"] += 1
                else:
                    row["compared"] += 1
                    row["wrong"] += len(bad)
                    if bad:
                        print(f"{f}: {len(bad)} exact bones differ from the runtime: {bad[:5]}", flush=True)
            if args.meshes:
                options = WeightOptions(bones="auto", replace=True, method="harmonic")
                for o in weight_document(doc, str(f), options):
                    reason = o.reason or ""
                    if o.status == "weighted":
                        row["meshes weighted"] += 1
                    elif o.status == "skipped" and ("setup position depends on bone" in reason
                                                    or "none of its bones has an exact" in reason):
                        row["meshes left: bone not exact"] += 1
    keys = ["skeletons", "bones", "exact", "compared", "not dumped", "wrong", "meshes weighted",
            "meshes left: bone not exact"]
    print("| folder | " + " | ".join(keys) + " |")
    print("|---|" + "---|" * len(keys))
    total = collections.Counter()
    for name, row in rows.items():
        total.update(row)
        print(f"| {name} | " + " | ".join(str(row[k]) for k in keys) + " |")
    print("| all | " + " | ".join(str(total[k]) for k in keys) + " |")


if __name__ == "__main__":
    main()

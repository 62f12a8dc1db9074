"""Which region attachments would bend, per project: a quick scan before a ``--weights auto`` run.

    .venv/bin/python scripts/bending_regions.py ../shared/spine-corpus [--min 1] [--names]

For every project folder under each argument (or the argument itself, when it is a project),
every skeleton is read and each region attachment's whole quad is placed in the setup pose
(:class:`spinemesh.rig.upgraded_meshes.BendingRegions`): it *may bend* when the ``auto`` bone choice
gives it more than one bone (``upgrade --weights auto`` then lets the bone choice on the mesh decide, so
this is an upper bound). Prints per project: skeletons, region attachments, regions on an
exact slot bone, regions whose quad may bend, seconds. ``--names`` prints only the names of the
projects with at least ``--min`` such regions, space-separated (for ``bench_corpus_upgrade.py
run --only``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def scan(folder: Path) -> dict:
    from spinemesh.errors import SpineMeshError
    from spinemesh.project import find_project
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.upgraded_meshes import BendingRegions
    from spinemesh.skeleton import iter_attachments, load_skeleton

    t0 = time.perf_counter()
    out = {"skeletons": 0, "regions": 0, "exact": 0, "bend": 0, "errors": 0}
    try:
        proj = find_project(folder)
    except SpineMeshError:
        out["errors"] += 1
        return out
    for path in proj.skeletons:
        try:
            doc = load_skeleton(path)
            bending = BendingRegions.of(build_rig(doc))
        except SpineMeshError:
            out["errors"] += 1
            continue
        out["skeletons"] += 1
        for ref in iter_attachments(doc):
            if ref.type != "region":
                continue
            out["regions"] += 1
            bone = bending.rig.slot_bone.get(ref.slot)
            out["exact"] += bone is not None and bending.rig.bones[bone].exact
            out["bend"] += bending.bends(ref)
    out["seconds"] = time.perf_counter() - t0
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", type=Path, nargs="+")
    ap.add_argument("--min", type=int, default=1, help="fewest regions that may bend, for --names")
    ap.add_argument("--names", action="store_true")
    args = ap.parse_args()
    from spinemesh.project import find_projects

    rows = {}
    for folder in args.folders:
        for p in find_projects(folder):
            rows[p.relative_to(folder).as_posix() if p != folder else p.name] = scan(p)
    if args.names:
        print(" ".join(n for n, r in rows.items() if r["bend"] >= args.min))
        return
    print(f"{'project':36}{'skeletons':>10}{'regions':>9}{'exact':>8}{'may bend':>10}{'s':>7}")
    for n, r in rows.items():
        print(f"{n[:36]:36}{r['skeletons']:>10}{r['regions']:>9}{r['exact']:>8}{r['bend']:>10}"
              f"{r.get('seconds', 0.0):>7.2f}")
    tot = {k: sum(r.get(k, 0) for r in rows.values()) for k in ("skeletons", "regions", "exact", "bend", "seconds")}
    print(f"{'total (' + str(len(rows)) + ' projects)':36}{tot['skeletons']:>10}{tot['regions']:>9}{tot['exact']:>8}"
          f"{tot['bend']:>10}{tot['seconds']:>7.1f}")
    print(f"projects with at least {args.min} region that may bend: "
          f"{sum(r['bend'] >= args.min for r in rows.values())}", file=sys.stderr)


if __name__ == "__main__":
    main()

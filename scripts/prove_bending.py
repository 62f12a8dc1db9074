"""Runtime proof of ``upgrade --weights auto`` on real projects, for the meshes made only to bend.

    .venv/bin/python scripts/prove_bending.py PROJECT... --tool DIR

Each project is upgraded with ``--weights auto`` into a temporary folder; for every skeleton of
3.8-4.2 (what the harness plays) with at least one region meshed only because it bends, the
official runtime (``DIR``: an ``npm ci``'d copy of the Spine runtime harness) dumps the setup
pose of the original and of the upgrade, and ``compare.mjs`` checks that every mesh draws where
its region did (vertices inside the region's quad within 0.05, UVs matching, no visible texel
uncovered). Prints one line per skeleton: regions meshed to bend, their bones, the verdict.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

RUNTIME_VERSIONS = ("3.8", "4.0", "4.1", "4.2")


def node(tool: Path, *args) -> subprocess.CompletedProcess:
    return subprocess.run(["node", *map(str, args)], cwd=tool, capture_output=True, text=True, timeout=600)


def prove(project: Path, tool: Path, work: Path) -> list[str]:
    from spinemesh.project import find_project, image_source_for
    from spinemesh.skeleton import load_skeleton, spine_version
    from spinemesh.upgrade import Options, upgrade_project

    out = work / project.name
    result = upgrade_project(project, out, Options(weights="auto"))
    proj = find_project(project)
    lines = []
    for skeleton in proj.skeletons:
        rel = skeleton.relative_to(proj.root).as_posix()
        bent = [t for t in result.targets if t.skeleton == rel and t.weights and t.weights.get("meshed_to_bend")]
        if not bent:
            continue
        doc = load_skeleton(skeleton)
        if spine_version(doc)[:3] not in RUNTIME_VERSIONS:
            lines.append(f"{project.name}/{rel}: {len(bent)} meshed to bend; version {spine_version(doc)} not played")
            continue
        source = image_source_for(doc, skeleton, proj)
        atlas = source.atlases[0].path
        dumps = []
        for atlas_path, skel_path, name in ((atlas, skeleton, "a"),
                                            (out / atlas.relative_to(proj.root), out / rel, "b")):
            path = work / f"{name}.json"
            r = node(tool, "dump.mjs", atlas_path, skel_path, "--out", path)
            if r.returncode != 0:
                dumps = None
                lines.append(f"{project.name}/{rel}: dump {name} failed: {r.stderr.strip()[-300:]}")
                break
            dumps.append(path)
        if dumps is None:
            continue
        r = node(tool, "compare.mjs", *dumps, "--quiet")
        bones = sorted({len(t.weights["bones"]) for t in bent})
        verdict = "setup pose matches" if r.returncode == 0 else "MISMATCH " + (r.stdout + r.stderr).strip()[-300:]
        lines.append(f"{project.name}/{rel}: {len(bent)} meshed to bend (bones per mesh {bones}); {verdict}")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", type=Path, nargs="+")
    ap.add_argument("--tool", type=Path, required=True, help="npm ci'd copy of the runtime harness")
    args = ap.parse_args()
    bad = 0
    for project in args.projects:
        with tempfile.TemporaryDirectory() as work:
            for line in prove(project.resolve(), args.tool.resolve(), Path(work)):
                print(line, flush=True)
                bad += "MISMATCH" in line or "failed" in line
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()

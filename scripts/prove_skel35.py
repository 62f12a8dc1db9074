"""Proof on any folder of Spine 3.5 binary skeletons: byte-exact round trips, the editor's JSON, upgrade.

The official Spine 3.5 examples are not in ``../shared`` (nor may they be copied into this
repository); they are in the history of EsotericSoftware/spine-runtimes, exported by the
3.5.01 and 3.5.03 betas. This script proves whatever folder it is given. For every ``.skel``
under it whose header says Spine 3.5:

1. **bytes**: reading it and writing the document back gives the same bytes;
2. **convert**: ``spinemesh convert`` to ``.json`` and that JSON back to ``.skel`` gives the
   same bytes again;
3. **twin** (where a ``.json`` of the same name and version lies beside it, the editor's own
   export): the document read from the ``.skel`` equals that JSON, numbers compared within the
   editor's rounding (:func:`~spinemesh.skeleton_binary.compare.diff_documents`), but for the
   differences in :data:`KNOWN`, each a place where the two exports hold different information;
   and that JSON written as ``.skel`` reads back to it (within float32 rounding), stably;
4. **upgrade** (unless ``--no-upgrade``): ``spinemesh upgrade`` of the folder the ``.skel`` is
   in, default options; the upgraded ``.skel`` reads back and round-trips byte for byte, and
   equals the upgrade of its JSON twin: the same attachments meshed, each the same mesh over
   the image (UVs, triangles, hull, edges, size), and the rest of the documents equal as in 3.
   Vertices are not compared between the two: the twin's regions are the editor's rounded
   decimals (scales to 3 places: spineboy-hover's ``exhaust1`` glow, 274 pixels wide, is
   0.46290 wide in the binary and 0.462 in the JSON, 0.12 pixels apart at its ends), so each
   upgrade must instead place its mesh exactly where its own region drew the image
   (:func:`~spinemesh.attachment_geometry.region_quad_transform`, within float32 rounding).

It prints one row per file and a summary, and exits 1 when any check fails. No official 3.5
runtime can load the output here (the runtime harness starts at 3.8): the reading order is
proven against the runtime's by the fixtures of ``tests/test_skeleton_binary_v35.py``.

    git -C <spine-runtimes> archive 3.5.51 examples | tar -x -C /tmp/ex35   # the 3.5.03 beta exports
    .venv/bin/python scripts/prove_skel35.py /tmp/ex35 --json build/skel35.json
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import sys
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

import numpy as np  # noqa: E402

from spinemesh.attachment_geometry import region_quad_transform  # noqa: E402
from spinemesh.cli.convert_files import convert_files  # noqa: E402
from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.skeleton import is_binary_skeleton, iter_attachments, load_skeleton  # noqa: E402
from spinemesh.skeleton_binary import encode_skel, read_skel, sniff_version  # noqa: E402
from spinemesh.skeleton_binary.compare import diff_documents  # noqa: E402
from spinemesh.skeleton_binary.enums import EXTRA  # noqa: E402
from spinemesh.upgrade import Options, upgrade_project  # noqa: E402

from binary_pairs import is_known, no_motion  # noqa: E402

#: Differences between a 3.5 ``.skel`` and its JSON twin that remain because the two exports
#: hold different information: (version, file, path pattern, condition on the .skel document,
#: reason), as in ``tests/test_skeleton_binary_v3.py``.
KNOWN = [
    ("3.5*", "*", "animations/*/curve", no_motion,
     "Between two keys of equal values the JSON has a stepped curve where the binary has a "
     "linear one: the same motion, written two ways."),
    ("3.5*", "powerup.skel", "animations/animation/bones/star[5689]/*/1/curve", None,
     "The JSON steps these stars' bones from their second key to their third, different values; "
     "the binary moves them linearly. Between those keys the star's colour keys hold alpha 0: "
     "the difference is never seen (the same as in the 3.6 to 3.8 exports)."),
    ("3.5.01*", "*", "bones/*/transform", lambda doc, path: _bone(doc, path).get("transform") == "noRotationOrReflection",
     "The 3.5.01 beta's JSON spells the transform mode 'noRotation', a name no runtime's enum holds; "
     "its binary stores 2, noRotationOrReflection, which the 3.5.03 beta's JSON spells out."),
]


#: JSON twins our writer refuses, as the runtime's JSON loader of their version does too:
#: (version, file, what the refusal names, reason).
REFUSED = [
    ("3.5.01*", "*", "got 'noRotation'",
     "The 3.5.01 beta's JSON names a transform mode 'noRotation' (see KNOWN), which no 3.5 runtime "
     "loads (SkeletonJson looks the name up in TransformMode) and no .skel can store."),
]


def _refusal_known(version: str, name: str, message: str) -> bool:
    return any(fnmatch.fnmatchcase(version, v) and fnmatch.fnmatchcase(name, f) and what in message
               for v, f, what, _reason in REFUSED)


def _bone(doc: dict, path: str) -> dict:
    return doc["bones"][int(path.split("/")[1])]


@dataclass
class Row:
    """What one ``.skel`` gave: each check's outcome (None: not run) and its figures."""

    file: str
    version: str
    size: int
    bytes_same: bool = False
    convert_same: bool | None = None
    twin: str = ""
    twin_diffs: int | None = None
    twin_known: int = 0
    twin_unexplained: list[str] = field(default_factory=list)
    twin_writes_back: bool | None = None
    twin_refused: str = ""
    regions: int = 0
    meshed: int | None = None
    upgraded_reads_back: bool | None = None
    upgraded_twin_unexplained: list[str] | None = None
    error: str = ""

    @property
    def passed(self) -> bool:
        return (not self.error and self.bytes_same and self.convert_same is not False
                and not self.twin_unexplained and self.twin_writes_back is not False
                and (not self.twin_refused or _refusal_known(self.version, Path(self.file).name, self.twin_refused))
                and self.upgraded_reads_back is not False and not self.upgraded_twin_unexplained)


def find_binaries(root: Path) -> list[Path]:
    """Every binary skeleton under ``root`` whose header says Spine 3.5, sorted."""
    out = []
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.name.lower().endswith((".skel", ".skel.bytes")) and is_binary_skeleton(p):
            try:
                if sniff_version(p.read_bytes()).startswith("3.5."):
                    out.append(p)
            except SpineMeshError:
                continue
    return out


def twin_of(skel: Path, version: str) -> Path | None:
    """The editor's JSON export beside ``skel``: same name, same version."""
    js = skel.with_name(skel.name.split(".")[0] + ".json")
    try:
        doc = json.loads(js.read_text(encoding="utf-8-sig"))
    except (OSError, ValueError):
        return None
    return js if isinstance(doc, dict) and doc.get("skeleton", {}).get("spine") == version else None


def unexplained(skel_doc: dict, other: dict, version: str, name: str, **tolerances) -> tuple[int, list[str]]:
    """(all differences, those not in :data:`KNOWN`) between a document read from ``name``
    and another (its JSON twin, or their upgrades)."""
    diffs = diff_documents(skel_doc, other, ignore=[EXTRA], limit=100_000, **tolerances)
    return len(diffs), [str(d) for d in diffs if not is_known(KNOWN, version, name, skel_doc, d.path)]


#: How far (attachment units) an upgraded mesh's vertex may lie from where its region drew that
#: point of the image: float32 rounding of coordinates of up to a few thousand units.
PLACEMENT_TOL = 1e-3


def _glob_escape(text: str) -> str:
    return "".join(f"[{c}]" if c in "*?[" else c for c in text)


def _regions(doc: dict) -> dict[tuple, dict]:
    return {(a.skin, a.slot, a.name): a.attachment for a in iter_attachments(doc) if a.type == "region"}


def misplaced(region: dict, mesh: dict) -> float:
    """How far the mesh's vertices lie from where ``region`` draws their UVs (inf: weighted)."""
    uvs = np.asarray(mesh.get("uvs", []), float).reshape(-1, 2)
    verts = np.asarray(mesh.get("vertices", []), float)
    if verts.size != uvs.size:
        return float("inf")
    expected = np.c_[uvs, np.ones(len(uvs))] @ region_quad_transform(region).T
    return float(np.abs(verts.reshape(-1, 2) - expected).max()) if len(uvs) else 0.0


def upgrades_differ(source: dict, upgraded: dict, twin: dict, twin_upgraded: dict,
                    version: str, name: str) -> list[str]:
    """How the upgrade of a ``.skel`` differs from the upgrade of its JSON twin (see check 4)."""
    out: list[str] = []
    regions, twin_regions = _regions(source), _regions(twin)
    meshes = {(a.skin, a.slot, a.name): a.attachment for a in iter_attachments(upgraded)}
    twin_meshes = {(a.skin, a.slot, a.name): a.attachment for a in iter_attachments(twin_upgraded)}
    vertex_paths = []
    for key, region in regions.items():
        mine, theirs = meshes.get(key, {}), twin_meshes.get(key, {})
        where = "/".join(key)
        if mine.get("type", "region") != theirs.get("type", "region"):
            out.append(f"{where}: {mine.get('type', 'region')} != {theirs.get('type', 'region')}")
        elif mine.get("type") == "mesh" and key in twin_regions:
            vertex_paths.append("skins/" + _glob_escape(where) + "/vertices")
            for side, reg, mesh in (("binary", region, mine), ("twin", twin_regions[key], theirs)):
                off = misplaced(reg, mesh)
                if off > PLACEMENT_TOL:
                    out.append(f"{where}: the {side}'s mesh lies {off:.4g} from its region")
    diffs = diff_documents(upgraded, twin_upgraded, ignore=[EXTRA, *vertex_paths], limit=100_000)
    out += [str(d) for d in diffs if not is_known(KNOWN, version, name, upgraded, d.path)]
    return out


def prove_file(path: Path, root: Path, scratch: Path) -> Row:
    """Checks 1 to 3 on one file (see the module docstring)."""
    data = path.read_bytes()
    version = sniff_version(data)
    row = Row(str(path.relative_to(root)), version, len(data))
    doc = read_skel(data, path)
    row.bytes_same = encode_skel(doc) == data
    row.regions = sum(1 for a in iter_attachments(doc) if a.type == "region")
    as_json = scratch / (path.stem + ".json")
    back = scratch / (path.stem + ".skel")
    convert_files(path, as_json)
    convert_files(as_json, back)
    row.convert_same = back.read_bytes() == data
    js = twin_of(path, version)
    if js is not None:
        row.twin = js.name
        editor = json.loads(js.read_text(encoding="utf-8-sig"))
        row.twin_diffs, row.twin_unexplained = unexplained(doc, editor, version, path.name)
        row.twin_known = row.twin_diffs - len(row.twin_unexplained)
        try:
            ours = encode_skel(editor)
        except SpineMeshError as e:
            row.twin_refused = str(e)
        else:
            again = read_skel(ours)
            row.twin_writes_back = (not diff_documents(again, editor, abs_tol=1e-4, rel_tol=1e-6, ignore=[EXTRA])
                                    and encode_skel(again) == ours and sniff_version(ours) == version)
    return row


def prove_upgrade(folder: Path, rows: list[Row], root: Path, scratch: Path) -> None:
    """Check 4 on the rows of the files in ``folder``: one upgrade of the whole folder."""
    out = scratch / "upgraded"
    upgrade_project(folder, out, Options(overwrite=True))
    for row in rows:
        src = root / row.file
        upgraded = out / src.name
        data = upgraded.read_bytes()
        doc = read_skel(data, upgraded)
        row.upgraded_reads_back = encode_skel(doc) == data and sniff_version(data) == row.version
        row.meshed = sum(1 for a in iter_attachments(doc) if a.type == "mesh") - sum(
            1 for a in iter_attachments(read_skel(src)) if a.type == "mesh")
        if row.twin:
            row.upgraded_twin_unexplained = upgrades_differ(
                read_skel(src), doc, load_skeleton(src.with_name(row.twin)), load_skeleton(out / row.twin),
                row.version, src.name)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path, help="folder searched (recursively) for Spine 3.5 .skel files")
    parser.add_argument("--no-upgrade", action="store_true", help="skip check 4 (upgrade)")
    parser.add_argument("--json", type=Path, help="write every row here")
    args = parser.parse_args(argv)
    root = args.folder.resolve()
    files = find_binaries(root)
    if not files:
        print(f"no Spine 3.5 binary skeleton under {root}")
        return 1
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        by_folder: dict[Path, list[Row]] = {}
        for i, path in enumerate(files):
            scratch = Path(tmp) / str(i)
            scratch.mkdir()
            try:
                row = prove_file(path, root, scratch)
            except SpineMeshError as e:
                row = Row(str(path.relative_to(root)), "?", path.stat().st_size, error=str(e))
            rows.append(row)
            by_folder.setdefault(path.parent, []).append(row)
        if not args.no_upgrade:
            for j, (folder, group) in enumerate(by_folder.items()):
                scratch = Path(tmp) / f"up{j}"
                scratch.mkdir()
                try:
                    prove_upgrade(folder, [r for r in group if not r.error], root, scratch)
                except SpineMeshError as e:
                    for r in group:
                        r.error = r.error or f"upgrade: {e}"
    report(rows)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps([asdict(r) | {"passed": r.passed} for r in rows], indent=1))
    return 0 if all(r.passed for r in rows) else 1


def _mark(v: bool | None) -> str:
    return "-" if v is None else ("yes" if v else "NO")


def report(rows: list[Row]) -> None:
    """One row per file, then the totals."""
    print(f"{'file':52} {'version':12} {'bytes':>6} {'convert':>7} {'twin diffs (known)':>18} "
          f"{'json>skel':>9} {'regions':>7} {'meshed':>6} {'upgraded':>8} {'= twin':>6}")
    for r in rows:
        twin = "-" if r.twin_diffs is None else f"{len(r.twin_unexplained)} ({r.twin_known})"
        writes_back = "refused" if r.twin_refused else _mark(r.twin_writes_back)
        up_twin = "-" if r.upgraded_twin_unexplained is None else _mark(not r.upgraded_twin_unexplained)
        print(f"{r.file[-52:]:52} {r.version:12} {_mark(r.bytes_same):>6} {_mark(r.convert_same):>7} {twin:>18} "
              f"{writes_back:>9} {r.regions:>7} {'-' if r.meshed is None else r.meshed:>6} "
              f"{_mark(r.upgraded_reads_back):>8} {up_twin:>6}")
        for line in (r.twin_unexplained + (r.upgraded_twin_unexplained or []))[:5]:
            print(f"    unexplained: {line}")
        if r.twin_refused:
            known = "known: " if _refusal_known(r.version, Path(r.file).name, r.twin_refused) else ""
            print(f"    twin refused as .skel ({known}{r.twin_refused})")
        if r.error:
            print(f"    error: {r.error}")
    twins = [r for r in rows if r.twin]
    upgraded = [r for r in rows if r.meshed is not None]
    print(f"\n{len(rows)} Spine 3.5 binaries ({', '.join(sorted({r.version for r in rows}))}): "
          f"{sum(r.bytes_same for r in rows)} byte-exact round trips, "
          f"{sum(bool(r.convert_same) for r in rows)} byte-exact through convert to JSON and back; "
          f"{len(twins)} with a JSON twin: {sum(not r.twin_unexplained for r in twins)} equal to it "
          f"({sum(r.twin_known for r in twins)} known differences), "
          f"{sum(bool(r.twin_writes_back) for r in twins)} written back as .skel "
          f"({sum(bool(r.twin_refused) for r in twins)} refused); "
          f"{len(upgraded)} upgraded ({sum(r.meshed for r in upgraded)} of {sum(r.regions for r in upgraded)} "
          f"regions meshed), {sum(bool(r.upgraded_reads_back) for r in upgraded)} read back byte for byte, "
          f"{sum(r.upgraded_twin_unexplained == [] for r in upgraded)} of "
          f"{sum(r.upgraded_twin_unexplained is not None for r in upgraded)} equal to the twin's upgrade; "
          f"{sum(r.passed for r in rows)} of {len(rows)} pass")


if __name__ == "__main__":
    sys.exit(main())

"""Upgrade every project of the game corpus: what was meshed, what was kept, and what it saves.

    nice -n 10 .venv/bin/python benchmarks/bench_corpus_upgrade.py run --out rows.json
    .venv/bin/python benchmarks/bench_corpus_upgrade.py table rows.json [other_rows.json]

``run`` upgrades each project folder of ``../shared/spine-corpus`` with the default options
(one job), each in its own process with a time limit, into a temporary folder, and writes
one row per region attachment: status, reason, mesh seconds, vertices, the pixels the region
draws (its stored box on the atlas page) and the pixels the mesh draws (the area of its hull
polygon, holes included, as Spine fills them).

Mesh seconds are wall time as the upgrade reports them (inflated by whatever else runs on the
machine); where the upgrade exposes its worker function, CPU seconds per image are recorded too.

``table`` prints, for one or two row files side by side: attachments meshed, kept (by
reason), skipped and failed; the drawn-pixel saving against the regions in total and per
project; vertices added; mesh time per attachment (median, p90, p99, max) and in total; and,
for several files, the saving on the attachments every run counts (runs that read more
projects or mesh more sequences are then compared on the same set).

``gap A.json B.json`` says where B draws more pixels than A: by slot blend mode, meshed or kept.

``run --set NAME=NUMBER`` passes a mesher parameter to the upgrade (to measure its effect).

``run --weights auto`` upgrades with ``--weights auto``: rows then carry the bones each mesh
is weighted to and whether it was meshed only because it bends (the keep rule alone would keep
it), and ``table`` counts them. ``run --root FOLDER`` reads the project folders of another
library (the examples of one Spine version, say) instead of the corpus.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CORPUS = REPO.parent / "shared" / "spine-corpus"


def hull_area(doc: dict) -> float:
    """Area (px^2) of the hull polygon of a ``mesh.json`` dict: what Spine draws."""
    import numpy as np

    v = np.asarray(doc["vertices"], dtype=np.float64).reshape(-1, 2)[: int(doc["hull"])]
    x, y = v[:, 0], v[:, 1]
    return abs(0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))


def box_area(key: str) -> int | None:
    """Pixels of the stored box of an image key ``<hash>-x0-y0-x1-y1`` (None if absent)."""
    parts = key.rsplit("-", 4)
    if len(parts) != 5:
        return None
    x0, y0, x1, y1 = map(int, parts[1:])
    return (x1 - x0) * (y1 - y0)


def child(project: Path, min_saving: str = "", settings: list[str] | None = None, weights: str = "none") -> None:
    """Upgrade one project; print its rows as one JSON line.

    ``min_saving``: "" for the upgrade's default, "none" to mesh every region, or a share.
    ``settings``: mesher parameters ``NAME=NUMBER`` (:class:`spinemesh.mesher.MesherParams`)
    passed as the upgrade's overrides, for measuring their effect.
    """
    import cv2

    from spinemesh.upgrade import Options, upgrade_project
    try:  # where the worker's function lives (older versions: one module for the whole upgrade)
        from spinemesh.upgrade import meshing as upgrade_run
    except ImportError:
        from spinemesh.upgrade import run as upgrade_run

    sizes: dict[str, int] = {}
    cpu: dict[str, float] = {}
    if hasattr(upgrade_run, "mesh_one"):
        # the stored box each image is meshed on (what its region draws), as the worker sees it,
        # and the CPU time of meshing it (one job: this process), which the machine's load does
        # not inflate as it does wall time
        mesh_one = upgrade_run.mesh_one

        def recording(task):
            sizes[task.key] = int(task.rgba.shape[0] * task.rgba.shape[1])
            c0 = time.process_time()
            res = mesh_one(task)
            cpu[task.key] = time.process_time() - c0
            return res

        upgrade_run.mesh_one = recording
    cv2.setNumThreads(1)  # CPU time then measures the work, not idle threads spinning
    cache: dict = {}
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        options = Options(overrides=parse_settings(settings or []), weights=weights)
        if min_saving:
            options.min_saving = None if min_saving == "none" else float(min_saving)
        result = upgrade_project(project, Path(out) / "o", options, mesh_cache=cache)
        wall = time.perf_counter() - t0
    meshes = {k: v for (k, _settings), v in cache.items()}
    rows = []
    for t in result.targets:
        row = {"skeleton": t.skeleton, "slot": t.slot, "name": t.name, "status": t.status,
               "reason": t.reason, "seconds": float(t.seconds or 0.0), "vertices": int(t.vertices or 0),
               "image": t.key, "region_px": sizes.get(t.key) or (box_area(t.key) if t.key else None),
               "mesh_px": None, "cpu_seconds": cpu.get(t.key)}
        if t.weights is not None:  # --weights auto
            row["bones"] = len(t.weights["bones"]) if t.weights["status"] == "weighted" else 0
            row["meshed_to_bend"] = t.weights.get("meshed_to_bend")
        got = meshes.get(t.key)
        if t.status == "meshed" and got is not None:
            if isinstance(got, tuple):  # before the upgrade restructuring: (mesh.json dict, ...)
                row["mesh_px"] = hull_area(got[0])
            else:  # a MeshResult
                row["mesh_px"] = hull_area({"vertices": got.vertices, "hull": got.hull})
        rows.append(row)
    print(json.dumps({"wall": wall, "errors": result.errors, "rows": rows, "seconds": result.seconds}))


def parse_settings(settings: list[str]) -> dict:
    """``["hull_tolerance=0.02"]`` -> ``{"hull_tolerance": 0.02}`` (numbers only)."""
    out = {}
    for item in settings:
        name, _, value = item.partition("=")
        out[name.strip()] = int(value) if value.strip().lstrip("-").isdigit() else float(value)
    return out


def run(out: Path, timeout: float, only: list[str], min_saving: str = "", settings: list[str] | None = None,
        weights: str = "none", root: Path = CORPUS) -> None:
    projects = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    if only:
        projects = [p for p in projects if p.name in only]
    result = {"projects": {}}
    for i, p in enumerate(projects):
        t0 = time.perf_counter()
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            r = subprocess.run([sys.executable, __file__, "child", str(p), "--min-saving", min_saving,
                                "--weights", weights, *[f"--set={s}" for s in settings or []]],
                               capture_output=True, text=True, timeout=timeout)
            if r.returncode != 0:
                entry = {"error": r.stderr.strip().splitlines()[-1] if r.stderr.strip() else f"exit {r.returncode}"}
            else:
                entry = json.loads(r.stdout.strip().splitlines()[-1])
        except subprocess.TimeoutExpired:
            entry = {"error": f"timed out after {timeout:g} s"}
        entry["process_s"] = time.perf_counter() - t0
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)  # CPU: what the machine's load does not inflate
        entry["process_cpu_s"] = c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime
        result["projects"][p.name] = entry
        n = len(entry.get("rows", []))
        print(f"[{i + 1}/{len(projects)}] {p.name}: {n} attachments, {entry['process_s']:.1f} s, {entry['process_cpu_s']:.1f} s CPU"
              + (f"  ERROR {entry['error']}" if "error" in entry else ""), file=sys.stderr, flush=True)
        out.write_text(json.dumps(result))  # after each project: a partial run is still readable


def _reason_kind(reason: str) -> str:
    """A reason without its figures, for counting (``not worth meshing: 3 % saved`` -> its head)."""
    return reason.split(":")[0].split("(")[0].strip() or "-"


def _considered(row: dict) -> bool:
    """Whether an attachment counts in the drawn pixels: it reached the mesher (meshed, failed,
    or kept as not worth meshing); it then draws its region unless it was meshed. Regions
    left out before meshing (fully transparent, trimmed sequences) count in neither run."""
    if row["region_px"] is None:
        return False
    return row["status"] in ("meshed", "failed") or row["reason"].startswith("not worth meshing")


def summary(data: dict) -> dict:
    import numpy as np

    rows = [r for e in data["projects"].values() for r in e.get("rows", [])]
    out: dict = {"projects": len(data["projects"]),
                 "project_errors": sum("error" in e for e in data["projects"].values()),
                 "attachments": len(rows)}
    by_status: dict[str, int] = {}
    by_reason: dict[str, int] = {}
    for r in rows:
        by_status[r["status"]] = by_status.get(r["status"], 0) + 1
        if r["status"] != "meshed":
            k = f"{r['status']}: {_reason_kind(r['reason'])}"
            by_reason[k] = by_reason.get(k, 0) + 1
    out["status"] = by_status
    out["reasons"] = by_reason
    considered = [r for r in rows if _considered(r)]
    region = sum(r["region_px"] for r in considered)
    drawn = sum(r["mesh_px"] if r["status"] == "meshed" and r["mesh_px"] is not None else r["region_px"]
                for r in considered)
    out["region_px"] = region
    out["drawn_px"] = drawn
    out["saving"] = 1 - drawn / region if region else 0.0
    meshed = [r for r in rows if r["status"] == "meshed" and r["mesh_px"] is not None and r["region_px"]]
    out["worse_than_region"] = sum(r["mesh_px"] > r["region_px"] for r in meshed)
    out["vertices_added"] = sum(r["vertices"] - 4 for r in rows if r["status"] == "meshed")
    out["over_200_vertices"] = sum(r["vertices"] > 200 for r in rows if r["status"] == "meshed")
    secs = np.array([r["seconds"] for r in rows if _considered(r)] or [0.0])
    out["seconds"] = {"median": float(np.median(secs)), "p90": float(np.percentile(secs, 90)),
                      "p99": float(np.percentile(secs, 99)), "max": float(secs.max()), "sum": float(secs.sum()),
                      "over_2s": int((secs > 2).sum())}
    cpus = np.array([r["cpu_seconds"] for r in rows if _considered(r) and r.get("cpu_seconds") is not None]
                    or [np.nan])
    out["cpu"] = {"n": int(np.isfinite(cpus).sum()), "median": float(np.median(cpus)),
                  "p90": float(np.percentile(cpus, 90)), "p99": float(np.percentile(cpus, 99)),
                  "max": float(np.max(cpus)), "over_0.5s": int((cpus > 0.5).sum())}
    # an image shared by several attachments is meshed once
    once = {(name, r["image"]): r["seconds"] for name, e in data["projects"].items() for r in e.get("rows", [])
            if _considered(r) and r.get("image")}
    out["seconds"]["sum"] = float(sum(once.values()))
    out["images_meshed"] = len(once)
    out["wall"] = sum(e.get("process_s", 0.0) for e in data["projects"].values())
    cpu_runs = [e["process_cpu_s"] for e in data["projects"].values() if "process_cpu_s" in e]
    out["cpu_total"] = sum(cpu_runs) if cpu_runs else None
    per = {}
    for name, e in data["projects"].items():
        rs = [r for r in e.get("rows", []) if _considered(r)]
        reg = sum(r["region_px"] for r in rs)
        dr = sum(r["mesh_px"] if r["status"] == "meshed" and r["mesh_px"] is not None else r["region_px"] for r in rs)
        per[name] = {"saving": 1 - dr / reg if reg else None,
                     "meshed": sum(r["status"] == "meshed" for r in rs),
                     "kept": sum(r["status"] == "kept" for r in rs),
                     "seconds": sum(r["seconds"] for r in rs)}
    out["per_project"] = per
    if any("bones" in r for r in rows):  # --weights auto
        out["weights"] = {"weighted": sum(r.get("bones", 0) > 0 for r in rows if r["status"] == "meshed"),
                          "more_than_one_bone": sum(r.get("bones", 0) > 1 for r in rows if r["status"] == "meshed"),
                          "meshed_to_bend": sum(r.get("meshed_to_bend") is True for r in rows),
                          "kept_one_bone": sum(r.get("meshed_to_bend") is False for r in rows),
                          "write_s": sum(e.get("seconds", {}).get("write", 0.0) for e in data["projects"].values())}
    return out


def rows_by_attachment(data: dict) -> dict:
    """A run's report rows by ``(project, skeleton, slot, name)``, in order where a name repeats."""
    rows: dict = {}
    for name, e in data["projects"].items():
        for r in e.get("rows", []):
            rows.setdefault((name, r["skeleton"], r["slot"], r["name"]), []).append(r)
    return rows


def same_set(datas: list[dict]) -> dict:
    """Each run restricted to the attachments every run counts in its drawn pixels.

    Attachments are matched by project, skeleton, slot and name (in order where a name
    repeats); a run that counts more attachments (sequences it can mesh, projects it reads)
    is then compared on the others' set. Returns ``{"attachments": n, "region_px": [...],
    "drawn_px": [...], "vertices_added": [...]}``, one entry per run.
    """
    keyed = [rows_by_attachment(data) for data in datas]
    out = {"attachments": 0, "region_px": [0] * len(datas), "drawn_px": [0.0] * len(datas),
           "vertices_added": [0] * len(datas)}
    for key in set.intersection(*(set(k) for k in keyed)):
        lists = [k[key] for k in keyed]
        if len({len(rows) for rows in lists}) != 1:
            continue
        for same in zip(*lists):
            if not all(_considered(r) for r in same):
                continue
            out["attachments"] += 1
            for i, r in enumerate(same):
                meshed = r["status"] == "meshed" and r["mesh_px"] is not None
                out["region_px"][i] += r["region_px"]
                out["drawn_px"][i] += r["mesh_px"] if meshed else r["region_px"]
                out["vertices_added"][i] += r["vertices"] - 4 if r["status"] == "meshed" else 0
    return out


def slot_blends(project: Path) -> dict:
    """``(skeleton, slot) -> blend mode`` for every skeleton of a corpus project folder."""
    from spinemesh.errors import SpineMeshError
    from spinemesh.project import find_project
    from spinemesh.skeleton import load_skeleton

    out: dict = {}
    try:
        proj = find_project(project)
    except SpineMeshError:
        return out
    for skeleton in proj.skeletons:
        try:
            doc = load_skeleton(skeleton)
        except SpineMeshError:
            continue
        for s in doc.get("slots", []):
            if isinstance(s, dict):
                for name in {skeleton.name, skeleton.relative_to(project).as_posix()}:
                    out[(name, s.get("name"))] = s.get("blend", "normal")
    return out


def gap(base: Path, other: Path) -> None:
    """Where ``other`` draws more pixels than ``base``, on the attachments both count: by the
    slot's blend mode (normal, or additive/multiply/screen) and by what ``other`` did with the
    attachment (meshed, or kept as a region)."""
    datas = [json.loads(f.read_text()) for f in (base, other)]
    blends: dict = {}
    for name in datas[1]["projects"]:
        blends.update({(name, *k): v for k, v in slot_blends(CORPUS / name).items()})
    keyed = [rows_by_attachment(data) for data in datas]
    more: dict = {}
    regions: dict = {}
    for key in set(keyed[0]) & set(keyed[1]):
        if len(keyed[0][key]) != len(keyed[1][key]):
            continue
        blend = blends.get(key[:3], "normal")
        kind = "normal" if blend == "normal" else "additive, multiply, screen"
        for a, b in zip(keyed[0][key], keyed[1][key]):
            if not (_considered(a) and _considered(b)):
                continue
            drawn = [r["mesh_px"] if r["status"] == "meshed" and r["mesh_px"] is not None else r["region_px"]
                     for r in (a, b)]
            done = "meshed" if b["status"] == "meshed" else "kept as a region"
            more[(kind, done)] = more.get((kind, done), 0.0) + drawn[1] - drawn[0]
            regions[kind] = regions.get(kind, 0) + a["region_px"]
    print(f"pixels {other.stem} draws more than {base.stem} on the attachments both count (Mpx):")
    for (kind, done), v in sorted(more.items()):
        print(f"  {kind:28} {done:18} {v / 1e6:8.2f}   (regions of these slots: {regions[kind] / 1e6:.1f} Mpx)")
    print(f"  {'total':47} {sum(more.values()) / 1e6:8.2f}")


def table(files: list[Path], per_project: bool) -> None:
    import numpy as np

    datas = [json.loads(f.read_text()) for f in files]
    sums = [summary(d) for d in datas]
    w = 16
    names = [f.stem[:w] for f in files]
    print(f"{'':42}" + "".join(f"{n:>{w}}" for n in names))

    def line(label, vals):
        print(f"{label:42}" + "".join(f"{v:>{w}}" for v in vals))

    line("projects (errors)", [f"{s['projects']} ({s['project_errors']})" for s in sums])
    line("region attachments", [s["attachments"] for s in sums])
    for st in sorted({k for s in sums for k in s["status"]}):
        line(f"  {st}", [s["status"].get(st, 0) for s in sums])
    for rk in sorted({k for s in sums for k in s["reasons"]}):
        line(f"    {rk[:38]}", [s["reasons"].get(rk, 0) for s in sums])
    line("drawn pixels, regions (Mpx)", [f"{s['region_px'] / 1e6:.1f}" for s in sums])
    line("drawn pixels, after upgrade (Mpx)", [f"{s['drawn_px'] / 1e6:.1f}" for s in sums])
    line("drawn-pixel saving, total", [f"{s['saving']:.1%}" for s in sums])
    line("drawn-pixel saving, project median", [f"{np.median([p['saving'] for p in s['per_project'].values() if p['saving'] is not None]):.1%}" for s in sums])
    line("meshes drawing more than their region", [s["worse_than_region"] for s in sums])
    line("vertices added (over 4 per quad)", [s["vertices_added"] for s in sums])
    line("meshes over 200 vertices", [s["over_200_vertices"] for s in sums])
    for k in ("median", "p90", "p99", "max"):
        line(f"mesh s per attachment, {k}", [f"{s['seconds'][k]:.3f}" for s in sums])
    line("attachments over 2 s", [s["seconds"]["over_2s"] for s in sums])
    for k in ("median", "p90", "p99", "max"):
        line(f"mesh CPU s per attachment, {k}", ["-" if not s["cpu"]["n"] else f"{s['cpu'][k]:.3f}" for s in sums])
    line("attachments over 0.5 s CPU", ["-" if not s["cpu"]["n"] else s["cpu"]["over_0.5s"] for s in sums])
    line("unique images sent to the mesher", [s["images_meshed"] for s in sums])
    line("mesh s, sum over unique images", [f"{s['seconds']['sum']:.0f}" for s in sums])
    line("wall s, all projects (one process each)", [f"{s['wall']:.0f}" for s in sums])
    line("CPU s, all projects (one process each)", ["-" if s["cpu_total"] is None else f"{s['cpu_total']:.0f}"
                                                     for s in sums])
    if any("weights" in s for s in sums):
        labels = {"weighted": "meshes weighted (--weights auto)", "more_than_one_bone": "  to more than one bone",
                  "meshed_to_bend": "  meshed only because they bend",
                  "kept_one_bone": "made to bend, one bone: region again",
                  "write_s": "write s, weighting included (sum)"}
        for k, label in labels.items():
            line(label, ["-" if "weights" not in s else (f"{s['weights'][k]:.0f}" if k == "write_s"
                                                          else s["weights"][k]) for s in sums])
    if len(datas) > 1:
        same = same_set(datas)
        print(f"\non the {same['attachments']:,} attachments every run counts:")
        line("  drawn pixels, regions (Mpx)", [f"{v / 1e6:.1f}" for v in same["region_px"]])
        line("  drawn pixels, after upgrade (Mpx)", [f"{v / 1e6:.1f}" for v in same["drawn_px"]])
        line("  drawn-pixel saving, total", [f"{1 - d / r:.1%}" if r else "-"
                                            for d, r in zip(same["drawn_px"], same["region_px"])])
        line("  vertices added (over 4 per quad)", same["vertices_added"])
    if per_project:
        print()
        print(f"{'project':28}" + "".join(f"{n + ' saving':>{w + 4}}{'meshed/kept':>{w}}" for n in names))
        for name in sorted(sums[0]["per_project"]):
            cells = []
            for s in sums:
                p = s["per_project"].get(name)
                if p is None:
                    cells.append(f"{'-':>{w + 4}}{'-':>{w}}")
                    continue
                sv = "-" if p["saving"] is None else f"{p['saving']:.1%}"
                cells.append(f"{sv:>{w + 4}}{str(p['meshed']) + '/' + str(p['kept']):>{w}}")
            print(f"{name[:28]:28}" + "".join(cells))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--timeout", type=float, default=900.0, help="seconds per project")
    r.add_argument("--only", nargs="*", default=[], help="project folder names")
    r.add_argument("--min-saving", default="", help="'none' meshes every region (no keep rule); default: "
                                                    "the upgrade's own default")
    r.add_argument("--set", action="append", default=[], metavar="NAME=NUMBER",
                   help="a mesher parameter for the upgrade (repeatable), e.g. hull_tolerance=0.02")
    r.add_argument("--weights", choices=("none", "auto"), default="none", help="the upgrade's --weights")
    r.add_argument("--root", type=Path, default=CORPUS, help="folder of project folders (default: the corpus)")
    t = sub.add_parser("table")
    t.add_argument("files", type=Path, nargs="+")
    t.add_argument("--per-project", action="store_true")
    g = sub.add_parser("gap")
    g.add_argument("base", type=Path)
    g.add_argument("other", type=Path)
    c = sub.add_parser("child")
    c.add_argument("project", type=Path)
    c.add_argument("--min-saving", default="")
    c.add_argument("--set", action="append", default=[])
    c.add_argument("--weights", default="none")
    args = ap.parse_args()
    if args.cmd == "child":
        child(args.project, args.min_saving, args.set, args.weights)
    elif args.cmd == "run":
        if not args.root.is_dir():
            sys.exit(f"{args.root} is absent: the benchmark needs the game corpus (or the --root given)")
        run(args.out, args.timeout, args.only, args.min_saving, args.set, args.weights, args.root)
    elif args.cmd == "gap":
        gap(args.base, args.other)
    else:
        table(args.files, args.per_project)


if __name__ == "__main__":
    main()

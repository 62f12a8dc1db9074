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

``sweep`` runs ``spinemesh upgrade P --out O --pack`` and ``spinemesh pack P --out O2`` on
every project as a user does (the CLI, one job, a process each with a time limit) and checks
what they wrote: exit status, tracebacks, error and warning lines, files of the project
missing from the output, NaN/Infinity in written JSON, written skeletons our reader cannot read
back, page bytes of every atlas before and after, and the official runtime loading every written
skeleton of Spine 3.8-4.3 (3.8-4.2 dumped at animation times by the harness, 4.3 posed by
spine-core 4.3). ``sweep-table`` prints defects by kind, the slowest runs and the bytes.
``--option ARG`` adds an argument to the commands, ``--command`` runs one of them; a sweep
stopped goes on from its row file:

    nice -n 10 .venv/bin/python benchmarks/bench_corpus_upgrade.py sweep --out build/sweep.json
    nice -n 10 .venv/bin/python benchmarks/bench_corpus_upgrade.py sweep --option=--pages --option=any --out any.json
    nice -n 10 .venv/bin/python benchmarks/bench_corpus_upgrade.py sweep --command 'upgrade --pack' \
        --option=--weights --option=auto --out weights.json
    .venv/bin/python benchmarks/bench_corpus_upgrade.py sweep-table build/sweep.json

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


# --- the commands as a user runs them, every output checked -------------------------------------

#: Exit statuses the commands document: done, bad input (one line), partly done.
DOCUMENTED_EXITS = (0, 2, 3)

#: The two runs of ``sweep`` per project: the command's arguments after ``spinemesh``.
SWEEP_COMMANDS = {"upgrade --pack": ["upgrade", "{project}", "--out", "{out}", "--pack"],
                  "pack": ["pack", "{project}", "--out", "{out}"]}


def _no_constant(name: str):
    raise ValueError(f"{name} in the JSON")


def json_constants(path: Path) -> str:
    """``""`` when ``path`` is JSON without NaN/Infinity (or not JSON at all), else why."""
    try:
        json.loads(path.read_text(encoding="utf-8-sig"), parse_constant=_no_constant)
    except ValueError as e:
        return str(e) if "in the JSON" in str(e) else ""
    except UnicodeDecodeError:
        return ""
    return ""


def atlas_page_bytes(atlas: Path) -> int:
    """Bytes of the page images an atlas file names (0 for a page that is absent)."""
    from spinemesh.atlas import read_atlas

    pages = [atlas.parent / p.name for p in read_atlas(atlas).pages]
    return sum(p.stat().st_size for p in pages if p.is_file())


def runtime_dump(tools: dict, project: Path, out: Path, skeleton: Path, work: Path) -> str:
    """Load the written ``out`` copy of ``skeleton`` in the official runtime of its version with
    the written copy of its atlas: 3.8-4.2 dumped by the harness (setup pose, two times of up to
    three animations), 4.3 posed by ``tests/runtime43`` (setup pose, every attachment's world
    vertices and UVs). ``tools``: ``{"harness": folder, "4.3": folder}``, each installed.
    Returns ``"ok"``, why it is not loaded (``"-: ..."``), or the runtime's error."""
    sys.path[:0] = [p for p in (str(REPO / "tests"), str(REPO / "scripts")) if p not in sys.path]
    from prove_corpus import (
        RENDERABLE,
        atlas_for,
        harness_atlas,
        harness_copy,
        pose_list,
    )
    from runtime_tool import dump, node

    from spinemesh.skeleton import is_binary_skeleton, load_skeleton, spine_version

    doc = load_skeleton(skeleton)
    version = spine_version(doc)[:3]
    if version not in RENDERABLE and version != "4.3":
        return f"-: Spine {spine_version(doc) or '?'} (no runtime in the harness)"
    atlas, why = atlas_for(doc, skeleton, project)
    if atlas is None:
        return f"-: {why}"
    ours = out / skeleton.relative_to(project)
    work.mkdir(parents=True, exist_ok=True)
    ours_atlas = out / atlas.relative_to(project)
    if version == "4.3":
        r = node(tools["4.3"], "world.mjs", ours_atlas, ours, work / "world.json")
        return "ok" if r.returncode == 0 else node_error(r.stderr)
    try:
        dump(tools["harness"], harness_atlas(ours_atlas, work / "atlas"),
             harness_copy(ours, is_binary_skeleton(ours), work), None, "", work / "dump.json",
             poses=pose_list(doc) or None)
    except AssertionError as e:
        return node_error(str(e))
    return "ok"


def node_error(stderr: str) -> str:
    """The line of Node's output that says what went wrong (``Error: Region not found ...``)."""
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    said = [ln for ln in lines if ln.split(":")[0].endswith("Error")]  # not the source line it quotes
    return (said or lines or ["failed, saying nothing"])[0][:300]


def check_output(project: Path, out: Path, tools: dict | None, work: Path) -> dict:
    """What a user would find wrong in ``out``, written from ``project``.

    Returns ``{"missing": [...], "nan": [...], "unreadable": [...], "atlases": {atlas:
    [bytes before, bytes after]}, "runtime": {skeleton: result}}``: files of the project absent
    from ``out`` (and pages an atlas of ``out`` names that the project ships but ``out`` lacks;
    exported pages that no written atlas names any more are ``"pages_dropped"``), written JSON holding
    NaN/Infinity where the input's did not, written skeletons our reader cannot read back, the
    page bytes of every atlas, and the official runtime's load of every written skeleton of
    Spine 3.8-4.3 (``tools``: see :func:`runtime_dump`; None skips it).
    """
    from spinemesh.atlas import read_atlas
    from spinemesh.errors import SpineMeshError
    from spinemesh.project import find_project, skeletons_to_read
    from spinemesh.skeleton import load_skeleton

    src = find_project(project)
    res: dict = {"missing": [], "nan": [], "unreadable": [], "atlases": {}, "runtime": {}, "pages_dropped": []}
    pages = set()  # pages of the exported atlases: a packed atlas may need fewer
    for atlas in src.atlases:
        try:
            pages |= {(atlas.parent / p.name).resolve() for p in read_atlas(atlas).pages}
        except SpineMeshError:
            pass
    for f in src.files:
        rel = f.relative_to(project)
        if not (out / rel).is_file():
            res["pages_dropped" if f.resolve() in pages else "missing"].append(rel.as_posix())
        elif f.name.lower().endswith(".json") and not json_constants(f):
            why = json_constants(out / rel)
            if why:
                res["nan"].append(f"{rel.as_posix()}: {why}")
    for atlas in src.atlases:
        rel = atlas.relative_to(project)
        if not (out / rel).is_file():
            continue
        try:
            named = [out / rel.parent / p.name for p in read_atlas(out / rel).pages]
        except SpineMeshError as e:
            res["unreadable"].append(f"{rel.as_posix()}: {e}")
            continue
        res["missing"] += [p.relative_to(out).as_posix() for p in named
                           if not p.is_file() and (project / p.relative_to(out)).is_file()]  # shipped
        try:
            res["atlases"][rel.as_posix()] = [atlas_page_bytes(atlas), atlas_page_bytes(out / rel)]
        except SpineMeshError:
            pass  # a broken atlas of the export: left out by the commands too
    for skeleton in skeletons_to_read(src.skeletons):
        rel = skeleton.relative_to(project).as_posix()
        try:
            load_skeleton(skeleton)
        except SpineMeshError:
            continue  # unreadable as exported: refused by the commands, not ours to prove
        try:
            load_skeleton(out / rel)
        except (SpineMeshError, OSError) as e:
            res["unreadable"].append(f"{rel}: {e}")
            continue
        if tools is not None:
            res["runtime"][rel] = runtime_dump(tools, project, out, skeleton, work / rel.replace("/", "~"))
    return res


def sweep_one(project: Path, command: str, timeout: float, tools: dict | None, scratch: Path,
              options: tuple[str, ...] = ()) -> dict:
    """Run one of :data:`SWEEP_COMMANDS` on ``project`` (one job, its own process, ``options``
    added: ``("--pages", "any")``) and check its output."""
    out = scratch / "out"
    report = scratch / "report.json"
    args = [a.format(project=project, out=out) for a in SWEEP_COMMANDS[command]]
    cmd = [sys.executable, "-m", "spinemesh", *args, *options, "--jobs", "1", "--report", str(report)]
    t0 = time.perf_counter()
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        r = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=timeout, cwd=scratch,
                           env={**__import__("os").environ, "COLUMNS": "200"})
        rc, stderr, stdout = r.returncode, r.stderr, r.stdout
    except subprocess.TimeoutExpired as e:
        rc, stderr, stdout = None, (e.stderr or b"").decode(errors="replace") if isinstance(e.stderr, bytes) \
            else (e.stderr or ""), ""
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    text = stdout + "\n" + stderr
    entry = {"rc": rc, "wall": time.perf_counter() - t0,
             "cpu": c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime,
             "traceback": "Traceback (most recent call last)" in text,
             "errors": [ln.strip() for ln in text.splitlines() if ln.strip().startswith("error:")],
             "warnings": [ln.strip() for ln in text.splitlines() if ln.strip().startswith("warning:")],
             "tail": [ln for ln in stderr.strip().splitlines()[-4:]]}
    if report.is_file():
        try:
            doc = json.loads(report.read_text())
            entry["report_atlas_totals"] = doc.get("atlas_totals") or doc.get("totals")
            entry["report_errors"] = doc.get("errors", [])[:20]
        except ValueError as e:
            entry["report_unreadable"] = str(e)
    if out.is_dir() and rc in (0, 3):
        entry.update(check_output(project, out, tools, scratch / "work"))
    return entry


def sweep_defects(entry: dict) -> list[str]:
    """The defects a user would meet in one :func:`sweep_one` entry, one kind each (empty: none)."""
    out = []
    if entry["rc"] is None:
        out.append("timed out")
    elif entry["rc"] not in DOCUMENTED_EXITS:
        out.append(f"exit {entry['rc']}")
    if entry["traceback"]:
        out.append("traceback")
    if entry["rc"] == 2:
        out.append("refused (exit 2)")
    if entry.get("missing"):
        out.append("files missing")
    if entry.get("nan"):
        out.append("NaN/Infinity written")
    if entry.get("unreadable"):
        out.append("unreadable output")
    if any(after > before for before, after in entry.get("atlases", {}).values()):
        out.append("atlas more bytes")
    if any(not (v == "ok" or v.startswith("-:")) for v in entry.get("runtime", {}).values()):
        out.append("runtime cannot load")
    return out


def sweep(out: Path, timeout: float, only: list[str], root: Path, runtime: bool, options: tuple[str, ...] = (),
          commands: tuple[str, ...] = tuple(SWEEP_COMMANDS)) -> None:
    """``commands`` (of :data:`SWEEP_COMMANDS`) on every project folder of ``root`` with ``options``
    added (``--pages any``, or ``--weights auto`` for ``upgrade --pack`` alone); a row each,
    written after each."""
    tools = None
    if runtime:
        sys.path.insert(0, str(REPO / "tests"))
        from runtime_tool import ToolUnavailable, install, install43
        try:
            tools = {"harness": install(Path(tempfile.gettempdir()) / "spine-tool"),
                     "4.3": install43(Path(tempfile.gettempdir()) / "spine-runtime43")}
        except ToolUnavailable as e:
            sys.exit(f"the official runtime is unavailable: {e} (--no-runtime to sweep without it)")
    projects = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    if only:
        projects = [p for p in projects if p.name in only]
    result: dict = {"projects": {}}
    if out.is_file():  # go on where a stopped sweep ended
        result = json.loads(out.read_text())
    for i, p in enumerate(projects):
        for command in commands:
            if command in result["projects"].get(p.name, {}):
                continue
            with tempfile.TemporaryDirectory() as scratch:
                entry = sweep_one(p, command, timeout, tools, Path(scratch), options)
            result["projects"].setdefault(p.name, {})[command] = entry
            out.write_text(json.dumps(result))
            bad = sweep_defects(entry)
            print(f"[{i + 1}/{len(projects)}] {p.name} {command}: exit {entry['rc']}, {entry['wall']:.1f} s"
                  + (f"  DEFECT {', '.join(bad)}" if bad else ""), file=sys.stderr, flush=True)


def sweep_table(files: list[Path], slowest: int = 5) -> None:
    """Per command: projects, exits, defects by kind (with the projects), the slowest runs, and the
    page bytes of every atlas before and after, of one or more sweep row files."""
    data: dict = {"projects": {}}
    for f in files:  # several files (one per --root): projects named by file, as names repeat
        data["projects"].update({(f"{f.stem}/{name}" if len(files) > 1 else name): e
                                 for name, e in json.loads(f.read_text())["projects"].items()})
    for command in SWEEP_COMMANDS:
        entries = {name: e[command] for name, e in sorted(data["projects"].items()) if command in e}
        if not entries:
            continue
        print(f"spinemesh {command} (--jobs 1): {len(entries)} projects")
        exits: dict = {}
        for e in entries.values():
            exits[e["rc"]] = exits.get(e["rc"], 0) + 1
        print("  exit status      " + ", ".join(f"{'timeout' if k is None else k}: {v}"
                                                 for k, v in sorted(exits.items(), key=lambda kv: str(kv[0]))))
        kinds: dict = {}
        for name, e in entries.items():
            for kind in sweep_defects(e):
                kinds.setdefault(kind, []).append(name)
        if not kinds:
            print("  defects          none")
        for kind, names in sorted(kinds.items()):
            print(f"  {kind:17}{len(names):4}  " + ", ".join(names[:8]) + (" ..." if len(names) > 8 else ""))
        warned = sum(bool(e["warnings"]) for e in entries.values())
        print(f"  {'with warnings':17}{warned:4}")
        runtime = [v for e in entries.values() for v in e.get("runtime", {}).values()]
        print(f"  {'runtime loads':17}{sum(v == 'ok' for v in runtime):4} skeletons loaded (and dumped), "
              f"{sum(v.startswith('-:') for v in runtime)} not loaded (no runtime for the version, no one atlas), "
              f"{sum(not (v == 'ok' or v.startswith('-:')) for v in runtime)} failed")
        walls = sorted(((e["wall"], name) for name, e in entries.items()), reverse=True)
        print(f"  {'wall s, total':17}{sum(w for w, _ in walls):6.0f}   slowest: "
              + ", ".join(f"{name} {w:.0f}" for w, name in walls[:slowest]))
        atlases = [ba for e in entries.values() for ba in e.get("atlases", {}).values()]
        before, after = sum(b for b, _ in atlases), sum(a for _, a in atlases)
        print(f"  {'page bytes':17}{before / 1e6:9.1f} MB -> {after / 1e6:.1f} MB ({after / before - 1:+.1%}) "
              f"over {len(atlases)} atlases; {sum(a < b for b, a in atlases)} smaller, "
              f"{sum(a > b for b, a in atlases)} larger" if before else "  page bytes        -")


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
    s = sub.add_parser("sweep", help="upgrade --pack and pack every project as a user runs them; check the output")
    s.add_argument("--out", type=Path, required=True, help="row file (a sweep stopped goes on from it)")
    s.add_argument("--timeout", type=float, default=300.0, help="seconds per command and project")
    s.add_argument("--only", nargs="*", default=[], help="project folder names")
    s.add_argument("--root", type=Path, default=CORPUS, help="folder of project folders (default: the corpus)")
    s.add_argument("--no-runtime", action="store_true", help="skip the official runtime's load and dump")
    s.add_argument("--option", action="append", default=[], metavar="ARG",
                   help="an argument added to the commands (repeatable): --option=--pages --option=any")
    s.add_argument("--command", action="append", choices=list(SWEEP_COMMANDS),
                   help="run only this command (repeatable; default: both)")
    st = sub.add_parser("sweep-table")
    st.add_argument("files", type=Path, nargs="+")
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
    elif args.cmd == "sweep":
        if not args.root.is_dir():
            sys.exit(f"{args.root} is absent: the sweep needs the game corpus (or the --root given)")
        sweep(args.out, args.timeout, args.only, args.root, not args.no_runtime, tuple(args.option),
              tuple(args.command or SWEEP_COMMANDS))
    elif args.cmd == "sweep-table":
        sweep_table(args.files)
    elif args.cmd == "gap":
        gap(args.base, args.other)
    else:
        table(args.files, args.per_project)


if __name__ == "__main__":
    main()

"""Every project of the game corpus through ``upgrade --preview``, its pages opened in Chromium.

    nice -n 10 .venv/bin/python scripts/sweep_preview.py sweep --out build/preview-sweep.jsonl   # about 35 min
    .venv/bin/python scripts/sweep_preview.py table build/preview-sweep.jsonl

``sweep`` copies each project folder of ``../shared/spine-corpus`` (or ``--root``) to a scratch
folder and runs ``spinemesh upgrade P --out O --preview V --jobs 1`` there as a user does (the
CLI, its own process under ``nice -n 10``, a time limit), then records: exit status, whether a
traceback was printed, ``error:`` lines, the upgrade's seconds (its timing line) and the
preview's (its last line), the preview's problem lines (a skeleton "not shown", "could not
pose", animations "not shown", the players' "Not as a game shows it" notes), and the sizes of
what it wrote (largest page, largest script, all files). Then every skeleton's page is opened
in headless Chromium twice (the flags of the tests, ``tests/browser.py``): paused in its longest
animation (its setup pose when it has none) at ``--at`` seconds, both canvases read back
(visible pixels of each: a blank canvas is a defect until shown otherwise; where that animation
draws nothing, the setup pose is opened too), then its player
seeking that animation to 8 times over it (:data:`SEEK_PAGE`: whether the frames drawn
change); page errors (uncaught exceptions, console errors, files not found) of both runs are
recorded. One JSON row per project, appended to the ``--out`` file as each ends (a sweep
stopped goes on from it); the scratch folder is deleted after each project.

``table`` prints the totals, the defects by kind with their projects, and the slowest
previews against their upgrades.
"""

from __future__ import annotations

import argparse
import base64
import io
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
CORPUS = REPO.parent / "shared" / "spine-corpus"

from browser import FLAGS, chromium, page_errors

_TIMING = re.compile(r"^read [\d.]+ s\b.*$", re.MULTILINE)
_SECONDS = re.compile(r"([\d.]+) s\b")
_PREVIEW = re.compile(r"^preview: .* \(([\d.]+) s\)$", re.MULTILINE)
_LI = re.compile(r"<li>(.*?)</li>", re.DOTALL)
_NOT_SHOWN = re.compile(r"<small>not shown: (.*?)</small>", re.DOTALL)
_NOTE = re.compile(r'"note":"((?:[^"\\]|\\.)+)"')


def unescape(text: str) -> str:
    return text.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", '"').replace("&#x27;", "'") \
        .replace("&amp;", "&")


def upgrade(project: Path, scratch: Path, timeout: float) -> dict:
    """Run the upgrade with its preview on a copy of ``project``; what the console said."""
    copy = scratch / "project"
    shutil.copytree(project, copy, symlinks=True)
    cmd = ["nice", "-n", "10", sys.executable, "-m", "spinemesh", "upgrade", str(copy), "--out", str(scratch / "out"),
           "--preview", str(scratch / "preview"), "--jobs", "1"]
    t0 = time.perf_counter()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=scratch, check=False,
                           env={**os.environ, "COLUMNS": "200", "PYTHONPATH": str(REPO)})
        rc, text = r.returncode, r.stdout + "\n" + r.stderr
    except subprocess.TimeoutExpired as e:
        rc = None
        text = "\n".join(x.decode(errors="replace") if isinstance(x, bytes) else (x or "") for x in (e.stdout, e.stderr))
    timing = _TIMING.search(text)
    preview = _PREVIEW.search(text)
    return {"rc": rc, "wall": round(time.perf_counter() - t0, 2),
            "traceback": "Traceback (most recent call last)" in text,
            "errors": [ln.strip() for ln in text.splitlines() if ln.strip().startswith("error:")],
            "tail": text.strip().splitlines()[-6:] if rc not in (0, 3) or "Traceback" in text else [],
            "upgrade_s": round(sum(float(s) for s in _SECONDS.findall(timing.group(0))), 2) if timing else None,
            "timing": timing.group(0) if timing else None,
            "preview_s": float(preview.group(1)) if preview else None}


def preview_contents(preview: Path) -> dict:
    """The problem lines of a written preview and the sizes of its files."""
    files = [p for p in preview.rglob("*") if p.is_file()]
    pages = [p for p in files if p.suffix == ".html"]
    scripts = [p for p in files if p.suffix == ".js"]
    index = preview / "index.html"
    problems = [f"index: not shown: {unescape(m)}" for m in _NOT_SHOWN.findall(index.read_text(encoding="utf-8"))] \
        if index.is_file() else ["no index.html"]
    no_player = []
    for page in sorted(preview.glob("s/*.html")):
        text = page.read_text(encoding="utf-8")
        problems += [f"{page.stem}: {unescape(m)}" for m in _LI.findall(text)]
        if 'class="player"' not in text:
            no_player.append(page.stem)
    notes = sorted({f"{p.parent.name}: {json.loads(chr(34) + m + chr(34))}" for p in scripts
                    if p.parent.parent.name == "data" for m in _NOTE.findall(p.read_text(encoding="utf-8"))})

    def biggest(group: list[Path]) -> tuple[int, str]:
        return max(((p.stat().st_size, p.relative_to(preview).as_posix()) for p in group), default=(0, ""))

    return {"problems": problems, "notes": notes, "no_player": no_player, "files": len(files),
            "bytes": sum(p.stat().st_size for p in files), "largest_page": biggest(pages),
            # the player's own script is one fixed file; what grows with a project is its data
            "largest_script": biggest([p for p in scripts if p.relative_to(preview).parts[0] == "data"]),
            "pages": len(pages) - index.is_file()}


#: Times a page is opened again when the browser does not end (headless Chromium, rarely, hangs
#: on a loaded machine; the same page opened again ends in seconds).
RETRIES = 2


def open_page(url: str, tmp: Path, budget_ms: int = 5000, timeout: float = 90,
              pre: str = "sm-test") -> tuple[dict | None, list[str], str]:
    """Open ``url`` in headless Chromium; what the page wrote in ``<pre id="PRE">`` (by default
    the player's test hook), the page errors, and why nothing came back (empty when something did)."""
    for attempt in range(RETRIES + 1):
        profile = tmp / f"profile{attempt}"
        try:
            r = subprocess.run(["nice", "-n", "10", chromium(), *FLAGS, f"--user-data-dir={profile}",
                                f"--virtual-time-budget={budget_ms}", "--dump-dom", url],
                               capture_output=True, text=True, timeout=timeout, check=False,
                               env={**os.environ, "HOME": str(tmp)})
            break
        except subprocess.TimeoutExpired:
            print(f"  chromium did not end in {timeout:.0f} s: {url} (try {attempt + 1})", file=sys.stderr, flush=True)
        finally:
            shutil.rmtree(profile, ignore_errors=True)
    else:
        return None, [], f"chromium did not end in {timeout:.0f} s, {RETRIES + 1} times"
    errors = page_errors(r.stderr)
    found = re.search(f'<pre id="{pre}">(.*?)</pre>', r.stdout, re.DOTALL)
    if r.returncode != 0:
        return None, errors, f"chromium exit {r.returncode}: {r.stderr.strip()[-300:]}"
    if not (found and found.group(1)):
        return None, errors, "the player wrote no test result"
    return json.loads(unescape(found.group(1))), errors, ""


def visible(data_url: str, alpha: int = 0) -> int:
    """Pixels of a canvas (PNG data URL) with alpha over ``alpha`` (0 to 255)."""
    import numpy as np
    from PIL import Image

    rgba = np.asarray(Image.open(io.BytesIO(base64.b64decode(data_url.split(",", 1)[1]))).convert("RGBA"))
    return int((rgba[..., 3] > alpha).sum())


#: Alpha over which a pixel counts when the two sides' drawn areas are compared (a glow's faint
#: fringe, where a mesh's edge and the region's quad sample alpha 1 or 2 differently, does not).
SEEN = 32


#: A page beside a skeleton's page that loads its player as the page does, paused in an
#: animation (``#at=A,0``), then, once the player's own test hook has written its result (the
#: frames and images loaded), seeks the animation to ``SEEKS`` times spread over it: each drawn
#: once to load its images, then again, with a checksum of each canvas. Not played by the
#: page's clock: headless Chromium's virtual time and a page that draws every frame hang it, now
#: and then, for minutes.
SEEK_PAGE = """<!doctype html><html><head><meta charset="utf-8"></head><body>
<div class="player" id="player-{pid}"></div><script src="../player.js"></script>
<script src="../data/{pid}/model.js"></script><script>
(function () {{
  var N = {seeks};
  function sum(c) {{
    var px = c.getContext("2d").getImageData(0, 0, c.width, c.height).data, s = 0;
    for (var i = 0; i < px.length; i++) s = (s * 31 + px[i]) % 1000000007;
    return s;
  }}
  function loading(P) {{ return P.images.some(function (im) {{ return im && !im.complete; }}); }}
  function pass(P, checked) {{
    var out = [];
    for (var i = 0; i < N; i++) {{
      P.t = P.data.dur * i / N;
      P.draw();
      if (checked) {{
        var cs = document.querySelectorAll("#player-{pid} canvas");
        out.push({{ t: P.t, before: sum(cs[0]), after: sum(cs[1]) }});
      }}
    }}
    return out;
  }}
  function go() {{
    var P = SM.players && SM.players["{pid}"], done = document.getElementById("sm-test");
    if (!P || !done || !done.textContent) {{ setTimeout(go, 50); return; }}
    pass(P, false);
    (function wait() {{
      if (loading(P)) {{ setTimeout(wait, 50); return; }}
      var pre = document.createElement("pre");
      pre.id = "sm-seek";
      pre.textContent = JSON.stringify(pass(P, true));
      document.body.appendChild(pre);
    }})();
  }}
  go();
}})();
</script></body></html>
"""
SEEKS = 8


def in_browser(preview: Path, tmp: Path, at: float) -> dict:
    """Every skeleton page of ``preview`` opened paused, and its player seeking (:data:`SEEK_PAGE`):
    per page what it drew."""
    out = {}
    for page in sorted(preview.glob("s/*.html")):
        model = preview / "data" / page.stem / "model.js"
        if not model.is_file():
            out[page.stem] = {"no_player": True}
            continue
        anims = json.loads(model.read_text(encoding="utf-8").split(",", 1)[1].rsplit(");", 1)[0])["anims"]
        # the longest animation (0 is the setup pose: still), the first of them
        anim = max(range(1, len(anims)), key=lambda i: (anims[i]["dur"], -i)) if len(anims) > 1 else 0
        row = {"anim": anims[anim]["name"], "anims": len(anims) - 1, "dur": anims[anim]["dur"]}
        got, errors, why = open_page(page.resolve().as_uri() + f"#at={anim},{at:g}", tmp)
        row["errors"] = errors
        if got is None:
            row["still"] = why
        else:
            row["visible"] = [visible(got["before"]), visible(got["after"])]
            row["seen"] = [visible(got["before"], SEEN), visible(got["after"], SEEN)]
            if anim and min(row["visible"]) == 0:  # an animation may hide all: the setup pose then
                got, errors, why = open_page(page.resolve().as_uri() + "#at=0,0", tmp)
                row["errors"] += [e for e in errors if e not in row["errors"]]
                row["setup_visible"] = why or [visible(got["before"]), visible(got["after"])]
        seek = page.with_name(f"{page.stem}.seek.html")
        seek.write_text(SEEK_PAGE.format(pid=page.stem, seeks=SEEKS), encoding="utf-8")
        got, errors, why = open_page(seek.resolve().as_uri() + f"#at={anim},0", tmp, pre="sm-seek")
        row["errors"] += [e for e in errors if e not in row["errors"]]
        if got is None:
            row["seeking"] = why
        else:
            row["frames_differ"] = [len({s[k] for s in got}) for k in ("before", "after")]
        out[page.stem] = row
    return out


def sweep_one(project: Path, timeout: float, at: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="sweep-preview-", dir="/tmp") as scratch:
        scratch = Path(scratch)
        row = {"project": project.name, **upgrade(project, scratch, timeout)}
        if (scratch / "preview").is_dir():
            row.update(preview_contents(scratch / "preview"))
            t0 = time.perf_counter()
            row["browser"] = in_browser(scratch / "preview", scratch / "chromium", at)
            row["browser_s"] = round(time.perf_counter() - t0, 1)
    return row


#: What the player says of its own limits and of animations that draw nothing: words for the
#: user, not defects (the skins past the four it offers, frames a second under the budget).
_TELLING = ("not offered alone: the player offers at most", "Nothing to see", "Shown at ")


def _telling(line: str) -> bool:
    return any(words in line for words in _TELLING)


def defects(row: dict) -> list[str]:
    """The kinds of defect a user would meet in one project's row (empty: none)."""
    out = []
    if row["rc"] is None:
        out.append("timed out")
    elif row["rc"] not in (0, 3):
        out.append(f"exit {row['rc']}")
    if row["traceback"]:
        out.append("traceback")
    if row["rc"] in (0, 3) and row.get("preview_s") is None:
        out.append("no preview")
    if any(not _telling(line) for line in row.get("problems", ())):
        out.append("preview problem line")
    if any("Not as a game shows it" in note for note in row.get("notes", ())):
        out.append("'not as a game shows it' note")
    if row.get("no_player"):
        out.append("page without player")
    pages = row.get("browser", {}).values()
    if any(p.get("errors") for p in pages):
        out.append("page error")
    if any(p.get("still") or p.get("seeking") for p in pages):
        out.append("no test result")
    if any("visible" in p and min(p["visible"]) == 0 and min(p.get("setup_visible", [0])) == 0 for p in pages):
        out.append("blank canvas")
    if any(abs(seen[1] - seen[0]) > max(100, 0.05 * seen[0]) for seen in (p.get("seen", p.get("visible"))
                                                                         for p in pages) if seen):
        out.append("the sides draw unlike areas")
    if any(min(p.get("frames_differ", [2])) < 2 < 100 * p.get("dur", 0) for p in pages):
        out.append("frames all alike")
    return out


def sweep(out: Path, root: Path, only: list[str], timeout: float, at: float) -> None:
    done = set()
    if out.is_file():  # go on where a stopped sweep ended; the projects named in ``only`` again
        rows = [line for line in out.read_text().splitlines() if line.strip()]
        out.write_text("".join(line + "\n" for line in rows if json.loads(line)["project"] not in only))
        done = {json.loads(line)["project"] for line in rows} - set(only)
    projects = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    projects = [p for p in projects if (not only or p.name in only) and p.name not in done]
    out.parent.mkdir(parents=True, exist_ok=True)
    for i, p in enumerate(projects):
        row = sweep_one(p, timeout, at)
        with out.open("a") as f:
            f.write(json.dumps(row) + "\n")
        bad = defects(row)
        print(f"[{i + 1}/{len(projects)}] {p.name}: exit {row['rc']}, upgrade {row['upgrade_s']} s, preview "
              f"{row.get('preview_s')} s, browser {row.get('browser_s')} s" + (f"  DEFECT {', '.join(bad)}" if bad else ""),
              file=sys.stderr, flush=True)


def table(files: list[Path], slowest: int = 5) -> None:
    rows = [json.loads(line) for f in files for line in f.read_text().splitlines() if line.strip()]
    pages = [p for r in rows for p in r.get("browser", {}).values()]
    exits: dict = {}
    for r in rows:
        exits[r["rc"]] = exits.get(r["rc"], 0) + 1
    print(f"projects {len(rows)}; exit " + ", ".join(f"{'timeout' if k is None else k}: {v}"
                                                     for k, v in sorted(exits.items(), key=lambda kv: str(kv[0]))))
    print(f"skeleton pages {len(pages)}; opened paused {sum('visible' in p for p in pages)}, "
          f"both canvases drawn {sum('visible' in p and min(p['visible']) > 0 for p in pages)}; "
          f"seeked {sum('frames_differ' in p for p in pages)}, frames changing on both sides "
          f"{sum(min(p.get('frames_differ', [0])) > 1 for p in pages)}; page errors "
          f"{sum(bool(p.get('errors')) for p in pages)}")
    kinds: dict = {}
    for r in rows:
        for kind in defects(r):
            kinds.setdefault(kind, []).append(r["project"])
    for kind, names in sorted(kinds.items()):
        print(f"  {kind:32}{len(names):4}  " + ", ".join(names[:10]) + (" ..." if len(names) > 10 else ""))
    print(f"seconds: upgrade {sum(r.get('upgrade_s') or 0 for r in rows):.0f}, preview "
          f"{sum(r.get('preview_s') or 0 for r in rows):.0f}, browser {sum(r.get('browser_s') or 0 for r in rows):.0f}")
    slow = sorted((r for r in rows if r.get("preview_s")), key=lambda r: -r["preview_s"])[:slowest]
    print("slowest previews (preview s / upgrade s): " + ", ".join(
        f"{r['project']} {r['preview_s']:.0f} / {r['upgrade_s']:.0f}" for r in slow))
    ratio = sorted((r for r in rows if r.get("preview_s") and r.get("upgrade_s")),
                   key=lambda r: -r["preview_s"] / max(r["upgrade_s"], 0.1))[:slowest]
    print("preview / upgrade, largest: " + ", ".join(
        f"{r['project']} {r['preview_s'] / max(r['upgrade_s'], 0.1):.0f}x" for r in ratio))
    sized = [r for r in rows if "bytes" in r]
    if sized:
        page = max(sized, key=lambda r: r["largest_page"][0])
        script = max(sized, key=lambda r: r["largest_script"][0])
        total = max(sized, key=lambda r: r["bytes"])
        print(f"largest page {page['largest_page'][0] / 1e6:.2f} MB ({page['project']}), largest data script "
              f"{script['largest_script'][0] / 1e6:.2f} MB ({script['project']}), largest preview "
              f"{total['bytes'] / 1e6:.1f} MB in {total['files']} files ({total['project']}); all previews "
              f"{sum(r['bytes'] for r in sized) / 1e6:.0f} MB")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("sweep", help="upgrade --preview every project and open its pages in Chromium")
    s.add_argument("--out", type=Path, required=True, help="JSONL row file (a sweep stopped goes on from it)")
    s.add_argument("--root", type=Path, default=CORPUS, help="folder of project folders (default: the corpus)")
    s.add_argument("--only", nargs="*", default=[], help="project folder names (swept again if swept before)")
    s.add_argument("--timeout", type=float, default=300.0, help="seconds per upgrade")
    s.add_argument("--at", type=float, default=0.5, help="seconds into the animation of the paused page")
    t = sub.add_parser("table")
    t.add_argument("files", type=Path, nargs="+")
    args = ap.parse_args()
    if args.cmd == "sweep":
        if not args.root.is_dir():
            sys.exit(f"{args.root} is absent: the sweep needs the game corpus (or the --root given)")
        sweep(args.out, args.root, args.only, args.timeout, args.at)
    else:
        table(args.files)


if __name__ == "__main__":
    main()

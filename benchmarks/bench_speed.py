"""Where users wait: a library upgrade by phase, one large sprite, and ``dataset``, before and after.

    git worktree add --detach /tmp/main-before main      # the code to compare against
    nice -n 10 .venv/bin/python benchmarks/bench_speed.py --before /tmp/main-before
    nice -n 10 .venv/bin/python benchmarks/bench_speed.py --before /tmp/main-before --only sprite

Every measurement runs in a fresh process, once with the code of ``--before`` on
``PYTHONPATH`` and once with that of ``--after`` (default this checkout), one after the other, and the table puts the two
side by side with their ratio (above 1 is faster now: before / after for times, after / before
for rates).

``upgrade``: ``upgrade_library`` of a folder of copied corpus projects (``--projects``, default a
fixed list of 30 that holds the projects where most skeletons share one atlas, the 60-page
and 11-page atlases, WebP pages and premultiplied pages) with ``--jobs`` workers. Columns:
the run's own phase timings (read/plan, mesh, write; wall seconds as the run reports them),
wall and CPU seconds of the whole process (parent and workers), the atlas pages decoded, and
the image encodes: Pillow ``tobytes`` and ``save`` calls and OpenCV ``imencode`` calls made in
the planning process. The outputs of the two runs are compared byte for byte.

``project``: the same columns for ``upgrade_project`` of one corpus project (``--project``,
default the one whose atlas has 60 pages): the command most users run.

``read``: reading and planning alone (``upgrade_project`` with ``dry_run``) of every corpus
project, one after the other in one process: CPU seconds and page decodes, in all and for the
eight projects that took longest before, and the user CPU alone in all (the system time, mostly
the kernel handing out the decoded pages' memory, moves most on a shared machine); ``--repeat``
runs per side, the two sides taking turns, each project's best kept.

``sprite``: ``spinemesh mesh`` on two 6000x6000 sprites written by this script (a textured
one, :func:`bench_mesher.textured_sprite`, and a corpus page scaled 1.5x and tiled), start-up
excluded: CPU seconds of the command's work (user and system apart, and wall seconds; the
command's runs back to back) and of its loading, mask and meshing, best of ``--repeat`` runs in
one process; the ``mesh.json`` files are compared byte for byte. Then the decoders side by side on the same
files (Pillow, OpenCV, imagecodecs' libspng and libpng, and ``load_rgba`` of this checkout; CPU
seconds, best of three, texels checked equal), and the floor under any PNG decoder: inflating
the file's compressed stream alone (zlib, zlib-ng, libdeflate), before a row is unfiltered.

``decode``: every PNG, WebP and JPEG of the examples and the corpus, decoded as ``load_rgba``
did before imagecodecs (Pillow), by imagecodecs on the file as it is (libpng, libwebp,
libjpeg-turbo: what ``load_rgba`` did before PNG rows were inflated by libdeflate) and by
``load_rgba`` of this checkout, in this process: CPU seconds by format, Pillow's and
``load_rgba``'s texels compared.

``dataset``: ``build_dataset`` of the same projects with ``--jobs`` workers: samples, wall,
samples/s, CPU seconds (parent and workers) and samples per CPU-second (x cores = the rate on
an idle machine); the data sets are compared byte for byte (their ``index`` rows included).
Then each project's extraction alone, one after the other in one process (OpenCV on one thread,
as in a worker), and the span of ``--jobs`` workers taking them in order: samples / span is the
rate that many idle cores would give, the parent's writing left out.

The machine may be shared: the load average is printed, CPU seconds are the fairer figure,
and both runs of a row are made back to back so that they meet the same load.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
from bench_upgrade import tree_digest  # noqa: E402  (one hash of a folder's files for the benchmarks)

CORPUS = REPO.parent / "shared" / "spine-corpus"

#: 30 corpus projects: the ten with several skeletons on one atlas, the largest atlases (60, 17
#: and 11 pages), premultiplied and WebP pages, and others of every Spine version.
PROJECTS = (
    "stake-symbols", "kraken-symbols", "gtl-symbols", "nf-symbols", "cm-symbols", "dq-symbols", "wg-symbols",
    "dm-symbols", "jt-jungle", "degamex-degamers", "vsp-man", "dq-ui", "color-nature", "jt-people",
    "pail-crowd-w1", "dm-ui", "ajpet-griffin", "wine-carriage", "coh-robot1", "gm-21454", "bmyq-bigwin",
    "cafe-waiter", "hieu-char", "isk-bats", "js-bird", "sakura-girl", "tga-hero", "verse-neko", "wg-ui",
    "zse-cabin",
)

#: Counters patched into the child process: page decodes and image encodes. Decodes are counted
#: in shared memory, so that those of forked worker processes (pages decoded ahead of the
#: planning) count as the planning process's own do; encodes are the planning process's.
COUNTERS = r"""
import multiprocessing, cv2, PIL.Image, spinemesh.images.decode as _im
DECODES = multiprocessing.Value("q", 0)
ENCODES = [0]
def _counting(f, key):
    def wrapped(*a, **k):
        if key == "decodes":
            with DECODES.get_lock():
                DECODES.value += 1
        else:
            ENCODES[0] += 1
        return f(*a, **k)
    return wrapped
def counts():
    return {"decodes": DECODES.value, "encodes": ENCODES[0]}
_im.load_rgba = _counting(_im.load_rgba, "decodes")
PIL.Image.Image.tobytes = _counting(PIL.Image.Image.tobytes, "encodes")
PIL.Image.Image.save = _counting(PIL.Image.Image.save, "encodes")
cv2.imencode = _counting(cv2.imencode, "encodes")
"""

UPGRADE = COUNTERS + r"""
import json, resource, sys, time
from spinemesh.upgrade import Options, upgrade_library, upgrade_project
from spinemesh.upgrade.library import is_library
library, out, jobs = sys.argv[1], sys.argv[2], int(sys.argv[3])
t = time.perf_counter()
r = (upgrade_library if is_library(library) else upgrade_project)(library, out, Options(jobs=jobs))
wall = time.perf_counter() - t
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
cpu = me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime
print(json.dumps({"wall": wall, "cpu": cpu, **r.seconds, "meshed": r.counts().get("meshed", 0), **counts()}))
"""

SPRITE = r"""
import json, os, sys, time
from pathlib import Path
from spinemesh.cli.mesh import _one
from spinemesh.images.decode import load_rgba
from spinemesh.mesher import compute_mask, mesh_image, resolve_params
image, out, repeat = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
params = resolve_params("default", mask_source="auto")
best = {k: float("inf") for k in ("total", "user", "system", "wall", "load", "mask", "mesh")}
_one(image, "default", {"mask_source": "auto"}, out, None, None)  # imports done: start-up excluded
# The command's runs come back to back, as a user's do; the steps are timed apart afterwards
# (steps between the runs would leave the kernel fewer free huge pages for the next run's
# buffers, and it would compact memory for them: system time a user does not see).
for _ in range(repeat):  # best of: a shared machine only ever adds time
    t0 = os.times(); w0 = time.perf_counter()
    _one(image, "default", {"mask_source": "auto"}, out, None, None)  # what the command does
    t1 = os.times()
    best["wall"] = min(best["wall"], time.perf_counter() - w0)
    best["user"] = min(best["user"], t1.user - t0.user)
    best["system"] = min(best["system"], t1.system - t0.system)
    best["total"] = min(best["total"], t1.user - t0.user + t1.system - t0.system)
for _ in range(repeat):
    t0 = time.process_time(); rgba = load_rgba(image)
    t1 = time.process_time(); mask = compute_mask(rgba, params.mask_source, params.alpha_threshold)
    t2 = time.process_time(); mesh_image(rgba, params, mask=mask)
    t3 = time.process_time()
    for k, v in (("load", t1 - t0), ("mask", t2 - t1), ("mesh", t3 - t2)):
        best[k] = min(best[k], v)
    del rgba, mask
print(json.dumps(best))
"""

READ = COUNTERS + r"""
import json, resource, sys, tempfile, time
from pathlib import Path
from spinemesh.errors import SpineMeshError
from spinemesh.upgrade import Options, upgrade_project
rows = {}
for folder in sys.argv[1:]:
    before, t, u = counts()["decodes"], time.process_time(), resource.getrusage(resource.RUSAGE_SELF).ru_utime
    try:
        upgrade_project(folder, Path(tempfile.mkdtemp()) / "out", Options(dry_run=True))
    except SpineMeshError:  # a project the reader refuses counts as nothing here
        continue
    user = resource.getrusage(resource.RUSAGE_SELF).ru_utime - u
    rows[Path(folder).name] = (time.process_time() - t, counts()["decodes"] - before, user)
print(json.dumps(rows))
"""

DATASET = r"""
import json, resource, sys, time
from spinemesh.dataset import build_dataset
library, out, jobs = sys.argv[1], sys.argv[2], int(sys.argv[3])
t = time.perf_counter()
s = build_dataset([library], out, jobs=jobs)
wall = time.perf_counter() - t
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"wall": wall, "cpu": me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime,
                  "samples": s.total_samples}))
"""

#: Each project's extraction alone (one process, OpenCV on one thread as in a worker), then the
#: time two workers taking the projects in order need: the rate two idle cores would give.
DATASET_SPREAD = r"""
import heapq, json, sys, time
from pathlib import Path
import cv2
from spinemesh.dataset.build import _project_names
from spinemesh.dataset.extract import extract_project
cv2.setNumThreads(1)
library, jobs = Path(sys.argv[1]), int(sys.argv[2])
costs = []
for folder, name in _project_names([library]):
    t = time.process_time()
    extract_project(folder, name)
    costs.append(time.process_time() - t)
free = [0.0] * jobs
for c in costs:
    heapq.heappush(free, heapq.heappop(free) + c)
print(json.dumps({"cpu": sum(costs), "largest": max(costs), "makespan": max(free)}))
"""


def child(code: str, pythonpath: Path, *args) -> dict:
    """Run ``code`` in a fresh interpreter that imports ``spinemesh`` from ``pythonpath``; its last line as JSON."""
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    # -P: the current folder (this checkout) must not come before PYTHONPATH on sys.path
    r = subprocess.run([sys.executable, "-P", "-c", code, *map(str, args)], capture_output=True, text=True, env=env,
                       cwd=tempfile.gettempdir())
    if r.returncode != 0:
        sys.exit(f"run with {pythonpath} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def run_into(code: str, pythonpath: Path, label: str, library: Path, out: Path, jobs: int) -> dict:
    """One side's run of ``code`` over ``library`` into ``out``: its figures and a digest of what it wrote."""
    row = child(code, pythonpath, library, out, jobs)
    row["digest"] = tree_digest(out)
    print(f"  {label}: {row['wall']:.1f} s, spinemesh from {pythonpath}", file=sys.stderr)
    return row


def library_of(projects: list[str], folder: Path) -> Path:
    """A folder holding copies of the corpus projects (``upgrade`` does not follow symlinked projects)."""
    import shutil

    folder.mkdir(parents=True, exist_ok=True)
    for name in projects:
        shutil.copytree(CORPUS / name, folder / name)
    return folder


def ratio(before: float, after: float) -> str:
    return f"{before / after:6.2f}x" if after > 0 else "     -"


def bench_upgrade(before: Path, after: Path, library: Path, tmp: Path, jobs: int, title: str) -> bool:
    """``upgrade`` of ``library`` (a folder of projects, or one project) by both sides, phase by phase."""
    b, a = (run_into(UPGRADE, code, label, library, tmp / f"upgrade-{label}", jobs)
            for label, code in (("before", before), ("after", after)))
    print(f"\n## {title}, --jobs {jobs}\n")
    print(f"{'':14} {'before':>9} {'after':>9} {'ratio':>7}")
    for key, fmt in (("read", ".1f"), ("mesh", ".1f"), ("write", ".1f"), ("wall", ".1f"), ("cpu", ".1f"),
                     ("decodes", "d"), ("encodes", "d"), ("meshed", "d")):
        name = {"read": "read/plan s", "mesh": "mesh s", "write": "write s", "wall": "wall s", "cpu": "CPU s",
                "decodes": "page decodes", "encodes": "image encodes", "meshed": "meshed"}[key]
        print(f"{name:14} {b[key]:>9{fmt}} {a[key]:>9{fmt}} {ratio(b[key], a[key]) if key != 'meshed' else '':>7}")
    share = a["read"] / max(a["read"] + a["mesh"] + a["write"], 1e-9)
    print(f"{'read share':14} {b['read'] / max(b['read'] + b['mesh'] + b['write'], 1e-9):>9.0%} {share:>9.0%}")
    same = b["digest"] == a["digest"]
    print(f"same output bytes: {'yes' if same else 'NO'}")
    return same


def sprites(folder: Path) -> list[Path]:
    """The two 6000x6000 sprites, written once into ``folder``."""
    import cv2
    import numpy as np
    from PIL import Image

    from bench_mesher import textured_sprite

    textured, tiled = folder / "textured-6000.png", folder / "tiled-6000.png"
    if not textured.is_file():
        Image.fromarray(textured_sprite(6000)).save(textured)
    if not tiled.is_file():
        with Image.open(CORPUS / "jt-jungle" / "jungle.png") as im:
            page = np.array(im.convert("RGBA"))
        page = cv2.resize(page, None, fx=1.5, fy=1.5, interpolation=cv2.INTER_CUBIC)
        img = np.zeros((6000, 6000, 4), np.uint8)
        h, w = page.shape[:2]
        for y in range(0, 6000, h):
            for x in range(0, 6000, w):
                part = page[:6000 - y, :6000 - x]
                img[y:y + part.shape[0], x:x + part.shape[1]] = part
        img[:40], img[-40:], img[:, :40], img[:, -40:] = 0, 0, 0, 0  # a transparent border: a sprite
        Image.fromarray(img).save(tiled)
    return [textured, tiled]


def bench_sprite(before: Path, after: Path, images: list[Path], tmp: Path, repeat: int) -> bool:
    same = True
    print(f"\n## spinemesh mesh on a 6000x6000 sprite (CPU s, best of {repeat}, start-up excluded)\n")
    print(f"{'sprite':18} {'step':8} {'before':>8} {'after':>8} {'ratio':>7}")
    for image in images:
        rows = {label: child(SPRITE, code, image, tmp / f"{image.stem}-{label}.mesh.json", repeat)
                for label, code in (("before", before), ("after", after))}
        for step in ("load", "mask", "mesh", "total", "user", "system", "wall"):
            b, a = rows["before"][step], rows["after"][step]
            name = {"wall": "wall s", "user": "  user", "system": "  system"}.get(step, step)
            print(f"{image.stem:18} {name:8} {b:8.2f} {a:8.2f} {ratio(b, a):>7}")
        same &= (tmp / f"{image.stem}-before.mesh.json").read_bytes() == (tmp / f"{image.stem}-after.mesh.json").read_bytes()
    print(f"same mesh.json bytes: {'yes' if same else 'NO'}")
    bench_decoders(images)
    return same


def bench_decoders(images: list[Path]) -> None:
    """Pillow, OpenCV and imagecodecs decodes of the same files, best CPU of three, texels checked
    equal; then the floor: inflating the PNG's compressed stream alone, without unfiltering a row."""
    import time

    import cv2
    import imagecodecs
    import numpy as np
    from PIL import Image

    from spinemesh.images.decode import load_rgba

    def pil_array(p):
        with Image.open(p) as im:
            return np.array(im.convert("RGBA"))

    def pil_asarray(p):
        with Image.open(p) as im:
            im.load()
            return np.asarray(im if im.mode == "RGBA" else im.convert("RGBA"))

    def cv2_imdecode(p):
        a = cv2.imdecode(np.fromfile(p, np.uint8), cv2.IMREAD_UNCHANGED)
        return cv2.cvtColor(a, cv2.COLOR_BGRA2RGBA, dst=a)

    decoders = {"Pillow np.array": pil_array, "Pillow np.asarray (before)": pil_asarray,
                "cv2.imdecode + swap": cv2_imdecode,
                "imagecodecs spng_decode": lambda p: imagecodecs.spng_decode(p.read_bytes()),
                "imagecodecs png_decode": lambda p: imagecodecs.png_decode(p.read_bytes()),
                "load_rgba (this checkout)": load_rgba}
    inflaters = {"inflate only: zlib": lambda z, n: imagecodecs.zlib_decode(z, out=n),
                 "inflate only: zlib-ng": lambda z, n: imagecodecs.zlibng_decode(z, out=n),
                 "inflate only: libdeflate": lambda z, n: imagecodecs.deflate_decode(z, out=n)}
    print("\ndecoders (CPU s, best of 3):\n")
    print(f"{'decoder':28} " + " ".join(f"{p.stem:>15}" for p in images))
    best = {name: [float("inf")] * len(images) for name in (*decoders, *inflaters)}
    for i, p in enumerate(images):
        ref = None
        stream, raw_size = idat_stream(p)
        for _ in range(3):
            for name, f in decoders.items():
                t = time.process_time()
                a = f(p)
                best[name][i] = min(best[name][i], time.process_time() - t)
                ref = a if ref is None else ref
                assert np.array_equal(ref, a), f"{name} gives other texels for {p}"
                del a
            for name, f in inflaters.items():
                t = time.process_time()
                assert len(f(stream, raw_size)) == raw_size
                best[name][i] = min(best[name][i], time.process_time() - t)
    for name in best:
        print(f"{name:28} " + " ".join(f"{s:15.2f}" for s in best[name]))
    print("same texels: yes")


def idat_stream(path: Path) -> tuple[bytes, int]:
    """A PNG's compressed image stream (its IDAT chunks joined) and the size of the filtered rows it inflates to."""
    import struct

    data = path.read_bytes()
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[colour]
    parts, at = [], 8
    while at < len(data):
        size, kind = struct.unpack(">I4s", data[at:at + 8])
        if kind == b"IDAT":
            parts.append(data[at + 8:at + 8 + size])
        at += 12 + size
    return b"".join(parts), height * (1 + (width * channels * depth + 7) // 8)


def bench_decode_corpus(roots: list[Path]) -> bool:
    """Every PNG, WebP and JPEG of the examples and the corpus: Pillow (as ``load_rgba`` decoded
    before imagecodecs), imagecodecs on the file as it is, and ``load_rgba`` of this checkout;
    CPU seconds by format, Pillow's and ``load_rgba``'s texels compared."""
    import time

    import imagecodecs
    import numpy as np
    from PIL import Image

    from spinemesh.images.decode import load_rgba

    codec_of = {".png": imagecodecs.png_decode, ".webp": imagecodecs.webp_decode, ".jpg": imagecodecs.jpeg8_decode}

    files = sorted(p for root in roots for p in root.rglob("*")
                   if p.suffix.lower() in (".png", ".webp", ".jpg", ".jpeg") and p.is_file())
    rows: dict[str, list] = {}
    differ = []
    for p in files:
        t = time.process_time()
        with Image.open(p) as im:
            im.load()
            before = np.asarray(im if im.mode == "RGBA" else im.convert("RGBA"))
        t1 = time.process_time()
        after = load_rgba(p)
        t2 = time.process_time()
        kind = p.suffix.lower().replace(".jpeg", ".jpg")
        codec_of[kind](p.read_bytes())  # texels as the codec gives them (RGB, palette expanded): timed only
        t3 = time.process_time()
        row = rows.setdefault(kind, [0, 0.0, 0.0, 0.0])
        row[0] += 1
        row[1] += t1 - t
        row[2] += t2 - t1
        row[3] += t3 - t2
        if not np.array_equal(before, after):
            differ.append(p)
    print(f"\n## decoding every image of {', '.join(r.name for r in roots)} (CPU s)\n")
    print(f"{'format':8} {'files':>6} {'Pillow':>8} {'imagecodecs':>11} {'load_rgba':>9} {'Pillow/load':>11} "
          f"{'codecs/load':>11}")
    for name, (n, b, c, a) in sorted((k, (v[0], v[1], v[3], v[2])) for k, v in rows.items()):
        print(f"{name:8} {n:>6d} {b:8.2f} {c:11.2f} {a:9.2f} {ratio(b, a):>11} {ratio(c, a):>11}")
    print(f"same texels: {'yes' if not differ else 'NO: ' + ', '.join(map(str, differ[:5]))}")
    return not differ


def bench_read(before: Path, after: Path, projects: list[Path], repeat: int = 1) -> None:
    """Reading and planning alone: a dry run of each project, one process, CPU seconds and page decodes.

    ``repeat`` runs per side, before and after taking turns, each project's best CPU kept: a
    shared machine only ever adds time, and taking turns gives both sides its quiet moments.
    """
    rows: dict[str, dict] = {"before": {}, "after": {}}
    for _ in range(repeat):
        for label, code in (("before", before), ("after", after)):
            for name, (cpu, decodes, user) in child(READ, code, *projects).items():
                best = rows[label].get(name)
                rows[label][name] = (cpu, decodes, user) if best is None \
                    else (min(best[0], cpu), decodes, min(best[2], user))
    b, a = rows["before"], rows["after"]
    print(f"\n## reading and planning (dry run), {len(a)} projects, one process, best of {repeat} per side\n")
    print(f"{'project':22} {'CPU before':>10} {'CPU after':>10} {'ratio':>7} {'decodes before':>14} {'after':>6}")
    worst = sorted(a, key=lambda k: -b.get(k, (0, 0))[0])[:8]
    for name in ["all"] + worst:
        if name == "all":
            cb, db = sum(v[0] for v in b.values()), sum(v[1] for v in b.values())
            ca, da = sum(v[0] for v in a.values()), sum(v[1] for v in a.values())
        else:
            (cb, db, _), (ca, da, _) = b[name], a[name]
        print(f"{name:22} {cb:10.2f} {ca:10.2f} {ratio(cb, ca):>7} {db:14d} {da:6d}")
    # The kernel's share (handing out the decoded pages' memory) moves most from run to run
    ub, ua = sum(v[2] for v in b.values()), sum(v[2] for v in a.values())
    print(f"{'all, user CPU only':22} {ub:10.2f} {ua:10.2f} {ratio(ub, ua):>7}")


def bench_dataset(before: Path, after: Path, library: Path, tmp: Path, jobs: int) -> bool:
    b, a = (run_into(DATASET, code, label, library, tmp / f"dataset-{label}", jobs)
            for label, code in (("before", before), ("after", after)))
    print(f"\n## dataset, {len(list(library.iterdir()))} corpus projects, --jobs {jobs}\n")
    print(f"{'':18} {'before':>9} {'after':>9} {'ratio':>7}")
    print(f"{'samples':18} {b['samples']:>9d} {a['samples']:>9d}")
    print(f"{'wall s':18} {b['wall']:>9.1f} {a['wall']:>9.1f} {ratio(b['wall'], a['wall']):>7}")
    print(f"{'samples/s (wall)':18} {b['samples'] / b['wall']:>9.0f} {a['samples'] / a['wall']:>9.0f} "
          f"{ratio(b['wall'], a['wall']):>7}")
    print(f"{'CPU s':18} {b['cpu']:>9.1f} {a['cpu']:>9.1f} {ratio(b['cpu'], a['cpu']):>7}")
    print(f"{'samples/CPU-s':18} {b['samples'] / b['cpu']:>9.0f} {a['samples'] / a['cpu']:>9.0f} "
          f"{ratio(b['cpu'], a['cpu']):>7}")
    same = b["digest"] == a["digest"]
    print(f"same data set bytes: {'yes' if same else 'NO'}")
    spread = {label: child(DATASET_SPREAD, code, library, jobs) for label, code in (("before", before), ("after", after))}
    print(f"\nprojects one by one (one process), and {jobs} workers taking them in order:\n")
    print(f"{'':28} {'before':>9} {'after':>9} {'ratio':>7}")
    for key, name in (("cpu", "extraction CPU s"), ("largest", "largest project CPU s"),
                      ("makespan", f"{jobs} workers' span s")):
        print(f"{name:28} {spread['before'][key]:>9.1f} {spread['after'][key]:>9.1f} "
              f"{ratio(spread['before'][key], spread['after'][key]):>7}")
    b_rate, a_rate = (a["samples"] / spread[k]["makespan"] for k in ("before", "after"))
    print(f"{'samples/s on idle cores':28} {b_rate:>9.0f} {a_rate:>9.0f} {a_rate / b_rate:>6.2f}x"
          "  (the parent's writing left out)")
    return same


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, required=True, help="a checkout of the code to compare against")
    ap.add_argument("--after", type=Path, default=REPO, help="the code measured (default: this checkout)")
    ap.add_argument("--projects", nargs="+", default=list(PROJECTS), help="corpus project folders to upgrade")
    ap.add_argument("--jobs", type=int, default=2, help="workers of the upgrade and dataset runs (default 2)")
    ap.add_argument("--project", default="degamex-degamers",
                    help="corpus project of the one-project run (default: the one with the most pages, 60)")
    ap.add_argument("--only", choices=("upgrade", "project", "read", "sprite", "decode", "dataset"), nargs="+",
                    default=["upgrade", "read", "sprite", "decode", "dataset"], help="which measurements (default all)")
    ap.add_argument("--repeat", type=int, default=3, help="sprite and read runs per side, the best kept (default 3)")
    ap.add_argument("--sprites", type=Path, default=Path(tempfile.gettempdir()) / "spinemesh-bench-sprites",
                    help="where the 6000x6000 sprites are written once (default: the temporary folder)")
    args = ap.parse_args()
    for code in (args.before, args.after):
        if not (code / "spinemesh").is_dir():
            sys.exit(f"{code} holds no spinemesh package")
    missing = [p for p in args.projects if not (CORPUS / p).is_dir()]
    if missing:
        sys.exit(f"not in {CORPUS}: {', '.join(missing)}")
    print(f"cores available: {len(os.sched_getaffinity(0))}, load average {os.getloadavg()[0]:.1f}, "
          f"before: {args.before}, after: {args.after}")
    # What this process measures itself (the decoders) is the code of --after, not whichever
    # spinemesh the interpreter would find first (an installed one, say).
    sys.path.insert(0, str(args.after))
    same = True
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        library = library_of(args.projects, tmp / "library")
        if "upgrade" in args.only:
            same &= bench_upgrade(args.before, args.after, library, tmp, args.jobs,
                                  f"upgrade_library, {len(args.projects)} corpus projects")
        if "project" in args.only:  # the command most users run: one project
            one = library_of([args.project], tmp / "one") / args.project
            same &= bench_upgrade(args.before, args.after, one, tmp / "one", args.jobs,
                                  f"upgrade_project, {args.project}")
        if "read" in args.only:  # every corpus project: reading is where pages are decoded
            bench_read(args.before, args.after, sorted(p for p in CORPUS.iterdir() if p.is_dir()), args.repeat)
        if "sprite" in args.only:
            args.sprites.mkdir(parents=True, exist_ok=True)
            same &= bench_sprite(args.before, args.after, sprites(args.sprites), tmp, args.repeat)
        if "decode" in args.only:
            same &= bench_decode_corpus([CORPUS.parent / "spine-examples", CORPUS])
        if "dataset" in args.only:
            same &= bench_dataset(args.before, args.after, library, tmp, args.jobs)
    if not same:
        sys.exit("outputs differ between before and after")


if __name__ == "__main__":
    main()

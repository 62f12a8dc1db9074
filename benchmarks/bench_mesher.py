"""Benchmark the auto-mesher against the artists' own meshes.

Every image in ``../shared/spine-examples/4.2/*/images/`` (deduplicated by pixel content) is
meshed with each preset; artist meshes come from the 4.2 editor ``.json`` skeletons
(attachments of ``"type": "mesh"``; pixel position = uv * image size). Plus one generated
6000 x 6000 sprite for the large-image timing.

Run::

    .venv/bin/python benchmarks/bench_mesher.py            # all images
    .venv/bin/python benchmarks/bench_mesher.py --limit 50 # quicker

Prints, per preset, the median of each metric and the time, then the comparison with the
artists' meshes of the same images, and the CLAUDE-SPINE peer figures as quoted in issue 4.

Times are CPU seconds of this process (``time.process_time``, OpenCV on one thread), so that
they do not depend on what else runs on a shared machine; wall times are printed beside them.
The large-image timing uses a generated *textured* sprite (noisy colour, a torn edge, specks
around it), since a smooth shape is the easy case.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.images.decode import load_rgba  # noqa: E402
from spinemesh.mesher import mesh_image  # noqa: E402
from spinemesh.metrics import (angle_ratio, boundary_adherence, coverage,  # noqa: E402
                               mesh_problems, opaque_mask, significant_edges, waste)

EXAMPLES = REPO.parent / "shared" / "spine-examples" / "4.2"

#: The open-source CLAUDE-SPINE mesher, figures as quoted in issue 4 (not measured by us).
PEER_CLAUDE_SPINE = {"waste": 0.09, "vertices": 76, "coverage": "misses some pixels"}


def sprite_images() -> tuple[dict[str, Path], dict[Path, str]]:
    """(content hash -> first image path, every image path -> content hash), over 4.2 images."""
    out: dict[str, Path] = {}
    every: dict[Path, str] = {}
    for png in sorted(EXAMPLES.glob("*/images/**/*.png")):
        im = load_rgba(png)
        h = hashlib.sha1(np.array(im.shape).tobytes() + im.tobytes()).hexdigest()
        out.setdefault(h, png)
        every[png] = h
    return out, every


def artist_meshes(by_hash_path: dict[Path, str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Content hash -> (vertices px (n,2), triangles (m,3)) of the first artist mesh of that image.

    Meshes and linked meshes (which reuse their parent mesh's UVs and triangles over their own
    image); the image is ``images/<path or name or key>.png`` (first frame of a sequence).
    """
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    sizes: dict[Path, tuple[int, int]] = {}
    for js in sorted(EXAMPLES.glob("*/*.json")):
        doc = json.loads(js.read_text(encoding="utf-8"))
        skins = doc.get("skins", [])
        if isinstance(skins, dict):  # 3.x layout, not expected in 4.2
            skins = [{"name": k, "attachments": v} for k, v in skins.items()]
        by_skin = {sk.get("name"): sk.get("attachments", {}) for sk in skins}
        for skin in skins:
            for slot, atts in sorted(skin.get("attachments", {}).items()):
                for key, att in sorted(atts.items()):
                    geo = att
                    if att.get("type") == "linkedmesh":
                        parent_skin = by_skin.get(att.get("skin", "default"), {})
                        geo = parent_skin.get(slot, {}).get(att.get("parent"), {})
                    elif att.get("type") != "mesh":
                        continue
                    if "uvs" not in geo or "triangles" not in geo:
                        continue
                    rel = str(att.get("path") or att.get("name") or key)
                    seq = att.get("sequence")
                    if isinstance(seq, dict):
                        rel += str(int(seq.get("start", 1))).zfill(int(seq.get("digits", 0)))
                    png = js.parent / "images" / f"{rel}.png"
                    h = by_hash_path.get(png)
                    if h is None or h in out:
                        continue
                    if png not in sizes:
                        im = load_rgba(png)
                        sizes[png] = (im.shape[1], im.shape[0])
                    w, hh = sizes[png]
                    uv = np.asarray(geo["uvs"], dtype=np.float64).reshape(-1, 2)
                    tri = np.asarray(geo["triangles"], dtype=np.int64).reshape(-1, 3)
                    out[h] = (uv * [w, hh], tri)
    return out


def generated_sprite(size: int = 6000) -> np.ndarray:
    """A deterministic large sprite: an anti-aliased body with coloured parts and a hole."""
    img = np.zeros((size, size, 4), np.uint8)
    c = size // 2
    cv2.ellipse(img, (c, c), (int(size * 0.38), int(size * 0.28)), 15, 0, 360, (200, 120, 60, 255), -1, cv2.LINE_AA)
    cv2.circle(img, (int(c * 0.7), int(c * 0.8)), size // 9, (40, 80, 200, 255), -1, cv2.LINE_AA)
    pts = np.array([[c, int(size * 0.15)], [int(size * 0.8), c], [c, int(size * 0.9)]], np.int32)
    cv2.fillPoly(img, [pts], (90, 200, 90, 255), cv2.LINE_AA)
    cv2.circle(img, (int(c * 1.3), int(c * 1.05)), size // 14, (0, 0, 0, 0), -1, cv2.LINE_AA)
    cv2.circle(img, (int(size * 0.1), int(size * 0.1)), size // 40, (250, 250, 0, 255), -1, cv2.LINE_AA)
    return img


def textured_sprite(size: int = 6000, seed: int = 0) -> np.ndarray:
    """A deterministic large textured sprite: noisy colour at three scales, a torn alpha edge,
    a flat part, a hole and 40 specks scattered around (islands to bridge)."""
    rng = np.random.default_rng(seed)

    def noise(cells, ch=1):
        a = rng.random((cells, cells, ch)).astype(np.float32)
        return cv2.resize(a, (size, size), interpolation=cv2.INTER_CUBIC).reshape(size, size, ch)

    c = size // 2
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32)
    dx, dy = (xx - c) / (size * 0.38), (yy - c) / (size * 0.28)
    r = np.sqrt(dx * dx + dy * dy)
    edge = 1.0 + 0.08 * (noise(24)[..., 0] - 0.5) + 0.03 * (noise(160)[..., 0] - 0.5)
    alpha = np.clip((edge - r) * size * 0.05, 0, 1)
    col = 255 * (0.5 * noise(12, 3) + 0.35 * noise(300, 3) + 0.15 * noise(1500, 3))
    img = np.zeros((size, size, 4), np.uint8)
    img[..., :3] = np.clip(col, 0, 255).astype(np.uint8)
    img[..., 3] = (alpha * 255).astype(np.uint8)
    cv2.circle(img, (int(c * 0.7), int(c * 0.8)), size // 9, (40, 80, 200, 255), -1, cv2.LINE_AA)
    cv2.circle(img, (int(c * 1.3), int(c * 1.05)), size // 14, (0, 0, 0, 0), -1, cv2.LINE_AA)
    for x, y in rng.integers(0, size, (40, 2)):
        cv2.circle(img, (int(x), int(y)), int(rng.integers(3, 30)), (250, 250, 0, 255), -1, cv2.LINE_AA)
    return img


def measure(vertices, triangles, image, edges_px) -> dict:
    art = opaque_mask(image)
    return {
        "coverage": coverage(vertices, triangles, art),
        "waste": waste(vertices, triangles, art),
        # None when the image has no significant internal edge (most small parts)
        "adherence": boundary_adherence(vertices, edges_px) if edges_px.any() else None,
        "angle": angle_ratio(vertices, triangles),
        "vertices": len(vertices),
        "triangles": len(triangles),
        "valid": not mesh_problems(vertices, triangles),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--limit", type=int, default=0, help="only the first N images (0: all)")
    ap.add_argument("--presets", default="default,paper")
    ap.add_argument("--no-large", action="store_true", help="skip the 6000 x 6000 sprites")
    args = ap.parse_args()
    cv2.setNumThreads(1)  # CPU time then measures the work, not the threads' spinning
    if not EXAMPLES.is_dir():
        sys.exit(f"{EXAMPLES} is absent: the benchmark needs the real example images")
    images, path_hash = sprite_images()
    hashes = list(images)
    if args.limit:
        hashes = hashes[: args.limit]
    artists = artist_meshes(path_hash)
    presets = args.presets.split(",")
    rows: dict[str, list[dict]] = {p: [] for p in presets}
    art_rows: dict[str, dict] = {}
    failures = {p: 0 for p in presets}
    for h in hashes:
        img = load_rgba(images[h])
        edges_px = significant_edges(img)
        if h in artists:
            v, t = artists[h]
            art_rows[h] = measure(v, t, img, edges_px)
        for p in presets:
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                m = mesh_image(img, p)
            except SpineMeshError:
                # e.g. the paper preset on a sprite that its 1-px blur erases: no mesh at all
                failures[p] += 1
                continue
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            r = measure(m.vertices, m.triangles, img, edges_px)
            r["ms"] = 1000 * dc
            r["wall_ms"] = 1000 * dt
            r["hash"] = h
            r["side"] = max(img.shape[:2])
            rows[p].append(r)

    def med(vals):
        vals = [v for v in vals if v is not None]
        return float(np.median(vals)) if len(vals) else float("nan")

    n_edges = sum(r["adherence"] is not None for r in rows[presets[0]])
    print(f"\n{len(hashes)} unique images from {EXAMPLES} ({len(art_rows)} with an artist mesh; "
          f"{n_edges} with significant internal edges, over which 'adher.' is the median)\n")
    hdr = f"{'preset':10} {'n':>4} {'cover med':>9} {'cover min':>9} {'100%':>6} {'waste':>6} {'adher.':>6} " \
          f"{'angle':>6} {'verts':>6} {'p90':>5} {'tris':>5} {'valid':>6} {'ms med':>7} {'ms p90':>7} " \
          f"{'p90 all':>7} {'max':>7} {'wall p90':>8}"
    print(hdr)
    print("-" * len(hdr))
    for p in presets:
        rs = rows[p]
        cov = [r["coverage"] for r in rs]
        small = [r["ms"] for r in rs if r["side"] <= 1024]
        print(f"{p:10} {len(rs):4d} {med(cov):9.4f} {min(cov):9.4f} {np.mean([c >= 1.0 for c in cov]):6.1%} "
              f"{med([r['waste'] for r in rs]):6.3f} {med([r['adherence'] for r in rs]):6.3f} "
              f"{med([r['angle'] for r in rs]):6.3f} {med([r['vertices'] for r in rs]):6.1f} "
              f"{np.percentile([r['vertices'] for r in rs], 90):5.0f} {med([r['triangles'] for r in rs]):5.0f} "
              f"{np.mean([r['valid'] for r in rs]):6.1%} {med(small):7.1f} {np.percentile(small, 90):7.1f} "
              f"{np.percentile([r['ms'] for r in rs], 90):7.1f} {max(r['ms'] for r in rs):7.0f} "
              f"{np.percentile([r['wall_ms'] for r in rs], 90):8.1f}"
              + (f"   ({failures[p]} images gave no mesh)" if failures[p] else ""))
    ar = list(art_rows.values())
    if ar:
        cov = [r["coverage"] for r in ar]
        print(f"{'artists':10} {len(ar):4d} {med(cov):9.4f} {min(cov):9.4f} {np.mean([c >= 1.0 for c in cov]):6.1%} "
              f"{med([r['waste'] for r in ar]):6.3f} {med([r['adherence'] for r in ar]):6.3f} "
              f"{med([r['angle'] for r in ar]):6.3f} {med([r['vertices'] for r in ar]):6.1f} "
              f"{np.percentile([r['vertices'] for r in ar], 90):5.0f} {med([r['triangles'] for r in ar]):5.0f} "
              f"{np.mean([r['valid'] for r in ar]):6.1%} {'':>7} {'':>7}")
    print(f"{'CLAUDE-SPINE (quoted in issue 4, not measured)':>10}: waste ~{PEER_CLAUDE_SPINE['waste']:.0%}, "
          f"~{PEER_CLAUDE_SPINE['vertices']} vertices per sprite, {PEER_CLAUDE_SPINE['coverage']}")
    print("paper (quoted, sec. 4): 484 +- 185 vertices, angle ratio 0.42, adherence 78.3%, < 3 s for 6000 px on a GPU")

    if ar:
        print("\nSame images, ours vs the artist's mesh (medians over images that have an artist mesh):")
        print(f"{'preset':10} {'verts ours':>10} {'artist':>7} {'ratio med':>9} {'waste ours':>10} {'artist':>7} "
              f"{'coverage ours':>13} {'artist':>7}")
        for p in presets:
            mine = [r for r in rows[p] if r["hash"] in art_rows]
            if not mine:
                continue
            theirs = [art_rows[r["hash"]] for r in mine]
            ratio = [a["vertices"] / max(b["vertices"], 1) for a, b in zip(mine, theirs)]
            print(f"{p:10} {med([r['vertices'] for r in mine]):10.1f} {med([r['vertices'] for r in theirs]):7.1f} "
                  f"{med(ratio):9.2f} {med([r['waste'] for r in mine]):10.3f} {med([r['waste'] for r in theirs]):7.3f} "
                  f"{med([r['coverage'] for r in mine]):13.4f} {med([r['coverage'] for r in theirs]):7.4f}")

    print("\n(ms: CPU milliseconds per image; 'ms med'/'ms p90' over images up to 1024 px, 'p90 all' and "
          "'max' over all; 'wall p90' in wall-clock ms on this machine as loaded)")
    if not args.no_large:
        for label, big in (("smooth", generated_sprite()), ("textured", textured_sprite())):
            large(label, big, presets)


def large(label: str, big: np.ndarray, presets: list[str]) -> None:
    """Time each preset on one large sprite (median of 3 CPU times) and measure its mesh."""
    print(f"\nGenerated {big.shape[1]}x{big.shape[0]} {label} sprite (CPU seconds):")
    art = opaque_mask(big)
    for p in presets:
        times = []
        for _ in range(3):  # the first call also pays for page faults on the 144 MB image
            t0 = time.process_time()
            m = mesh_image(big, p)
            times.append(time.process_time() - t0)
        print(f"  {p:10} first {times[0]:5.2f} s, median of 3 {np.median(times):5.2f} s   "
              f"{len(m.vertices)} vertices, {len(m.triangles)} triangles, "
              f"coverage {coverage(m.vertices, m.triangles, art):.4f}, waste {waste(m.vertices, m.triangles, art):.3f}")

if __name__ == "__main__":
    main()

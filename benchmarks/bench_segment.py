"""CPU time of the segmentation mask paths, per image, on real-size inputs.

Times the shipped ONNX model (alone, with the flood fill combination, with a test-time
flip), any other ONNX models given (each with its card beside it), the classical baselines,
and, when torch and a checkpoint are given, the torch forward pass, on synthetic sprites
flattened onto solid, gradient and coarse-noise backgrounds. The methods take turns image by
image. Prints median and fastest milliseconds with ratios to the shipped model.

    .venv/bin/python benchmarks/bench_segment.py --threads 2 --repeat 20
    .venv/bin/python benchmarks/bench_segment.py --onnx previous/segment.onnx --checkpoint runs/segment/best.pt
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from spinemesh.segment import DEFAULT_MODEL, model_card, predict_mask  # noqa: E402
from spinemesh.segment.baseline import floodfill_mask, grabcut_mask  # noqa: E402
from spinemesh.segment.composite import BACKGROUNDS, flatten  # noqa: E402
from spinemesh.segment.preprocess import to_input  # noqa: E402


def sprite(h: int, w: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    r = ((yy - h / 2) / (h * 0.4)) ** 2 + ((xx - w / 2) / (w * 0.35)) ** 2
    a = np.clip((1 - r) * 10, 0, 1) * 255
    rgb = np.clip(rng.integers(40, 200, 3) + 50 * np.sin(yy / 9)[..., None], 0, 255)
    return np.dstack([rgb, a]).astype(np.uint8)


def timed_together(fns: dict, images, repeat: int, clock=time.perf_counter) -> dict[str, tuple[float, float]]:
    """(median, fastest) milliseconds per call of each function, taking turns image by image
    (after one warm-up each), so that a shared machine's changing load hits all alike. On a
    loaded machine the fastest call is the better estimate of an idle one; ``clock``
    ``time.process_time`` counts the CPU time of all the process's threads instead, which
    load changes little (with one thread it is the idle machine's wall time)."""
    for fn in fns.values():
        fn(images[0])
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeat):
        for img in images:
            for name, fn in fns.items():
                t0 = clock()
                fn(img)
                times[name].append(clock() - t0)
    return {name: (1000 * float(np.median(t)), 1000 * float(np.min(t))) for name, t in times.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=2, help="ONNX Runtime / torch threads")
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--size", type=int, nargs=2, default=(512, 384), help="image height width, pixels")
    ap.add_argument("--onnx", type=Path, nargs="*", default=[], help="more ONNX models (card beside, or same "
                    "input size as the shipped one)")
    ap.add_argument("--checkpoint", type=Path, help="a best.pt, to time the torch forward pass too")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall", help="wall time, or the CPU time of "
                    "all threads (steadier on a shared machine; use with --threads 1)")
    args = ap.parse_args()

    h, w = args.size
    images = [flatten(sprite(h, w, i), BACKGROUNDS[i % 3], np.random.default_rng(i)) for i in range(3)]
    card = model_card()
    fns = {f"network, shipped ({card.get('precision', '?')}, {card['input_size']} px, "
           f"{DEFAULT_MODEL.stat().st_size / 2**20:.1f} MB)":
               lambda im: predict_mask(im, threads=args.threads, flips=False, floodfill=False),
           "  + flood fill where unsure on a flat background (shipped default)":
               lambda im: predict_mask(im, threads=args.threads, flips=False, floodfill=True),
           "  + test-time flip": lambda im: predict_mask(im, threads=args.threads, flips=True, floodfill=False)}
    for path in args.onnx:
        if not path.with_suffix(".json").is_file():
            raise SystemExit(f"{path}: its model card {path.with_suffix('.json')} is missing")
        fns[f"network, {path.name} ({model_card(path)['input_size']} px, {path.stat().st_size / 2**20:.1f} MB)"] = \
            lambda im, p=path: predict_mask(im, p, threads=args.threads, flips=False, floodfill=False)
    if args.checkpoint:
        import torch
        from spinemesh.train.export import load_checkpoint

        torch.set_num_threads(args.threads)
        torch.set_flush_denormal(True)
        model = load_checkpoint(args.checkpoint)
        size = model.config["image_size"]

        @torch.no_grad()
        def forward(im):
            return model(torch.from_numpy(to_input(im, size)[None]))

        fns[f"network, torch forward ({size} px)"] = forward
    fns["baseline: border flood fill"] = floodfill_mask
    clock = time.process_time if args.clock == "cpu" else time.perf_counter
    rows = list(timed_together(fns, images, args.repeat, clock).items())
    rows += list(timed_together({"baseline: GrabCut (at most 256 px)": grabcut_mask}, images,
                                max(1, args.repeat // 3), clock).items())

    ref = rows[0][1][0]
    print(f"{args.clock} time per {w}x{h} image, {args.threads} thread(s), {args.repeat} rounds x 3 images, "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'method':<68} {'median ms':>10} {'fastest ms':>11} {'x shipped':>10}")
    for name, (ms, fastest) in rows:
        print(f"{name:<68} {ms:10.1f} {fastest:11.1f} {ms / ref:10.2f}")


if __name__ == "__main__":
    main()

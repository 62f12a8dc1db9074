"""CPU time of the segmentation mask paths (issue 7), per image, on real-size inputs.

Times the shipped ONNX model (and any other ONNX models given), the classical baselines,
and, when torch and a checkpoint are given, the torch forward pass, on synthetic sprites
flattened onto the three kinds of background. Prints a table with ratios to the shipped
model.

    .venv/bin/python benchmarks/bench_segment.py --threads 2 --repeat 20
    .venv/bin/python benchmarks/bench_segment.py --onnx /tmp/seg-runs/lite0.fp32.onnx --checkpoint /tmp/seg-runs/lite0/best.pt
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


def timed(fn, images, repeat: int) -> tuple[float, float]:
    """(median, fastest) milliseconds per call over ``repeat`` rounds of ``images`` (after one
    warm-up). On a shared machine the fastest call is the better estimate of an idle one."""
    fn(images[0])
    times = []
    for _ in range(repeat):
        for img in images:
            t0 = time.perf_counter()
            fn(img)
            times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times)), 1000 * float(np.min(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=2, help="ONNX Runtime / torch threads")
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--size", type=int, nargs=2, default=(512, 384), help="image height width, pixels")
    ap.add_argument("--onnx", type=Path, nargs="*", default=[], help="more ONNX models (card beside, or same "
                    "input size as the shipped one)")
    ap.add_argument("--checkpoint", type=Path, help="a best.pt, to time the torch forward pass too")
    args = ap.parse_args()

    h, w = args.size
    images = [flatten(sprite(h, w, i), BACKGROUNDS[i % 3], np.random.default_rng(i)) for i in range(3)]
    card = model_card()
    rows = [(f"network, shipped ({card.get('precision', '?')}, {card['input_size']} px, "
             f"{DEFAULT_MODEL.stat().st_size / 2**20:.1f} MB)",
             timed(lambda im: predict_mask(im, threads=args.threads, flips=False, floodfill=False), images,
                   args.repeat)),
            ("  + flood fill where unsure on a flat background",
             timed(lambda im: predict_mask(im, threads=args.threads, flips=False, floodfill=True), images,
                   args.repeat)),
            ("  + test-time flip",
             timed(lambda im: predict_mask(im, threads=args.threads, flips=True, floodfill=False), images,
                   args.repeat))]
    for path in args.onnx:
        if not path.with_suffix(".json").is_file():
            import shutil
            shutil.copy(DEFAULT_MODEL.with_suffix(".json"), path.with_suffix(".json"))
        rows.append((f"network, {path.name} ({path.stat().st_size / 2**20:.1f} MB)",
                     timed(lambda im, p=path: predict_mask(im, p, threads=args.threads), images, args.repeat)))
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

        rows.append((f"network, torch forward ({size} px)", timed(forward, images, args.repeat)))
    rows.append(("baseline: border flood fill", timed(floodfill_mask, images, args.repeat)))
    rows.append(("baseline: GrabCut (at most 256 px)", timed(grabcut_mask, images, max(1, args.repeat // 3))))

    ref = rows[0][1][0]
    print(f"CPU time per {w}x{h} image, {args.threads} thread(s), {args.repeat} rounds x 3 images, "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'method':<58} {'median ms':>10} {'fastest ms':>11} {'x shipped':>10}")
    for name, (ms, fastest) in rows:
        print(f"{name:<58} {ms:10.1f} {fastest:11.1f} {ms / ref:10.2f}")


if __name__ == "__main__":
    main()

"""Runtime proof of the preview's player: its frames look like the official runtime's renders.

For each skeleton file given as ``SKELETON:ANIMATION`` (default: the 4.2 examples' spineboy-pro
"run", celestial-circus-pro "swing" (physics) and raptor-pro "walk"): its skeleton, atlas and
pages are copied into a scratch project, upgraded (default options), and the preview written;
then the animation at ``--time`` is rendered by the official runtime (render.mjs, original and
upgraded in one frame) and drawn by the player in headless Chromium in that frame, and the
share of pixels off by more than 32/255 (premultiplied) is printed per side, with the worst
pixel and the visible pixels the player lost. The tests hold the demo and spineboy to
``RENDER_TOLERANCE`` (tests/test_preview.py).

    .venv/bin/python scripts/prove_preview.py
    .venv/bin/python scripts/prove_preview.py ../shared/spine-examples/4.2/owl/owl-pro.json:blink --time 0.3
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO))

from browser import against_the_runtime  # noqa: E402
from runtime_tool import install  # noqa: E402

EXAMPLES = REPO.parent / "shared" / "spine-examples" / "4.2"
DEFAULT = [f"{EXAMPLES}/spineboy/spineboy-pro.json:run", f"{EXAMPLES}/celestial-circus/celestial-circus-pro.json:swing",
           f"{EXAMPLES}/raptor/raptor-pro.json:walk"]


def prove(skeleton: Path, anim: str, time: float, tool: Path, tmp: Path) -> list[dict]:
    """Upgrade a copy of ``skeleton``'s project (the skeleton, its atlas, its pages), write the
    preview and compare the player with the runtime; the two sides' differences."""
    from spinemesh.project import find_project, image_source_for
    from spinemesh.skeleton import load_skeleton
    from spinemesh.upgrade import Options, upgrade_project
    from spinemesh.upgrade.preview import write_preview

    project = tmp / "project"
    project.mkdir(parents=True)
    source = image_source_for(load_skeleton(skeleton), skeleton, find_project(skeleton))
    atlases = [a.path for a in source.atlases]
    shutil.copy(skeleton, project)
    for atlas in atlases:
        shutil.copy(atlas, project)
        for page in source.atlases[atlases.index(atlas)].pages:
            shutil.copy(atlas.parent / page.name, project)
    result = upgrade_project(project, tmp / "out", Options())
    index = write_preview(result, project, tmp / "out", tmp / "preview")
    page = next(index.parent.glob("s/*.html")).name
    model = next(index.parent.glob("data/*/model.js")).read_text(encoding="utf-8")
    names = re.findall(r'"name":"([^"]+)","dur"', model)
    atlas = project / atlases[0].name
    return against_the_runtime(tool, tmp, index.parent, page, names.index(anim), anim,
                               (atlas, project / skeleton.name), (tmp / "out" / atlas.name, tmp / "out" / skeleton.name),
                               time)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", metavar="SKELETON:ANIMATION")
    ap.add_argument("--time", type=float, default=0.5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        tool = install(tmp / "spine-runtime")
        print(f"{'skeleton':<28}{'animation':<12}{'side':<10}{'off >32/255':>12}{'worst':>7}{'lost':>7}{'visible':>10}")
        for i, case in enumerate(args.cases or DEFAULT):
            path, anim = case.rsplit(":", 1)
            diffs = prove(Path(path), anim, args.time, tool, tmp / str(i))
            for side, d in zip(("original", "upgraded"), diffs):
                print(f"{Path(path).name:<28}{anim:<12}{side:<10}{d['off_share']:>11.4%}{d['worst']:>7}{d['lost']:>7}"
                      f"{d['visible']:>10,}", flush=True)


if __name__ == "__main__":
    main()

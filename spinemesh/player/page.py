"""The player's part of a skeleton's page, and the scripts it loads.

:func:`write_player` writes, under the preview folder, ``player.js`` (once: the drawing code,
:file:`player.js` beside this module), ``data/<id>/model.js`` (the images and the attachment
tables of both sides) and one ``data/<id>/<animation>.<skin>.js`` per animation and skin
sampled, and returns the HTML that shows the player. Nothing is inlined but that small HTML.
"""

from __future__ import annotations

import html
import json
import math
from importlib import resources

from .files import PreviewFolder
from .frames import Animation, EncodedAnimation, SideTable, encode_animation

#: The player's styles, for the pages that show it.
PLAYER_CSS = """
.player .controls{display:flex;flex-wrap:wrap;gap:8px;align-items:center;margin:6px 0}
.player .controls input[type=range]{width:260px}.player .clock{font-variant-numeric:tabular-nums;min-width:110px}
.player .stage{display:flex;flex-wrap:wrap;gap:16px}.player figure{margin:0}
.player figcaption{font-size:12px;color:#555;text-align:center}
.player .status{color:#555;font-size:12px;min-height:1.2em;overflow-wrap:anywhere}
.player select{max-width:100%}.player .found{color:#555;font-size:12px}
.checker{background:repeating-conic-gradient(#d8d8d8 0 25%,#f4f4f4 0 50%) 0 0/16px 16px;border:1px solid #bbb}
"""


def player_script() -> str:
    """The player's drawing code (the text of :file:`player.js`)."""
    return resources.files(__package__).joinpath("player.js").read_text(encoding="utf-8")


def write_player(folder: PreviewFolder, pid: str, page_rel: str, animations: list[Animation | EncodedAnimation],
                 image_of) -> str:
    """Write the scripts of one skeleton's player and return the HTML that shows it.

    Parameters
    ----------
    folder : PreviewFolder
    pid : str
        The skeleton's id in the preview (a safe file name).
    page_rel : str
        The page's path under the preview folder (script and image paths are made relative
        to it).
    animations : list of Animation or EncodedAnimation
        At least one (the setup pose as a still animation when nothing else); encoded here
        where not yet (:func:`spinemesh.player.frames.encode_animation`).
    image_of : callable
        ``image_of(image path) -> rgba or None``: the attachment's original image (what
        :class:`spinemesh.images.sources.RegionImage` gives), RGBA (H, W, 4) uint8.
    """
    up = "../" * page_rel.count("/")
    if "player.js" not in folder.sizes:
        folder.write_text("player.js", player_script())
    images: list[str] = []
    index: dict[str, int | None] = {}

    def image_index(path: str) -> int | None:
        if path not in index:
            rgba = image_of(path)
            index[path] = None if rgba is None else len(images)
            if rgba is not None:
                images.append(up + folder.image(rgba))
        return index[path]

    tables = {side: SideTable(image_index) for side in ("before", "after")}
    animations = [a if isinstance(a, EncodedAnimation) else encode_animation(a) for a in animations]
    skins = list(dict.fromkeys(s for a in animations for s in a.by_skin))
    anims = []
    for i, a in enumerate(animations):
        # by the skin's place in ``skins``, never keyed by its name: a name is any text, and in the
        # script's object literal "__proto__" sets no property (the player loaded "[object Object]")
        src: list[str | None] = [None] * len(skins)
        dur = a.duration if math.isfinite(a.duration) else 0.0  # nothing that is not a number is written
        for skin, (frames, box, (before, after)) in a.by_skin.items():
            at = skins.index(skin)
            data = {"n": frames, "fps": a.rate, "dur": dur, "box": [round(v, 4) for v in box], "note": a.note,
                    "before": tables["before"].absorb(before), "after": tables["after"].absorb(after)}
            rel = f"data/{pid}/{i}.{at}.js"
            text = json.dumps(data, separators=(",", ":"), allow_nan=False)
            folder.write_text(rel, f"SM.frames({json.dumps(f'{pid}/{i}/{at}')},{text});\n")
            src[at] = up + rel
        anims.append({"name": a.name, "dur": dur, "src": src})
    model = {"images": images, "skins": skins, "anims": anims,
             "sides": {k: t.rows for k, t in tables.items()}}
    folder.write_text(f"data/{pid}/model.js",
                      f"SM.model({json.dumps(pid)},{json.dumps(model, separators=(',', ':'), allow_nan=False)});\n")
    return (f'<div class="player" id="player-{html.escape(pid)}"></div>'
            f'<script src="{up}player.js"></script><script src="{up}data/{html.escape(pid)}/model.js"></script>')

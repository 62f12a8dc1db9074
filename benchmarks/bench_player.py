"""The preview's player in headless Chromium, on written previews: how fast its page shows a
frame, whether every animation plays, the memory of the page once every animation was shown,
and the CPU it takes paused and playing, with this tree's ``player.js`` and, with
``--compare-with``, another's, side by side.

Each preview folder given (what ``upgrade --preview`` wrote) is measured on its skeleton page
with the most animations: a copy of the folder (hard links) gets the player measured, then the
page is opened in headless Chromium (the tests' flags, ``tests/browser.py``, on real time: the
Chrome DevTools protocol over ``--remote-debugging-pipe``, no library needed) and:

- **first frame**: seconds from the address given to the player's first animation loaded and
  every image it draws decoded;
- **CPU, % of a core**: the browser's processes over ``--seconds`` (jiffies from ``/proc``),
  paused, then playing the setup pose (a still: nothing moves), then playing the longest
  animation; and while playing, the frames the player drew a second (both canvases cleared);
- **every animation**: each chosen in turn and drawn at 0, 0.37 and 0.71 of its duration: how
  many loaded, are of 0 s, draw nothing, show frames that change, show one picture throughout;
- **renderer memory**: the proportional set size of the page's renderer processes once every
  animation was shown (the player keeps the frames of those it was shown).

The index is opened too (seconds to its ``load``). A machine shared with other work disturbs the
CPU shares: compare columns of one run.

Usage::

    .venv/bin/python benchmarks/bench_player.py PREVIEW [PREVIEW ...] [--compare-with OLD] [--seconds 5]

``OLD``: a checkout (its ``spinemesh/player/player.js``) or a ``player.js``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from browser import DevTools  # noqa: E402

#: The page's player, for the scripts below.
PLAYER = "Object.values(SM.players)[0]"
#: True once the player drew its first animation with every image decoded.
READY = ("(function(){var P=window.SM&&SM.players&&Object.values(SM.players)[0];"
         "return !!(P&&P.data&&P.images.every(function(i){return !i||(i.complete&&i.naturalWidth)}));})()")
#: A canvas's pixels as one number (0: nothing drawn).
CHECKSUM = ("(function(c){var px=c.getContext('2d').getImageData(0,0,c.width,c.height).data,s=0,a=0;"
            "for(var i=0;i<px.length;i+=4){s=(s*31+px[i+3]+px[i])%1000000007;a+=px[i+3];}return a?s:0;})")


def page_with_most_animations(preview: Path) -> Path:
    """The skeleton page of ``preview`` whose player lists the most animations."""
    counts = {m.parent.name: m.read_text(encoding="utf-8").count('"src":') for m in preview.glob("data/*/model.js")}
    return preview / "s" / f"{max(counts, key=counts.get)}.html"


def every_animation(tools: DevTools) -> dict:
    """Each animation chosen in turn and drawn at three times: what became of them."""
    count = tools.js(f"{PLAYER}.model.anims.length")
    out = {"animations": count, "loaded": 0, "of 0 s": 0, "draw nothing": 0, "frames change": 0, "one picture": 0}
    for i in range(count):
        tools.js(f"(function(){{var P={PLAYER};P.data=null;P.anim={i};P.t=0;P.choose();}})()")
        if not tools.wait(f"!!{PLAYER}.data", timeout=60):
            continue
        out["loaded"] += 1
        sums = tools.js(f"(function(){{var P={PLAYER},c=document.querySelectorAll('#'+CSS.escape('player-'+P.id)+' canvas'),"
                        f"o=[];[0,0.37,0.71].forEach(function(f){{P.t=f*P.data.dur;P.draw();"
                        f"o.push({CHECKSUM}(c[0]),{CHECKSUM}(c[1]));}});return [P.data.dur,o];}})()")
        duration, pictures = sums
        kind = ("of 0 s" if duration == 0 else "draw nothing" if not any(pictures) else
                "frames change" if len(set(pictures[0::2])) > 1 or len(set(pictures[1::2])) > 1 else "one picture")
        out[kind] += 1
    return out


#: Counts the canvases cleared (each drawing of a frame clears both) in ``window.smCleared``.
COUNT_DRAWS = ("(function(){if(window.smCleared!==undefined)return;window.smCleared=0;"
               "var p=CanvasRenderingContext2D.prototype,f=p.clearRect;"
               "p.clearRect=function(){window.smCleared++;return f.apply(this,arguments);};})()")


def playing(tools: DevTools, seconds: float) -> tuple[float, float]:
    """Over the next ``seconds``: percent of a core the browser took, and frames the player drew a second."""
    tools.js(COUNT_DRAWS)
    cleared = tools.js("window.smCleared")
    cpu = tools.cpu_share(seconds)
    return cpu, round((tools.js("window.smCleared") - cleared) / 2 / seconds, 1)


def measure_page(page: Path, seconds: float) -> dict:
    """The figures of one skeleton page (the module's list), in a browser of its own."""
    profile = Path(tempfile.mkdtemp(prefix="bench-player-"))
    tools = DevTools(profile)
    try:
        start = time.perf_counter()
        tools.call("Page.navigate", url=page.resolve().as_uri())
        shown = tools.wait(READY)
        out = {"first frame, s": round(time.perf_counter() - start, 2) if shown else None}
        time.sleep(1)
        out["CPU paused, %"] = tools.cpu_share(seconds)
        tools.js(f"{PLAYER}.setPlaying(true)")
        time.sleep(1)
        out["CPU playing the setup pose, %"], out["frames drawn a second, the setup pose"] = playing(tools, seconds)
        tools.js(f"{PLAYER}.setPlaying(false)")
        out |= every_animation(tools)
        out["renderer MB after every animation"] = tools.renderer_mb()
        longest = tools.js(f"(function(){{var a={PLAYER}.model.anims,m=0;a.forEach(function(x,i){{if(x.dur>a[m].dur)m=i}});"
                           "return m})()")
        tools.js(f"(function(){{var P={PLAYER};P.data=null;P.anim={longest};P.choose();P.setPlaying(true)}})()")
        tools.wait(f"!!{PLAYER}.data")
        time.sleep(1)
        out["CPU playing the longest, %"], out["frames drawn a second, the longest"] = playing(tools, seconds)
        out["the longest's frames a second"] = round(tools.js(f"{PLAYER}.data.fps"), 2)
    finally:
        tools.close()
        shutil.rmtree(profile, ignore_errors=True)
    return out


def index_seconds(preview: Path) -> float:
    """Seconds headless Chromium takes to the index's ``load``."""
    profile = Path(tempfile.mkdtemp(prefix="bench-player-"))
    tools = DevTools(profile)
    try:
        start = time.perf_counter()
        tools.call("Page.navigate", url=(preview / "index.html").resolve().as_uri())
        tools.wait("document.readyState === 'complete'")
        return round(time.perf_counter() - start, 2)
    finally:
        tools.close()
        shutil.rmtree(profile, ignore_errors=True)


def with_player(preview: Path, player: Path, where: Path) -> Path:
    """A copy of ``preview`` under ``where`` (hard links) playing with ``player``."""
    copy = where / preview.name
    shutil.copytree(preview, copy, copy_function=os.link)
    (copy / "player.js").unlink()
    shutil.copyfile(player, copy / "player.js")
    return copy


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("previews", nargs="+", type=Path)
    parser.add_argument("--compare-with", type=Path, help="a checkout, or a player.js")
    parser.add_argument("--seconds", type=float, default=5.0, help="seconds each CPU share is measured over")
    args = parser.parse_args()
    players = {"this tree": REPO / "spinemesh" / "player" / "player.js"}
    if args.compare_with:
        old = args.compare_with
        players["compared"] = old if old.is_file() else old / "spinemesh" / "player" / "player.js"
    for preview in args.previews:
        page = page_with_most_animations(preview)
        columns = {}
        for label, player in players.items():
            with tempfile.TemporaryDirectory() as where:
                copy = with_player(preview, player, Path(where))
                columns[label] = measure_page(copy / "s" / page.name, args.seconds)
                columns[label]["index opened, s"] = index_seconds(copy)
        print(f"\n{preview.name}: {page.name}")
        print("| | " + " | ".join(columns) + " |\n|---|" + "--:|" * len(columns))
        for row in columns["this tree"]:
            print(f"| {row} | " + " | ".join(str(c[row]) for c in columns.values()) + " |")


if __name__ == "__main__":
    main()

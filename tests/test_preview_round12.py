"""The preview's player at any size of project, in headless Chromium: a skeleton of 500
animations with hostile names (thousands of characters, HTML and script, emoji), one of 0 s and
one of an hour. The player draws the animation its list shows however fast choices come, redraws
nothing while nothing moves, stays as wide as the window, and finds an animation by a part of
its name. Each page is driven by a script added to a copy of it (the page itself is unchanged)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from spinemesh.demo import make_demo_project
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.preview import write_preview

#: Hostile names: each must reach the page as text, never as markup or script.
LONG = "L" * 3000
SMILES = "\U0001F642" * 100  # characters outside the 16-bit plane: a cut between halves shows as garbage
MARKUP = "<img src=x onerror=window.smInjected=1>"
SCRIPT = "</script><script>window.smInjected=2</script>"
SKELETON = "<b>x<i>\"onload=window.smInjected=3'" + "S" * 180


@pytest.fixture(scope="module")
def crowded(tmp_path_factory) -> tuple[Path, list[str]]:
    """The demo's skeleton with 500 more animations and hostile names, previewed: its page and
    the player's animation list (the setup pose first)."""
    tmp = tmp_path_factory.mktemp("crowded")
    demo = make_demo_project(tmp / "demo")
    doc = json.loads((demo / "demo.json").read_text())
    wave = doc["animations"]["wave"]
    doc["animations"] = {"wave": wave, "still": {},
                         "hour": {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 3600, "value": 90}]}}},
                         MARKUP: wave, SCRIPT: wave, "__proto__": wave, LONG: wave, SMILES: wave}
    doc["animations"] |= {f"anim {i:03d} {'walk' if i % 3 else 'idle'}": wave for i in range(500)}
    (demo / "demo-binary.skel").unlink()
    (demo / "demo.json").unlink()
    (demo / f"{SKELETON}.json").write_text(json.dumps(doc))
    result = upgrade_project(demo, tmp / "out", Options(jobs=1))
    index = write_preview(result, demo, tmp / "out", tmp / "preview")
    return next(index.parent.glob("s/*.html")), ["setup pose", *doc["animations"]]


#: What every driver script starts with: the page's player, a wait, the report the tests read.
DRIVER = """
var P = window.SM ? Object.values(SM.players)[0] : null, list = document.querySelector('select[aria-label=animation]');
function when(ok, then) { (function poll() { if (ok()) then(); else setTimeout(poll, 20); })(); }
function pick(i) { list.value = String(i); list.dispatchEvent(new Event('change')); }
function report(o) { var pre = document.createElement('pre'); pre.id = 'sm-test'; pre.textContent = JSON.stringify(o);
                     document.body.appendChild(pre); }
"""


def driven(page: Path, script: str, tmp_path: Path, *args: str, budget_ms: int = 6000) -> dict:
    """Open a copy of ``page`` (beside it) running :data:`DRIVER` and ``script`` once the page has
    loaded; what the script reported."""
    from browser import player_result

    copy = page.with_name(f"driven-{tmp_path.name}.html")
    text = page.read_text(encoding="utf-8")
    copy.write_text(text.replace("</body>", f"<script>{DRIVER}{script}</script></body>"), encoding="utf-8")
    try:
        return player_result(copy.resolve().as_uri(), tmp_path, *args, budget_ms=budget_ms)
    finally:
        copy.unlink()


def test_the_player_draws_the_animation_its_list_shows_however_fast_it_is_chosen(crowded, tmp_path):
    """A keyboard's arrows choose an animation at every press: the frames of an animation still
    loading when another is chosen never replace the other's (the list said "setup pose", the
    canvases played "wave")."""
    page, names = crowded
    got = driven(page, """
    when(function () { return P.data; }, function () {
      pick(1); pick(0);  // wave's frames are loading when the setup pose (loaded) is chosen again
      setTimeout(function () {
        var seen = { listed: +list.value, anim: P.anim, drawn: P.data.dur, n: P.data.n };
        pick(1);  // loaded by now: drawn at once
        seen.waveLoaded = P.data.dur;
        report(seen);
      }, 1500);
    });""", tmp_path)
    assert names[1] == "wave" and got["waveLoaded"] > 0, got
    assert got["listed"] == got["anim"] == 0 and (got["drawn"], got["n"]) == (0, 1), got


def test_the_player_redraws_nothing_while_nothing_moves(crowded, tmp_path):
    """Playing a still (the setup pose, an animation of 0 s) or an animation between its frames (an
    hour sampled every 12 s) draws nothing and asks the browser for no frame until the next is due
    (its clock aside, a few times a second):
    a page left playing burnt a core redrawing the same picture 60 times a second. A moving
    animation still plays, drawn once per frame of its own. The browser's frames and timers are
    played by the test on a clock of its own (headless Chromium on virtual time makes a few frames
    a second, whatever a page asks)."""
    page, names = crowded
    got = driven(page, """
    var clears = 0, clear = CanvasRenderingContext2D.prototype.clearRect, requests = 0, clock = 0, queued = [], timers = [];
    CanvasRenderingContext2D.prototype.clearRect = function () { clears++; return clear.apply(this, arguments); };
    var realTimeout = window.setTimeout.bind(window);
    window.requestAnimationFrame = function (f) { requests++; queued.push(f); return queued.length; };
    window.cancelAnimationFrame = function () {};
    window.setTimeout = function (f, ms) { timers.push([clock + (ms || 0), f]); return -timers.length; };
    window.clearTimeout = function () {};
    performance.now = function () { return clock; };
    function second() {  // 60 frames of 1/60 s: the timers due, then the frames asked for
      clears = 0; requests = 0;
      var seen = {}, time = document.querySelector('.player .clock').textContent;
      for (var k = 0; k < 60; k++) {
        clock += 1000 / 60;
        timers.filter(function (t) { return t[0] <= clock; }).forEach(function (t) { timers.splice(timers.indexOf(t), 1); t[1](); });
        var now = queued; queued = [];
        now.forEach(function (f) { f(clock); });
        seen[Math.floor(P.t * P.data.fps + 1e-6)] = 1;
      }
      return { draws: clears / 2, requests: requests, frames: Object.keys(seen).length, t: P.t,
               clock: [time, document.querySelector('.player .clock').textContent] };
    }
    var out = {}, steps = [['setup', 0], ['still', %d], ['hour', %d], ['wave', %d]];
    function next() {
      if (!steps.length) { report(out); return; }
      var step = steps.shift(), i = step[1];
      pick(i);
      (function ready() {  // its frames loaded (the page's scripts come in on the browser's own time)
        if (P.data && P.anim === i && P.data.dur === P.model.anims[i].dur) { out[step[0]] = second(); next(); }
        else realTimeout(ready, 20);
      })();
    }
    (function start() { if (P.data) { document.querySelector('.player button').click(); next(); } else realTimeout(start, 20); })();
    """ % (names.index("still"), names.index("hour"), names.index("wave")), tmp_path, budget_ms=8000)
    for name in ("setup", "still"):
        assert got[name]["draws"] == 0 and got[name]["requests"] <= 1, (name, got)
    # between the hour's frames, its clock only, 4 times a second (it stood still for 12 s)
    hour = got["hour"]
    assert hour["draws"] == 0 and hour["requests"] <= 5 and hour["clock"][0] != hour["clock"][1], got
    wave = got["wave"]  # sampled at 2 frames a second (the hour spends the skeleton's budget)
    assert wave["t"] > 0.9 and wave["frames"] >= 2 and wave["frames"] - 1 <= wave["draws"] <= wave["frames"], got


@pytest.mark.parametrize("width", [1280, 500])
def test_names_of_any_length_or_markup_leave_the_page_as_wide_as_the_window(crowded, tmp_path, width):
    """A name of 3,000 characters made the animation list 22,000 pixels wide and the page scroll
    sideways; names with markup and script reach the page as text; a name cut for the list is cut
    between characters (never between the halves of an emoji) and is whole in its title."""
    page, names = crowded
    got = driven(page, """
    when(function () { return P.data; }, function () {
      var o = [].map.call(list.options, function (x) { return [x.textContent, x.title]; });
      report({ scroll: document.documentElement.scrollWidth, window: innerWidth, options: o,
               injected: window.smInjected || 0, title: document.title, h1: document.querySelector('h1').textContent });
    });""", tmp_path, f"--window-size={width},800")
    assert got["injected"] == 0 and SKELETON in got["title"] and SKELETON in got["h1"], got["title"]
    assert got["scroll"] <= got["window"], (got["scroll"], got["window"])
    if width == 1280:  # the index too, its table naming the skeleton (at 500, its columns of figures scroll)
        index = driven(page.parent.parent / "index.html", "report({ scroll: document.documentElement.scrollWidth, "
                       "window: innerWidth });", tmp_path, f"--window-size={width},800")
        assert index["scroll"] <= index["window"], index
    assert [title for _, title in got["options"]] == names
    labels = {title: text for text, title in got["options"]}
    assert labels[MARKUP].startswith(MARKUP) and labels[SCRIPT].startswith(SCRIPT)
    assert labels[LONG] == "L" * 59 + "… (1.00 s)", labels[LONG]
    assert labels[SMILES] == SMILES[:59] + "… (1.00 s)", labels[SMILES]


def test_an_animation_is_found_by_a_part_of_its_name(crowded, tmp_path):
    """Among 508 animations a list's own search finds only by the first letters typed: the player
    offers a box that narrows the list to the names holding the text typed, and shows the first."""
    page, names = crowded
    got = driven(page, """
    when(function () { return P.data; }, function () {
      var find = document.querySelector('input[type=search]');
      find.value = '9 IDLE'; find.dispatchEvent(new Event('input'));
      var shown = [].filter.call(list.options, function (o) { return !o.hidden; }).map(function (o) { return o.title; });
      when(function () { return P.data && P.data.dur > 0; }, function () {
        report({ shown: shown, listed: +list.value, anim: P.anim, found: document.querySelector('.found').textContent });
      });
    });""", tmp_path)
    wanted = [n for n in names if "9 idle" in n]
    assert len(wanted) == 17 and got["shown"] == wanted, got["shown"]
    assert got["listed"] == got["anim"] == names.index("anim 009 idle"), got
    assert got["found"] == f"17 of {len(names)}", got["found"]


def test_a_phone_shows_the_player_at_its_own_width(crowded, tmp_path):
    """On a phone's screen (360 pixels, a mobile browser) the pages are laid out at the screen's
    width, the canvases within it: without a viewport a phone lays a page out at 980 pixels and
    shrinks it, the player's canvases a third of the screen wide; the index's tables, wider than
    a phone, scroll in their own box, where they widened the page or broke its names a letter a
    line."""
    from browser import DevTools

    page, _ = crowded
    tools = DevTools(tmp_path / "profile")
    try:
        tools.as_a_phone()
        tools.call("Page.navigate", url=page.resolve().as_uri())
        assert tools.wait("!!(window.SM && SM.players && Object.values(SM.players)[0].data)", timeout=60)
        got = tools.layout("canvas")
        tools.call("Page.navigate", url=(page.parent.parent / "index.html").resolve().as_uri())
        assert tools.wait("document.readyState === 'complete'", timeout=60)
        index = tools.layout("table.sum td:first-child", width=True)
    finally:
        tools.close()
    assert got["window"] == 360 and got["scroll"] <= 360, got
    assert len(got["boxes"]) == 2 and all(0 <= left and right <= 360 for left, right in got["boxes"]), got
    assert min(right - left for left, right in got["boxes"]) > 240, got  # and not a thumbnail
    # the index too: its tables scroll in their own box, their names readable (not a letter a line)
    assert index["window"] == 360 and index["scroll"] <= 360, index
    assert index["boxes"] and min(index["boxes"]) > 150, index


def test_a_page_shown_every_animation_keeps_the_frames_of_the_last_few(crowded, tmp_path):
    """Each animation's frames are a script of up to 4 MB: a page shown each of 500 animations in
    turn kept every one (and its script element). It keeps those of the last 12 shown: one shown
    again after more is read again from its file, the last shown is not, and the scripts run are
    taken out of the page."""
    page, names = crowded
    got = driven(page, """
    var added = [];
    new MutationObserver(function (changes) {
      changes.forEach(function (c) { [].forEach.call(c.addedNodes, function (n) { if (n.src) added.push(n.src); }); });
    }).observe(document.head, { childList: true });
    var first = %d, order = [];
    for (var i = 0; i < 20; i++) order.push(first + i);
    function show(list, then) {
      if (!list.length) { then(); return; }
      var i = list.shift();
      pick(i);
      when(function () { return P.data && P.anim === i && !/^loading/.test(document.querySelector('.player .status').textContent); },
           function () { setTimeout(function () { show(list, then); }, 0); });  // the observer told
    }
    show(order, function () {
      var before = added.length;
      show([first + 19], function () {  // the last shown: held
        var again = added.length;
        show([first], function () {  // shown 19 choices ago: read again
          report({ loaded: before, lastAgain: again - before, firstAgain: added.length - again,
                   scripts: document.querySelectorAll('script[src*="/data/"]').length });
        });
      });
    });""" % names.index("anim 000 idle"), tmp_path, budget_ms=15000)
    assert got["loaded"] == 20 and got["lastAgain"] == 0 and got["firstAgain"] == 1, got
    assert got["scripts"] == 1, got  # the model's, in the page itself


def test_a_time_or_speed_set_while_the_player_sleeps_between_frames_starts_from_then(crowded, tmp_path):
    """Between frames far apart (an hour sampled every 12 s) the player sleeps on a timer: a speed
    chosen meanwhile played the seconds slept before it at the new speed (6 s at 1x, then 2x, showed
    the frame of 12 s at once), and a time scrubbed to, or an animation chosen, meanwhile had them
    added (the next frame came early). The browser's frames, timers and clock are played by the test on a clock of its own."""
    page, names = crowded
    got = driven(page, """
    var clock = 0, queued = [], timers = [], realTimeout = window.setTimeout.bind(window);
    window.requestAnimationFrame = function (f) { queued.push(f); return queued.length; };
    window.cancelAnimationFrame = function (id) { queued[id - 1] = null; };
    window.setTimeout = function (f, ms) { timers.push([clock + (ms || 0), f]); return timers.length; };
    window.clearTimeout = function (id) { if (timers[id - 1]) timers[id - 1][1] = null; };
    performance.now = function () { return clock; };
    function play(ms) {  // frames of 1/60 s for ms: the timers due, then the frames asked for
      for (var end = clock + ms; clock < end;) {
        clock += 1000 / 60;
        timers.forEach(function (t) { if (t[1] && t[0] <= clock) { var f = t[1]; t[1] = null; f(); } });
        var now = queued; queued = [];
        now.forEach(function (f) { if (f) f(clock); });
      }
      return Math.floor(P.t * P.data.fps + 1e-6);  // the frame shown
    }
    var hour = %d, out = {};
    (function start() {
      if (!(P.data && P.anim === 0)) { realTimeout(start, 20); return; }
      pick(hour);
      (function ready() {
        if (!(P.data && P.anim === hour && P.data.dur === P.model.anims[hour].dur)) { realTimeout(ready, 20); return; }
        document.querySelector('.player button').click();
        out.fps = P.data.fps;
        play(6000);  // asleep till the next frame, 12 s on
        var speed = document.querySelector('select[aria-label=speed]');
        speed.value = '2'; speed.dispatchEvent(new Event('change'));
        out.speed = [play(1000), play(2200)];  // 12 s reached 3 s after, at 2x
        var scrub = document.querySelector('input[type=range]');
        scrub.value = '500'; scrub.dispatchEvent(new Event('input'));
        out.scrub = Math.floor(P.t * P.data.fps + 1e-6);
        out.scrubbed = [play(5500), play(1000)];  // the frame after it 6 s after, at 2x
        play(3000);  // asleep again
        pick(hour);  // chosen again (its frames kept): from its start, at 2x
        out.chosen = [play(5500), play(1000)];
        report(out);
      })();
    })();
    """ % names.index("hour"), tmp_path, budget_ms=8000)
    assert abs(got["fps"] - 1 / 12) < 1e-9, got
    assert got["speed"] == [0, 1], got
    assert got["scrubbed"] == [got["scrub"], got["scrub"] + 1], got
    assert got["chosen"] == [0, 1], got

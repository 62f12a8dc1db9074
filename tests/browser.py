"""Headless Chromium for the tests of the HTML pages we write (installed by scripts/setup.sh)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import time
from pathlib import Path

from conftest import unavailable

#: Flags of every run: no network, no GPU, and pages may read pixels of images beside them
#: (a file:// canvas is otherwise "tainted" and the player's test hook cannot read it back).
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--enable-logging=stderr", "--v=0",
         "--allow-file-access-from-files"]


def chromium() -> str:
    """The browser's path; a skip (a failure in CI) when it is not installed."""
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    unavailable("chromium is not installed (scripts/setup.sh installs it as root)")


def run(url: str, tmp: Path, *args: str, budget_ms: int = 5000) -> subprocess.CompletedProcess:
    """Open ``url`` with ``args`` (``--dump-dom``, ``--screenshot=...``) and fail on a page error."""
    tmp.mkdir(parents=True, exist_ok=True)
    profile = tmp / f"profile{len(list(tmp.glob('profile*')))}"
    r = subprocess.run([chromium(), *FLAGS, f"--user-data-dir={profile}", f"--virtual-time-budget={budget_ms}",
                        *args, url], capture_output=True, text=True, timeout=180, env={**os.environ, "HOME": str(tmp)})
    assert r.returncode == 0, r.stderr[-2000:]
    errors = page_errors(r.stderr)
    assert not errors, "\n".join(errors)
    return r


def page_errors(stderr: str) -> list[str]:
    """The page's errors in the browser's log (``--enable-logging=stderr``): uncaught
    exceptions, console errors, files it could not load."""
    return [line for line in stderr.splitlines() if "Uncaught" in line or "net::ERR_FILE_NOT_FOUND" in line
            or ("CONSOLE" in line and ("Error" in line or "Failed" in line))]


def player_result(url: str, tmp: Path, *args: str, budget_ms: int = 5000) -> dict:
    """What the preview player's test hook wrote in ``<pre id="sm-test">`` (see player.js);
    ``args``: more of the browser's flags (``--window-size=1280,720``)."""
    dom = run(url, tmp, "--dump-dom", *args, budget_ms=budget_ms).stdout
    found = re.search(r'<pre id="sm-test">(.*?)</pre>', dom, re.S)
    assert found and found.group(1), f"the player wrote no test result:\n{dom[-1500:]}"
    return json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))


def canvases(got: dict) -> list:
    """The player's two canvases (original, upgraded) its test hook wrote, RGBA arrays."""
    import base64

    from spinemesh.images.decode import decode_rgba

    return [decode_rgba(base64.b64decode(got[k].split(",", 1)[1])) for k in ("before", "after")]


def against_the_runtime(tool: Path, tmp: Path, preview: Path, page: str, anim_index: int, anim: str,
                        original: tuple[Path, Path], upgraded: tuple[Path, Path], time: float = 0.5,
                        frame: tuple[float, float, float, float] | None = None) -> list[dict]:
    """Render ``anim`` at ``time`` with the official runtime (``original`` and ``upgraded``:
    (atlas, skeleton), the second in the first's frame; the first in ``frame``, world x, y,
    width, height, when given, else in its file's bounds) and with our player (the preview's
    ``s/<page>``, its animation ``anim_index``) in that frame; the differences
    (:func:`runtime_tool.render_difference`, 32/255), original then upgraded."""
    from PIL import Image

    from runtime_tool import render, render_difference

    def at(pngs: list[Path]) -> Path:  # the render also writes the setup pose
        return next(p for p in pngs if p.name.endswith(f"{anim}@{time:g}.png"))

    theirs = [at(render(tool, *original, anim, f"{time:g}", tmp / "a", frame=frame))]
    theirs.append(at(render(tool, *upgraded, anim, f"{time:g}", tmp / "b", frame_from=tmp / "a.frame.json")))
    frame = json.loads((tmp / "a.frame.json").read_text())
    f = frame["frame"]
    view = f"{f['x']},{f['y']},{f['width']},{f['height']},{frame['ppu']}"
    got = player_result((preview / "s" / page).resolve().as_uri() + f"#at={anim_index},{time:g},{view}",
                        tmp / "chromium")
    out = []
    for i, ours in enumerate(canvases(got)):
        Image.fromarray(ours).save(tmp / f"ours{i}.png")
        out.append(render_difference(theirs[i], tmp / f"ours{i}.png", tol=32))
    return out


#: A phone's screen width in CSS pixels (:meth:`DevTools.as_a_phone`).
PHONE_WIDTH = 360


class DevTools:
    """Headless Chromium on real time, driven over ``--remote-debugging-pipe`` (the Chrome DevTools
    protocol: JSON messages ended by a NUL byte, commands on the browser's file descriptor 3,
    answers on 4; no library needed), attached to its one page: what a flag cannot ask (a phone's
    screen, key presses, the browser's CPU and memory; ``benchmarks/bench_player.py``)."""

    def __init__(self, profile: Path, size: str = "1280,800"):
        commands, self._to = os.pipe()
        self._from, answers = os.pipe()
        flags = [f for f in FLAGS if f not in ("--enable-logging=stderr", "--v=0")]
        self.profile = str(profile)

        def pipes():  # in the child: the two ends where Chromium looks for them
            os.dup2(commands, 3)
            os.dup2(answers, 4)

        self.process = subprocess.Popen(
            [chromium(), *flags, f"--user-data-dir={profile}", f"--window-size={size}", "--remote-debugging-pipe",
             "about:blank"], preexec_fn=pipes, pass_fds=(3, 4), stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, env={**os.environ, "HOME": str(profile)})
        os.close(commands)
        os.close(answers)
        self._buffer, self._count, self.session = b"", 0, None
        page = next(t for t in self.call("Target.getTargets")["targetInfos"] if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]
        for domain in ("Page", "Runtime", "Performance"):
            self.call(f"{domain}.enable")

    def _message(self) -> dict:
        while b"\0" not in self._buffer:
            chunk = os.read(self._from, 1 << 16)
            if not chunk:
                raise EOFError("the browser closed its pipe")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method: str, **params) -> dict:
        """Send one command (to the page once attached) and return its result."""
        self._count += 1
        message = {"id": self._count, "method": method, "params": params}
        if self.session:
            message["sessionId"] = self.session
        os.write(self._to, json.dumps(message).encode() + b"\0")
        while True:
            got = self._message()
            if got.get("id") == self._count:
                if "error" in got:
                    raise RuntimeError(f"{method}: {got['error']}")
                return got["result"]

    def js(self, expression: str):
        """The value of ``expression`` in the page."""
        got = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in got:
            raise RuntimeError(got["exceptionDetails"])
        return got["result"].get("value")

    def wait(self, expression: str, timeout: float = 120) -> bool:
        """Whether ``expression`` came true within ``timeout`` seconds."""
        end = time.perf_counter() + timeout
        while time.perf_counter() < end:
            if self.js(expression):
                return True
            time.sleep(0.02)
        return False

    def as_a_phone(self) -> None:
        """Lay pages out as a phone's browser does: :data:`PHONE_WIDTH` pixels wide, mobile."""
        self.call("Emulation.setDeviceMetricsOverride", width=PHONE_WIDTH, height=740, deviceScaleFactor=2, mobile=True)

    def layout(self, selector: str, width: bool = False) -> dict:
        """The page's layout: the window's width (``window``), the page's (``scroll``), and the
        left and right edges of each element ``selector`` finds (``boxes``; their widths alone
        with ``width``)."""
        box = "r.width" if width else "[r.left, r.right]"
        return self.js(f"({{ window: innerWidth, scroll: document.documentElement.scrollWidth, boxes: "
                       f"[].map.call(document.querySelectorAll({selector!r}), function (c) {{ "
                       f"var r = c.getBoundingClientRect(); return {box}; }}) }})")

    def processes(self) -> list[int]:
        """The browser's process and every process under it."""
        parents = {}
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    stat = Path(f"/proc/{entry}/stat").read_text()
                except OSError:
                    continue
                parents[int(entry)] = int(stat[stat.rindex(")") + 2:].split()[1])
        ours, grown = {self.process.pid}, True
        while grown:
            new = {p for p, parent in parents.items() if parent in ours} - ours
            ours |= new
            grown = bool(new)
        return sorted(ours)

    def cpu_share(self, seconds: float) -> float:
        """Percent of one core the browser's processes took over the next ``seconds``."""
        def jiffies() -> int:
            total = 0
            for pid in self.processes():
                try:
                    stat = Path(f"/proc/{pid}/stat").read_text()
                except OSError:
                    continue
                fields = stat[stat.rindex(")") + 2:].split()
                total += int(fields[11]) + int(fields[12])
            return total

        start = jiffies()
        time.sleep(seconds)
        return round(100 * (jiffies() - start) / os.sysconf("SC_CLK_TCK") / seconds, 1)

    def renderer_mb(self) -> float:
        """Proportional set size of the browser's renderer processes, MB."""
        total = 0
        for pid in self.processes():
            try:
                if b"--type=renderer" not in Path(f"/proc/{pid}/cmdline").read_bytes():
                    continue
                rollup = Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines()
            except OSError:
                continue
            total += 1024 * int(next(line for line in rollup if line.startswith("Pss:")).split()[1])
        return round(total / 1e6, 1)

    def close(self) -> None:
        try:
            self.call("Browser.close")
        except (EOFError, OSError, RuntimeError):
            pass
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            self.process.kill()

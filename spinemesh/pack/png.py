"""PNG files as small as oxipng makes them, losslessly, in any process.

oxipng (through ``pyoxipng``, MIT) compresses on rayon's pool of threads, made in a process the
first time it runs there. A process forked after that has a copy of the pool but none of its
threads, and oxipng then waits for them for ever (seen in a worker forked under pytest). So a
process that inherited a used pool by fork runs oxipng in a helper process of its own, a new
interpreter (never forked) started on first need and kept while the process lives, which ends
when its pipe closes; every other process runs it in place.
"""

from __future__ import annotations

import os
import struct
import sys

import numpy as np

#: oxipng's effort (0-6). Level 2 took a packed 2048x2048 page from 2.66 MB, as Pillow writes it
#: by default, to 1.78 MB; levels 3 and 4 saved under 1% more for 2 to 3 times the time
#: (docs/benchmarks/pack.md).
LEVEL = 2

_used_here = False  # oxipng ran in this process: rayon's pool of threads lives here
_inherited = False  # this process was forked from one where it had run: the pool's threads are missing
_helper = None  # the helper process that compresses for an _inherited one (subprocess.Popen)


def _after_fork_in_child() -> None:
    global _used_here, _inherited, _helper
    _inherited = _inherited or _used_here
    _used_here, _helper = False, None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _compress(image, shape) -> bytes:
    """oxipng of a PNG file's bytes (``shape`` None) or of raw RGBA / RGB texels of ``shape`` (h, w, channels)."""
    import oxipng

    if shape is None:
        return oxipng.optimize_from_memory(bytes(image), level=LEVEL)
    h, w, channels = shape
    color = oxipng.ColorType.rgba() if channels == 4 else oxipng.ColorType.rgb(None)
    return oxipng.RawImage(image, w, h, color_type=color).create_optimized_png(level=LEVEL)


#: A request to the helper: its data's length, then the texels' shape (-1s for a PNG file's bytes).
_REQUEST = struct.Struct("<qqqq")
#: Its answer: the PNG's length (negative: the length of an error message instead).
_ANSWER = struct.Struct("<q")


def serve() -> None:
    """The helper's loop: requests on stdin, PNG files on stdout, until stdin closes (its parent ended)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is its parent's to handle
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    while True:
        head = stdin.read(_REQUEST.size)
        if len(head) < _REQUEST.size:
            return
        size, h, w, channels = _REQUEST.unpack(head)
        data = stdin.read(size)
        try:
            out = _compress(data, None if h < 0 else (h, w, channels))
            stdout.write(_ANSWER.pack(len(out)) + out)
        except Exception as e:  # noqa: BLE001 - handed back to the caller, which raises it
            message = f"{type(e).__name__}: {e}".encode()
            stdout.write(_ANSWER.pack(-len(message)) + message)
        stdout.flush()


def _in_helper(data: bytes, shape) -> bytes:
    """:func:`_compress` in the helper process (started on first use)."""
    import subprocess
    from pathlib import Path

    global _helper
    if _helper is None or _helper.poll() is not None:
        root = str(Path(__file__).resolve().parents[2])
        code = f"import sys; sys.path.insert(0, {root!r}); from spinemesh.pack.png import serve; serve()"
        _helper = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    h, w, channels = shape if shape is not None else (-1, -1, -1)
    _helper.stdin.write(_REQUEST.pack(len(data), h, w, channels) + data)
    _helper.stdin.flush()
    (size,) = _ANSWER.unpack(_helper.stdout.read(_ANSWER.size))
    answer = _helper.stdout.read(abs(size))
    if size < 0:
        raise RuntimeError(f"oxipng: {answer.decode(errors='replace')}")
    return answer


def optimized_png(image: np.ndarray | bytes) -> bytes:
    """A PNG file of ``image``, as small as oxipng makes it at :data:`LEVEL`, losslessly.

    Parameters
    ----------
    image : ndarray, shape (H, W, 4) or (H, W, 3), uint8; or bytes
        Texels (RGBA or RGB), or a PNG file already encoded (a palette PNG: its palette is kept,
        or reduced where entries go unused).

    Returns
    -------
    bytes
        Every colour of every texel kept, transparent ones included (no alpha optimisation);
        oxipng stores the texels with fewer bits (a palette, grey, fewer bits per channel) only
        where that loses nothing. Callers writing what a runtime reads decode it back first
        (:func:`spinemesh.pack.run.encode_page`).
    """
    global _used_here
    if isinstance(image, np.ndarray):
        data, shape = np.ascontiguousarray(image).tobytes(), image.shape
    else:
        data, shape = bytes(image), None
    if not _inherited:
        _used_here = True
        return _compress(data, shape)
    return _in_helper(data, shape)

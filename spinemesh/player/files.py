"""The files of a preview folder: pages, images and frame scripts side by side.

A preview is a folder a browser opens from disk (``file://``, no network): HTML pages that
stay small, and beside them the images (PNG files, named by their content so that an image
two pages show is written once) and the player's data (``.js`` files loaded with
``<script src>``: Chromium forbids ``fetch`` of a local file, not a script element).
"""

from __future__ import annotations

import hashlib
import html
import io
from pathlib import Path

import numpy as np

from ..files.atomic import atomic_write_bytes, atomic_write_text
from ..files.names import named_within
from ..written_folder import check_written_folder, mark_written_files, mark_written_folder, written_files

#: Largest side, in pixels, of an image written for a page (a sprite, an atlas page).
IMAGE_SIZE = 1024


def html_page(title: str, css: str, body: str) -> str:
    """A preview's HTML page: ``title`` (text, escaped here), its style sheet ``css`` and its
    ``body`` (HTML), in UTF-8, laid out at the width of the screen that shows it.

    Examples
    --------
    >>> page = html_page("a < b", "p{margin:0}", "<p>x</p>")
    >>> page[page.index("<title>"):page.index("</title>")]
    '<title>a &lt; b'
    """
    # a phone lays out a page without a viewport at 980 pixels, shrunk: the player's canvases a third of the screen
    return (f"<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{html.escape(title)}</title>"
            f"<style>{css}</style></head><body>{body}</body></html>\n")


def png_bytes(rgba: np.ndarray) -> bytes:
    """``rgba`` (H, W, 4 or 3, uint8) encoded as PNG."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgba)).save(buf, "PNG", optimize=False, compress_level=6)
    return buf.getvalue()


class PreviewFolder:
    """Writes the files of one preview under ``root`` and keeps their sizes.

    A ``root`` that holds files but no spinemesh preview is refused
    (:func:`~spinemesh.written_folder.check_written_folder`: its files would be replaced).

    Attributes
    ----------
    sizes : dict of str to int
        Bytes of every file written, by its path relative to ``root``.
    """

    def __init__(self, root: str | Path, within: str | Path | None = None):
        # every preview is written through this class: a folder of a user's files is refused
        # here, whoever calls (the commands check it earlier, before any work)
        check_written_folder(root)
        mark_written_folder(root)  # before its first file: a preview cut short is written into again
        self.root = Path(root)
        self.sizes: dict[str, int] = {}
        self._images: dict[int, str] = {}
        self._earlier = written_files(root)  # an earlier preview's files, removed by finish() unless written again
        self.within = within  # the project: its files named from its name on the pages (named_within)

    def write_text(self, rel: str, text: str) -> str:
        """Write ``text`` (UTF-8) at ``rel``, every path into the project named from its name (the
        same bytes from any folder, :func:`~spinemesh.files.names.named_within`); returns ``rel``."""
        path = self.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        text = named_within(text, self.within)
        atomic_write_text(path, text)
        self.sizes[rel] = len(text.encode("utf-8"))
        return rel

    def image(self, rgba: np.ndarray, size: int = IMAGE_SIZE) -> str:
        """Write ``rgba`` shrunk to fit ``size`` as ``img/<content hash>.png`` (once per
        content) and return that path, relative to ``root``."""
        from ..images.texels import fit_within

        key = id(rgba)
        if key in self._images and self._images[key][0] is rgba:
            return self._images[key][1]
        data = png_bytes(fit_within(rgba, size))
        rel = f"img/{hashlib.sha1(data).hexdigest()[:20]}.png"
        if rel not in self.sizes:
            path = self.root / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(path, data)
            self.sizes[rel] = len(data)
        self._images[key] = (rgba, rel)  # the array itself is held so that its id stays its own
        return rel

    def finish(self) -> None:
        """Once every file is written: remove the earlier preview's files that this one did not
        write again (a skeleton's page, a picture of art since changed), never a file spinemesh did
        not write, and list this preview's files in the folder's marker for the next one."""
        mark_written_files(self.root, self.sizes, self._earlier)

    def largest_page(self) -> tuple[str, int]:
        """The largest HTML page written: its path and bytes (``("", 0)`` when none)."""
        pages = [(n, s) for n, s in self.sizes.items() if n.endswith(".html")]
        return max(pages, key=lambda p: p[1], default=("", 0))

"""Decoded atlas pages: each page decoded once per project (:class:`PageStore`), and pages
decoded ahead on worker processes (:class:`PagePrefetch`), within one memory budget.

Separate from :mod:`.sources` because it is about memory and workers, not about regions: the
sources ask the store for a page and cut from what it gives.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import numpy as np

from . import decode
from .decode import texel_bytes


class PageStore:
    """Decoded atlas pages by real path: each page decoded once, however many skeletons use it.

    One store serves every atlas of a project (:func:`spinemesh.project.project_pages`), so
    skeletons, skins and sequences that share a page share its one decode. Pages are kept
    read-only (regions are cut from them as views) until :meth:`release` or until they would
    exceed ``max_bytes`` together; then the least recently used page goes first.

    Parameters
    ----------
    max_bytes : int
        Decoded texels kept at most (default :data:`spinemesh.limits.MAX_PAGE_STORE_BYTES`),
        pages decoded ahead and not taken yet (:attr:`PagePrefetch.bytes_ahead`) included; the
        page in use is kept whatever its size. A project whose pages exceed it together may
        have a page decoded again.
    max_pages : int, optional
        Pages kept at most (default: no limit besides ``max_bytes``).

    Attributes
    ----------
    decodes : int
        Pages decoded so far (for the benchmarks).
    """

    def __init__(self, max_bytes: int | None = None, max_pages: int | None = None):
        from ..limits import MAX_PAGE_STORE_BYTES

        self.max_bytes = MAX_PAGE_STORE_BYTES if max_bytes is None else max_bytes
        self.max_pages = max_pages
        self.decodes = 0
        #: Decodes pages ahead on worker processes (:meth:`decode_ahead`); None: none ahead.
        self.prefetch: PagePrefetch | None = None
        self._pages: OrderedDict[Path, np.ndarray] = OrderedDict()
        self._ahead: set[Path] = set()  # asked of self.prefetch and not taken yet

    def decode_ahead(self, paths) -> None:
        """Have ``self.prefetch`` decode these pages (real, checked paths) before :meth:`page` asks.

        Nothing without a prefetch; pages held already or asked for already are not asked again.
        """
        if self.prefetch is None:
            return
        new = [p for p in dict.fromkeys(paths) if p not in self._pages and p not in self._ahead]
        self._ahead.update(new)
        self.prefetch.want(new)

    def page(self, path: Path) -> np.ndarray:
        """The page image at ``path``: (H, W, 4) uint8, read-only.

        ``path`` is the page's real path, checked to lie inside its project
        (:meth:`.sources.AtlasImages.page_path`): one key per file however it was named. A page
        decoded ahead (:meth:`decode_ahead`) is taken as the worker decoded it; one whose decode
        ahead failed or never ran is decoded here, so that its texels, or its error, are this
        process's own.
        """
        pixels = self._pages.get(path)
        if pixels is not None:
            self._pages.move_to_end(path)
            return pixels
        pixels = None
        if path in self._ahead:
            self._ahead.discard(path)
            pixels = self.prefetch.take(path)
        if pixels is None:
            # through the module, as every decode of a page: one patch of decode.load_rgba sees them all
            pixels = decode.load_rgba(path)
        self.decodes += 1
        pixels.flags.writeable = False  # shared by every region cut from it
        self._pages[path] = pixels
        # pages decoded ahead and not taken yet are this process's memory too: one budget for both
        ahead = self.prefetch.bytes_ahead if self.prefetch is not None else 0
        while len(self._pages) > 1 and (sum(p.nbytes for p in self._pages.values()) + ahead > self.max_bytes
                                        or (self.max_pages is not None and len(self._pages) > self.max_pages)):
            self._pages.popitem(last=False)
        return pixels

    def release(self) -> None:
        """Drop every decoded page (a project is planned: its regions are cut), and any decode ahead
        this store asked for and did not take."""
        self._pages.clear()
        if self._ahead:
            self.prefetch.forget(self._ahead)
            self._ahead.clear()


#: Pages a :class:`PagePrefetch` has decoding or decoded and not yet taken, per worker: enough
#: that the workers are a few pages ahead of the planning (pages are 16 MB at 2048x2048).
PREFETCH_PAGES_PER_WORKER = 4


#: Bytes of texels a :class:`PagePrefetch` has decoding or decoded and not yet taken, at most,
#: whatever the number of workers: half of :data:`~spinemesh.limits.MAX_PAGE_STORE_BYTES`, the
#: budget of every decoded page a process holds (:class:`PageStore` counts these in). Sixteen
#: 2048x2048 pages fit; of 9400x9400 pages (353 MB), one.
PREFETCH_BYTES = 512 << 20


class PagePrefetch:
    """Atlas pages decoded by local worker processes ahead of the planning that cuts them.

    Decoding pages is most of what the parent process of a library run spends reading and
    planning. :meth:`PageStore.decode_ahead` queues a project's pages here, in the order the
    planning will take them; they are submitted to the workers (ahead of their queued meshes,
    :func:`spinemesh.upgrade.plan.decode_page_shared`), at most ``window`` not yet taken at
    once. :meth:`take` gives a page's texels, or None when its decode failed, its worker was
    lost or it was not submitted yet: the store then decodes it itself, as without workers, so
    texels and errors are the same either way.

    Memory is bounded by bytes as well as pages: a page is submitted only while the texels of
    those submitted and not taken stay within ``max_bytes`` (sizes read from the headers,
    :func:`texel_bytes`); a page larger than ``max_bytes`` alone is not decoded ahead at all
    (the store decodes it when it is needed). What the workers hold while they decode is
    within the same bound, so decoded pages of a run with workers take at most
    :data:`~spinemesh.limits.MAX_PAGE_STORE_BYTES` in this process (the store counts these in)
    plus ``max_bytes`` in flight, whatever ``--jobs`` is.

    Parameters
    ----------
    submit : callable
        ``submit(path) -> Future`` of the page's :func:`.decode.load_rgba` texels, decoded elsewhere.
    window : int
        Pages submitted and not yet taken, at most.
    max_bytes : int
        Texels of the pages submitted and not yet taken, at most (default :data:`PREFETCH_BYTES`).
    """

    def __init__(self, submit, window: int, max_bytes: int = PREFETCH_BYTES):
        self._submit = submit
        self.window = window
        self.max_bytes = max_bytes
        #: Bytes of texels of the pages submitted and not taken yet.
        self.bytes_ahead = 0
        self._wanted: OrderedDict[Path, None] = OrderedDict()  # not submitted yet, in order
        self._submitted: dict[Path, tuple[object, int]] = {}  # path -> (Future, bytes of texels)

    def want(self, paths) -> None:
        """Queue these pages (real paths checked inside their project) for decoding ahead."""
        for path in paths:
            if path not in self._submitted:
                self._wanted[path] = None
        self._top_up()

    def _top_up(self) -> None:
        while self._wanted and len(self._submitted) < self.window:
            path = next(iter(self._wanted))
            nbytes = texel_bytes(path)
            if nbytes > self.max_bytes:  # never ahead: the store decodes it when it comes to it
                del self._wanted[path]
                continue
            if self.bytes_ahead + nbytes > self.max_bytes:
                return  # its turn comes when a page is taken
            del self._wanted[path]
            try:
                self._submitted[path] = (self._submit(path), nbytes)
            except RuntimeError:  # the workers are closing: the store decodes what is left
                self._wanted.clear()
                return
            self.bytes_ahead += nbytes

    def _pop(self, path: Path):
        """The future of a submitted page, no longer counted ahead; None if not submitted."""
        future, nbytes = self._submitted.pop(path, (None, 0))
        self.bytes_ahead -= nbytes
        return future

    def take(self, path: Path) -> np.ndarray | None:
        """The page decoded ahead, read-only; None if the caller must decode it (see the class)."""
        from concurrent.futures import CancelledError

        self._wanted.pop(path, None)  # still waiting for a turn: decoded by the caller, now
        future = self._pop(path)
        try:
            return future.result() if future is not None else None
        except (Exception, CancelledError):  # failed or lost: the caller's own decode says why
            return None
        finally:
            self._top_up()

    def forget(self, paths) -> None:
        """Drop these pages: not decoded if still waiting, their texels freed if decoded."""
        for path in paths:
            self._wanted.pop(path, None)
            future = self._pop(path)
            if future is not None:
                future.cancel()
        self._top_up()

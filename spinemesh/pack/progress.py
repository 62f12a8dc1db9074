"""How far packing an atlas has gone, counted in work known before it starts.

An atlas's steps are of very unequal cost: its pages are read in a blink, each fill tried
takes about a second, encoding one large packed page (oxipng) takes several, and the pages of
an atlas packed on several processes end together. Counted as steps, and with the steps told
as they became known, a bar stood still for most of a run with its ETA unknown (rich forgets
its speed whenever a total changes). So an atlas's bar counts *work*: per phase, the atlas's
page texels times what a texel costs in that phase (:data:`COST`), all of it known from the
page images' headers as the project's atlases are read, before a page is decoded (:func:`atlas_work`),
and told once. Each phase
hands its share out as its parts end: the fills of a group of pages share that group's part
of the placing, packed pages share the writing by their texels. Work found later (another
layout written after the first grew in bytes) adds to the total, which happens rarely.
"""

from __future__ import annotations

from collections import deque

#: What one kilotexel of the atlas's pages costs in each phase, relative to reading it (page
#: decoded). Measured with ``spinemesh pack --jobs 1`` (CPU seconds per megatexel of the pages
#: as exported): cafe-waiter (2 pages, 6.7 Mtexels) read 0.015, place 0.55, write 2.8, prove
#: 0.05; vsp-man (17 pages, 16.7 Mtexels) read 0.006, place 0.38, write 1.4, prove 0.06. Writing
#: (oxipng) costs three to five times the placing, proving a sixth of it.
COST = {"read": 1, "place": 30, "write": 100, "prove": 5}

#: The phases of :data:`COST`, in the order an atlas goes through them.
PHASES = tuple(COST)


def kilotexels(size: tuple[int, int] | None) -> int:
    """A page's texels in thousands, at least 1 (``size``: (width, height); None, unknown: 1)."""
    if size is None:
        return 1
    return max(1, -(-int(size[0]) * int(size[1]) // 1000))


def page_kilotexels(sizes: list[tuple[int, int] | None]) -> list[int]:
    """Each page's :func:`kilotexels` of its image's ``sizes`` (``Atlas.image_sizes``: read from
    the files' headers once, by :func:`spinemesh.project.project_atlases`)."""
    return [kilotexels(size) for size in sizes]


def atlas_work(pages: list[int]) -> int:
    """The work of packing an atlas of ``pages`` (each one's kilotexels, :func:`page_kilotexels`):
    every phase of :data:`COST` over them; what :meth:`AtlasMeter.start` tells."""
    return sum(COST.values()) * sum(pages)


class AtlasMeter:
    """Turns the steps of one atlas's packing into work done, on a total told first.

    ``pages``: each page's kilotexels (:func:`page_kilotexels`); ``groups``: the pages of each
    group placed on its own (page indices, in the order their fills are tried); ``on_step(done,
    planned, step)``: told the total (``planned``) once by :meth:`start`, then work ``done`` as
    parts end, and the words ``step`` for what the atlas does now. Work done never passes what
    was planned; a phase begun again (another layout written) plans its work anew.

    It is itself an ``on_step``: ``meter(done=1, planned=0, step="")`` ends one part (``done``),
    begins the placing of the next group of ``planned`` fills, and says ``step``.
    """

    def __init__(self, pages: list[int], groups: list[list[int]] | None = None, on_step=None):
        self.pages = list(pages)
        self.groups = deque(groups if groups is not None else [list(range(len(self.pages)))])
        self.on_step = on_step or (lambda done=1, planned=0, step="": None)
        self.left = {phase: COST[phase] * sum(self.pages) for phase in PHASES}
        self.total = atlas_work(self.pages)
        self.parts: deque[int] = deque()

    def start(self) -> None:
        """Tell the atlas's whole work, before any of it is done."""
        self.on_step(0, self.total, "")

    def say(self, words: str) -> None:
        """What the atlas does now, in words."""
        if words:
            self.on_step(0, 0, words)

    def begin(self, phase: str, weights: list[int], words: str = "", pages: list[int] | None = None) -> None:
        """``phase`` begins, in parts of ``weights`` (their shares of its work); ``pages``: the
        indices of the pages its work is of (default: all). A part not ended by now is dropped."""
        self.say(words)
        work = COST[phase] * sum(self.pages[i] for i in (pages if pages is not None else range(len(self.pages))))
        if work > self.left[phase]:  # begun again: new work, told
            more = work - self.left[phase]
            self.total += more
            self.left[phase] += more
            self.on_step(0, more, "")
        self.left[phase] -= work
        weights = [max(0, int(w)) for w in weights] or [1]
        if not any(weights):  # parts of no weight share the work evenly
            weights = [1] * len(weights)
        whole = sum(weights)
        shares = [work * w // whole for w in weights]
        shares[-1] += work - sum(shares)
        self.parts = deque(shares)

    def end_part(self) -> None:
        """One part of the phase under way ended (none left: nothing)."""
        if self.parts:
            self.on_step(self.parts.popleft(), 0, "")

    def __call__(self, done: int = 1, planned: int = 0, step: str = "") -> None:
        if planned:
            group = self.groups.popleft() if self.groups else []
            self.begin("place", [1] * planned, pages=group)
        self.say(step)
        for _ in range(done):
            self.end_part()

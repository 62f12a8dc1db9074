"""What every whole-project run reports: its items' statuses, its problems, its exit status.

``upgrade`` (:class:`spinemesh.upgrade.Result`) and ``weights``
(:class:`spinemesh.rig.run.WeightResult`) both count their attachments by status and end with
the same exit status when something failed.
"""

from __future__ import annotations

import re
from collections import Counter

#: Exit status when the input or options give nothing to work on: a bad value, a folder
#: without a skeleton, ``--only`` matching nothing (0: all that was asked was done, deliberate
#: skips included).
EXIT_BAD_INPUT = 2

#: Exit status of a run in which some attachments or files could not be done.
EXIT_PARTIAL = 3


class RunSummary:
    """Mixin for a run's result: ``_items()`` yields everything that has a ``status``, and
    ``errors`` lists the problems that stopped a whole file.

    The results of ``upgrade`` (:class:`spinemesh.upgrade.report.Result`), ``weights`` and
    ``pack`` are ones; :mod:`spinemesh.cli._summary` prints them, and :attr:`partial` decides
    the exit status (:data:`EXIT_PARTIAL`).

    Examples
    --------
    >>> from dataclasses import dataclass, field
    >>> @dataclass
    ... class Item:
    ...     status: str
    >>> @dataclass
    ... class Run(RunSummary):
    ...     items: list = field(default_factory=list)
    ...     errors: list = field(default_factory=list)
    ...     def _items(self):
    ...         return self.items
    >>> run = Run([Item("meshed"), Item("kept"), Item("meshed")])
    >>> run.counts(), run.partial
    ({'kept': 1, 'meshed': 2}, False)
    >>> run.items.append(Item("failed")); run.partial
    True
    """

    errors: list[str]

    def _items(self):
        raise NotImplementedError

    @property
    def partial(self) -> bool:
        """True when something failed: an item, or a whole file."""
        return bool(self.errors) or any(item.status == "failed" for item in self._items())

    def counts(self) -> dict[str, int]:
        """Items by status, in the order of the statuses' names: a report's keys come in one order
        whatever the project (in the order statuses first occurred, they changed with its first
        attachment, and a text diff of two nights' reports showed a change where there was none)."""
        return dict(sorted(Counter(item.status for item in self._items()).items()))


_FIGURE = re.compile(r"\d+(?:[.,]\d+)*")


def reason_groups(reasons: list[str]) -> list[tuple[str, int, int]]:
    """Reasons grouped by their words, figures aside, most frequent first.

    "the art fills 97% of the region ..." and "... 99% ..." are one group; a reason worded
    differently ("a mesh would draw only 3% fewer pixels ...") is another, never folded in.

    Parameters
    ----------
    reasons : list of str
        One reason per item (repeats count).

    Returns
    -------
    list of (str, int, int)
        Per group: its most frequent reason (the example), how many items, and how many of
        them have other figures than the example (the console said "4 (...; 1 more like it
        with other figures)", counting other wordings, which read as a fifth item).
    """
    groups: dict[str, Counter] = {}
    for reason in reasons:
        groups.setdefault(_FIGURE.sub("#", reason), Counter())[reason] += 1
    rows = []
    for counts in groups.values():
        (example, alike), total = counts.most_common(1)[0], sum(counts.values())
        rows.append((example, total, total - alike))
    return sorted(rows, key=lambda row: (-row[1], row[0]))


def _joined(parts: list[str], keep: list[int]) -> str:
    """The components at ``keep`` (ascending) joined by ``/``, each gap shown as ``…``."""
    out, last = [], -1
    for i in keep:
        if i > last + 1:
            out.append("…")
        out.append(parts[i])
        last = i
    return "/".join(out)


def short_names(names: list[str], width: int) -> dict[str, str]:
    """Each name shortened to at most ``width`` characters, the shortened names kept distinct.

    Library runs name skeletons by their path under the library, and paths that share a long
    beginning (``studio-2021/spine/...``) would all be cut to the same text. A long path keeps
    its first folder (the project) and as many of its last parts as fit, the rest shown as
    ``…`` (``studio-2021/…/hero/hero.json``); paths that would then read the same keep the
    parts in which they differ (``studio-2021/…/hero3/…/hero.json``).

    Parameters
    ----------
    names : list of str
        Distinct names (paths with ``/``).
    width : int
        Most characters per shown name (at least 8).

    Returns
    -------
    dict
        Name -> shown name (the name itself when it fits).
    """
    width = max(width, 8)

    def first_fit(name: str, keeps: list[list[int]], taken=frozenset()) -> str | None:
        parts = name.split("/")
        for keep in keeps:
            text = _joined(parts, keep)
            if len(text) <= width and text not in taken:
                return text
        return None

    def fallback(name: str) -> str:
        head = (width - 1) // 3
        return name if len(name) <= width else name[:head] + "…" + name[-(width - 1 - head):]

    def around(name: str, at: int) -> str:
        """The characters from ``at`` (where a group of names starts to differ) and the end."""
        if len(name) - at + 1 <= width:
            return "…" + name[at:]
        middle = (width - 2) // 2
        return "…" + name[at:at + middle] + "…" + name[-(width - 2 - middle):]

    shown = {}
    for name in names:
        n = len(name.split("/"))
        keeps = [list(range(n))] + [[0, *range(k, n)] for k in range(2, n)] + [list(range(k, n)) for k in range(1, n)]
        shown[name] = first_fit(name, keeps) or fallback(name)
    by_shown: dict[str, list[str]] = {}
    for name, text in shown.items():
        by_shown.setdefault(text, []).append(name)
    for text, group in by_shown.items():
        if len(group) < 2:
            continue
        split = [g.split("/") for g in group]
        # every part in which these names differ (counted from the start) is kept
        differ = [i for i in range(min(map(len, split))) if len({p[i] for p in split}) > 1]
        taken = set(shown.values()) - {text}
        for name, parts in zip(group, split):
            n = len(parts)
            keeps = [sorted({*head, *differ, *range(k, n)}) for k in range(n - 1, 0, -1)[::-1]
                     for head in ((0,), ())]
            shown[name] = (first_fit(name, keeps + [sorted({*differ, n - 1})], frozenset(taken))
                           or around(name, next((i for i, c in enumerate(zip(*group)) if len(set(c)) > 1), 0)))
            taken.add(shown[name])
    return shown

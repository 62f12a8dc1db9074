"""Counts said in words, the one way every page and message says them.

Examples
--------
>>> counted(1, "atlas", "atlases"), counted(2, "atlas", "atlases"), counted(1_200, "page")
('1 atlas', '2 atlases', '1,200 pages')
"""

from __future__ import annotations


def counted(n: int, one: str, many: str | None = None) -> str:
    """``n`` and the words for that many, thousands separated by commas.

    Parameters
    ----------
    n : int
        How many.
    one : str
        The words for one (``"attachment"``, ``"kept as a region"``).
    many : str, optional
        The words for any other count; ``one`` with an ``s`` by default.
    """
    return f"{n:,} {one if n == 1 else (many if many is not None else one + 's')}"


#: Attachments that cannot be used said one by one per skeleton; the rest are counted in one line.
MAX_UNUSABLE_SAID = 20


def unusable_said(problems: list[str], skeleton, each: str, rest: str) -> list[str]:
    """The lines that say a skeleton's attachments that cannot be used (``info``'s problems,
    ``pose``'s warnings): the first :data:`MAX_UNUSABLE_SAID` one by one, then how many more.

    Parameters
    ----------
    problems : list of str
        What is wrong with each attachment (``skeleton.checked_attachments``), in order.
    skeleton : path
        The skeleton, which begins every line.
    each, rest : str
        Each problem's words (``"{problem}; not drawn"``), and the last line's for the ``more``
        left unsaid (``"{more} more attachments not drawn"``).

    Examples
    --------
    >>> lines = unusable_said(["a: bad"] * 21, "s.json", "{problem}", "{more} more")
    >>> len(lines), lines[0], lines[-1]
    (21, 's.json: a: bad', 's.json: 1 more')
    """
    lines = [f"{skeleton}: " + each.format(problem=problem) for problem in problems[:MAX_UNUSABLE_SAID]]
    if len(problems) > MAX_UNUSABLE_SAID:
        lines.append(f"{skeleton}: " + rest.format(more=len(problems) - MAX_UNUSABLE_SAID))
    return lines

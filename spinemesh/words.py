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

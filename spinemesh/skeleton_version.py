"""The Spine version a skeleton is written for, read as the official runtimes read it.

The editor writes ``skeleton.spine`` (JSON) and the version string of a ``.skel`` header as
``"4.2.43"``, ``"4.3.39-beta"``, or, when it exports a project to an older version,
``"4.1-from-4.2.33"`` (a 4.1 file made by editor 4.2.33) and ``"3.8-from-4.0.64"``. The
runtimes look only at the leading ``major.minor`` (those that check it, the C and C++ runtimes
from 4.1 on, compare its beginning with their own), and so does every part of spinemesh that
decides by version: they all call :func:`major_minor`.
"""

from __future__ import annotations

import re

_LEADING = re.compile(r"(\d+)\.(\d+)")


def major_minor(version: object) -> tuple[int, int] | None:
    """``(major, minor)`` from the leading numbers of an editor version; None when it has none.

    Parameters
    ----------
    version : str
        ``skeleton.spine`` or a ``.skel`` header's version; anything else (None, a number)
        gives None.

    Examples
    --------
    >>> major_minor("4.2.43"), major_minor("4.1-from-4.2.33"), major_minor("3.8-from-4.0.64")
    ((4, 2), (4, 1), (3, 8))
    >>> major_minor("4.10.1"), major_minor(""), major_minor("v4.2")
    ((4, 10), None, None)
    """
    m = _LEADING.match(version) if isinstance(version, str) else None
    return (int(m[1]), int(m[2])) if m else None


def doc_major_minor(doc: object) -> tuple[int, int] | None:
    """:func:`major_minor` of a skeleton document's ``skeleton.spine`` (None without one)."""
    skel = doc.get("skeleton") if isinstance(doc, dict) else None
    return major_minor(skel.get("spine")) if isinstance(skel, dict) else None

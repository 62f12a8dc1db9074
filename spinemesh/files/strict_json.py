"""Strict JSON: no NaN or Infinity is ever written (strict parsers and the runtimes reject them),
whole (:func:`strict_json`) or one list item at a time (:func:`strict_json_pieces`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path

from ..errors import SpineMeshError


def strict_json(obj, indent=None, path: str | Path | None = None, compact: bool = False) -> str:
    """JSON text that never holds NaN or Infinity (strict parsers and the runtimes reject them).

    ``compact``: no space after ``,`` and ``:`` (a model of thousands of trees), for ``indent`` None.

    Raises
    ------
    SpineMeshError
        If ``obj`` holds a non-finite number (naming ``path``, the file it was meant for).
    """
    try:
        return json.dumps(obj, indent=indent, ensure_ascii=False, allow_nan=False,
                          separators=(",", ":") if compact else None)
    except ValueError as e:
        raise SpineMeshError(f"not written: it would hold a non-finite number ({e})", path) from None


def finite(obj):
    """``obj`` with every NaN or infinite float (Python's or NumPy's) replaced by None, in dicts,
    lists and tuples at any depth: strict JSON for figures that may be undefined (a score of no
    sample, a loss that diverged), where :func:`strict_json` would refuse them."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


def strict_json_pieces(head: dict, key: str, items: Iterable, path: str | Path | None = None):
    """The text of ``strict_json({**head, key: list(items)}, None, path)``, in pieces: the
    object up to the list's ``[``, then each item's text as the item is taken from ``items``
    (an iterator may make them one at a time), then ``]}``. So a list too large to hold
    whole is written as one item at a time, to the same characters.

    Parameters
    ----------
    head : dict
        The object's members before the list; ``key`` must not be one of them.
    key : str
        The name of the list, the object's last member.
    items : iterable
        The list's items, each turned to text (and checked) when it is taken.

    Yields
    ------
    str
        Pieces of the text, in order.

    Raises
    ------
    SpineMeshError
        When an item holds a non-finite number, as :func:`strict_json` does, when that item is
        reached: what came before it is already given out.
    """
    if key in head:
        raise ValueError(f"{key!r} is one of the head's members: the list must be the last one")
    empty = strict_json({**head, key: []}, None, path)
    yield empty[:-len("[]}")] + "["    # the list, last, closes the text
    for i, item in enumerate(items):
        yield (", " if i else "") + strict_json(item, None, path)
    yield "]}"

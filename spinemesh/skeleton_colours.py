"""How Spine JSON spells a colour, read as the runtimes read it: one reading the pose sampler
(:mod:`spinemesh.anim`) and the binary writer (:mod:`spinemesh.skeleton_binary`, ``convert``)
share, so that a colour the sampler draws is the colour ``convert`` writes.
"""

from __future__ import annotations

HEX_DIGITS = frozenset("0123456789abcdefABCDEF")


def read_colour(text) -> tuple[int, int, int, int | None]:
    """A JSON colour ``[#]rrggbb[aa]`` as spine-core's ``Color.fromString`` and libGDX's
    ``Color.valueOf`` read it: a leading ``#`` skipped, red, green and blue from the first six
    digits, alpha from the seventh and eighth only where there are exactly eight.

    Returns
    -------
    tuple
        ``(r, g, b, a)``, each 0..255; ``a`` is None where the text gives none (the runtimes
        take 1, opaque; a dark colour has no alpha).

    Raises
    ------
    ValueError
        Not text, fewer than six digits, or a digit read that is not hex: no colour a runtime
        reads (spine-core gets NaN, libGDX fails).

    Examples
    --------
    >>> read_colour("ff8040"), read_colour("#ff804080"), read_colour("ff80401")
    ((255, 128, 64, None), (255, 128, 64, 128), (255, 128, 64, None))
    """
    if not isinstance(text, str):  # a number is no colour either: one error for every unreadable one
        raise ValueError(text)  # noqa: TRY004
    digits = text.removeprefix("#")
    used = digits[:8] if len(digits) == 8 else digits[:6]
    if len(digits) < 6 or not HEX_DIGITS.issuperset(used):
        raise ValueError(text)
    r, g, b = (int(digits[i:i + 2], 16) for i in (0, 2, 4))
    return r, g, b, int(digits[6:8], 16) if len(digits) == 8 else None

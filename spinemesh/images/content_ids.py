"""The one image hash of the package: an image's identity by its size and texels.

``upgrade`` meshes each id once and ``dataset`` stores each id once; separate so that both, and
the image sources, share the one definition.
"""

from __future__ import annotations

import numpy as np


def content_id(rgba: np.ndarray, box: tuple[int, int, int, int]) -> str:
    """128-bit hash of an image's size and the pixels inside ``box``, as 32 hex digits.

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 4), uint8
    box : (x, y, w, h)
        The part that counts (the callers know everything outside it is zero, or unused).
        The size and the box are hashed too, so equal pixels in other places differ.

    SHA-256, truncated, because CPUs hash it in hardware. The one image hash of the
    package: ``upgrade`` meshes each id once, ``dataset`` stores each id once.
    """
    x, y, w, h = box
    return part_content_id(rgba.shape, box, rgba[y:y + h, x:x + w])


def part_content_id(shape: tuple[int, ...], box: tuple[int, int, int, int], part: np.ndarray,
                    mask: np.ndarray | None = None) -> str:
    """:func:`content_id` of an image of ``shape`` whose pixels inside ``box`` are ``part``.

    For callers that hold that part already: hashed as it is when contiguous (no copy).

    Parameters
    ----------
    mask : ndarray of bool, optional
        A per-texel mask that belongs to the identity too (the texels a mesh must cover), of
        the shape it has: hashed after the pixels, as bits (eight texels a byte, an eighth of
        its bytes to hash). Equal ids then mean equal pixels and equal masks. Without it, the
        id is :func:`content_id`'s.
    """
    import hashlib

    digest = hashlib.sha256()
    digest.update(np.asarray(tuple(shape) + tuple(box), np.int64).tobytes())
    digest.update(part if part.flags.c_contiguous else np.ascontiguousarray(part))
    if mask is not None:
        digest.update(np.asarray(mask.shape, np.int64).tobytes())
        digest.update(np.packbits(mask))
    return digest.hexdigest()[:32]

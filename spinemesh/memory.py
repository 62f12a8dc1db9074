"""Memory that runs out: an image that cannot be allocated fails as that image, and the rest goes on.

An image's work takes memory in proportion to its texels. When the system (or an address-space
limit, ``ulimit -v``) refuses it, numpy raises ``MemoryError``, OpenCV ``cv2.error`` with
"Insufficient memory" or "Failed to allocate", and a module imported for the first time then
cannot map its library ("failed to map segment"). :func:`image_memory` turns each of those, while
one image is worked on, into an :class:`~spinemesh.errors.ImageMemoryError` that names the
image, its size and about how much the work needs (:data:`BYTES_PER_TEXEL`): the callers that
report one image's failure and go on (``upgrade``'s attachments, ``mesh DIR``, ``dataset``)
treat it as any other bad image.
"""

from __future__ import annotations

import resource
from contextlib import contextmanager
from pathlib import Path

from .errors import ImageMemoryError

#: Peak memory of each kind of work per texel of the image, in bytes, decoded texels included,
#: measured on a 9000x9000 sprite (``/usr/bin/time -f %M``, less the 50 MB of the interpreter
#: and its modules): ``spinemesh mesh`` 8 (645 MB), ``spinemesh segment`` with the alpha mask
#: 14 (1,112 MB), ``spinemesh dataset`` of a project with that one image 12 (958 MB), ``mesh``
#: with ``--preview`` and ``--steps`` no more than without (the pictures: 8); decoding alone is
#: the texels, 4. Used only to say what a failed image needed.
BYTES_PER_TEXEL = {"decode": 4, "mesh": 8, "mask": 14, "sample": 12, "draw": 8}

#: What the verb is for each kind of work, in the error line.
_DOING = {"decode": "decode", "mesh": "mesh", "mask": "find the sprite mask of", "sample": "store",
          "draw": "draw the pictures of"}

_OPENCV_OUT_OF_MEMORY = ("Insufficient memory", "Failed to allocate")
_LIBRARY_OUT_OF_MEMORY = ("failed to map segment", "Cannot allocate memory")


def out_of_memory(error: BaseException) -> bool:
    """Whether ``error`` says that memory could not be had (see the module's description)."""
    if isinstance(error, MemoryError):
        return True
    text = str(error)
    if type(error).__name__ == "error" and type(error).__module__.startswith("cv2"):
        return any(words in text for words in _OPENCV_OUT_OF_MEMORY)
    if isinstance(error, (ImportError, OSError)):
        return any(words in text for words in _LIBRARY_OUT_OF_MEMORY)
    return False


def memory_message(work: str, width: int, height: int) -> str:
    """``"9000x9000 image: not enough memory to mesh it (about 648 MB needed, ...)"``.

    ``work`` is a key of :data:`BYTES_PER_TEXEL`. The address-space limit is named when one is set.
    """
    need = BYTES_PER_TEXEL[work] * width * height
    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    within = "" if limit == resource.RLIM_INFINITY else f", within this process's limit of {limit / 1e6:,.0f} MB"
    return (f"{width}x{height} image: not enough memory to {_DOING[work]} it (about {need / 1e6:,.0f} MB "
            f"needed{within})")


@contextmanager
def image_memory(work: str, source: str | Path | None, width: int, height: int):
    """Turn running out of memory inside the block into :class:`ImageMemoryError` naming ``source``.

    Parameters
    ----------
    work : str
        What is done to the image: a key of :data:`BYTES_PER_TEXEL`.
    source : path or str, optional
        The image (or the attachment's name) the error line names.
    width, height : int
        The image's size in texels.
    """
    try:
        yield
    except Exception as e:
        if not out_of_memory(e):
            raise
        raise ImageMemoryError(memory_message(work, width, height), source) from None


__all__ = ["BYTES_PER_TEXEL", "out_of_memory", "memory_message", "image_memory"]

"""Step 1 of the pipeline (paper sec. 3.1): the foreground mask."""

from __future__ import annotations

import numpy as np

from ..errors import ImageError
from ..foreground import foreground


def compute_mask(image: np.ndarray, source: str = "alpha", threshold: int = 8) -> np.ndarray:
    """Foreground mask of a sprite.

    Parameters
    ----------
    image : ndarray, shape (H, W, 4) or (H, W, 3), uint8
        Straight (not premultiplied) RGBA, or RGB.
    source : {"alpha", "model", "auto"}
        ``"alpha"``: threshold the alpha channel (an RGB image is all foreground).
        ``"model"``: the segmentation network (:func:`spinemesh.segment.predict_mask`).
        ``"auto"``: alpha when it is meaningful (:func:`spinemesh.segment.has_meaningful_alpha`),
        else the network; the paper's rule (sec. 3.1). A blank image (every pixel alike) uses alpha.
    threshold : int
        Foreground is ``alpha >= threshold``. The paper's ``alpha > 128`` is ``threshold=129``.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] not in (3, 4) or image.dtype != np.uint8:
        raise ImageError(f"expected an (H, W, 3|4) uint8 image, got {image.shape} {image.dtype}")
    if source not in ("alpha", "model", "auto"):
        raise ValueError(f"mask source must be 'alpha', 'model' or 'auto', not {source!r}")
    has_alpha = image.shape[2] == 4
    if source == "auto":
        # A blank image (every pixel the same) holds no art for the network to find either:
        # its alpha is the answer (an empty mask for a fully transparent one).
        if is_blank(image) or (has_alpha and _segment().has_meaningful_alpha(image)):
            source = "alpha"
        else:
            source = "model"
    if source == "alpha":
        return foreground(image, threshold)
    mask = _segment().predict_mask(np.ascontiguousarray(image[:, :, :3]))
    return np.asarray(mask, dtype=bool)


#: Rows compared at a time by :func:`is_blank`: a few MB per step, so that art, which
#: differs from its first pixel within a few rows, stops the scan at once.
BLANK_ROWS = 64


def is_blank(image: np.ndarray) -> bool:
    """Whether every pixel of ``image`` equals its first one (every channel).

    Compared a band of :data:`BLANK_ROWS` rows at a time, stopping at the first band that
    differs: linear in the pixels for a blank image, a few rows' work for a sprite (whole-image
    ``(image == image[0, 0]).all()`` built a full boolean copy of a 6000x6000 image first).

    Parameters
    ----------
    image : ndarray, shape (H, W, C)

    Returns
    -------
    bool
    """
    first = image[:1, :1]
    return all(bool((image[y:y + BLANK_ROWS] == first).all()) for y in range(0, image.shape[0], BLANK_ROWS))


def _segment():
    # Imported lazily: the alpha path must work without the segmentation model installed.
    try:
        from .. import segment
    except ImportError as e:  # pragma: no cover - depends on the install
        raise ImageError(f"the segmentation model is not available ({e}); use --mask alpha") from None
    if not hasattr(segment, "predict_mask"):
        raise ImageError("the segmentation model is not available yet; use the alpha mask")
    return segment

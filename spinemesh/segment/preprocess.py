"""The one resize-and-normalise step shared by training, ONNX inference and evaluation.

Paper section 3.1: the image is resized to the square model input (no letterbox: the
output is resized back to the image's own size, so the stretch cancels out) and normalised
with ImageNet statistics; the predicted probability map is resized back with bilinear
interpolation and thresholded at 0.5.
"""

from __future__ import annotations

import cv2
import numpy as np

#: ImageNet mean and standard deviation of RGB in 0..1 (paper section 3.4).
IMAGENET_MEAN = np.array([0.485, 0.456, 0.406], np.float32)
IMAGENET_STD = np.array([0.229, 0.224, 0.225], np.float32)


def resize(img: np.ndarray, width: int, height: int) -> np.ndarray:
    """Resize with area averaging when shrinking and bilinear when enlarging."""
    h, w = img.shape[:2]
    shrinking = width * height < w * h
    return cv2.resize(img, (width, height), interpolation=cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR)


def to_input(rgb: np.ndarray, size: int) -> np.ndarray:
    """Model input from an image.

    Parameters
    ----------
    rgb : ndarray, shape (H, W, 3), uint8
    size : int
        Model input side, pixels.

    Returns
    -------
    ndarray, shape (3, size, size), float32, ImageNet-normalised
    """
    x = resize(np.ascontiguousarray(rgb[..., :3]), size, size).astype(np.float32) / 255.0
    x = (x - IMAGENET_MEAN) / IMAGENET_STD
    return np.ascontiguousarray(x.transpose(2, 0, 1))


def to_target(mask: np.ndarray, size: int) -> np.ndarray:
    """A full-size boolean mask at model size: (size, size) float32 of 0 and 1."""
    m = resize(mask.astype(np.float32), size, size)
    return (m > 0.5).astype(np.float32)


def from_output(prob: np.ndarray, height: int, width: int, threshold: float = 0.5) -> np.ndarray:
    """Probabilities at model size back to a boolean mask at the image's size.

    Parameters
    ----------
    prob : ndarray, shape (S, S), float32, 0..1
    height, width : int
        The image's size.
    threshold : float
        Paper section 3.1: 0.5.

    Returns
    -------
    ndarray, shape (height, width), bool
    """
    up = cv2.resize(prob.astype(np.float32), (width, height), interpolation=cv2.INTER_LINEAR)
    return up > threshold

"""Image preprocessing: grey conversion, crops, area resizing, patch normalisation (NeuroSLAM eq. 26) and an
estimate of the sensor's noise (eq. V2 of :mod:`.local_view`)."""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np
from scipy import ndimage

from ..config import Region
from ..errors import InvalidInputError

__all__ = [
    "ROUNDING_LIMIT", "crop", "grey", "noise_deviation", "patch_normalise", "reduce_to_width", "resize",
]

_LUMA = np.array([0.299, 0.587, 0.114], dtype=np.float32)
# Immerkaer's (1996) mask: the difference of two Laplacians, blind to any plane and to most of a smooth image's
# curvature; independent pixel noise of deviation sigma comes through it with deviation 6 sigma (the root of
# the sum of its squared weights, 36)
_NOISE_MASK = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], dtype=np.float32)
_NORMAL_MEDIAN = 0.6745  # the median of |x| over a standard normal distribution
# eq. V2's noise up to half a grey level of 255 is taken as none: rounding to 8 bits errs by at most half a level,
# so no deviation above it can come from rounding alone (uniform rounding errors have 1 / sqrt(12) = 0.29 of a
# level, and a clean render's edges and smooth shading, rounded, read up to 0.28 levels on the testbed)
ROUNDING_LIMIT = 0.5 / 255.0


def grey(image: np.ndarray) -> np.ndarray:
    """Grey levels in [0, 1] (float32) from an HxWx3 RGB or HxW grey image of uint8 or floats in [0, 1]."""
    array = np.asarray(image)
    scale = 1.0 / 255.0 if array.dtype == np.uint8 else 1.0
    if array.ndim == 3:  # OpenCV's RGB to grey: the same weights (0.299, 0.587, 0.114)
        converted = cv2.cvtColor(np.ascontiguousarray(array, dtype=np.float32), cv2.COLOR_RGB2GRAY)
        return converted * np.float32(scale) if scale != 1.0 else converted
    return array.astype(np.float32) * np.float32(scale)


def crop(image: np.ndarray, region: Region) -> np.ndarray:
    """The part of ``image`` inside ``region`` (fractions of height and width; at least one pixel)."""
    rows, columns = image.shape[:2]
    top = min(int(round(region.top * rows)), rows - 1)
    bottom = max(int(round(region.bottom * rows)), top + 1)
    left = min(int(round(region.left * columns)), columns - 1)
    right = max(int(round(region.right * columns)), left + 1)
    return image[top:bottom, left:right]


def resize(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Area-average ``image`` to ``shape`` (rows, columns): every output pixel is the mean of the input
    pixels it covers (fractional coverage at the edges), so no input pixel is skipped."""
    rows, columns = image.shape
    out_rows, out_columns = shape
    if out_rows <= rows and out_columns <= columns:  # OpenCV's area interpolation: the same means, faster
        return cv2.resize(np.asarray(image, dtype=np.float32), (out_columns, out_rows), interpolation=cv2.INTER_AREA)
    return _area_matrix(rows, out_rows) @ image @ _area_matrix(columns, out_columns).T


def reduce_to_width(image: np.ndarray, width: int) -> np.ndarray:
    """``image`` area-averaged (:func:`resize`) to ``width`` columns and its rows in proportion, where it is
    wider (0: never); otherwise ``image`` itself. The field of view is unchanged, so pixels stay square to
    within the rounding of the rows."""
    rows, columns = image.shape[:2]
    if width <= 0 or columns <= width:
        return image
    return resize(image, (max(1, round(rows * width / columns)), width))


@lru_cache(maxsize=64)
def _area_matrix(size: int, out: int) -> np.ndarray:
    """(out, size) matrix whose rows average the input cells covered by each output cell (cached)."""
    edges = np.linspace(0.0, size, out + 1)
    cells = np.arange(size)
    overlap = np.clip(np.minimum(edges[1:, None], cells + 1) - np.maximum(edges[:-1, None], cells), 0.0, None)
    matrix = (overlap / overlap.sum(axis=1, keepdims=True)).astype(np.float32)
    matrix.flags.writeable = False
    return matrix


def noise_deviation(grey_image: np.ndarray) -> float:
    """The standard deviation of a grey image's independent pixel noise (units of the image's values; eq. V2 of
    :mod:`.local_view`): the median absolute response to Immerkaer's mask at every other inner pixel of every
    other row (a quarter of them: 4,700 at 160 x 120, the median within about 2 %; 0.05 ms), over the median
    0.6745 × 6 that pure noise of deviation 1 gives. The median, not Immerkaer's mean, so edges and
    texture on fewer than half the pixels do not count as noise (a clean render: 0 on most frames, at most 0.28
    grey levels of 255 on the testbed's worlds; the benchmark camera's noise, 3.5 levels a channel at mid-grey:
    2.1–2.4). An image under 3 × 3 pixels: 0."""
    image = np.asarray(grey_image, dtype=np.float32)
    if image.ndim != 2 or min(image.shape) < 3:
        return 0.0
    response = cv2.filter2D(image, cv2.CV_32F, _NOISE_MASK)[1:-1:2, 1:-1:2]
    return float(np.median(np.abs(response))) / (_NORMAL_MEDIAN * 6.0)


def check_noise(noise: float | None) -> float | None:
    """``noise`` (an image's noise deviation, eq. V2) as a float, or None; raises
    :class:`~neuroslam.errors.InvalidInputError` naming ``noise`` for anything but a finite number >= 0."""
    if noise is None:
        return None
    if (not isinstance(noise, (int, float, np.floating)) or isinstance(noise, bool) or not math.isfinite(noise)
            or noise < 0):
        raise InvalidInputError("noise", repr(noise), "must be a finite number >= 0 (the image's units)")
    return float(noise)


def patch_normalise(image: np.ndarray, patch_size: int, *, wrap_columns: bool = False,
                    noise: float = 0.0) -> np.ndarray:
    """Subtract the local mean and divide by the local standard deviation over a square patch (NeuroSLAM eq. 26),
    that deviation counted as at least ``noise`` (eq. V1 of :mod:`.local_view`: sqrt(deviation² + noise²), in
    the image's units).

    Flat patches (standard deviation below 1e-3 of the grey range) become 0 rather than noise.
    ``wrap_columns`` treats the columns as circular (panoramic images).
    """
    if wrap_columns:  # circular columns: scipy's filter wraps them (OpenCV's box filter cannot)
        mode = ("nearest", "wrap")
        mean = ndimage.uniform_filter(image, patch_size, mode=mode)
        mean_square = ndimage.uniform_filter(image * image, patch_size, mode=mode)
    else:  # OpenCV's box filter, the border replicated: scipy's uniform_filter with mode "nearest"
        image = np.asarray(image, dtype=np.float32)
        mean = cv2.blur(image, (patch_size, patch_size), borderType=cv2.BORDER_REPLICATE)
        mean_square = cv2.blur(image * image, (patch_size, patch_size), borderType=cv2.BORDER_REPLICATE)
    variance = np.maximum(mean_square - mean * mean, 0.0)
    deviation = np.sqrt(variance + np.float32(noise * noise)) if noise > 0 else np.sqrt(variance)
    return ((image - mean) / np.maximum(deviation, 1e-3)).astype(np.float32)

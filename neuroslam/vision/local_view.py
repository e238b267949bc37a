"""Local view cells: one cell per stored visual template (Fig. 9, and NeuroSLAM eqs. 10–11 for what they recall).

A view is a patch-normalised thumbnail (NeuroSLAM eq. 26). It is compared with every stored template by the mean
absolute difference over the overlap of the two after a 2-D shift (rows ±``max_row_shift``, columns
±``max_column_shift``; in panoramic mode the columns shift circularly over the whole strip). The shift
for each template is the one with the least squared difference (all shifts of all candidates in two
matrix products); the score is the mean absolute difference at that shift. The best template within
``threshold`` becomes active; otherwise the view is stored as a new template.

All templates live in one contiguous array. To keep the cost nearly flat as the map grows, a cheap,
shift-tolerant pre-selection picks ``candidates`` templates first: each thumbnail row's column spectrum
magnitude (unchanged by a circular column shift) compared by one matrix-vector product; the exact
shifted comparison then runs on those candidates only.

Eq. 26 divides each thumbnail pixel's difference from its patch's mean by the patch's standard deviation, so a
patch of any contrast comes out at unit contrast. A blank patch under a camera's noise is then that noise at
unit contrast: a view of a blank wall differs from the same view a frame later by 2 / sqrt(pi) = 1.13, nearly
four times ``threshold``, and every such view becomes a new template (the generalization benchmark's camera
noise, 3.5 grey levels a channel at mid-grey, doubled the templates of the 13 largely blind worlds and made
seven times as many on one, docs/generalization.md's fortieth step). The patch's deviation is therefore
counted with the noise left in a thumbnail pixel:

    v(x) = (t(x) - mean_P(x)) / sqrt(sd_P(x)^2 + (c sigma_n / sqrt(A))^2)                     (V1)

(t: the thumbnail; mean_P and sd_P over the patch around x; A: the image pixels a thumbnail pixel averages,
at least 1; c: ``noise_floor``), with the image's noise sigma_n estimated on every frame from the image itself,
robustly to its edges (Immerkaer 1996's mask N, which passes no plane, and a median):

    sigma_n = median |I * N| / (0.6745 x 6),   N = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]        (V2)

(:func:`~.preprocessing.noise_deviation`). A patch of noise alone then has the contrast 1 / sqrt(1 + c^2), and
two views of one blank scene differ by 1.13 / sqrt(1 + c^2) before the best shift is taken. c is the least
whole number that brings that under the default ``threshold`` (0.3): c > 3.6, so 4 (0.27; the best of the
comparison's shifts: 0.23, at most 0.26 over 200 frames under 2, 3.5 and 8 grey levels, so a blank view is one
template). A larger c would flatten more of the faint texture a camera can still tell from its noise (a patch
of a few times the noise's contrast comes out at k / sqrt(k^2 + c^2)), and a place seen again under more noise
(a dimmer light: more shot noise) would differ more from its template. A texture whose contrast is many times
the noise keeps eq. 26's unit contrast. A sigma_n up to half a grey level (of 255) counts as none: rounding to 8
bits errs by at most half a level, so nothing beyond it comes from rounding alone. A clean render of the testbed
has sigma_n = 0 on most frames and at most 0.28 levels (all 154,385 frames of twelve recorded drives of the
generalization benchmark), and eq. 26 is then unchanged, bit for bit. A texture fine on most of the image's
pixels (a value-noise texture at a few pixels a cell) is read as 1–3 grey levels of noise; its patches' contrast
lies far above a floor of that size, and it keeps its unit contrast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import LocalViewConfig
from .preprocessing import ROUNDING_LIMIT, check_noise, crop, noise_deviation, patch_normalise, resize

__all__ = ["LocalViewCells", "ViewMatch"]


@dataclass(frozen=True)
class ViewMatch:
    """The outcome of one view.

    Attributes:
        template_id: the active local view cell.
        new: True when the view was stored as a new template this frame.
        difference: mean absolute difference to the matched template (0 for a new one).
        column_shift: columns the view is shifted against the template (positive: content moved right).
        relative_yaw: the yaw of the view relative to the template's, rad (counter-clockwise positive).
        alternatives: the other templates the view also matches within the threshold, best first (a
            place seen again slightly off its first path can match a neighbouring template a little
            better than its own; the loop confirmation counts these too).
    """

    template_id: int
    new: bool
    difference: float
    column_shift: int
    relative_yaw: float
    alternatives: tuple[int, ...] = ()


class LocalViewCells:
    """Visual templates and the local view cells they drive.

    Args:
        config: template parameters (Table 7).
        horizontal_fov: the camera's horizontal field of view, rad (for the relative yaw of a match).
        panoramic: columns wrap around (a 360-degree strip).
    """

    def __init__(self, config: LocalViewConfig = LocalViewConfig(), *, horizontal_fov: float = math.radians(80),
                 panoramic: bool = False):
        config.validate("local_view")
        self.config = config
        self.panoramic = panoramic
        rows, columns = config.thumbnail
        self.radians_per_column = (2 * math.pi if panoramic else horizontal_fov) / columns
        self._descriptor_size = rows * (columns // 2 + 1)
        self._templates = np.empty((64, rows, columns), dtype=np.float32)
        self._descriptors = np.empty((64, self._descriptor_size), dtype=np.float32)
        self._contrasts = np.empty(64, dtype=np.float32)  # each template against itself a column off (derived)
        self.count = 0
        if panoramic:
            half = columns // 2
            self._column_shifts = np.arange(-half + 1, half + 1)
        else:
            self._column_shifts = np.arange(-config.max_column_shift, config.max_column_shift + 1)
        self._row_shifts = np.arange(-config.max_row_shift, config.max_row_shift + 1)
        # for every (row shift, column shift): which view pixel lies over each template pixel, and whether
        # it exists (the overlap); built once, so a comparison is a few array operations
        shift_rows, shift_columns = np.meshgrid(self._row_shifts, self._column_shifts, indexing="ij")
        shift_rows, shift_columns = shift_rows.ravel(), shift_columns.ravel()
        view_rows = np.arange(rows)[None, :, None] + shift_rows[:, None, None]
        view_columns = np.arange(columns)[None, None, :] + shift_columns[:, None, None]
        inside = (view_rows >= 0) & (view_rows < rows)
        if panoramic:
            view_columns = view_columns % columns
        else:
            inside = inside & (view_columns >= 0) & (view_columns < columns)
        self._shift_columns = shift_columns
        shape = (len(shift_rows), rows, columns)
        flat_index = np.clip(view_rows, 0, rows - 1) * columns + np.clip(view_columns, 0, columns - 1)
        self._gather = np.broadcast_to(flat_index, shape).copy()
        self._overlap = np.broadcast_to(inside, shape).astype(np.float32)
        self._overlap_size = self._overlap.sum(axis=(1, 2))

    @property
    def column_contrasts(self) -> np.ndarray:
        """(count,) each template's mean absolute difference from itself shifted by one column (the lesser of
        the two shifts; patch-normalised values, as ``threshold``): how much one column of turn changes it. A
        view matched with a difference under half of it has its column shift pinned (by the triangle inequality,
        the view one column off lies farther from the template than the view itself); a blank template (0)
        pins no shift."""
        return self._contrasts[: self.count]

    def _column_contrast(self, templates: np.ndarray) -> np.ndarray:
        """:attr:`column_contrasts` of (K, rows, columns) templates."""
        if len(templates) == 0:
            return np.zeros(0, dtype=np.float32)
        if self.panoramic:
            return np.minimum(*(np.abs(templates - np.roll(templates, shift, axis=2)).mean(axis=(1, 2))
                                for shift in (1, -1))).astype(np.float32)
        return np.abs(templates[:, :, 1:] - templates[:, :, :-1]).mean(axis=(1, 2)).astype(np.float32)

    @property
    def templates(self) -> np.ndarray:
        """The stored templates, shape (count, rows, columns), patch-normalised (a view, not a copy)."""
        return self._templates[: self.count]

    def state_dict(self) -> dict[str, np.ndarray]:
        """The stored templates and their descriptors, for saving (:meth:`load_state_dict` restores them)."""
        return {"templates": self.templates.copy(), "descriptors": self._descriptors[: self.count].copy()}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output. Raises ValueError when it does not fit this configuration."""
        templates, descriptors = np.asarray(state["templates"]), np.asarray(state["descriptors"])
        count = len(templates)
        if templates.shape[1:] != self._templates.shape[1:] or templates.dtype != np.float32:
            raise ValueError(f"templates are {templates.dtype} {templates.shape[1:]}, the thumbnail is float32 "
                             f"{self._templates.shape[1:]}")
        if descriptors.shape != (count, self._descriptor_size) or descriptors.dtype != np.float32:
            raise ValueError(f"descriptors are {descriptors.dtype} {descriptors.shape}, expected float32 "
                             f"{(count, self._descriptor_size)}")
        capacity = max(64, count)
        self._templates = np.empty((capacity, *templates.shape[1:]), dtype=np.float32)
        self._descriptors = np.empty((capacity, self._descriptor_size), dtype=np.float32)
        self._templates[:count] = templates
        self._descriptors[:count] = descriptors
        self._contrasts = np.empty(capacity, dtype=np.float32)
        self._contrasts[:count] = self._column_contrast(templates)
        self.count = count

    def extend(self, other: LocalViewCells) -> int:
        """Append another set's templates (another session's map); returns the first new template's id."""
        if other._templates.shape[1:] != self._templates.shape[1:]:
            raise ValueError(f"thumbnails of {other._templates.shape[1:]} do not match {self._templates.shape[1:]}")
        first = self.count
        state = self.state_dict()
        extra = other.state_dict()
        self.load_state_dict({key: np.concatenate([state[key], extra[key]]) for key in state})
        return first

    def thumbnail(self, grey_image: np.ndarray, *, noise: float | None = None) -> np.ndarray:
        """The patch-normalised thumbnail of a grey image (values in [0, 1]: crop, area resize, NeuroSLAM eq. 26
        with the sensor noise's floor of eqs. V1–V2 where ``noise_floor`` is above 0). ``noise``: the image's
        noise deviation (eq. V2) where the caller has it already; otherwise it is estimated.

        Raises :class:`~neuroslam.errors.InvalidInputError` for a ``noise`` that is not a finite number >= 0."""
        noise = check_noise(noise)
        region = crop(grey_image, self.config.region)
        small = resize(region, self.config.thumbnail)
        floor = 0.0
        if self.config.noise_floor > 0:  # eq. V1: the noise left in a thumbnail pixel, the mean of `area` pixels
            deviation = noise_deviation(grey_image) if noise is None else noise
            if deviation > ROUNDING_LIMIT:  # no more than rounding to 8 bits could give: none
                area = max(region.shape[0] * region.shape[1] / (small.shape[0] * small.shape[1]), 1.0)
                floor = self.config.noise_floor * deviation / math.sqrt(area)
        return patch_normalise(small, self.config.patch_size, wrap_columns=self.panoramic, noise=floor)

    def _descriptor(self, thumbnail: np.ndarray) -> np.ndarray:
        spectrum = np.abs(np.fft.rfft(thumbnail, axis=1)).ravel()
        norm = np.linalg.norm(spectrum)
        return (spectrum / norm if norm > 0 else spectrum).astype(np.float32)

    def compare(self, thumbnail: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Smallest shifted mean absolute difference to the templates ``indices`` and the column shift of it.

        Returns (differences (K,), column shifts (K,)).
        """
        templates = self._templates[indices].reshape(len(indices), -1)  # (K, P)
        overlap = self._overlap.reshape(len(self._overlap), -1)  # (S, P)
        shifted = thumbnail.ravel()[self._gather].reshape(len(overlap), -1) * overlap  # zero outside the overlap
        # the shift: least squared difference over the overlap, for all templates and shifts in two
        # matrix products (sum M T^2 - 2 sum T Q + sum Q^2)
        squared = ((templates * templates) @ overlap.T - 2 * templates @ shifted.T
                   + (shifted * shifted).sum(axis=1)[None]) / self._overlap_size[None]
        best = squared.argmin(axis=1)
        # the score at that shift: mean absolute difference over the overlap
        absolute = np.abs(templates - shifted[best]) * overlap[best]
        differences = absolute.sum(axis=1) / self._overlap_size[best]
        return differences.astype(np.float32), self._shift_columns[best]

    def candidates(self, thumbnail: np.ndarray) -> np.ndarray:
        """Indices of the templates most similar in the shift-tolerant descriptor (at most ``candidates``)."""
        if self.count <= self.config.candidates:
            return np.arange(self.count)
        similarity = self._descriptors[: self.count] @ self._descriptor(thumbnail)
        chosen = np.argpartition(-similarity, self.config.candidates - 1)[: self.config.candidates]
        return np.sort(chosen)

    def observe(self, thumbnail: np.ndarray) -> ViewMatch:
        """Match a thumbnail against the templates; store it as a new template when nothing matches."""
        if self.count:
            indices = self.candidates(thumbnail)
            differences, shifts = self.compare(thumbnail, indices)
            order = np.argsort(differences, kind="stable")
            matching = order[differences[order] <= self.config.threshold]
            if len(matching):
                best = int(matching[0])
                shift = int(shifts[best])
                # content moved right (positive shift) means the camera turned left: positive yaw
                return ViewMatch(int(indices[best]), False, float(differences[best]), shift,
                                 shift * self.radians_per_column, tuple(int(index) for index in indices[matching[1:]]))
        return ViewMatch(self.add(thumbnail), True, 0.0, 0, 0.0)

    def add(self, thumbnail: np.ndarray) -> int:
        """Store a thumbnail as a new template; returns its id."""
        if self.count == len(self._templates):
            self._templates = np.concatenate([self._templates, np.empty_like(self._templates)])
            self._descriptors = np.concatenate([self._descriptors, np.empty_like(self._descriptors)])
            self._contrasts = np.concatenate([self._contrasts, np.empty_like(self._contrasts)])
        self._templates[self.count] = thumbnail
        self._descriptors[self.count] = self._descriptor(thumbnail)
        self._contrasts[self.count] = self._column_contrast(thumbnail[None])[0]
        self.count += 1
        return self.count - 1

"""Grid-cell path integration with the Burak–Fiete periodic network (grid-network paper, section II).

The network (grid-network eqs. 1–4): n × n neurons on a torus, neuron i at x_i with a preferred direction theta_i
(each 2 × 2 block holds east, north, west and south). Its synaptic activation s follows

    tau ds_i/dt + s_i = f(sum_j W_ij s_j + B_i),   f(x) = max(x, 0)                         (grid-network eq. 1)
    W_ij = W_0(x_i - x_j - l e_theta_j)                                                       (grid-network eq. 2)
    W_0(x) = alpha exp(-gamma |x|²) - exp(-beta |x|²)                                        (grid-network eq. 3)
    B_i = A(x_i) (1 + eta e_theta_i · v),   A = 1 on the periodic sheet                       (grid-network eq. 4)

(grid-network eq. 2 as Burak and Fiete define it: the outgoing weights of neuron j are shifted along j's own
direction, which is what makes the pattern flow with the velocity input). ``sum_j W_ij s_j`` is, for each of
the four directions, a circular convolution of that direction's neurons with W_0 shifted by l along it;
one frame of it is four real FFTs of the masked activity, one product-sum with the four kernel spectra
and one inverse FFT, then the Euler step of grid-network eq. 1. From a random start at rest the activity settles into a
triangular lattice (period about 25 neurons with Table II's parameters); a velocity input makes the
lattice flow along it, 0.36 neurons per step per unit of ``eta |v|``, linearly while that stays below
about 0.04 (measured: beyond it the lattice deforms and the flow direction errs by several degrees;
an Euler step of 2 ms instead of 0.5 makes the sheet unstable).

The read-out (Table I): the shift between two consecutive frames of activity. Instead of the paper's
brute-force search over every shift in [-Delta, Delta]², the circular cross-correlation of the two frames
is computed with one FFT product and its peak taken within ±Delta; the sub-neuron part is then refined by
Gauss–Newton on the whole sheet (the earlier frame shifted by an exact Fourier phase ramp until it best
matches the later one), which is accurate to about 0.001 neurons where a parabola through the peak errs
by up to 0.1 (direction errors of 2 degrees at the flows a frame produces).

The metric displacement (grid-network eq. 5) takes only the direction of that shift; its length is the distance driven:
r = distance (dx, dy) / |(dx, dy)|. The lattice flows slightly off its input's direction (up to about a
degree, depending on the heading against the lattice's axes); the network measures that once, after it
settles (``calibration_directions`` headings), and the read-out direction is corrected by it. The
sheet's axes are the world's x and y (grid-network eq. 5's minus sign for dy comes from the image row axis of the
paper's figures, which this sheet does not have). Heading comes from outside (the rotations accumulated)
and height from the height rate: the network integrates planar motion only.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import fft

from ..config import GridNetworkConfig
from .kernels import euler_step, phase_ramp, polyphase_recurrence, shift_normal_equations

__all__ = ["GridNetwork", "cyclic_shift"]

PREFERRED_DIRECTIONS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])  # east, north, west, south
REFINEMENT_ITERATIONS = 4  # Gauss–Newton steps of the sub-neuron read-out at most
REFINEMENT_SETTLED = 1e-5  # neurons: the refinement stops once a step is smaller


def _fourier_shift(spectrum: np.ndarray, shape: tuple[int, int], shift: np.ndarray) -> np.ndarray:
    """The real array whose real-FFT ``spectrum`` is given, shifted circularly by ``shift`` (cells, any
    fraction) along its two axes: a multiplication by the phase ramp of the shift."""
    return fft.irfft2(phase_ramp(spectrum, shape[0], shape[1], float(shift[0]), float(shift[1])), s=shape)


def cyclic_shift(previous: np.ndarray, current: np.ndarray, search_radius: int) -> np.ndarray:
    """The circular shift (d0, d1) along the two axes, in cells with a sub-cell part, that best maps
    ``previous`` onto ``current`` (``current ≈ previous`` moved by d), searched within ±``search_radius``.

    Table I's search for the best shift, done as the peak of the FFT cross-correlation, then refined below
    a cell by Gauss–Newton on the residual of the exactly (Fourier-) shifted ``previous``, within one cell
    of the peak.
    """
    previous = np.asarray(previous, dtype=np.float64)
    current = np.asarray(current, dtype=np.float64)
    shape = previous.shape
    a, b = previous - previous.mean(), current - current.mean()
    spectrum = fft.rfft2(a)
    correlation = fft.irfft2(np.conj(spectrum) * fft.rfft2(b), s=shape)
    offsets = np.arange(-search_radius, search_radius + 1)
    window = correlation[np.ix_(offsets % shape[0], offsets % shape[1])]
    peak = np.unravel_index(int(np.argmax(window)), window.shape)
    whole = np.array([offsets[peak[0]], offsets[peak[1]]], dtype=float)
    shift = whole.copy()
    for _ in range(REFINEMENT_ITERATIONS):
        moved = _fourier_shift(spectrum, shape, shift)
        # b ≈ moved(x - delta) ≈ moved - gradient · delta (central differences): least squares for delta
        normal, right = shift_normal_equations(moved, b)
        if abs(np.linalg.det(normal)) < 1e-12:
            break
        delta = np.linalg.solve(normal, right)
        shift = np.clip(shift + delta, whole - 1, whole + 1)  # the refinement stays by the correlation's peak
        if np.abs(delta).max() < REFINEMENT_SETTLED:
            break
    return shift


class GridNetwork:
    """The Burak–Fiete periodic grid-cell network as a planar path integrator.

    Args:
        config: network parameters (Table II).

    Example::

        network = GridNetwork()
        dx, dy = network.integrate(0.1, heading=0.3, dt=0.1)   # 10 cm at 0.3 rad: metres, grid-network eq. 5
    """

    def __init__(self, config: GridNetworkConfig = GridNetworkConfig()):
        config.validate("grid_network")
        self.config = config
        n = config.size
        self.shape = (n, n)
        beta = 3.0 / config.lattice_period**2
        gamma = config.surround_ratio * beta
        offsets = np.arange(n)
        offsets = np.where(offsets >= n // 2, offsets - n, offsets).astype(float)
        first, second = np.meshgrid(offsets, offsets, indexing="ij")
        # each 2 x 2 block of neurons holds the four directions
        self.direction_index = (2 * (np.arange(n)[:, None] % 2) + (np.arange(n)[None, :] % 2)).astype(np.int64)
        kernels = []
        for direction in PREFERRED_DIRECTIONS:  # grid-network eqs. 2-3: W_0 centred l cells along the direction
            x = first - config.weight_shift * direction[0]
            y = second - config.weight_shift * direction[1]
            squared = x * x + y * y
            weights = config.excitation_scale * np.exp(-gamma * squared) - np.exp(-beta * squared)
            kernels.append(fft.rfft2(weights))
        # each kernel's spectrum times the phase of its direction's place (r, c) in the 2 x 2 blocks, d = 2 r + c:
        # the masked sheet's spectrum is its sub-sheet's repeated, times e^{-2 pi i (k r + l c) / n} (step)
        rows = np.fft.fftfreq(n, 1.0 / n)[:, None]
        columns = np.arange(n // 2 + 1)[None, :]
        phases = [np.exp(-2j * math.pi * (rows * (d // 2) + columns * (d % 2)) / n) for d in range(4)]
        self._kernels = (np.stack(kernels) * np.stack(phases)).astype(np.complex64)
        self._preferred = PREFERRED_DIRECTIONS[self.direction_index].astype(np.float32)  # (n, n, 2)
        rng = np.random.default_rng(config.seed)
        self.activity = rng.uniform(0.0, 0.1, self.shape).astype(np.float32)
        self.step(np.zeros(2), config.settle_steps)
        self.direction_bias = self._calibrate() if config.calibration_directions else np.zeros(0)

    def step(self, velocity: np.ndarray, steps: int = 1) -> None:
        """``steps`` Euler steps of grid-network eq. 1 with the velocity input ``v`` of grid-network eq. 4
        (network units; see ``velocity_scale``).

        The recurrent input Σ_j W_ij s_j is, per direction, a circular convolution of that direction's neurons
        (one of each 2 × 2 block) with its kernel: its spectrum is taken from the real FFTs of the four
        quarter-size sub-sheets (:func:`~.kernels.polyphase_recurrence`), a quarter of the work of
        transforming four masked whole sheets, the same sums."""
        config = self.config
        drive = 1.0 + config.velocity_gain * (self._preferred @ np.asarray(velocity, dtype=np.float32))
        rate = config.time_step / config.time_constant
        half = self.shape[0] // 2
        activity = self.activity.copy()
        for _ in range(steps):
            # the sub-sheets s[r::2, c::2], direction d = 2 r + c (direction_index)
            sub_sheets = activity.reshape(half, 2, half, 2).transpose(1, 3, 0, 2).reshape(4, half, half)
            spectrum = polyphase_recurrence(fft.rfft2(sub_sheets), self._kernels)
            euler_step(activity, fft.irfft2(spectrum, s=self.shape), drive, rate)
        self.activity = activity

    def _calibrate(self) -> np.ndarray:
        """The lattice's own direction error: for each of ``calibration_directions`` headings, how far the
        read-out flow direction turns from the input's at 1 m/s (rad). A triangular lattice flows slightly
        off its input (up to about 1 degree, depending on the heading against the lattice's axes, which the
        random start sets); :meth:`integrate` subtracts it. The activity is left as it was."""
        settled = self.activity.copy()
        config = self.config
        biases = []
        for heading in np.linspace(0, 2 * math.pi, config.calibration_directions, endpoint=False):
            velocity = config.velocity_scale * np.array([math.cos(heading), math.sin(heading)])
            self.activity = settled.copy()
            self.step(velocity, 6 * config.steps_per_frame)  # let the flow settle into its direction
            before = self.activity
            self.step(velocity, 3 * config.steps_per_frame)
            shift = cyclic_shift(before, self.activity, config.search_radius)
            biases.append(math.remainder(math.atan2(shift[1], shift[0]) - heading, 2 * math.pi))
        self.activity = settled
        return np.array(biases)

    def _corrected(self, direction: float) -> float:
        """A read-out flow direction (rad) less the calibrated bias at that direction (interpolated)."""
        count = len(self.direction_bias)
        if count == 0:
            return direction
        position = (direction % (2 * math.pi)) / (2 * math.pi) * count
        below = int(position) % count
        fraction = position - int(position)
        return direction - ((1 - fraction) * self.direction_bias[below]
                            + fraction * self.direction_bias[(below + 1) % count])

    def integrate(self, distance: float, heading: float, dt: float) -> tuple[float, float]:
        """One frame: drive the network with the robot's velocity (``distance`` m along ``heading`` rad over
        ``dt`` s) for ``steps_per_frame`` steps, read out the lattice's shift (Table I) and return the
        metric displacement of grid-network eq. 5 (dx, dy) in metres: the distance along the shift's direction."""
        if dt <= 0:
            return 0.0, 0.0
        config = self.config
        speed = distance / dt
        velocity = config.velocity_scale * speed * np.array([math.cos(heading), math.sin(heading)])
        before = self.activity
        self.step(velocity, config.steps_per_frame)
        if distance == 0:
            return 0.0, 0.0
        shift = cyclic_shift(before, self.activity, config.search_radius)
        if math.hypot(shift[0], shift[1]) < 1e-9:  # no measurable flow: grid-network eq. 5 has no direction;
            # keep the heading
            return distance * math.cos(heading), distance * math.sin(heading)
        direction = self._corrected(math.atan2(shift[1], shift[0]))
        return distance * math.cos(direction), distance * math.sin(direction)

    def state_dict(self) -> dict[str, np.ndarray]:
        """The network's state (its activity), for saving."""
        return {"activity": self.activity.copy()}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output. Raises ValueError when it does not fit this network."""
        activity = np.asarray(state["activity"])
        if activity.shape != self.shape or activity.dtype != np.float32:
            raise ValueError(f"activity is {activity.dtype} {activity.shape}, the network is float32 {self.shape}")
        self.activity = activity.copy()

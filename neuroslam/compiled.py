"""The options every compiled loop of the library is built with (numba), and the one compiler setting they need.

The per-pixel and per-cell loops (:mod:`neuroslam.vision.kernels`, :mod:`neuroslam.cells.kernels`) end in
sums. A compiler may only run such a loop on the vector units (8 or 16 pixels an instruction) by splitting
each sum into partial sums, which changes its rounding; numba's ``fastmath`` allows that, and did it
differently for a function compiled afresh and the same function loaded from numba's cache, so two runs of
one drive differed in the last digits (``tests/test_determinism.py``). LLVM can instead vectorise everything
but the sums and add each vector's terms to the sum one after another, in the loop's own order (an *ordered*
reduction): every result is bit for bit the scalar loop's, whatever the compiler decides, and the arithmetic
of the loop body runs on the vector units. LLVM does this only when asked, with its option
``force-ordered-reductions``; :func:`enable_ordered_reductions` sets it, once, before the first compilation.
It changes no result of any numba function in the process (ordered reductions keep IEEE order); where an
LLVM does not know the option, it is ignored and the loops run scalar, slower (about 2.5× for the floor
alignment) and with the same results. ``benchmarks/slam_speed.py`` prints whether the loops were vectorised.
"""

from __future__ import annotations

import logging

__all__ = ["JIT", "enable_ordered_reductions", "vectorised"]

logger = logging.getLogger(__name__)

# no fastmath: with it the compiler may reorder the sums, and did so differently for a function compiled
# afresh and the same function loaded from numba's cache; IEEE order keeps every run's numbers the same
JIT = {"cache": True, "nogil": True, "error_model": "numpy"}

_enabled = False


def enable_ordered_reductions() -> None:
    """Let LLVM vectorise loops that end in floating-point sums, keeping each sum's order (see the module's
    docstring). Idempotent; call before the first compilation (the kernels' modules do, on import)."""
    global _enabled
    if _enabled:
        return
    import llvmlite.binding

    llvmlite.binding.set_option("neuroslam", "--force-ordered-reductions")
    _enabled = True
    logger.debug("LLVM option force-ordered-reductions set")


def vectorised() -> bool:
    """Whether this process's compiled loops run on the vector units: compiles (uncached) a probe loop shaped like
    the kernels' (bilinear-style gathers from an image, a float32 sum) and looks for vector gathers in its
    machine code (x86 AVX2 / AVX-512 ``vgather``; False on other processors, whose instructions differ).
    ``benchmarks/slam_speed.py`` prints it."""
    import numba
    import numpy as np

    @numba.njit(cache=False, error_model="numpy")
    def probe(image, index, weight):
        total = np.float32(0.0)
        for k in range(weight.shape[0]):
            total += image[index[k]] * weight[k]
        return total

    values = np.ones(64, dtype=np.float32)
    probe(values, np.arange(64, dtype=np.int32), values)
    assembly = "".join(probe.inspect_asm().values())
    return "vgather" in assembly or "vpgather" in assembly

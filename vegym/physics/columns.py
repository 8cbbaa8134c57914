"""Array arguments prepared for the scalar numba kernels of the physics modules, the kernels' scratch space and
the vector width they ask for."""

from __future__ import annotations

import numpy as np
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

SMALL_SCRATCH = 64
"""Scratch arrays of at most this many elements live on the kernel's stack (no allocation)."""


def floats(*values: np.ndarray | float | list) -> list[np.ndarray]:
    """``values`` (numbers, lists or arrays) as float64 arrays, copied only where the dtype changes."""
    return [np.asarray(value, dtype=np.float64) for value in values]


def flat_columns(*arrays: np.ndarray | float) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The broadcast shape of ``arrays`` and each of them broadcast to it as a contiguous, writeable 1-d float64
    array (a copy only where broadcasting, a dtype change or the memory layout needs one)."""
    columns = floats(*arrays)
    shape = np.broadcast_shapes(*(c.shape for c in columns))
    return shape, [
        np.ascontiguousarray(c).reshape(-1) if c.shape == shape else np.array(np.broadcast_to(c, shape)).reshape(-1)
        for c in columns
    ]


@njit(cache=True)
def pairwise_sum(values: np.ndarray) -> float:
    """``np.sum`` of a contiguous 1-d float64 array, bit for bit: numpy's pairwise summation (8 accumulators), for
    kernels that must add up as the numpy code they replace did."""
    n = len(values)
    if n < 8:
        total = 0.0
        for x in values:
            total += x
        return total
    if n > 128:
        half = n // 2
        half -= half % 8
        return pairwise_sum(values[:half]) + pairwise_sum(values[half:])
    r0, r1, r2, r3 = values[0], values[1], values[2], values[3]
    r4, r5, r6, r7 = values[4], values[5], values[6], values[7]
    for i in range(8, n - n % 8, 8):  # eight running sums in locals: no array allocated per call
        r0, r1, r2, r3 = r0 + values[i], r1 + values[i + 1], r2 + values[i + 2], r3 + values[i + 3]
        r4, r5, r6, r7 = r4 + values[i + 4], r5 + values[i + 5], r6 + values[i + 6], r7 + values[i + 7]
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(n - n % 8, n):
        total += values[i]
    return total


@intrinsic
def _stack_floats(typingctx, count):  # noqa: ANN001, ANN202 (numba's intrinsic protocol)
    """Pointer to ``count`` (a compile-time constant) float64s on the stack of the calling kernel."""

    def codegen(context, builder, signature, args):  # noqa: ANN001, ANN202
        return cgutils.alloca_once(builder, context.get_value_type(types.float64), size=args[0])

    return types.CPointer(types.float64)(types.intp), codegen


@njit(cache=True, inline="always")
def scratch(n: int) -> np.ndarray:
    """Uninitialised float64 scratch space of ``n`` elements for a kernel's passes, never returned or kept: on the
    kernel's stack for ``n <= SMALL_SCRATCH`` (a single env's step allocates nothing), else on the heap. Either
    way a memory of its own, which the compiler knows apart from every other array (rows of one array are not)."""
    small = carray(_stack_floats(SMALL_SCRATCH), (SMALL_SCRATCH,))
    return small[:n] if n <= SMALL_SCRATCH else np.empty(n)


WIDE_VECTORS = '"prefer-vector-width"="512"'
"""The LLVM function attribute that :func:`prefer_wide_vectors` gives a kernel."""


@intrinsic
def prefer_wide_vectors(typingctx):  # noqa: ANN001, ANN202 (numba's intrinsic protocol)
    """Have the compiler write the calling kernel's SIMD loops in 512-bit vectors where the CPU has them (AVX-512):
    LLVM's x86 backend otherwise keeps to 256-bit vectors on such CPUs. Results are the same, bit for bit, for loops
    of arithmetic, square roots and :mod:`vegym.physics.vmath`'s functions (the same operations on each element; a
    libm function that numba vectorises through Intel's SVML, where installed, may round otherwise at another
    width); only the speed changes, and not always for the better (SteerableWheel's kernel stepped 2% slower,
    Thread's 5%), so kernels call it where it was measured faster. It marks the function it is called in, and every
    function that inlines that one (``inline="always"``), not the helpers that function calls without inlining. No
    effect on other CPUs."""

    def codegen(context, builder, signature, args):  # noqa: ANN001, ANN202
        attributes = builder.function.attributes
        if isinstance(attributes, set):  # llvmlite checks names against its list of enum attributes only
            set.add(attributes, WIDE_VECTORS)
        return context.get_dummy_value()

    return types.void(), codegen

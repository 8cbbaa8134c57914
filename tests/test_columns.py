"""vegym.physics.columns: the kernels' scratch space and numpy's pairwise sum."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from vegym.physics.columns import SMALL_SCRATCH, WIDE_VECTORS, pairwise_sum, prefer_wide_vectors, scratch


@njit
def _fill_two(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Two scratch arrays filled with different values, copied out (scratch itself is never returned)."""
    a, b = scratch(n), scratch(n)
    for i in range(n):
        a[i], b[i] = float(i), -float(i) - 1.0
    return a.copy(), b.copy()


@pytest.mark.parametrize("n", [0, 1, SMALL_SCRATCH, SMALL_SCRATCH + 1, 10_000])
def test_scratch_arrays_hold_n_floats_each_in_memory_of_their_own(n: int) -> None:
    a, b = _fill_two(n)
    np.testing.assert_array_equal(a, np.arange(n, dtype=float))
    np.testing.assert_array_equal(b, -np.arange(n, dtype=float) - 1.0)


@pytest.mark.parametrize("n", [1, 7, 8, 9, 100, 128, 129, 1000, 4099])
def test_pairwise_sum_is_numpys_sum_bit_for_bit(n: int) -> None:
    values = np.random.default_rng(n).normal(size=n) * 10.0 ** np.random.default_rng(n + 1).integers(-8, 8, n)
    assert pairwise_sum(values) == np.sum(values)


def test_pairwise_sum_of_eight_values_uses_numpys_eight_accumulators() -> None:
    """n = 8 is the first length numpy sums with its eight accumulators, not left to right."""
    values = np.array([1.0] + [1e-16] * 7)
    assert np.sum(values) != sum(values.tolist())  # the two orders differ on these values
    assert pairwise_sum(values) == np.sum(values)


def _quotients(numerators: np.ndarray, denominators: np.ndarray) -> np.ndarray:
    """A loop that compiles to SIMD code, with divisions, square roots and sines."""
    out = np.empty_like(numerators)
    for i in range(len(out)):
        out[i] = np.sqrt(numerators[i] / denominators[i]) + np.sin(numerators[i])
    return out


_inlined_quotients = njit(inline="always")(_quotients)


@njit
def _wide_quotients(numerators: np.ndarray, denominators: np.ndarray) -> np.ndarray:
    prefer_wide_vectors()
    return _inlined_quotients(numerators, denominators)


def test_a_kernel_that_prefers_wide_vectors_is_marked_so_and_computes_the_same_bits() -> None:
    plain = njit(_quotients)
    numerators, denominators = np.random.default_rng(0).normal(size=(2, 1001))
    np.testing.assert_array_equal(_wide_quotients(numerators, denominators), plain(numerators, denominators))
    (wide_ir,), (plain_ir,) = _wide_quotients.inspect_llvm().values(), plain.inspect_llvm().values()
    assert WIDE_VECTORS in wide_ir
    assert WIDE_VECTORS not in plain_ir

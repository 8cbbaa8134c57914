"""vegym.physics.columns: the kernels' scratch space and numpy's pairwise sum."""

from __future__ import annotations

import gymnasium as gym
import llvmlite.binding as llvm
import numpy as np
import pytest
from numba import njit

import vegym  # noqa: F401  (registers the envs)
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
    """A loop that compiles to SIMD code (numpy's error model: no division-by-zero check) of divisions and square
    roots."""
    out = np.empty_like(numerators)
    for i in range(len(out)):
        out[i] = np.sqrt(numerators[i] / denominators[i]) + numerators[i]
    return out


_inlined_quotients = njit(inline="always", error_model="numpy")(_quotients)


@njit(error_model="numpy")
def _wide_quotients(numerators: np.ndarray, denominators: np.ndarray) -> np.ndarray:
    prefer_wide_vectors()
    return _inlined_quotients(numerators, denominators)


def _has_avx512() -> bool:
    return "+avx512f" in llvm.get_host_cpu_features().flatten().split(",")


def test_a_kernel_that_prefers_wide_vectors_is_marked_so_and_computes_the_same_bits() -> None:
    """Marked through a helper it inlines; on an AVX-512 CPU its loop is compiled to 512-bit vectors (zmm
    registers; the unmarked one's to 256-bit vectors where LLVM tunes the CPU so, as on this project's machines),
    and it gives the unmarked loop's bits."""
    plain = njit(error_model="numpy")(_quotients)
    numerators, denominators = np.random.default_rng(0).normal(size=(2, 1001)) ** 2
    np.testing.assert_array_equal(_wide_quotients(numerators, denominators), plain(numerators, denominators))
    (wide_ir,), (plain_ir,) = _wide_quotients.inspect_llvm().values(), plain.inspect_llvm().values()
    assert WIDE_VECTORS in wide_ir
    assert WIDE_VECTORS not in plain_ir
    (wide_asm,) = _wide_quotients.inspect_asm().values()
    assert ("zmm" in wide_asm) == _has_avx512()


@pytest.mark.parametrize("env_id", ["vegym/Aircraft-v0", "vegym/ProjectileAdjust-v0"])
def test_the_step_kernels_measured_faster_so_prefer_wide_vectors(env_id: str) -> None:
    """Their kernels compiled afresh (numba's cache keeps no IR) carry the attribute."""
    env = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    task, state = env.unwrapped.task, env.unwrapped.state
    kernel, args = task.step_call(state, np.zeros((2, *env.single_action_space.shape)), task.outputs(2))
    options = {name: value for name, value in kernel.targetoptions.items() if name not in ("cache", "nopython")}
    fresh = njit(**options)(kernel.py_func)
    fresh.compile(tuple(fresh.typeof_pyval(arg) for arg in args))
    (ir,) = fresh.inspect_llvm().values()
    assert WIDE_VECTORS in ir

"""The single env's bound kernel calls: the packed shim must do exactly what the kernel called directly does."""

import gc
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from vegym.envs import kernel_call
from vegym.envs.kernel_call import bind_kernel


@njit(cache=True)
def _mixed_kernel(
    table: np.ndarray, flags: np.ndarray, constants: np.ndarray, scale: float, pair: tuple, count: int, out: np.ndarray
) -> float:
    """Writes ``out`` (n, 2) from arrays of three dtypes, a read-only one, a float, a tuple and an int."""
    total = 0.0
    for i in range(table.shape[0]):
        for k in range(2):
            out[i, k] = table[i, k] * scale + constants[k] * pair[k] + count * flags[i]
            total += out[i, k]
        table[i, 0] += 1.0
    return total


def _arguments() -> tuple:
    rng = np.random.default_rng(5)
    constants = rng.normal(size=2)
    constants.flags.writeable = False
    return rng.normal(size=(3, 2)), np.array([True, False, True]), constants, 0.5, (2.0, -3.0), 7, np.empty((3, 2))


def test_bound_kernel_writes_and_returns_what_the_direct_call_does() -> None:
    direct, bound_args = _arguments(), _arguments()
    bound = bind_kernel(_mixed_kernel, bound_args)
    assert hasattr(bound, "arrays"), "these arguments take the packed shim"
    for _ in range(3):  # the bound call sees each call's changes (table[:, 0] grows)
        assert bound() == _mixed_kernel(*direct)
        for got, want in zip(bound_args, direct, strict=True):
            np.testing.assert_array_equal(got, want)


def test_bound_kernel_keeps_its_arrays_alive() -> None:
    args = _arguments()
    expected = _mixed_kernel(*_arguments())
    bound = bind_kernel(_mixed_kernel, args)
    out = args[-1]
    del args
    gc.collect()
    assert bound() == expected
    np.testing.assert_array_equal(bound.arrays[-1], out)


def test_kernels_with_arguments_the_shim_cannot_take_are_called_directly() -> None:
    direct, bound_args = _arguments(), _arguments()
    strided = np.asfortranarray(bound_args[0])
    bound = bind_kernel(_mixed_kernel, (strided, *bound_args[1:]))
    assert not hasattr(bound, "arrays")
    assert bound() == _mixed_kernel(*direct)
    np.testing.assert_array_equal(strided, direct[0])


@njit(cache=True)
def _scaled_in_place(values: np.ndarray, factor: float) -> np.ndarray:
    values *= factor
    return values


def test_kernels_returning_arrays_are_called_directly() -> None:
    """Through the shim a returned argument would be a view of memory the bound function owns, without a base."""
    values = np.arange(3.0)
    bound = bind_kernel(_scaled_in_place, (values, 2.0))
    assert not hasattr(bound, "arrays")
    assert bound() is values
    np.testing.assert_array_equal(values, [0.0, 2.0, 4.0])


def test_a_shim_compiled_for_another_layout_is_not_used(monkeypatch: pytest.MonkeyPatch) -> None:
    """Processes saving shims at once could leave a cache entry with another layout's code, which numba registers
    under that layout's signature: without an overload for this layout after compiling, the kernel is called
    directly."""
    table, flags, constants, scale, pair, count, out = _arguments()
    arguments = (table, flags, constants, scale, pair, np.int32(count), out)  # a layout no other test compiles
    other = bind_kernel(_mixed_kernel, (*arguments[:5], float(count), out))
    assert hasattr(other, "arrays")
    monkeypatch.setattr(kernel_call._call_packed, "compile", lambda signature: other.func)
    bound = bind_kernel(_mixed_kernel, arguments)
    assert not hasattr(bound, "arrays")
    assert bound() == _mixed_kernel(*_arguments())


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="the lock file is POSIX's")
def test_a_compile_lock_file_that_cannot_be_opened_leaves_the_first_reset_unlocked_not_failing(tmp_path: Path) -> None:
    """Another user's ``vegym-kernel-call-<uid>.lock`` in a shared temporary directory (here a directory of that
    name, which not even root opens as a file) made every process's first single-env reset raise PermissionError
    (a helper's review)."""
    (tmp_path / f"vegym-kernel-call-{os.getuid()}.lock").mkdir()
    code = "import gymnasium as gym, vegym; gym.make('vegym/Projectile-v0').reset(seed=0); print('reset')"
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "TMPDIR": str(tmp_path)},
    )
    assert done.returncode == 0 and done.stdout.strip() == "reset", done.stderr

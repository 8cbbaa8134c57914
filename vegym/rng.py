"""Counter-based random numbers over batches of 64-bit keys (SplitMix64).

Each sub-environment carries one ``uint64`` key per episode. Every random quantity of an episode is a
pure function of that key and a counter, so the single env and each sub-env of the vector env draw
exactly the same numbers whatever the other sub-envs do, resets included. A vector env reset with
``seed=s`` gives sub-env ``i`` the key of a single env reset with ``seed=s + i`` (Gymnasium's
``SyncVectorEnv`` convention); the next episode's key is :func:`next_key` of the previous one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_NEXT_EPISODE = np.uint64(0xD1B54A32D192ED03)
_TO_UNIT = 2.0**-53


@njit(cache=True, inline="always")
def _mix_one(z: np.uint64) -> np.uint64:
    """SplitMix64 finaliser of one uint64 (wrapping arithmetic)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit(cache=True)
def _mix_each(z: np.ndarray) -> np.ndarray:
    out = np.empty_like(z)
    for i in range(z.size):
        out[i] = _mix_one(z[i])
    return out


@njit(cache=True, inline="always")
def advance_rows(keys: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """For kernels: replace the keys of the rows ``rows`` (int indices) of ``keys`` by :func:`next_key` of them, in
    place, and return those new keys (inlined: numba's cache does not see edits to it, clear it)."""
    advanced = np.empty(len(rows), np.uint64)
    for j in range(len(rows)):
        advanced[j] = keys[rows[j]] = _mix_one(keys[rows[j]] ^ _NEXT_EPISODE)
    return advanced


def _mix(z: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser of every element of a uint64 array (any shape)."""
    z = np.asarray(z, dtype=np.uint64)
    return _mix_each(np.ascontiguousarray(z).reshape(-1)).reshape(z.shape)[()]  # [()]: a scalar for a 0-d input


def seed_keys(seeds: np.ndarray | Sequence[int] | int) -> np.ndarray:
    """Episode keys from integer seeds in [0, 2**64) (any shape); ValueError for any other seed (a bool too)."""
    s = seeds if isinstance(seeds, np.ndarray) else np.array(seeds, dtype=object)  # numpy would guess a dtype
    if s.dtype == object:  # Python ints, checked one by one
        if not all(isinstance(x, int | np.integer) and not isinstance(x, bool) and 0 <= x < 2**64 for x in s.flat):
            raise ValueError(f"seeds must be integers in [0, 2**64); got {seeds!r}")
        s = s.astype(np.uint64)
    elif s.dtype.kind not in "iu" or (s.dtype.kind == "i" and s.size and s.min() < 0):
        raise ValueError(f"seeds must be integers in [0, 2**64); got {seeds!r}")
    return _mix(s.astype(np.uint64) * _GOLDEN + _GOLDEN)


def next_key(keys: np.ndarray) -> np.ndarray:
    """The key of the next episode of each sub-environment."""
    return _mix(keys ^ _NEXT_EPISODE)


@njit(cache=True, inline="always")
def stream_base(key: np.uint64, stream_offset: np.uint64, counter: np.uint64) -> np.uint64:
    """The mixed state that the lanes of one draw (one key, stream and counter) are taken from (uint64 scalars)."""
    return _mix_one(key * _GOLDEN + stream_offset + counter * _M2)


@njit(cache=True, inline="always")
def lane(base: np.uint64, j: int) -> float:
    """Lane ``j`` of a draw from :func:`stream_base`: a float in [0, 1)."""
    return np.float64(_mix_one(base + np.uint64(j + 1) * _GOLDEN) >> _S11) * _TO_UNIT


@njit(cache=True)
def _uniform_kernel(keys: np.ndarray, stream_offset: np.uint64, size: int, counters: np.ndarray) -> np.ndarray:
    """:func:`uniform` fused per key: lane j is ``_mix(_mix(key GOLDEN + stream + counter M2) + (j + 1) GOLDEN)``."""
    out = np.empty((len(keys), size))
    for i in range(len(keys)):
        base = stream_base(keys[i], stream_offset, counters[i])
        for j in range(size):
            out[i, j] = lane(base, j)
    return out


def stream_offset(stream: int) -> np.uint64:
    """The offset that separates draws of stream number ``stream`` (as the kernels take it)."""
    return np.uint64((stream * int(_M1)) % 2**64)


def uniform(keys: np.ndarray, stream: int, size: int, counter: np.ndarray | int = 0) -> np.ndarray:
    """Uniform floats in [0, 1), shape ``(len(keys), size)``.

    ``stream`` separates independent uses within an episode (initial state, per-step noise, ...);
    ``counter`` (scalar or per key, e.g. the step index) indexes successive draws of one stream.
    """
    keys = np.ascontiguousarray(keys, dtype=np.uint64)
    counters = np.broadcast_to(np.asarray(counter, dtype=np.uint64).reshape(-1), keys.shape)
    return _uniform_kernel(keys, stream_offset(stream), size, np.ascontiguousarray(counters))


def uniform_in(
    keys: np.ndarray, stream: int, low: float, high: float, size: int = 1, counter: np.ndarray | int = 0
) -> np.ndarray:
    """Uniform floats in [low, high), shape ``(len(keys), size)``."""
    return low + (high - low) * uniform(keys, stream, size, counter)

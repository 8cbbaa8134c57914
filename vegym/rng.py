"""Counter-based random numbers over batches of 64-bit keys (SplitMix64).

Each sub-environment carries one ``uint64`` key per episode. Every random quantity of an episode is a
pure function of that key and a counter, so the single env and each sub-env of the vector env draw
exactly the same numbers whatever the other sub-envs do, resets included. A vector env reset with
``seed=s`` gives sub-env ``i`` the key of a single env reset with ``seed=s + i`` (Gymnasium's
``SyncVectorEnv`` convention); the next episode's key is :func:`next_key` of the previous one.
"""

from __future__ import annotations

import numpy as np

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_NEXT_EPISODE = np.uint64(0xD1B54A32D192ED03)
_TO_UNIT = 2.0**-53


def _mix(z: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser (wrapping uint64 arithmetic)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


def seed_keys(seeds: np.ndarray | int) -> np.ndarray:
    """Episode keys from integer seeds (any shape)."""
    s = np.asarray(seeds, dtype=np.int64).astype(np.uint64)
    return _mix(s * _GOLDEN + _GOLDEN)


def next_key(keys: np.ndarray) -> np.ndarray:
    """The key of the next episode of each sub-environment."""
    return _mix(keys ^ _NEXT_EPISODE)


def uniform(keys: np.ndarray, stream: int, size: int, counter: np.ndarray | int = 0) -> np.ndarray:
    """Uniform floats in [0, 1), shape ``(len(keys), size)``.

    ``stream`` separates independent uses within an episode (initial state, per-step noise, ...);
    ``counter`` (scalar or per key, e.g. the step index) indexes successive draws of one stream.
    """
    stream_offset = np.uint64((stream * int(_M1)) % 2**64)
    base = keys * _GOLDEN + stream_offset + np.asarray(counter, dtype=np.uint64).reshape(-1) * _M2
    lanes = np.arange(1, size + 1, dtype=np.uint64) * _GOLDEN
    z = _mix(_mix(base)[:, None] + lanes)
    return (z >> _S11).astype(np.float64) * _TO_UNIT


def uniform_in(
    keys: np.ndarray, stream: int, low: float, high: float, size: int = 1, counter: np.ndarray | int = 0
) -> np.ndarray:
    """Uniform floats in [low, high), shape ``(len(keys), size)``."""
    return low + (high - low) * uniform(keys, stream, size, counter)

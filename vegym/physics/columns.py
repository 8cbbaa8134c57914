"""Array arguments prepared for the scalar numba kernels of the physics modules."""

from __future__ import annotations

import numpy as np


def flat_columns(*arrays: np.ndarray | float) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The broadcast shape of ``arrays`` and each of them broadcast to it as a contiguous, writeable 1-d float64
    array (a copy only where broadcasting, a dtype change or the memory layout needs one)."""
    columns = [np.asarray(a, dtype=np.float64) for a in arrays]
    shape = np.broadcast_shapes(*(c.shape for c in columns))
    return shape, [
        np.ascontiguousarray(c).reshape(-1) if c.shape == shape else np.array(np.broadcast_to(c, shape)).reshape(-1)
        for c in columns
    ]

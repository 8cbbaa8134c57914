"""Test set-up: a headless SDL video driver, so render_mode="human" works without a screen; shared checks."""

import os
from collections.abc import Callable

import numpy as np
import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")


def _assert_independent_draws_fill(draws: dict[str, tuple[np.ndarray, float, float]]) -> None:
    """Each named sample (thousands of values) lies in its [low, high] and comes within 1% of the range of both
    ends (a uniform draw of 4,000 misses an end's 1% with probability 0.99^4000, 4e-18), and no two samples
    correlate beyond 0.1 (one lane drawn for two quantities correlates fully)."""
    for name, (sample, low, high) in draws.items():
        margin = 0.01 * (high - low)
        assert low <= sample.min() < low + margin, (name, sample.min(), low)
        assert high - margin < sample.max() <= high, (name, sample.max(), high)
    correlation = np.corrcoef([sample for sample, _, _ in draws.values()])
    assert np.abs(correlation - np.eye(len(draws))).max() < 0.1, correlation


@pytest.fixture
def assert_independent_draws_fill() -> Callable[[dict[str, tuple[np.ndarray, float, float]]], None]:
    """:func:`_assert_independent_draws_fill`, for tests of starting states."""
    return _assert_independent_draws_fill

"""Interval estimates of normalized scores across training seeds and evaluation episodes (rliable's bootstrap).

An agent's scores form a matrix of shape ``(seeds, episodes)``: one row per training seed (a single row for the
analytic controller, the random policy and the references, which are not trained), one column per evaluation
episode (the same seeds for every agent). The aggregates are the mean and the interquartile mean (IQM: the mean
of the middle 50% of all scores). Their 95% confidence intervals come from rliable's stratified bootstrap
(Agarwal et al., NeurIPS 2021) applied to the nested structure of the data: the training seeds are the strata,
whole seeds are resampled (``task_bootstrap``) and, within each, its episodes. A seed's episodes come from one
model, so resampling seeds as a whole keeps the variation between seeds in the interval; with three seeds that
part of the interval rests on three values and is coarse. The resampling is seeded, so a report is reproducible.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rliable import library, metrics

BOOTSTRAP_REPS = 2000
"""Bootstrap resamples per interval."""
BOOTSTRAP_SEED = 0
"""Seed of the resampling."""
CONFIDENCE = 0.95


@dataclass(frozen=True)
class ScoreSummary:
    """Mean and IQM of a score matrix with their 95% stratified-bootstrap confidence intervals."""

    mean: float
    iqm: float
    mean_ci95: tuple[float, float]
    iqm_ci95: tuple[float, float]


def _aggregates(scores: np.ndarray) -> np.ndarray:
    return np.array([metrics.aggregate_mean(scores), metrics.aggregate_iqm(scores)])


def summarize(scores: np.ndarray) -> ScoreSummary:
    """Mean, IQM and their 95% CIs of ``scores``, shape ``(seeds, episodes)``."""
    scores = np.asarray(scores, dtype=np.float64)
    if scores.ndim != 2 or scores.size == 0:
        raise ValueError(f"scores must be a non-empty (seeds, episodes) matrix, got shape {scores.shape}")
    if not np.all(np.isfinite(scores)):
        raise ValueError("scores must be finite")
    # rliable draws its resampling indices from numpy's global generator (its random_state only reaches arch),
    # so the global generator is seeded for the call and restored after it
    saved = np.random.get_state()  # noqa: NPY002
    np.random.seed(BOOTSTRAP_SEED)  # noqa: NPY002
    try:
        point, interval = library.get_interval_estimates(
            {"agent": scores.T},  # rliable's (runs, tasks): episodes resampled within each seed, seeds whole
            _aggregates,
            task_bootstrap=True,
            reps=BOOTSTRAP_REPS,
            confidence_interval_size=CONFIDENCE,
        )
    finally:
        np.random.set_state(saved)  # noqa: NPY002
    (mean, iqm), ((mean_low, iqm_low), (mean_high, iqm_high)) = point["agent"], interval["agent"]
    return ScoreSummary(float(mean), float(iqm), (float(mean_low), float(mean_high)), (float(iqm_low), float(iqm_high)))

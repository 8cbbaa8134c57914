"""Interval estimates of normalized scores across training seeds and evaluation episodes (a crossed bootstrap).

An agent's scores form a matrix of shape ``(seeds, episodes)``: one row per training seed (a single row for the
analytic controller, the random policy and the references, which are not trained), one column per evaluation
episode (the same seeds for every agent). The aggregates are the mean and the interquartile mean (IQM: the mean
of the middle 50% of all scores, rliable's ``aggregate_iqm``). Their 95% confidence intervals come from a
percentile bootstrap that resamples both factors of this crossed design: each replicate draws the training seeds
(whole rows) and, once for all of them, the evaluation episodes (whole columns), the two-way "pigeonhole"
bootstrap (Owen, Ann. Appl. Stat. 2007). Every seed plays the same episodes, so an episode's difficulty is
shared by the seeds: rliable's stratified bootstrap, which resamples the episodes of each seed on their own,
treats them as independent and divides that part of the variance by the number of seeds (three copies of one
seed would give an interval sqrt(3) times narrower than the seed alone); no library offers the crossed version.
With three seeds the between-seed part of an interval rests on three values and is coarse. The resampling is
seeded, so a report is reproducible.

The normalized score divides by the random policy's and the analytic controller's mean returns, measured on the
same episodes. Each replicate normalizes by their means over its own draw of episodes (a paired comparison): an
episode's difficulty, shared by the agent and the baselines, cancels instead of showing as spread. So the
analytic controller's mean has the point interval [1, 1], and an agent's interval tells whether it differs from
that controller on these episodes (holding the baselines at their overall means gave Aircraft's PPO [0.960,
1.002] where the paired interval is [0.971, 0.988]).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from rliable import metrics
from scipy import stats

BOOTSTRAP_REPS = 2000
"""Bootstrap resamples per interval."""
BOOTSTRAP_SEED = 0
"""Seed of the resampling (the episode draws and the seed draws come from two streams of it)."""
CONFIDENCE = 0.95


@dataclass(frozen=True)
class ScoreSummary:
    """Mean and IQM of a score matrix with their 95% crossed-bootstrap confidence intervals (None for a single
    score, one seed's one episode, which leaves nothing to resample)."""

    mean: float
    iqm: float
    mean_ci95: tuple[float, float] | None
    iqm_ci95: tuple[float, float] | None


def normalized(value: float, low: float, high: float) -> float | None:
    """``(value - low) / (high - low)``, None when the references tie."""
    return None if math.isclose(high, low, rel_tol=0.0, abs_tol=1e-12) else (value - low) / (high - low)


def summarize(returns: np.ndarray, random: np.ndarray, analytic: np.ndarray) -> ScoreSummary:
    """Mean, IQM and their 95% CIs of the normalized scores ``(R - mean(random)) / (mean(analytic) -
    mean(random))`` of ``returns``, shape ``(seeds, episodes)``, where ``random`` and ``analytic`` (episodes,) are
    the baselines' returns on the same episodes. ValueError if the baselines' means tie; a replicate whose
    episode draw ties them is left out. A single score (one seed, one episode) has no interval."""
    returns = np.asarray(returns, dtype=np.float64)
    baselines = np.asarray([random, analytic], dtype=np.float64)
    if returns.ndim != 2 or returns.size == 0:
        raise ValueError(f"returns must be a non-empty (seeds, episodes) matrix, got shape {returns.shape}")
    if baselines.shape != (2, returns.shape[1]):
        raise ValueError(f"the baselines' returns must have shape ({returns.shape[1]},), one per episode")
    if not (np.all(np.isfinite(returns)) and np.all(np.isfinite(baselines))):
        raise ValueError("returns must be finite")
    low, high = (float(mean) for mean in baselines.mean(axis=1))
    if normalized(high, low, high) is None:
        raise ValueError(f"the baselines tie (mean return {low!r}): no normalized score")
    scores = (returns - low) / (high - low)
    mean, iqm = float(metrics.aggregate_mean(scores)), float(metrics.aggregate_iqm(scores))
    if scores.size == 1:
        return ScoreSummary(mean, iqm, None, None)
    n_seeds, n_episodes = returns.shape
    episode_draws = np.random.default_rng([BOOTSTRAP_SEED, 0]).integers(0, n_episodes, (BOOTSTRAP_REPS, n_episodes))
    seed_draws = np.random.default_rng([BOOTSTRAP_SEED, 1]).integers(0, n_seeds, (BOOTSTRAP_REPS, n_seeds))
    drawn = returns[seed_draws[:, :, None], episode_draws[:, None, :]].reshape(BOOTSTRAP_REPS, -1)
    drawn_low, drawn_high = baselines[:, episode_draws].mean(axis=2)
    kept = drawn_high != drawn_low
    replicates = (drawn[kept] - drawn_low[kept, None]) / (drawn_high - drawn_low)[kept, None]
    tail = 50.0 * (1.0 - CONFIDENCE)
    mean_low, mean_high = np.percentile(replicates.mean(axis=1), [tail, 100.0 - tail])
    iqm_low, iqm_high = np.percentile(stats.trim_mean(replicates, 0.25, axis=1), [tail, 100.0 - tail])
    return ScoreSummary(mean, iqm, (float(mean_low), float(mean_high)), (float(iqm_low), float(iqm_high)))

"""Interval estimates of normalized scores (agents.statistics, the crossed bootstrap over seeds and episodes)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from agents.statistics import ScoreSummary, summarize


def summarize_scores(scores: np.ndarray) -> ScoreSummary:
    """:func:`summarize` of scores that are already normalized: baselines returning 0 (random) and 1 (analytic)
    on every episode, whose draws normalize every replicate alike (the crossed bootstrap of the scores alone)."""
    episodes = np.shape(scores)[-1]
    return summarize(scores, np.zeros(episodes), np.ones(episodes))


def test_constant_scores_have_a_point_interval() -> None:
    summary = summarize_scores(np.full((3, 20), 0.7))
    assert summary.mean == pytest.approx(0.7) and summary.iqm == pytest.approx(0.7)
    assert summary.mean_ci95 == pytest.approx((0.7, 0.7)) and summary.iqm_ci95 == pytest.approx((0.7, 0.7))


def test_a_single_score_has_no_interval_and_one_episode_of_several_seeds_has_one() -> None:
    single = summarize_scores(np.array([[0.7]]))
    assert single.mean == pytest.approx(0.7) and single.mean_ci95 is None and single.iqm_ci95 is None
    seeds = summarize_scores(np.array([[0.6], [0.8]]))
    assert seeds.mean_ci95 == pytest.approx((0.6, 0.8)) and seeds.iqm_ci95 == pytest.approx((0.6, 0.8))


def outlier_scores() -> np.ndarray:
    """Three seeds of 20 episodes around 1.0, three of them outliers at -5 (which move the mean, not the IQM)."""
    scores = np.random.default_rng(0).normal(1.0, 0.2, (3, 20))
    scores[0, :3] = -5.0
    return scores


def test_mean_and_iqm_are_the_closed_forms_and_the_intervals_contain_them() -> None:
    scores = outlier_scores()
    summary = summarize_scores(scores)
    assert summary.mean == pytest.approx(scores.mean(), abs=1e-12)
    assert summary.iqm == pytest.approx(stats.trim_mean(scores.ravel(), 0.25), abs=1e-12)
    assert summary.mean < summary.iqm
    assert summary.mean_ci95[0] < summary.mean < summary.mean_ci95[1]
    assert summary.iqm_ci95[0] < summary.iqm < summary.iqm_ci95[1]
    assert summarize_scores(scores) == summary  # seeded: a report is reproducible


def test_the_iqm_interval_is_the_iqm_s_and_ignores_outliers_that_move_the_mean_s() -> None:
    summary = summarize_scores(outlier_scores())
    assert summary.mean_ci95[0] < 0.0 < 0.8 < summary.iqm_ci95[0]


def test_the_seeded_intervals_of_a_fixed_matrix_do_not_change() -> None:
    """The README publishes these intervals: their resampling (seed, streams, replicate count, the IQM's 25% trim)
    must not change unnoticed."""
    summary = summarize_scores(outlier_scores())
    assert summary.mean_ci95 == pytest.approx((-0.2156599, 1.0907305), abs=1e-7)
    assert summary.iqm_ci95 == pytest.approx((0.8822851, 1.1081839), abs=1e-7)


def test_seeds_resampled_whole_give_the_exact_bootstrap_quantiles() -> None:
    """Five seeds scoring 0, 1, 2, 3, 4 on every episode: a replicate's mean is that of five seeds drawn with
    replacement, whose sum is at most 3 with probability C(8, 5) / 5^5 = 1.8% and at most 4 with C(9, 5) / 5^5 =
    4.0%, so the 2.5% quantile is 4 / 5 and, by symmetry, the 97.5% quantile 16 / 5."""
    scores = np.repeat(np.arange(5.0)[:, None], 20, axis=1)
    assert summarize_scores(scores).mean_ci95 == pytest.approx((0.8, 3.2), abs=1e-12)


def test_disagreeing_training_seeds_widen_the_interval() -> None:
    """The bootstrap resamples training seeds: the same episodes with one seed far off give a wider CI."""
    episodes = np.random.default_rng(1).normal(1.0, 0.05, 20)
    agree = np.stack([episodes, episodes, episodes])
    disagree = np.stack([episodes, episodes, episodes - 0.6])
    width = [np.diff(summarize_scores(m).mean_ci95)[0] for m in (agree, disagree)]
    assert width[1] > 3 * width[0]


def test_one_run_is_bootstrapped_over_episodes() -> None:
    """An untrained controller has one run; its interval reflects the spread of its episodes."""
    scores = np.random.default_rng(2).normal(1.0, 0.3, (1, 40))
    low, high = summarize_scores(scores).mean_ci95
    half_width = 1.96 * scores.std() / np.sqrt(scores.size)
    assert high - low == pytest.approx(2 * half_width, rel=0.25)


@pytest.mark.parametrize("bad", [np.zeros(5), np.zeros((0, 3)), np.array([[1.0, np.nan]])])
def test_bad_return_matrices_are_rejected(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match="returns must be"):
        summarize_scores(bad)


def test_baselines_of_another_length_or_tying_are_rejected() -> None:
    with pytest.raises(ValueError, match=r"the baselines' returns must have shape \(3,\)"):
        summarize(np.zeros((2, 3)), np.zeros(4), np.ones(4))
    with pytest.raises(ValueError, match="the baselines tie"):
        summarize(np.zeros((2, 3)), np.full(3, 2.0), np.full(3, 2.0))


def test_seeds_are_resampled_whole() -> None:
    """Seeds far apart and episodes alike: the interval spans the seeds' spread (resampling a seed per episode,
    as if every episode came from an independent model, would make it about ten times narrower)."""
    episodes = np.random.default_rng(3).normal(0.0, 0.01, 20)
    scores = np.stack([0.5 + episodes, 1.0 + episodes, 1.5 + episodes])
    low, high = summarize_scores(scores).mean_ci95
    assert low < 0.75 and high > 1.25


def test_copies_of_one_seed_give_that_seed_s_interval() -> None:
    """Every seed plays the same episodes: identical seeds add no information (resampling each seed's episodes on
    their own would narrow the interval by sqrt(3) for three copies)."""
    episodes = np.random.default_rng(4).normal(1.0, 0.3, (1, 20))
    one, three = summarize_scores(episodes), summarize_scores(np.tile(episodes, (3, 1)))
    assert three.mean_ci95 == pytest.approx(one.mean_ci95, abs=1e-12)
    assert three.iqm_ci95 == pytest.approx(one.iqm_ci95, abs=1e-12)


def test_intervals_cover_the_mean_of_seeds_sharing_their_episodes() -> None:
    """Three seeds on the same 20 episodes whose difficulty they share (episode sd 0.3, seed sd 0.05, noise sd
    0.05): the 95% interval of the mean covers the true mean in about 95% of 300 datasets (0.67-0.77 when each
    seed's episodes were resampled on their own)."""
    rng = np.random.default_rng(5)
    covered = 0
    for _ in range(300):
        scores = 1.0 + rng.normal(0.0, 0.3, (1, 20)) + rng.normal(0.0, 0.05, (3, 1)) + rng.normal(0.0, 0.05, (3, 20))
        low, high = summarize_scores(scores).mean_ci95
        covered += low <= 1.0 <= high
    assert 0.88 <= covered / 300 <= 0.99


def test_the_analytic_controller_and_the_random_policy_have_point_intervals_at_1_and_0() -> None:
    """Each replicate normalizes by the baselines' means over its own episodes: the controllers that define the
    score score exactly 1 and 0 in every replicate, however much their episodes differ."""
    rng = np.random.default_rng(6)
    random, analytic = rng.normal(-5.0, 2.0, 20), rng.normal(-1.0, 0.5, 20)
    assert summarize(analytic[None], random, analytic).mean_ci95 == pytest.approx((1.0, 1.0), abs=1e-12)
    assert summarize(random[None], random, analytic).mean_ci95 == pytest.approx((0.0, 0.0), abs=1e-12)


def test_an_agent_is_compared_with_the_baselines_on_the_same_episodes() -> None:
    """Episodes of very different difficulty, shared by every agent, and an agent 2% of the baselines' gap above
    the analytic controller on each: paired with the baselines' draws the interval is about 1.02 and excludes 1;
    with the baselines held at their overall means it spans the episodes' difficulty and contains 1."""
    rng = np.random.default_rng(7)
    difficulty = rng.normal(0.0, 1.0, 20)
    random, analytic = difficulty - 4.0 + rng.normal(0.0, 0.1, 20), difficulty - 1.0
    agent = np.stack([analytic + 0.06 + rng.normal(0.0, 0.01, 20) for _ in range(3)])  # 0.06 = 2% of the gap
    low, high = summarize(agent, random, analytic).mean_ci95
    assert 1.0 < low < 1.02 < high < 1.04
    gap = analytic.mean() - random.mean()
    held_low, held_high = summarize_scores((agent - random.mean()) / gap).mean_ci95
    assert held_low < 1.0 < held_high


def test_a_replicate_whose_episode_draw_ties_the_baselines_is_left_out() -> None:
    """The baselines differ on one episode of four only: about a third of the replicates draw none of it, tie the
    baselines and are left out (not divided by zero), so the analytic controller's mean still has the point
    interval 1."""
    random, analytic = np.zeros(4), np.array([0.0, 0.0, 0.0, 4.0])
    summary = summarize(analytic[None], random, analytic)
    assert summary.mean_ci95 == pytest.approx((1.0, 1.0), abs=1e-12)
    assert np.all(np.isfinite(summary.iqm_ci95))  # the IQM of the episodes' scores is not 1 in every replicate
    agent = summarize(np.array([[0.5, 0.0, 1.0, 3.0], [0.0, 0.5, 0.0, 4.0]]), random, analytic)
    assert np.all(np.isfinite([*agent.mean_ci95, *agent.iqm_ci95]))


def test_baselines_with_nan_or_inf_returns_are_rejected() -> None:
    with pytest.raises(ValueError, match="returns must be finite"):
        summarize(np.zeros((2, 3)), np.array([0.0, np.nan, 0.0]), np.ones(3))
    with pytest.raises(ValueError, match="returns must be finite"):
        summarize(np.zeros((2, 3)), np.zeros(3), np.array([1.0, np.inf, 1.0]))

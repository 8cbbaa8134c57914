"""Elastic thread (PHYSICS.md section 9): one-node sag, symmetry, bounded energy, the step bound, mode frequencies."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vegym.physics import thread
from vegym.physics.thread import ThreadParams

DEFAULT = ThreadParams()
UNDAMPED = ThreadParams(drag=0.0)


def test_vector_form_is_the_books_component_form_8_106_8_107() -> None:
    rng = np.random.default_rng(0)
    positions = DEFAULT.span * np.sort(rng.uniform(0, 1, (4, 9)), axis=1)[..., None] * np.array([1.0, 0.0])
    positions[..., 1] = rng.uniform(-0.1, 0.1, (4, 9))
    chain = np.concatenate([np.zeros((4, 1, 2)), positions, np.tile([[DEFAULT.span, 0.0]], (4, 1, 1))], axis=1)
    left, right = chain[:, :-2], chain[:, 2:]
    l_left = np.hypot(*(positions - left).transpose(2, 0, 1))
    l_right = np.hypot(*(right - positions).transpose(2, 0, 1))
    s_over_m, natural = DEFAULT.stiffness / DEFAULT.node_mass, DEFAULT.natural_length
    book = np.stack(
        [
            s_over_m * ((l_right - natural) * (right[..., c] - positions[..., c]) / l_right)
            - s_over_m * ((l_left - natural) * (positions[..., c] - left[..., c]) / l_left)
            for c in (0, 1)
        ],
        axis=-1,
    )
    book[..., 1] -= DEFAULT.gravity
    a = thread.acceleration(positions, np.zeros_like(positions), 0.0, UNDAMPED)
    np.testing.assert_allclose(a, book, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize(("half_span", "length"), [(0.5, 0.4), (0.5, 0.6), (0.3, 0.3)])
def test_one_node_sags_to_the_root_of_the_closed_form_balance(half_span: float, length: float) -> None:
    """N = 1, span 2a: ``2 S (sqrt(a^2 + s^2) - l) s / sqrt(a^2 + s^2) = m g``, taut, slack and exactly unstretched;
    both the equilibrium solver and the damped simulation come to rest at that sag."""
    params = ThreadParams(n_nodes=1, node_mass=0.1, stiffness=50.0, natural_length=length, span=2 * half_span)
    s_, m, g = params.stiffness, params.node_mass, params.gravity

    def balance(sag: float) -> float:
        hyp = math.hypot(half_span, sag)
        return 2.0 * s_ * (hyp - length) * sag / hyp - m * g

    sag = brentq(balance, 1e-9, 10.0, xtol=1e-15, rtol=1e-15)
    np.testing.assert_allclose(thread.static_equilibrium(params), [[half_span, -sag]], rtol=0, atol=1e-9)
    damped = ThreadParams(**{**params.as_dict(), "drag": 2.0 * m * float(thread.mode_frequencies(params)[0])})
    positions, velocities = np.array([[[half_span, 0.05]]]), np.zeros((1, 1, 2))
    h = 0.5 * damped.stable_step
    for _ in range(int(20.0 / h)):
        positions, velocities = thread.step(positions, velocities, 0.0, h, damped)
    np.testing.assert_allclose(positions[0], [[half_span, -sag]], rtol=0, atol=1e-9)


def pluck(params: ThreadParams, height: float, at: float) -> np.ndarray:
    """The rest shape (1, N, 2) raised into a triangle of ``height`` (m) peaking at the fraction ``at`` of the span."""
    rest = thread.static_equilibrium(params)
    x = rest[:, 0] / params.span
    positions = rest[None].copy()
    positions[0, :, 1] += height * np.where(x <= at, x / at, (1.0 - x) / (1.0 - at))
    return positions


def test_symmetric_pluck_stays_mirror_symmetric() -> None:
    positions, velocities = pluck(UNDAMPED, 0.08, 0.5), np.zeros((1, 9, 2))
    rest = thread.static_equilibrium(UNDAMPED)
    worst = moved = 0.0
    for _ in range(2000):
        positions, velocities = thread.step(positions, velocities, 0.0, 1e-3, UNDAMPED)
        mirrored = positions[0, ::-1] * np.array([-1.0, 1.0]) + np.array([UNDAMPED.span, 0.0])
        worst = max(worst, float(np.max(np.abs(mirrored - positions[0]))))
        moved = max(moved, float(np.max(np.abs(positions[0] - rest))))
    assert worst < 1e-12 and moved > 0.05


def test_energy_stays_within_2_percent_of_the_pluck_without_drift() -> None:
    positions, velocities = pluck(UNDAMPED, 0.08, 0.3), np.zeros((1, 9, 2))
    rest = thread.energy(thread.static_equilibrium(UNDAMPED)[None], velocities, UNDAMPED)[0]
    start = thread.energy(positions, velocities, UNDAMPED)[0]
    energies = []
    for _ in range(5000):
        positions, velocities = thread.step(positions, velocities, 0.0, 1e-3, UNDAMPED)
        energies.append(thread.energy(positions, velocities, UNDAMPED)[0])
    excess = np.array(energies) - rest
    assert np.max(np.abs(excess / (start - rest) - 1.0)) < 0.02
    assert abs(excess[-1000:].mean() - excess[:1000].mean()) < 0.002 * (start - rest)


def test_step_refuses_a_step_beyond_sqrt_m_over_s_and_substeps_split_it() -> None:
    bound = math.sqrt(DEFAULT.node_mass / DEFAULT.stiffness)
    assert DEFAULT.stable_step == bound
    positions, velocities = pluck(DEFAULT, 0.05, 0.4), np.zeros((1, 9, 2))
    for dt in (bound, 0.01, 0.0, -1e-3):
        with pytest.raises(ValueError, match="sqrt"):
            thread.step(positions, velocities, 0.0, dt, DEFAULT)
    thread.step(positions, velocities, 0.0, 0.99 * bound, DEFAULT)
    assert ThreadParams(drag=10.0).stable_step == pytest.approx(0.002)  # m / c binds
    for dt in (0.001, 0.01, 0.02, 0.1):
        k = thread.substeps(dt, DEFAULT)
        assert dt / k <= 0.5 * bound < dt / (k - 1) if k > 1 else dt <= 0.5 * bound


def test_semi_implicit_euler_blows_up_just_above_two_over_omega_max_not_below() -> None:
    """Section 9: N = 9, S = 400, m = 0.02 has 2 / omega_max = 7.16e-3 s; the loop bypasses step()'s safe rule."""
    omega_max = 2.0 * math.sqrt(DEFAULT.stiffness / DEFAULT.node_mass) * math.sin(9 * math.pi / 20)
    assert 2.0 / omega_max == pytest.approx(7.16e-3, abs=1e-5)
    largest = []
    for dt in (7.0e-3, 7.3e-3):
        positions, velocities = pluck(UNDAMPED, 0.05, 0.4), np.zeros((1, 9, 2))
        for _ in range(400):
            velocities = velocities + dt * thread.acceleration(positions, velocities, 0.0, UNDAMPED)
            positions = positions + dt * velocities
        largest.append(float(np.max(np.abs(velocities))))
    assert largest[0] < 10.0 < 1e30 < largest[1]


def test_mode_frequencies_without_gravity_are_the_closed_forms_and_below_two_sqrt_s_over_m() -> None:
    params = ThreadParams(gravity=0.0)
    n, k = params.n_nodes, np.arange(1, params.n_nodes + 1)
    spacing = params.span / (n + 1)
    tension = params.stiffness * (spacing - params.natural_length)
    across = 2.0 * math.sqrt(tension / (params.node_mass * spacing)) * np.sin(k * np.pi / (2 * (n + 1)))
    along = 2.0 * math.sqrt(params.stiffness / params.node_mass) * np.sin(k * np.pi / (2 * (n + 1)))
    np.testing.assert_allclose(thread.mode_frequencies(params), np.sort(np.concatenate([across, along])), rtol=1e-9)
    assert thread.mode_frequencies(DEFAULT)[-1] < 2.0 * math.sqrt(DEFAULT.stiffness / DEFAULT.node_mass)


def test_rest_shape_balances_the_forces_and_hangs_symmetrically_below_the_ends() -> None:
    for params in (DEFAULT, ThreadParams(span=0.8), ThreadParams(n_nodes=30, span=2.0, stiffness=1e4)):
        rest = thread.static_equilibrium(params)
        force = params.node_mass * thread.acceleration(rest[None], np.zeros((1, params.n_nodes, 2)), 0.0, params)
        assert np.max(np.abs(force)) < 1e-11 * (params.node_mass * params.gravity + params.stiffness * 0.1)
        np.testing.assert_allclose(rest[::-1, 1], rest[:, 1], atol=1e-12)
        assert np.all(rest[:, 1] < 0.0) and np.all(np.diff(rest[:, 0]) > 0.0)
        assert not rest.flags.writeable


@pytest.mark.parametrize(
    "params",
    [
        ThreadParams(span=1100.0),
        ThreadParams(stiffness=4000.0, natural_length=1e-4),
        ThreadParams(n_nodes=64, span=5e3),
    ],
)
def test_a_taut_thread_s_rest_shape_is_found_with_its_tension_s_rounding(params: ThreadParams) -> None:
    """Springs stretched far beyond their length: forces of the tension's size (S (span / (N + 1) - l)) balance only
    to its rounding, which must not keep the solver from stopping."""
    rest = thread.static_equilibrium(params)
    force = params.node_mass * thread.acceleration(rest[None], np.zeros((1, params.n_nodes, 2)), 0.0, params)
    tension = params.stiffness * (params.spacing - params.natural_length)
    assert tension > 100.0 * params.stiffness * params.natural_length
    assert np.max(np.abs(force)) < 1e-11 * tension
    np.testing.assert_allclose(rest[::-1, 1], rest[:, 1], atol=1e-12 * params.span)
    np.testing.assert_allclose(rest[:, 0], params.spacing * np.arange(1, params.n_nodes + 1), rtol=1e-6)


def test_a_slack_thread_without_gravity_is_refused_naming_its_length() -> None:
    with pytest.raises(
        ValueError, match=r"natural_length=0.2 is outside the allowed range \[1e-09, span / \(n_nodes \+ 1\) = 0.11\)"
    ):
        ThreadParams(gravity=0.0, natural_length=0.2)
    assert thread.static_equilibrium(ThreadParams(gravity=0.0, natural_length=0.1))[:, 1] == pytest.approx(0.0)


def test_velocity_feedback_and_drag_damp_the_thread_to_rest() -> None:
    """Section 9: with c_fb = 0.05 N s/m on every node the motion dies out (max |v| 1.2e-5 m/s after 10 s)."""
    damped = ThreadParams(drag=0.05)
    positions, velocities = pluck(damped, 0.08, 0.3), np.zeros((1, 9, 2))
    for _ in range(10_000):
        positions, velocities = thread.step(positions, velocities, 0.0, 1e-3, damped)
    assert np.max(np.abs(velocities)) < 1e-4
    np.testing.assert_allclose(positions[0], thread.static_equilibrium(damped), atol=1e-5)


@pytest.mark.parametrize("rows", [1, 5, 8, 9, 18, 65, 128, 129, 300])
def test_column_sums_are_numpys_pairwise_sums_bit_for_bit(rows: int) -> None:
    values = np.random.default_rng(rows).normal(size=(rows, 7)) * 10.0 ** np.arange(-3, 4)
    out = np.empty(7)
    thread.column_sums(values.copy(), out)
    np.testing.assert_array_equal(out, [np.sum(np.ascontiguousarray(values[:, i])) for i in range(7)])


def test_a_batch_moves_and_weighs_each_of_its_threads_as_alone_bit_for_bit() -> None:
    """The compiled functions run in passes over the batch: each thread's result must not depend on the others."""
    rng = np.random.default_rng(1)
    positions = pluck(DEFAULT, 0.05, 0.3) + rng.uniform(-0.01, 0.01, (37, 9, 2))
    velocities, forces = rng.uniform(-0.5, 0.5, (37, 9, 2)), rng.uniform(-0.5, 0.5, (37, 9, 2))
    h, before = 0.5 * DEFAULT.stable_step, positions.copy()
    moved = thread.step(positions, velocities, forces, h, DEFAULT)
    for b in (0, 17, 36):
        alone = thread.step(positions[b : b + 1], velocities[b : b + 1], forces[b : b + 1], h, DEFAULT)
        np.testing.assert_array_equal(moved[0][b], alone[0][0])
        np.testing.assert_array_equal(moved[1][b], alone[1][0])
        a = thread.acceleration(positions[b : b + 1], velocities[b : b + 1], forces[b : b + 1], DEFAULT)
        np.testing.assert_array_equal(thread.acceleration(positions, velocities, forces, DEFAULT)[b], a[0])
        e = thread.energy(positions[b : b + 1], velocities[b : b + 1], DEFAULT)
        assert thread.energy(positions, velocities, DEFAULT)[b] == e[0]
    np.testing.assert_array_equal(positions, before)


def test_energy_is_the_closed_form_summed_as_numpy_sums() -> None:
    rng = np.random.default_rng(2)
    positions, velocities = pluck(DEFAULT, 0.07, 0.4) + rng.uniform(-0.01, 0.01, (6, 9, 2)), rng.normal(size=(6, 9, 2))
    _, length = thread.spring_forces(positions, DEFAULT)
    m, g, s_, l_ = DEFAULT.node_mass, DEFAULT.gravity, DEFAULT.stiffness, DEFAULT.natural_length
    for b in range(6):
        kinetic = 0.5 * m * np.sum((velocities[b] * velocities[b]).reshape(-1))
        potential = m * g * np.sum(np.ascontiguousarray(positions[b, :, 1]))
        elastic = 0.5 * s_ * np.sum((length[b] - l_) * (length[b] - l_))
        assert thread.energy(positions, velocities, DEFAULT)[b] == kinetic + potential + elastic


def test_a_thread_exactly_at_its_natural_length_without_gravity_is_refused() -> None:
    """The allowed range is open at span / (N + 1): a straight thread at zero tension has no transverse stiffness."""
    spacing = ThreadParams().spacing
    with pytest.raises(ValueError, match="natural_length=.* is outside the allowed range"):
        ThreadParams(gravity=0.0, natural_length=spacing)

"""Direct and oblique impact of two spheres (chapter 8.3, 8.47-8.62), and balls sliding to rest on a table.

Corrected forms from PHYSICS.md section 5: the total momentum is ``m_a v_a + m_b v_b`` (the printed 8.49 repeats
the clock's 8.46), the oblique momentum balance is ``m_a v_a cos(alpha) + m_b v_b cos(beta) = m_a u_a + m_b u_b``
(the printed 8.56 puts the cosines on the wrong side), and A's direction after striking B at rest is
``theta = atan2((m_a + m_b) sin(alpha), (m_a - e m_b) cos(alpha))`` from the line of centres (8.61, without its
singularity at ``m_a = e m_b``). The vector form, in 2-D or 3-D: with ``n = (c_b - c_a) / |c_b - c_a|`` and the
closing speed ``w = (v_a - v_b) . n``, the spheres collide only if ``w > 0``, and then the impulse
``J = (1 + e) mu w``, ``mu = m_a m_b / (m_a + m_b)``, gives ``u_a = v_a - (J / m_a) n``, ``u_b = v_b + (J / m_b) n``;
tangential components are unchanged and the kinetic energy lost is ``1/2 mu (1 - e^2) w^2``.

The table is an addition (the chapter's impact has none): a ball slides in a straight line with a constant
deceleration ``a`` (the cloth's rolling resistance) and comes to rest after ``|v|^2 / (2 a)`` metres in ``|v| / a``
seconds. Conventions: SI units, vectors with a leading batch axis (n, d) (scalars and single vectors broadcast),
masses and restitution as scalars or (n,) arrays; inputs are never modified.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vegym.params import check_positive, check_values
from vegym.physics.columns import flat_columns, floats


def _rows(vectors: list[np.ndarray], scalars: list[np.ndarray | float]) -> tuple[tuple[int, ...], list, list]:
    """Vectors broadcast to one shape (..., d) as contiguous (N, d) float64 arrays, and scalars broadcast to its
    batch shape as (N,) columns (for the loops over the scalar kernels)."""
    arrays = [np.asarray(v, dtype=np.float64) for v in vectors]
    shape = np.broadcast_shapes(*(a.shape for a in arrays), *(np.shape(x) + (1,) for x in scalars))
    rows = [np.ascontiguousarray(np.broadcast_to(a, shape)).reshape(-1, shape[-1]) for a in arrays]
    _, columns = flat_columns(*(np.broadcast_to(np.asarray(x, dtype=np.float64), shape[:-1]) for x in scalars))
    return shape, rows, columns


@njit(cache=True, error_model="numpy", inline="always")
def reduced_mass_one(mass_a: float, mass_b: float) -> float:
    """``mu = m_a m_b / (m_a + m_b)`` (kg) of one pair: the scalar core of :func:`reduced_mass`."""
    return mass_a * mass_b / (mass_a + mass_b)


@njit(cache=True, error_model="numpy", inline="always")
def impulse_one(closing_speed: float, mass_a: float, mass_b: float, restitution: float) -> float:
    """Impulse ``J = (1 + e) mu w`` (N s) along the line of centres of one impact at closing speed ``w`` (m/s), 0
    if the spheres are not closing (``w <= 0``): the scalar core of :func:`oblique_impact`, which the array
    function and Billiards-v0's kernel share."""
    return (1.0 + restitution) * reduced_mass_one(mass_a, mass_b) * closing_speed if closing_speed > 0.0 else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def contact_one(b: float, offset_square: float, contact_distance: float) -> float:
    """:func:`first_contact` of one sphere from ``b = d . (c_b - c_a)`` (m) and ``|c_b - c_a - b d|^2`` (m^2), the
    squared distance of B's centre from A's line of travel; ``+inf`` if it never touches."""
    disc = contact_distance * contact_distance - offset_square
    # abs(disc) is disc wherever the root is used; the root of a value known >= 0 is the sqrt instruction, not a
    # libm call, so a loop over this gets SIMD code
    root = math.sqrt(abs(disc))
    return max(b - root, 0.0) if (disc >= 0.0) & (b > 0.0) else math.inf


@njit(cache=True, error_model="numpy", inline="always")
def slide_one(square_speed: float, deceleration: float) -> tuple[float, float, float]:
    """:func:`slide` of one ball from its squared speed ``|v|^2`` (m^2/s^2): the time factor ``|v| / (2 a)`` (s)
    that carries it to rest at ``position + factor velocity``, the distance (m) and the time (s)."""
    speed = math.sqrt(square_speed)
    return speed / (2.0 * deceleration), speed**2 / (2.0 * deceleration), speed / deceleration


@njit(cache=True, error_model="numpy", inline="always")
def speed_after_one(speed: float, distance: float, deceleration: float) -> float:
    """:func:`speed_after` of one ball (m/s, m, m/s^2)."""
    return math.sqrt(max(speed * speed - 2.0 * deceleration * distance, 0.0))


@njit(cache=True, error_model="numpy", inline="always")
def energy_loss_one(closing_speed: float, mass_a: float, mass_b: float, restitution: float) -> float:
    """:func:`energy_loss` of one impact (J)."""
    return 0.5 * reduced_mass_one(mass_a, mass_b) * (1.0 - restitution * restitution) * closing_speed * closing_speed


@njit(cache=True)
def _impact_each(
    c_a: np.ndarray, c_b: np.ndarray, v_a: np.ndarray, v_b: np.ndarray, m_a: np.ndarray, m_b: np.ndarray, e: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    u_a, u_b = np.empty_like(v_a), np.empty_like(v_b)
    for i in range(len(c_a)):
        gap = 0.0
        for k in range(c_a.shape[1]):
            gap += (c_b[i, k] - c_a[i, k]) * (c_b[i, k] - c_a[i, k])
        gap = math.sqrt(gap)
        w = 0.0
        for k in range(c_a.shape[1]):
            w += (v_a[i, k] - v_b[i, k]) * ((c_b[i, k] - c_a[i, k]) / gap)
        impulse = impulse_one(w, m_a[i], m_b[i], e[i])
        for k in range(c_a.shape[1]):
            normal = (c_b[i, k] - c_a[i, k]) / gap
            u_a[i, k], u_b[i, k] = v_a[i, k] - impulse / m_a[i] * normal, v_b[i, k] + impulse / m_b[i] * normal
    return u_a, u_b


@njit(cache=True)
def _contact_each(c_a: np.ndarray, direction: np.ndarray, c_b: np.ndarray, contact_distance: float) -> np.ndarray:
    out = np.empty(len(c_a))
    for i in range(len(c_a)):
        b, offset_square = 0.0, 0.0
        for k in range(c_a.shape[1]):
            b += direction[i, k] * (c_b[i, k] - c_a[i, k])
        for k in range(c_a.shape[1]):
            offset = c_b[i, k] - c_a[i, k] - b * direction[i, k]
            offset_square += offset * offset
        out[i] = contact_one(b, offset_square, contact_distance)
    return out


@njit(cache=True)
def _slide_each(position: np.ndarray, velocity: np.ndarray, deceleration: float) -> tuple[np.ndarray, ...]:
    rest, distance, time = np.empty_like(position), np.empty(len(position)), np.empty(len(position))
    for i in range(len(position)):
        square = 0.0
        for k in range(position.shape[1]):
            square += velocity[i, k] * velocity[i, k]
        factor, distance[i], time[i] = slide_one(square, deceleration)
        for k in range(position.shape[1]):
            rest[i, k] = position[i, k] + velocity[i, k] * factor
    return rest, distance, time


@njit(cache=True)
def _speed_after_each(speed: np.ndarray, distance: np.ndarray, deceleration: np.ndarray) -> np.ndarray:
    out = np.empty(len(speed))
    for i in range(len(speed)):
        out[i] = speed_after_one(speed[i], distance[i], deceleration[i])
    return out


@njit(cache=True)
def _energy_loss_each(w: np.ndarray, m_a: np.ndarray, m_b: np.ndarray, e: np.ndarray) -> np.ndarray:
    out = np.empty(len(w))
    for i in range(len(w)):
        out[i] = energy_loss_one(w[i], m_a[i], m_b[i], e[i])
    return out


@njit(cache=True)
def _reduced_mass_each(m_a: np.ndarray, m_b: np.ndarray) -> np.ndarray:
    out = np.empty(len(m_a))
    for i in range(len(m_a)):
        out[i] = reduced_mass_one(m_a[i], m_b[i])
    return out


def _check_masses(mass_a: np.ndarray | float, mass_b: np.ndarray | float) -> None:
    """``ValueError`` for a mass that is not positive."""
    check_positive("mass_a", mass_a)
    check_positive("mass_b", mass_b)


def _check_impact(mass_a: np.ndarray | float, mass_b: np.ndarray | float, restitution: np.ndarray | float) -> None:
    """``ValueError`` for a mass that is not positive or a restitution outside [0, 1] (e > 1 creates energy)."""
    _check_masses(mass_a, mass_b)
    check_values("restitution", restitution, 0.0, 1.0)


def reduced_mass(mass_a: np.ndarray, mass_b: np.ndarray) -> np.ndarray:
    """``mu = m_a m_b / (m_a + m_b)`` (kg), by :func:`reduced_mass_one` (any broadcastable shapes)."""
    _check_masses(mass_a, mass_b)
    shape, (m_a, m_b) = flat_columns(mass_a, mass_b)
    return _reduced_mass_each(m_a, m_b).reshape(shape)[()]


def direct_impact(
    v_a: np.ndarray, v_b: np.ndarray, mass_a: np.ndarray, mass_b: np.ndarray, restitution: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Velocities ``(u_a, u_b)`` after a direct (head-on) impact, the solution of 8.51 and 8.48 (m/s, signed).

    ``u_a = ((m_a - e m_b) v_a + (1 + e) m_b v_b) / (m_a + m_b)``, ``u_b = ((m_b - e m_a) v_b + (1 + e) m_a v_a) /
    (m_a + m_b)``. Example (8.50): m_a = 5, v_a = 2, m_b = 3, v_b = -4, e = 1 gives u_a = -2.5, u_b = 3.5.
    """
    v_a, v_b, m_a, m_b, e = floats(v_a, v_b, mass_a, mass_b, restitution)
    _check_impact(m_a, m_b, e)
    total = m_a + m_b
    return ((m_a - e * m_b) * v_a + (1.0 + e) * m_b * v_b) / total, (
        (m_b - e * m_a) * v_b + (1.0 + e) * m_a * v_a
    ) / total


def oblique_impact(
    c_a: np.ndarray,
    c_b: np.ndarray,
    v_a: np.ndarray,
    v_b: np.ndarray,
    mass_a: np.ndarray,
    mass_b: np.ndarray,
    restitution: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Velocities ``(u_a, u_b)`` (n, d) after spheres at ``c_a``, ``c_b`` (in contact) meet with ``v_a``, ``v_b``.

    The impulse form of PHYSICS.md section 5 along the line of centres ``n``; spheres that are not closing
    (``w = (v_a - v_b) . n <= 0``) keep their velocities. Coincident centres (no line of centres) raise
    ``ValueError``.
    """
    _check_impact(mass_a, mass_b, restitution)
    shape, rows, columns = _rows([c_a, c_b, v_a, v_b], [mass_a, mass_b, restitution])
    coincident = np.all(rows[0] == rows[1], axis=-1)
    if np.any(coincident):
        raise ValueError(f"c_a and c_b coincide at {rows[0][np.argmax(coincident)].tolist()}: no line of centres")
    u_a, u_b = _impact_each(*rows, *columns)
    return u_a.reshape(shape), u_b.reshape(shape)


def energy_loss(
    closing_speed: np.ndarray, mass_a: np.ndarray, mass_b: np.ndarray, restitution: np.ndarray
) -> np.ndarray:
    """Kinetic energy (J) lost in an impact at closing speed ``w`` (m/s): ``1/2 mu (1 - e^2) w^2``."""
    _check_impact(mass_a, mass_b, restitution)
    shape, columns = flat_columns(closing_speed, mass_a, mass_b, restitution)
    return _energy_loss_each(*columns).reshape(shape)[()]


def deflection_angle(alpha: np.ndarray, mass_a: np.ndarray, mass_b: np.ndarray, restitution: np.ndarray) -> np.ndarray:
    """Angle (rad) of A's velocity after striking B at rest, from the line of centres (the corrected 8.61).

    ``alpha`` (rad) is the angle of A's incoming velocity from the line of centres ``c_a c_b``; the result is
    ``atan2((m_a + m_b) sin(alpha), (m_a - e m_b) cos(alpha))``, on the same side as ``alpha``. Equal masses:
    ``tan(theta) = 2 tan(alpha) / (1 - e)`` (8.62), 90 degrees at e = 1. B leaves along the line of centres.
    """
    alpha, m_a, m_b, e = floats(alpha, mass_a, mass_b, restitution)
    _check_impact(m_a, m_b, e)
    return np.arctan2((m_a + m_b) * np.sin(alpha), (m_a - e * m_b) * np.cos(alpha))


def ghost_point(c_b: np.ndarray, direction: np.ndarray, contact_distance: float) -> np.ndarray:
    """Where A's centre must be at the impact to send B (at rest) along the unit ``direction``: ``c_b - R d``.

    ``R = r_a + r_b``. B leaves along the line of centres, so A struck from this "ghost ball" position sends B
    along ``direction`` whatever A's velocity, provided A reaches it before touching B elsewhere.
    """
    return np.asarray(c_b, dtype=np.float64) - contact_distance * np.asarray(direction, dtype=np.float64)


def first_contact(c_a: np.ndarray, direction: np.ndarray, c_b: np.ndarray, contact_distance: float) -> np.ndarray:
    """Distance (n,) A's centre travels along the unit ``direction`` until it touches B, ``+inf`` if it never does.

    The smallest ``s >= 0`` with ``|c_a + s d - c_b| = R``: ``s = b - sqrt(R^2 - |c_b - c_a - b d|^2)`` with
    ``b = d . (c_b - c_a)``: the root ``sqrt(b^2 - (|c_b - c_a|^2 - R^2))`` without its cancellation, whose error
    grew with the squared distance (3e-8 m at 1 km, 0.5 mm at 100 km; from 1,000 km it missed contacts, and
    Billiards-v0 observed NaN). Spheres already overlapping (``|c_b - c_a| < R``) are outside the model.
    """
    shape, (c_a, direction, c_b), _ = _rows([c_a, direction, c_b], [])
    return _contact_each(c_a, direction, c_b, float(contact_distance)).reshape(shape[:-1])


def slide(position: np.ndarray, velocity: np.ndarray, deceleration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rest point (n, d), distance (n,) and time (n,) of a ball sliding from ``position`` at ``velocity``.

    Constant deceleration ``a`` (m/s^2) along the motion: distance ``|v|^2 / (2 a)``, time ``|v| / a``.
    """
    check_positive("deceleration", deceleration)
    shape, (position, velocity), _ = _rows([position, velocity], [])
    rest, distance, time = _slide_each(position, velocity, float(deceleration))
    return rest.reshape(shape), distance.reshape(shape[:-1]), time.reshape(shape[:-1])


def speed_after(speed: np.ndarray, distance: np.ndarray, deceleration: float) -> np.ndarray:
    """Speed (m/s) of a ball launched at ``speed`` after sliding ``distance`` (m): ``sqrt(v^2 - 2 a s)``, >= 0."""
    check_positive("deceleration", deceleration)
    shape, columns = flat_columns(speed, distance, deceleration)
    return _speed_after_each(*columns).reshape(shape)[()]


def launch_speed(speed: np.ndarray, distance: np.ndarray, deceleration: float) -> np.ndarray:
    """Speed (m/s) to launch a ball at so that it still has ``speed`` after ``distance`` m: ``sqrt(v^2 + 2 a s)``."""
    check_positive("deceleration", deceleration)
    speed = np.asarray(speed, dtype=np.float64)
    return np.sqrt(speed * speed + 2.0 * deceleration * np.asarray(distance, dtype=np.float64))

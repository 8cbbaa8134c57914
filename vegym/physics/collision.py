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

import numpy as np


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def reduced_mass(mass_a: np.ndarray, mass_b: np.ndarray) -> np.ndarray:
    """``mu = m_a m_b / (m_a + m_b)`` (kg)."""
    mass_a, mass_b = np.asarray(mass_a, dtype=np.float64), np.asarray(mass_b, dtype=np.float64)
    return mass_a * mass_b / (mass_a + mass_b)


def direct_impact(
    v_a: np.ndarray, v_b: np.ndarray, mass_a: np.ndarray, mass_b: np.ndarray, restitution: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Velocities ``(u_a, u_b)`` after a direct (head-on) impact, the solution of 8.51 and 8.48 (m/s, signed).

    ``u_a = ((m_a - e m_b) v_a + (1 + e) m_b v_b) / (m_a + m_b)``, ``u_b = ((m_b - e m_a) v_b + (1 + e) m_a v_a) /
    (m_a + m_b)``. Example (8.50): m_a = 5, v_a = 2, m_b = 3, v_b = -4, e = 1 gives u_a = -2.5, u_b = 3.5.
    """
    v_a, v_b = np.asarray(v_a, dtype=np.float64), np.asarray(v_b, dtype=np.float64)
    m_a, m_b, e = (np.asarray(x, dtype=np.float64) for x in (mass_a, mass_b, restitution))
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
    (``w = (v_a - v_b) . n <= 0``) keep their velocities.
    """
    c_a, c_b = np.asarray(c_a, dtype=np.float64), np.asarray(c_b, dtype=np.float64)
    v_a, v_b = np.asarray(v_a, dtype=np.float64), np.asarray(v_b, dtype=np.float64)
    offset = c_b - c_a
    n = offset / np.linalg.norm(offset, axis=-1, keepdims=True)
    w = _dot(v_a - v_b, n)
    m_a, m_b = np.asarray(mass_a, dtype=np.float64), np.asarray(mass_b, dtype=np.float64)
    impulse = np.where(w > 0.0, (1.0 + np.asarray(restitution, dtype=np.float64)) * reduced_mass(m_a, m_b) * w, 0.0)
    return v_a - (impulse / m_a)[..., None] * n, v_b + (impulse / m_b)[..., None] * n


def energy_loss(
    closing_speed: np.ndarray, mass_a: np.ndarray, mass_b: np.ndarray, restitution: np.ndarray
) -> np.ndarray:
    """Kinetic energy (J) lost in an impact at closing speed ``w`` (m/s): ``1/2 mu (1 - e^2) w^2``."""
    w = np.asarray(closing_speed, dtype=np.float64)
    e = np.asarray(restitution, dtype=np.float64)
    return 0.5 * reduced_mass(mass_a, mass_b) * (1.0 - e * e) * w * w


def deflection_angle(alpha: np.ndarray, mass_a: np.ndarray, mass_b: np.ndarray, restitution: np.ndarray) -> np.ndarray:
    """Angle (rad) of A's velocity after striking B at rest, from the line of centres (the corrected 8.61).

    ``alpha`` (rad) is the angle of A's incoming velocity from the line of centres ``c_a c_b``; the result is
    ``atan2((m_a + m_b) sin(alpha), (m_a - e m_b) cos(alpha))``, on the same side as ``alpha``. Equal masses:
    ``tan(theta) = 2 tan(alpha) / (1 - e)`` (8.62), 90 degrees at e = 1. B leaves along the line of centres.
    """
    alpha = np.asarray(alpha, dtype=np.float64)
    m_a, m_b, e = (np.asarray(x, dtype=np.float64) for x in (mass_a, mass_b, restitution))
    return np.arctan2((m_a + m_b) * np.sin(alpha), (m_a - e * m_b) * np.cos(alpha))


def ghost_point(c_b: np.ndarray, direction: np.ndarray, contact_distance: float) -> np.ndarray:
    """Where A's centre must be at the impact to send B (at rest) along the unit ``direction``: ``c_b - R d``.

    ``R = r_a + r_b``. B leaves along the line of centres, so A struck from this "ghost ball" position sends B
    along ``direction`` whatever A's velocity, provided A reaches it before touching B elsewhere.
    """
    return np.asarray(c_b, dtype=np.float64) - contact_distance * np.asarray(direction, dtype=np.float64)


def first_contact(c_a: np.ndarray, direction: np.ndarray, c_b: np.ndarray, contact_distance: float) -> np.ndarray:
    """Distance (n,) A's centre travels along the unit ``direction`` until it touches B, ``+inf`` if it never does.

    The smallest ``s >= 0`` with ``|c_a + s d - c_b| = R``: ``s = b - sqrt(b^2 - (|c_b - c_a|^2 - R^2))`` with
    ``b = d . (c_b - c_a)``. Spheres already overlapping (``|c_b - c_a| < R``) are outside the model.
    """
    offset = np.asarray(c_b, dtype=np.float64) - np.asarray(c_a, dtype=np.float64)
    b = _dot(np.asarray(direction, dtype=np.float64), offset)
    disc = b * b - (_dot(offset, offset) - contact_distance * contact_distance)
    with np.errstate(invalid="ignore"):
        s = b - np.sqrt(disc)
    return np.where((disc >= 0.0) & (b > 0.0), np.maximum(s, 0.0), np.inf)


def slide(position: np.ndarray, velocity: np.ndarray, deceleration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rest point (n, d), distance (n,) and time (n,) of a ball sliding from ``position`` at ``velocity``.

    Constant deceleration ``a`` (m/s^2) along the motion: distance ``|v|^2 / (2 a)``, time ``|v| / a``.
    """
    velocity = np.asarray(velocity, dtype=np.float64)
    speed = np.linalg.norm(velocity, axis=-1)
    return (
        np.asarray(position) + velocity * (speed / (2.0 * deceleration))[..., None],
        speed**2 / (2.0 * deceleration),
        speed / deceleration,
    )


def speed_after(speed: np.ndarray, distance: np.ndarray, deceleration: float) -> np.ndarray:
    """Speed (m/s) of a ball launched at ``speed`` after sliding ``distance`` (m): ``sqrt(v^2 - 2 a s)``, >= 0."""
    speed = np.asarray(speed, dtype=np.float64)
    return np.sqrt(np.maximum(speed * speed - 2.0 * deceleration * np.asarray(distance, dtype=np.float64), 0.0))


def launch_speed(speed: np.ndarray, distance: np.ndarray, deceleration: float) -> np.ndarray:
    """Speed (m/s) to launch a ball at so that it still has ``speed`` after ``distance`` m: ``sqrt(v^2 + 2 a s)``."""
    speed = np.asarray(speed, dtype=np.float64)
    return np.sqrt(speed * speed + 2.0 * deceleration * np.asarray(distance, dtype=np.float64))

"""The analogue clock of 8.2.4: hand angles from the time, and the hands' rotation (8.44-8.46).

Corrected form from PHYSICS.md section 4: the chapter's angles are right, in degrees **anticlockwise** from +x
(the hands are modelled pointing at "3 o'clock"), ``theta_sec = 90 - 6 sec``, ``theta_min = 90 - 6 min - sec/10``
and ``theta_hrs = 90 - 30 hrs - min/2 - sec/120``, with ``hrs`` taken mod 12 and a fractional ``sec`` giving a
sweeping second hand. They must be applied with the anticlockwise rotation ``R_z(+theta)``: the chapter's
"matrix for rolling objects" (8.26) is the clockwise ``R_z(-theta)`` and would mirror the clock.

Conventions: angles in degrees as in the chapter (radians only where a rotation matrix is built), times in
seconds, arrays with any leading batch shape (scalars broadcast).
"""

from __future__ import annotations

import numpy as np

from vegym.physics import wheel

SECONDS_PER_HOUR = 3600.0
HALF_DAY = 12.0 * SECONDS_PER_HOUR
"""The dial's period (s): ``hrs`` is taken mod 12."""


def clock_reading(seconds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(hrs, min, sec)`` shown ``seconds`` after 12:00:00: whole hours mod 12, whole minutes, fractional seconds."""
    t = np.mod(np.asarray(seconds, dtype=np.float64), HALF_DAY)
    hrs = np.floor(t / SECONDS_PER_HOUR)
    minutes = np.floor((t - hrs * SECONDS_PER_HOUR) / 60.0)
    return hrs, minutes, t - hrs * SECONDS_PER_HOUR - minutes * 60.0


def hand_angles(hrs: np.ndarray, minutes: np.ndarray, sec: np.ndarray) -> np.ndarray:
    """Second, minute and hour hand angles (..., 3) in degrees anticlockwise from +x (8.44-8.46, ``hrs`` mod 12)."""
    hrs = np.mod(np.asarray(hrs, dtype=np.float64), 12.0)
    minutes = np.asarray(minutes, dtype=np.float64)
    sec = np.asarray(sec, dtype=np.float64)
    hrs, minutes, sec = np.broadcast_arrays(hrs, minutes, sec)
    return np.stack(
        [90.0 - 6.0 * sec, 90.0 - 6.0 * minutes - sec / 10.0, 90.0 - 30.0 * hrs - minutes / 2.0 - sec / 120.0],
        axis=-1,
    )


def hand_angles_at(seconds: np.ndarray) -> np.ndarray:
    """Hand angles (..., 3) in degrees (second, minute, hour) ``seconds`` after 12:00:00; continuous sweep."""
    return hand_angles(*clock_reading(seconds))


def hand_tips(angles: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Tips (..., k, 2) of hands of ``lengths`` (k,) modelled along +x, rotated by ``R_z(+angle)`` (degrees, (..., k)).

    The anticlockwise rotation of PHYSICS.md section 4: a hand at 90 degrees points at 12 (+y).
    """
    angles = np.asarray(angles, dtype=np.float64)
    matrices = wheel.rotation_z(np.radians(angles.reshape(-1)))
    model = np.zeros((matrices.shape[0], 1, 3))
    model[:, 0, 0] = np.broadcast_to(np.asarray(lengths, dtype=np.float64), angles.shape).reshape(-1)
    return wheel.transform(matrices, model)[:, 0, :2].reshape(*angles.shape, 2)

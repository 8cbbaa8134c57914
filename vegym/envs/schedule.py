"""Demands that change at random times during an episode (Aircraft's clearances, PendulumPump's amplitudes).

A task whose demand changes keeps three integer arrays in its state: ``changes`` (demands handed out so far
minus one), ``last_change`` (step of the latest change) and ``next_change`` (step of the coming change, or
:data:`NO_CHANGE`). Intervals between changes are uniform in ``[interval_min, interval_max]`` seconds, drawn
from the episode key, and no change comes after ``last_step`` (so the final demand can be flown).

:func:`change_step` and :func:`advance_due` are inlined into the tasks' step kernels, which hand out the changes due
as their last work; their numba cache does not see edits here: clear ``__pycache__`` after changing them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from vegym import rng
from vegym.params import empty_range, invalid

NO_CHANGE = np.iinfo(np.int64).max
"""``next_change`` of an episode whose schedule has ended."""

Timing = tuple[np.uint64, float, float, float, int]
"""A schedule as the kernels take it (:attr:`ChangeSchedule.timing`)."""


def per_key(keys: np.ndarray, *values: np.ndarray | int) -> tuple[np.ndarray, ...]:
    """``keys`` as a C-contiguous uint64 array (n,), then each of ``values`` (int counters) broadcast to one per key
    as C-contiguous int64, as the kernels take them; ``ValueError`` for a value of another length."""
    keys = np.ascontiguousarray(keys, dtype=np.uint64)
    return keys, *(np.ascontiguousarray(np.broadcast_to(np.asarray(v, dtype=np.int64), keys.shape)) for v in values)


@njit(cache=True, nogil=True, inline="always")
def change_step(key: np.uint64, index: int, now: int, timing: Timing) -> int:
    """Step of the change that ends demand number ``index``, handed out at step ``now``, of the episode ``key``
    (:data:`NO_CHANGE` past the schedule's last step); ``timing`` from :attr:`ChangeSchedule.timing`."""
    offset, interval_min, interval_max, dt, last_step = timing
    u = rng.lane(rng.stream_base(key, offset, np.uint64(index)), 0)
    seconds = interval_min + (interval_max - interval_min) * u
    at = now + max(np.int64(np.rint(seconds / dt)), 1)  # rint: numpy's round half to even
    return at if at <= last_step else NO_CHANGE


@njit(cache=True, nogil=True)
def _change_steps(keys: np.ndarray, index: np.ndarray, now: np.ndarray, timing: Timing) -> np.ndarray:
    """:func:`change_step` of each key (n,)."""
    out = np.empty(len(keys), np.int64)
    for i in range(len(keys)):
        out[i] = change_step(keys[i], index[i], now[i], timing)
    return out


@njit(cache=True, nogil=True, inline="always")
def advance_due(
    key: np.ndarray,
    step: np.ndarray,
    changes: np.ndarray,
    last_change: np.ndarray,
    next_change: np.ndarray,
    timing: Timing,
) -> np.ndarray:
    """For step kernels, as their last work: at the new step ``step + 1``, in place, every episode whose change is
    due moves on to its next demand number (``changes``), handed out now, and the change after it. Returns the rows
    that changed (int indices, ascending); the caller draws their demands, number ``changes[row]``."""
    due = 0
    for i in range(len(step)):
        due += step[i] + 1 >= next_change[i]
    rows = np.empty(due, np.intp)
    j = 0
    for i in range(len(step)):
        if step[i] + 1 >= next_change[i]:
            rows[j] = i
            j += 1
    for i in rows:
        now = step[i] + 1
        changes[i] += 1
        last_change[i] = now
        next_change[i] = change_step(key[i], changes[i], now, timing)
    return rows


@dataclass(frozen=True)
class ChangeSchedule:
    """Random change times: intervals uniform in ``[interval_min, interval_max]`` s, none after ``last_step``."""

    interval_min: float
    interval_max: float
    dt: float
    last_step: int
    stream: int

    @classmethod
    def planned(
        cls, interval_min: float, interval_max: float, dt: float, episode_steps: int, final_hold: float, stream: int
    ) -> ChangeSchedule:
        """A schedule over ``episode_steps`` steps of ``dt`` with no change within ``final_hold`` s of the end.

        Raises ``ValueError`` naming ``change_interval_min`` or ``final_hold`` when they do not fit.
        """
        if not dt <= interval_min <= interval_max:
            allowed = f"[dt={dt}, change_interval_max={interval_max}]"
            empty = empty_range("dt", dt, "change_interval_max", interval_max)
            raise invalid("change_interval_min", interval_min, allowed + empty)
        if final_hold > episode_steps * dt:
            raise invalid(
                "final_hold", final_hold, f"[0, episode_steps * dt = {episode_steps} * {dt} = {episode_steps * dt:.6g}]"
            )
        last_step = episode_steps - int(math.ceil(final_hold / dt - 1e-9))
        return cls(interval_min, interval_max, dt, last_step, stream)

    @property
    def timing(self) -> Timing:
        """``(stream offset, interval_min, interval_max, dt, last_step)``, as the kernels take the schedule."""
        return rng.stream_offset(self.stream), self.interval_min, self.interval_max, self.dt, self.last_step

    def next_change(self, keys: np.ndarray, index: np.ndarray, now: np.ndarray) -> np.ndarray:
        """Step of the change that ends demand number ``index`` (n,), handed out at step ``now`` (n,)."""
        return _change_steps(*per_key(keys, index, now), self.timing)

    def initial(self, keys: np.ndarray) -> dict[str, np.ndarray]:
        """Schedule state of fresh episodes: demand 0 handed out at step 0."""
        zeros = np.zeros(len(keys), dtype=np.int64)
        return {"changes": zeros, "last_change": zeros.copy(), "next_change": self.next_change(keys, zeros, zeros)}


class ScheduledParams:
    """Mixin for a params dataclass with the fields ``change_interval_min``, ``change_interval_max`` (s), ``dt``
    (s), ``episode_steps`` and ``final_hold`` (s): their :class:`ChangeSchedule` as a derived property."""

    schedule_stream: ClassVar[int] = 3
    """Random stream of the change intervals."""

    @property
    def schedule(self: Any) -> ChangeSchedule:
        """When the demand changes: every ``change_interval_min`` to ``change_interval_max`` s, never within
        ``final_hold`` of the planned episode end. Raises ``ValueError`` for values that do not fit."""
        return ChangeSchedule.planned(
            self.change_interval_min,
            self.change_interval_max,
            self.dt,
            self.episode_steps,
            self.final_hold,
            self.schedule_stream,
        )

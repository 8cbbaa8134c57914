"""Demands that change at random times during an episode (Aircraft's clearances, PendulumPump's amplitudes).

A task whose demand changes keeps three integer arrays in its state: ``changes`` (demands handed out so far
minus one), ``last_change`` (step of the latest change) and ``next_change`` (step of the coming change, or
:data:`NO_CHANGE`). Intervals between changes are uniform in ``[interval_min, interval_max]`` seconds, drawn
from the episode key, and no change comes after ``last_step`` (so the final demand can be flown).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vegym import rng
from vegym.params import invalid

NO_CHANGE = np.iinfo(np.int64).max
"""``next_change`` of an episode whose schedule has ended."""


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
            raise invalid("change_interval_min", interval_min, f"[dt={dt}, change_interval_max={interval_max}]")
        if final_hold > episode_steps * dt:
            raise invalid("final_hold", final_hold, f"[0, episode_steps * dt={episode_steps * dt}]")
        last_step = episode_steps - int(math.ceil(final_hold / dt - 1e-9))
        return cls(interval_min, interval_max, dt, last_step, stream)

    def next_change(self, keys: np.ndarray, index: np.ndarray, now: np.ndarray) -> np.ndarray:
        """Step of the change that ends demand number ``index`` (n,), handed out at step ``now`` (n,)."""
        seconds = rng.uniform_in(keys, self.stream, self.interval_min, self.interval_max, counter=index)
        at = now + np.maximum(np.round(seconds[:, 0] / self.dt).astype(np.int64), 1)
        return np.where(at <= self.last_step, at, NO_CHANGE)

    def initial(self, keys: np.ndarray) -> dict[str, np.ndarray]:
        """Schedule state of fresh episodes: demand 0 handed out at step 0."""
        zeros = np.zeros(len(keys), dtype=np.int64)
        return {"changes": zeros, "last_change": zeros.copy(), "next_change": self.next_change(keys, zeros, zeros)}

    def advance(
        self,
        state: dict[str, np.ndarray],
        now: np.ndarray,
        name: str,
        draw: Callable[[np.ndarray, np.ndarray], np.ndarray],
    ) -> np.ndarray:
        """At step ``now`` (n,), in place: where a change is due, demand ``state[name]`` becomes
        ``draw(keys, index)`` and the schedule moves on. Returns the rows (int indices) that changed."""
        changing = np.flatnonzero(now >= state["next_change"])
        if len(changing):
            keys, index, at = state["key"][changing], state["changes"][changing] + 1, now[changing]
            state[name][changing] = draw(keys, index)
            state["changes"][changing] = index
            state["last_change"][changing] = at
            state["next_change"][changing] = self.next_change(keys, index, at)
        return changing


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

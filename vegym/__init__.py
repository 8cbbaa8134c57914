"""vegym: Gymnasium environments from the physical-simulation chapter, with its analytic controllers.

Importing the package registers every env under the ``vegym/`` namespace. In worker processes started
with ``spawn`` (or anywhere ``vegym`` may not be imported yet) use the ``"vegym:vegym/<Task>-v0"`` form,
which makes Gymnasium import the package first.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

ENVS: dict[str, dict[str, object]] = {
    "vegym/BouncingBall-v0": {
        "module": "vegym.envs.bouncing_ball",
        "env": "BouncingBallEnv",
        "max_episode_steps": 10,
        "summary": "choose the restitution at each impact to reach target apex heights",
    },
    "vegym/Projectile-v0": {
        "module": "vegym.envs.projectile",
        "env": "ProjectileEnv",
        "max_episode_steps": 1,
        "summary": "aim a launcher at a ground target in a constant wind (one shot)",
    },
    "vegym/SteerableWheel-v0": {
        "module": "vegym.envs.steerable_wheel",
        "env": "SteerableWheelEnv",
        "max_episode_steps": 400,
        "summary": "steer a rolling wheel through random waypoints in order",
    },
    "vegym/Aircraft-v0": {
        "module": "vegym.envs.aircraft",
        "env": "AircraftEnv",
        "max_episode_steps": 300,
        "summary": "fly changing altitude, airspeed and heading demands (first-order aircraft)",
    },
    "vegym/AircraftGusty-v0": {
        "module": "vegym.envs.aircraft",
        "env": "AircraftEnv",
        "max_episode_steps": 300,
        "kwargs": {"draft_max": 4.0, "gust_amplitude": 2.0},
        "summary": "Aircraft-v0 in a steady updraft or downdraft with gusts",
    },
    "vegym/Suspension-v0": {
        "module": "vegym.envs.suspension",
        "env": "SuspensionEnv",
        "max_episode_steps": 1000,
        "summary": "set a semi-active quarter-car damper for ride comfort over undulating terrain",
    },
    "vegym/PendulumPump-v0": {
        "module": "vegym.envs.pendulum_pump",
        "env": "PendulumPumpEnv",
        "max_episode_steps": 800,
        "summary": "swing a pendulum with a weak torque at a target amplitude that changes",
    },
    "vegym/Thread-v0": {
        "module": "vegym.envs.thread",
        "env": "ThreadEnv",
        "max_episode_steps": 500,
        "summary": "damp a plucked elastic thread with bounded forces at a few nodes",
    },
    "vegym/Billiards-v0": {
        "module": "vegym.envs.billiards",
        "env": "BilliardsEnv",
        "max_episode_steps": 1,
        "summary": "strike ball A so that ball B, after the oblique impact, slides to rest on a target (one strike)",
    },
    "vegym/GearTrain-v0": {
        "module": "vegym.envs.gear_train",
        "env": "GearTrainEnv",
        "max_episode_steps": 200,
        "summary": "drive the input gear of a chain of external gears so the output gear holds a target angle",
    },
    "vegym/ProjectileAdjust-v0": {
        "module": "vegym.envs.projectile_adjust",
        "env": "ProjectileAdjustEnv",
        "max_episode_steps": 16,
        "summary": "Projectile-v0 with the wind hidden: up to 3 shots, correcting from where the previous ones landed",
    },
}
"""Registered env ids: the module, the env class (its vector twin is ``<Name>VectorEnv`` minus ``Env``),
the episode length, optional default keyword arguments (``kwargs``) and a one-line description."""


def env_name(env_id: str) -> str:
    """``vegym/BouncingBall-v0`` -> ``BouncingBall-v0`` (the directory name of its models)."""
    return env_id.split("/", 1)[-1]


def resolve_env_id(name: str) -> str:
    """The registered id for ``vegym/Name-v0`` or ``Name-v0``; ValueError listing the ids otherwise."""
    for env_id in ENVS:
        if name in (env_id, env_name(env_id)):
            return env_id
    raise ValueError(f"unknown env {name!r}; registered: {', '.join(ENVS)}")


def _register_all() -> None:
    for env_id, spec in ENVS.items():
        if env_id in registry:
            continue
        name = str(spec["env"])
        register(
            id=env_id,
            entry_point=f"{spec['module']}:{name}",
            vector_entry_point=f"{spec['module']}:{name.removesuffix('Env')}VectorEnv",
            max_episode_steps=int(spec["max_episode_steps"]),  # type: ignore[call-overload]
            kwargs=dict(spec.get("kwargs", {})),  # type: ignore[call-overload]
        )


_register_all()

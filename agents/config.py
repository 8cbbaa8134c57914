"""Typed training configs, loaded from RL-Zoo-style YAML files: ``configs/<algo>.yml``, one entry per env id.

An entry holds the pipeline keys (the fields of :class:`TrainConfig`: ``n_timesteps``, ``policy``, ``n_envs``,
``normalize``, ``env_kwargs``, ``policy_kwargs``, ...) and, flat beside them, hyperparameters of the SB3
algorithm, which must be arguments of its constructor. Values are checked against the field types and the
constructor's annotations: numbers PyYAML leaves as strings (``3e-4``, ``1e6``) are converted, dicts may be
written as RL-Zoo strings (``"dict(net_arch=[64, 64], activation_fn=nn.Tanh)"``, parsed with :mod:`ast`, never
evaluated), schedules as ``lin_<start>`` (linear decay to 0). Anything else is a :class:`ConfigError` naming
the key and the file.
"""

from __future__ import annotations

import ast
import dataclasses
import difflib
import inspect
import math
import types
import typing
import warnings
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import yaml
from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.buffers import ReplayBuffer, RolloutBuffer
from stable_baselines3.common.noise import ActionNoise, NormalActionNoise, OrnsteinUhlenbeckActionNoise
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import VecNormalize

import vegym
from agents.basics import ALGO_NAMES, as_number, whole_number
from vegym.envs.base import load_object

ALGOS: dict[str, type[BaseAlgorithm]] = dict(zip(ALGO_NAMES, (PPO, SAC, TD3), strict=True))
"""The algorithms a config may name (its file name), by :data:`~agents.basics.ALGO_NAMES`."""

_INSTALLED_CONFIGS = Path(__file__).resolve().parent / "configs"
CONFIG_DIR = _INSTALLED_CONFIGS if _INSTALLED_CONFIGS.is_dir() else Path(__file__).resolve().parent.parent / "configs"
"""The committed configs, ``<algo>.yml`` for each algorithm: the checkout's ``configs/``, which a wheel installs as
``agents/configs/`` (setup.py's build hook)."""

VECTOR_POLICY = "MlpPolicy"
"""The SB3 policy alias for vegym's observations, flat vectors (CnnPolicy wants images, MultiInputPolicy dicts)."""
PIPELINE_ARGS = frozenset({"self", "policy", "env", "seed", "policy_kwargs", "tensorboard_log", "verbose"})
"""Constructor arguments the pipeline sets itself (``policy``/``seed``/``policy_kwargs`` are config fields)."""

NOISE_TYPES: dict[str, type[ActionNoise]] = {
    "normal": NormalActionNoise,
    "ornstein-uhlenbeck": OrnsteinUhlenbeckActionNoise,
}
"""Exploration noise of the off-policy algorithms (``noise_type``), RL-Zoo names."""

NAMED_CLASSES = {"activation_fn": (torch.nn, torch.nn.Module), "optimizer_class": (torch.optim, torch.optim.Optimizer)}
"""``policy_kwargs`` entries that name a torch class (``nn.Tanh``, ``th.optim.Adam``; RL Zoo evaluates the string
with ``nn`` and ``th`` in scope, so ``optim.Adam`` alone works here only): its module and base class."""

SCHEDULE_PREFIX = "lin_"

HYPERPARAM_RANGES: dict[str, tuple[float, float, bool]] = {
    "learning_rate": (0.0, math.inf, True),
    "gamma": (0.0, 1.0, False),
    "gae_lambda": (0.0, 1.0, False),
    "tau": (0.0, 1.0, True),
    "clip_range": (0.0, math.inf, True),
    "clip_range_vf": (0.0, math.inf, True),
    "ent_coef": (0.0, math.inf, False),
    "vf_coef": (0.0, math.inf, False),
    "max_grad_norm": (0.0, math.inf, True),
    "n_steps": (1, math.inf, False),
    "batch_size": (1, math.inf, False),
    "n_epochs": (1, math.inf, False),
    "buffer_size": (1, math.inf, False),
    "learning_starts": (0, math.inf, False),
    "policy_delay": (1, math.inf, False),
    "target_policy_noise": (0.0, math.inf, False),
    "target_noise_clip": (0.0, math.inf, False),
    "clip_obs": (0.0, math.inf, True),
    "clip_reward": (0.0, math.inf, True),
    "epsilon": (0.0, math.inf, True),
    "target_kl": (0.0, math.inf, True),  # PPO stops every epoch before its first update at target_kl <= 0
    "target_update_interval": (1, math.inf, False),  # SAC takes steps % 0 (ZeroDivisionError mid-run)
    "stats_window_size": (1, math.inf, False),
    "sde_sample_freq": (-1, math.inf, False),
}
"""Allowed values of arguments that SB3 takes unchecked (it trains with gamma -0.5): the algorithms' and
VecNormalize's (``normalize``: ``gamma``, ``clip_obs``, ...), as ``(low, high, low_open)``; ``high`` is allowed
unless infinite. A ``lin_<start>`` schedule is checked by its start; values that are not numbers (SAC's
``ent_coef: auto``, a null ``clip_range_vf``) pass."""


@dataclass(frozen=True)
class LinearDecay:
    """The schedule ``lin_<start>``: ``start`` at the beginning of training, decaying linearly to 0 at the end."""

    start: float

    def __call__(self, progress_remaining: float) -> float:
        return self.start * progress_remaining


class ConfigError(ValueError):
    """A config file or entry that cannot be used; the message names the file and the key."""


@dataclass(frozen=True)
class TrainConfig:
    """One training run: an env, an SB3 algorithm and its settings (an entry of ``configs/<algo>.yml``)."""

    env_id: str
    """Registered env id, e.g. ``vegym/BouncingBall-v0``: the entry's key."""
    algo: str
    """``ppo``, ``sac`` or ``td3``: the config file's name."""
    n_timesteps: int
    """Total env steps of training, over all parallel envs."""
    seed: int = 0
    """Seed of the model and of the training envs (sub-env i starts from seed + i)."""
    policy: str = VECTOR_POLICY
    """SB3 policy alias."""
    n_envs: int = 1
    """Parallel envs; above 1 the env's native vector env runs them in one batch."""
    normalize: bool | dict[str, Any] = False
    """VecNormalize: false, true (its defaults) or its keyword arguments (``norm_obs``, ``norm_reward``, ...)."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """Env parameters passed to ``gymnasium.make``; evaluation uses the same."""
    policy_kwargs: dict[str, Any] = field(default_factory=dict)
    """Policy constructor arguments (``net_arch``, ``activation_fn`` as a torch.nn name, ...)."""
    noise_type: str | None = None
    """Off-policy exploration noise added to actions: ``normal`` or ``ornstein-uhlenbeck`` (none if null)."""
    noise_std: float = 0.1
    """Standard deviation of that noise, in action units (actions span [-1, 1])."""
    eval_freq: int = 10_000
    """Env steps between evaluations during training."""
    n_eval_episodes: int = 20
    """Episodes per evaluation during training."""
    save_freq: int = 50_000
    """Env steps between checkpoints."""
    hyperparams: dict[str, Any] = field(default_factory=dict)
    """Further constructor arguments of the algorithm (``learning_rate``, ``batch_size``, ...), flat in YAML."""

    @property
    def algo_class(self) -> type[BaseAlgorithm]:
        """The SB3 algorithm class."""
        return ALGOS[self.algo]

    def setting(self, key: str) -> Any:
        """The value of the algorithm's argument ``key``: the config's own, or the constructor's default."""
        if key in self.hyperparams:
            return self.hyperparams[key]
        return inspect.signature(self.algo_class.__init__).parameters[key].default

    @property
    def collection_steps(self) -> int | None:
        """Env steps SB3 collects between updates, all envs together: PPO's rollout (``n_steps * n_envs``), an
        off-policy algorithm's ``train_freq`` steps on every env; None where ``train_freq`` counts episodes. SB3
        trains whole collections: a fresh run of ``n_timesteps`` trains it rounded up to a multiple of them."""
        if self.algo_class is PPO:
            return self.setting("n_steps") * self.n_envs
        every, unit = _train_freq(self.setting("train_freq"))
        return every * self.n_envs if unit == "step" else None

    def trained_steps(self, asked: int) -> int:
        """The env steps SB3 trains when ``learn`` is asked for ``asked`` more: rounded up to whole
        :attr:`collection_steps`."""
        step = self.collection_steps
        return -(-asked // step) * step if step else asked

    def to_entry(self) -> dict[str, Any]:
        """The flat YAML entry that loads back into this config, with ``env_id`` and ``algo`` (a run's record: RL
        Zoo's keys plus vegym's, not an RL Zoo file)."""
        entry = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "hyperparams"}
        return {**entry, **self.hyperparams}

    def algo_kwargs(self, action_dim: int) -> dict[str, Any]:
        """Constructor keyword arguments for :attr:`algo_class` (besides policy, env, seed): SB3 objects."""
        kwargs: dict[str, Any] = {}
        hints = constructor_hints(self.algo_class)
        for key, value in self.hyperparams.items():
            kwargs[key] = LinearDecay(schedule_start(value)) if _is_schedule(value, hints[key]) else value
        policy_kwargs = {
            k: resolve_class(v, *NAMED_CLASSES[k]) if k in NAMED_CLASSES else v for k, v in self.policy_kwargs.items()
        }
        if policy_kwargs:
            kwargs["policy_kwargs"] = policy_kwargs
        if self.noise_type is not None:
            zeros = np.zeros(action_dim)
            kwargs["action_noise"] = NOISE_TYPES[self.noise_type](zeros, self.noise_std * np.ones(action_dim))
        return kwargs

    def normalize_kwargs(self) -> dict[str, Any] | None:
        """VecNormalize keyword arguments, or None without normalisation (gamma defaults to the algorithm's)."""
        if self.normalize is False:
            return None
        kwargs = {} if self.normalize is True else dict(self.normalize)
        if "gamma" in self.hyperparams:
            kwargs.setdefault("gamma", self.hyperparams["gamma"])
        return kwargs


def constructor_hints(cls: type) -> dict[str, Any]:
    """The annotations of ``cls.__init__``'s parameters (``inspect.Parameter.empty`` where there is none)."""
    return {name: p.annotation for name, p in inspect.signature(cls.__init__).parameters.items()}


def _describe(hint: Any) -> str:
    if isinstance(hint, type):
        return hint.__name__
    return str(hint).replace("typing.", "")


def schedule_start(value: str) -> float:
    """The start value of a ``lin_<start>`` schedule string; ValueError if it is not one."""
    if not value.startswith(SCHEDULE_PREFIX):
        raise ValueError(f"{value!r} is not a schedule '{SCHEDULE_PREFIX}<start>'")
    return float(value[len(SCHEDULE_PREFIX) :])


def _is_schedule(value: Any, hint: Any) -> bool:
    return isinstance(value, str) and any(_origin(h) is Callable for h in _members(hint))


def _origin(hint: Any) -> Any:
    origin = typing.get_origin(hint)
    return Callable if origin is Callable or hint is Callable else origin


def _members(hint: Any) -> tuple[Any, ...]:
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return typing.get_args(hint)
    return (hint,)


def coerce(value: Any, hint: Any, where: str) -> Any:
    """``value`` checked against the annotation ``hint`` and converted (numeric strings, lists to tuples)."""
    if hint is inspect.Parameter.empty or hint is Any:
        return value
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        members = typing.get_args(hint)
        if value is None and type(None) in members:
            return None
        numeric_first = sorted(members, key=lambda m: m not in (int, float))
        for member in numeric_first if isinstance(value, str) else members:
            try:
                return coerce(value, member, where)
            except ConfigError:
                continue
        raise ConfigError(f"{where}: {value!r} is not {_describe(hint)}")
    if hint is type(None):
        if value is not None:
            raise ConfigError(f"{where}: {value!r} is not null")
        return None
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: {value!r} is not a bool (true or false)")
        return value
    if hint is int:
        number = whole_number(value)
        if number is None:
            raise ConfigError(f"{where}: {value!r} is not an integer")
        return number
    if hint is float:
        number = as_number(value)
        if number is None or math.isnan(number):
            raise ConfigError(f"{where}: {value!r} is not a real number")
        return number
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: {value!r} is not a string")
        return value
    if origin is Callable or hint is Callable:
        if isinstance(value, str):
            try:
                schedule_start(value)
                return value
            except ValueError:
                pass
        raise ConfigError(f"{where}: {value!r} is not a schedule '{SCHEDULE_PREFIX}<start>', e.g. lin_3e-4")
    if origin is tuple or origin is list:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: {value!r} is not a list")
        args = typing.get_args(hint)
        if origin is tuple:
            if len(args) != len(value):
                raise ConfigError(f"{where}: {value!r} is not a list of {len(args)} items ({_describe(hint)})")
            return tuple(coerce(v, a, where) for v, a in zip(value, args, strict=True))
        return [coerce(v, args[0] if args else Any, where) for v in value]
    if origin is dict or hint is dict:
        if isinstance(value, str):
            value = parse_dict(value, where)
        if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
            raise ConfigError(f"{where}: {value!r} is not a mapping with string keys")
        return dict(value)
    raise ConfigError(f"{where}: a {_describe(hint)} cannot be set in a config file")


def _literal(node: ast.expr, where: str, names_allowed: bool) -> Any:
    """A literal (numbers, strings, lists, tuples, dicts, ``dict(...)``) from an AST node; no evaluation."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
        if any(k.arg is None for k in node.keywords):
            raise ConfigError(f"{where}: '**' is not allowed in {ast.unparse(node)!r}")
        return {k.arg: _literal(k.value, where, k.arg in NAMED_CLASSES) for k in node.keywords}
    if isinstance(node, ast.Dict):
        out = {}
        for key, value in zip(node.keys, node.values, strict=True):
            k = _literal(key, where, False) if key is not None else None
            if not isinstance(k, str):
                raise ConfigError(f"{where}: dict keys must be strings in {ast.unparse(node)!r}")
            out[k] = _literal(value, where, k in NAMED_CLASSES)
        return out
    if isinstance(node, (ast.List, ast.Tuple)):
        items = [_literal(e, where, False) for e in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    if isinstance(node, (ast.Name, ast.Attribute)) and names_allowed:
        return ast.unparse(node)
    try:
        return ast.literal_eval(node)
    except ValueError:
        allowed = ", ".join(NAMED_CLASSES)
        raise ConfigError(
            f"{where}: {ast.unparse(node)!r} is not a literal (names are allowed only as {allowed})"
        ) from None


RUN_SETTINGS = ("seed", "eval_freq", "n_eval_episodes", "save_freq")
"""vegym's keys of an entry that say how a run goes, not what it trains; RL Zoo refuses them."""


def zoo_entry(entry: Mapping[str, Any]) -> dict[str, Any]:
    """An entry as :meth:`TrainConfig.to_entry` writes it, in the form of the committed ``configs/<algo>.yml``
    entries, which RL Zoo reads as well: without ``env_id``, ``algo`` and the :data:`RUN_SETTINGS`, the noise only
    where there is some, an empty ``env_kwargs`` or ``policy_kwargs`` left out, ``policy_kwargs`` and a
    ``normalize`` dict as RL Zoo's ``dict(...)`` strings (torch classes unquoted) and tuples as lists."""
    noisy = entry.get("noise_type") is not None
    out: dict[str, Any] = {}
    for key, value in entry.items():
        if key in ("env_id", "algo", *RUN_SETTINGS) or (key in ("noise_type", "noise_std") and not noisy):
            continue
        if key in ("env_kwargs", "policy_kwargs") and not value:
            continue
        if key == "policy_kwargs" or (key == "normalize" and isinstance(value, Mapping)):
            value = _dict_text(value)
        out[key] = list(value) if isinstance(value, tuple) else value
    return out


def _dict_text(values: Mapping[str, Any]) -> str:
    """``values`` as RL Zoo's ``dict(k=v, ...)`` string; a torch class name (``nn.Tanh``) unquoted, as RL Zoo
    evaluates it (and :func:`parse_dict` reads it)."""
    items = (f"{k}={v if k in NAMED_CLASSES else repr(v)}" for k, v in values.items())
    return f"dict({', '.join(items)})"


def parse_dict(text: str, where: str) -> dict[str, Any]:
    """An RL-Zoo dict string, ``"dict(a=1, b=[2, 3])"`` or ``"{'a': 1}"``, parsed with ast (never evaluated)."""
    try:
        node = ast.parse(text.strip(), mode="eval").body
    except SyntaxError as exc:
        raise ConfigError(f"{where}: {text!r} is not a dict expression ({exc.msg})") from None
    value = _literal(node, where, False)
    if not isinstance(value, dict):
        raise ConfigError(f"{where}: {text!r} is not a dict")
    return value


def resolve_class(name: str | type, module: types.ModuleType, base: type) -> type:
    """The class of ``module`` named ``name`` (``nn.Tanh``, ``torch.nn.Tanh`` or ``Tanh``), a subclass of ``base``."""
    if isinstance(name, type) and issubclass(name, base):
        return name
    short = str(name).rsplit(".", 1)[-1]
    cls = getattr(module, short, None)
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise ValueError(f"{name!r} is not a {module.__name__} class derived from {base.__name__}")
    return cls


FIELD_HINTS = typing.get_type_hints(TrainConfig)
ENTRY_FIELDS = [f.name for f in dataclasses.fields(TrainConfig) if f.name not in ("env_id", "algo", "hyperparams")]


def config_from_entry(entry: Mapping[str, Any], env_id: str, algo: str, source: str) -> TrainConfig:
    """Check and convert one config entry (flat RL-Zoo mapping) of ``env_id`` for ``algo``; ``source`` names it."""
    if algo not in ALGOS:
        raise ConfigError(f"{source}: unknown algorithm {algo!r}; choose one of {', '.join(ALGOS)}")
    if env_id not in vegym.ENVS:
        raise ConfigError(f"{source}: {env_id!r} is not a registered env; registered: {', '.join(vegym.ENVS)}")
    if not isinstance(entry, Mapping):
        raise ConfigError(f"{source}: the entry of {env_id} is {entry!r}, not a mapping of settings")
    cls = ALGOS[algo]
    hints = constructor_hints(cls)
    settable = [key for key in hints if key not in PIPELINE_ARGS and not key.startswith("_")]
    values: dict[str, Any] = {}
    hyperparams: dict[str, Any] = {}
    for key, value in entry.items():
        where = f"{source}: {env_id}: {key}"
        if key in ENTRY_FIELDS:
            values[key] = coerce(value, FIELD_HINTS[key], where)
        elif key in settable:
            hyperparams[key] = coerce(value, hints[key], where)
        else:
            raise ConfigError(
                f"{source}: {env_id}: unknown key {key!r}; allowed: {', '.join(ENTRY_FIELDS)} and "
                f"{cls.__name__} arguments {', '.join(settable)}"
            )
    if isinstance(values.get("normalize"), dict):
        values["normalize"] = _normalize_kwargs(values["normalize"], f"{source}: {env_id}: normalize")
    if "n_timesteps" not in values:
        raise ConfigError(f"{source}: {env_id}: missing key 'n_timesteps'")
    config = TrainConfig(env_id=env_id, algo=algo, hyperparams=hyperparams, **values)
    _check(config, f"{source}: {env_id}")
    return config


def _normalize_kwargs(kwargs: dict[str, Any], where: str) -> dict[str, Any]:
    hints = {k: v for k, v in constructor_hints(VecNormalize).items() if k not in ("self", "venv", "training")}
    for key in kwargs:
        if key not in hints:
            raise ConfigError(f"{where}: unknown key {key!r}; allowed: {', '.join(hints)}")
    return {key: coerce(value, hints[key], f"{where}: {key}") for key, value in kwargs.items()}


def _check(c: TrainConfig, where: str) -> None:
    """Ranges and cross-field rules of a typed config."""
    for key in ("n_timesteps", "n_envs", "eval_freq", "n_eval_episodes", "save_freq"):
        if getattr(c, key) < 1:
            raise ConfigError(f"{where}: {key}={getattr(c, key)!r} must be at least 1")
    if c.seed < 0:
        raise ConfigError(f"{where}: seed={c.seed!r} must be non-negative")
    if c.policy != VECTOR_POLICY:
        raise ConfigError(f"{where}: policy={c.policy!r}; vegym's observations are flat vectors: use {VECTOR_POLICY}")
    if c.noise_type is not None:
        if not issubclass(c.algo_class, OffPolicyAlgorithm):
            raise ConfigError(f"{where}: noise_type={c.noise_type!r}: action noise is for sac and td3, not {c.algo}")
        if c.noise_type not in NOISE_TYPES:
            raise ConfigError(f"{where}: noise_type={c.noise_type!r}; choose one of {', '.join(NOISE_TYPES)} or null")
    if c.noise_std < 0:
        raise ConfigError(f"{where}: noise_std={c.noise_std!r} must be non-negative")
    hints = constructor_hints(c.algo_class)
    for key, value in c.hyperparams.items():
        _check_range(key, schedule_start(value) if _is_schedule(value, hints[key]) else value, value, where)
    if isinstance(c.normalize, dict):
        for key, value in c.normalize.items():
            _check_range(key, value, value, f"{where}: normalize")
    _check_batches(c, where)
    _check_late_settings(c, where)
    learning_starts = c.setting("learning_starts") if issubclass(c.algo_class, OffPolicyAlgorithm) else None
    trained = c.trained_steps(c.n_timesteps)  # SB3 updates once it has collected more than learning_starts steps
    if learning_starts is not None and learning_starts >= trained:
        total = f"n_timesteps={c.n_timesteps}" + (f" (trained as {trained})" if trained != c.n_timesteps else "")
        warnings.warn(
            f"{where}: learning_starts={learning_starts} is not below {total}: the run only collects random steps "
            "and never updates its policy",
            stacklevel=2,
        )
    policy_hints = constructor_hints(c.algo_class.policy_aliases[c.policy])
    for key, value in c.policy_kwargs.items():
        if key not in policy_hints or key in ("self", "observation_space", "action_space", "lr_schedule"):
            raise ConfigError(f"{where}: policy_kwargs: unknown key {key!r} for {c.policy} of {c.algo}")
        if key in NAMED_CLASSES:
            try:
                resolve_class(value, *NAMED_CLASSES[key])
            except ValueError as exc:
                raise ConfigError(f"{where}: policy_kwargs: {key}: {exc}") from None
    time_limit = c.env_kwargs.get(TIME_LIMIT, 1)
    if isinstance(time_limit, bool) or not isinstance(time_limit, int) or time_limit < 1:
        raise ConfigError(f"{where}: env_kwargs: {TIME_LIMIT}={time_limit!r}; give a positive integer")
    try:
        params = env_params(c.env_id, {key: value for key, value in c.env_kwargs.items() if key != TIME_LIMIT})
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: env_kwargs: {exc}") from None
    planned = _task_class(c.env_id).planned_length_param
    if TIME_LIMIT in c.env_kwargs and planned is not None and time_limit != getattr(params, planned):
        raise ConfigError(
            f"{where}: env_kwargs: {TIME_LIMIT}={time_limit} cuts or outlives the episodes of "
            f"{planned}={getattr(params, planned)} that {c.env_id} plans; give both the same value"
        )


def _train_freq(train_freq: Any) -> tuple[Any, Any]:
    """An off-policy ``train_freq`` setting (``every`` or ``(every, unit)``) as ``(every, unit)``."""
    return tuple(train_freq) if isinstance(train_freq, list | tuple) else (train_freq, "step")


def _check_batches(c: TrainConfig, where: str) -> None:
    """ConfigError for the combinations SB3 asserts against when it builds or trains the model: PPO's
    normalised advantages need more than one sample per rollout and per mini-batch; an off-policy algorithm
    trains every n >= 1 steps or episodes, episodes only on one env."""
    if c.algo_class is PPO and c.setting("normalize_advantage"):
        batch_size, n_steps = c.setting("batch_size"), c.setting("n_steps")
        if batch_size < 2:
            raise ConfigError(f"{where}: batch_size={batch_size!r} must be at least 2 for ppo")
        if n_steps * c.n_envs < 2:
            raise ConfigError(f"{where}: n_steps * n_envs = {n_steps} * {c.n_envs} must be at least 2 for ppo")
    if issubclass(c.algo_class, OffPolicyAlgorithm):
        train_freq = c.setting("train_freq")
        every, unit = _train_freq(train_freq)
        if unit not in ("step", "episode"):
            raise ConfigError(f"{where}: train_freq={train_freq!r}: its unit is 'step' or 'episode', not {unit!r}")
        if isinstance(every, int) and every < 1:
            raise ConfigError(f"{where}: train_freq={train_freq!r} must train every 1 or more {unit}s")
        if unit == "episode" and c.n_envs > 1:
            raise ConfigError(f"{where}: train_freq={train_freq!r} counts episodes, which needs n_envs: 1")


AUTO = "auto"
"""SAC's learned ``ent_coef`` (``auto`` or ``auto_<start>``) and its ``target_entropy`` from the action size."""

BUFFER_ARGS_SET_BY_SB3 = frozenset(
    {"self", "buffer_size", "observation_space", "action_space", "device", "n_envs", "optimize_memory_usage", "gamma",
     "gae_lambda"}
)  # fmt: skip
"""Buffer constructor arguments the algorithm passes itself, which ``*_buffer_kwargs`` cannot set."""


def _check_late_settings(c: TrainConfig, where: str) -> None:
    """ConfigError for settings SB3 reads only once it builds or trains the model, where a wrong one fails with
    a bare error or trains nothing: SAC's ``ent_coef`` and ``target_entropy`` strings, ``device``, an off-policy
    ``gradient_steps`` of 0 (no update ever), the keys of ``rollout_buffer_kwargs`` and ``replay_buffer_kwargs``,
    and ``optimize_memory_usage``, which SB3's replay buffers refuse beside timeout handling and n-step returns."""
    ent_coef, target_entropy = c.hyperparams.get("ent_coef"), c.hyperparams.get("target_entropy")
    if isinstance(ent_coef, str) and ent_coef != AUTO:
        start = as_number(ent_coef.removeprefix(f"{AUTO}_")) if ent_coef.startswith(f"{AUTO}_") else None
        if start is None or not start > 0.0:
            allowed = f"a number >= 0, {AUTO!r} or '{AUTO}_<start>' with a start above 0 (e.g. {AUTO}_0.1)"
            raise ConfigError(f"{where}: ent_coef={ent_coef!r}; give {allowed}")
    if isinstance(target_entropy, str) and target_entropy != AUTO:
        raise ConfigError(f"{where}: target_entropy={target_entropy!r}; give a number or {AUTO!r}")
    if "device" in c.hyperparams:
        try:
            torch.device(c.hyperparams["device"])
        except (RuntimeError, TypeError) as exc:
            raise ConfigError(f"{where}: device={c.hyperparams['device']!r}: {exc}") from None
    gradient_steps = c.hyperparams.get("gradient_steps")
    if gradient_steps is not None and not (gradient_steps == -1 or gradient_steps >= 1):
        raise ConfigError(f"{where}: gradient_steps={gradient_steps!r}; give -1 (one per env step) or 1 or more")
    off_policy = issubclass(c.algo_class, OffPolicyAlgorithm)
    key, buffer = ("replay_buffer_kwargs", ReplayBuffer) if off_policy else ("rollout_buffer_kwargs", RolloutBuffer)
    buffer_kwargs = c.hyperparams.get(key) or {}
    hints = {k: v for k, v in constructor_hints(buffer).items() if k not in BUFFER_ARGS_SET_BY_SB3}
    for name, value in buffer_kwargs.items():
        if name not in hints:
            allowed = ", ".join(hints) or f"none: {c.algo} sets every argument of {buffer.__name__} itself"
            raise ConfigError(f"{where}: {key}: unknown key {name!r}; allowed: {allowed}")
        coerce(value, hints[name], f"{where}: {key}: {name}")
    if off_policy and c.setting("optimize_memory_usage"):
        if c.setting("n_steps") > 1:
            raise ConfigError(f"{where}: optimize_memory_usage=True does not work with n-step returns (n_steps > 1)")
        if buffer_kwargs.get("handle_timeout_termination", True):
            raise ConfigError(
                f"{where}: optimize_memory_usage=True needs replay_buffer_kwargs: "
                '"dict(handle_timeout_termination=False)" (SB3 cannot combine the two)'
            )


def _check_range(key: str, number: Any, value: Any, where: str) -> None:
    """ConfigError if the setting ``key`` (``value`` as written, ``number`` its value or a schedule's start) is a
    number outside its :data:`HYPERPARAM_RANGES` entry."""
    if key not in HYPERPARAM_RANGES or not isinstance(number, int | float) or isinstance(number, bool):
        return
    low, high, low_open = HYPERPARAM_RANGES[key]
    above = low < number if low_open else low <= number
    below = number < high if math.isinf(high) else number <= high
    if not (above and below):
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if math.isinf(high) else ']'}"
        raise ConfigError(f"{where}: {key}={value!r} is outside {interval}")


def _task_class(env_id: str) -> Any:
    spec = vegym.ENVS[env_id]
    return load_object(f"{spec['module']}:{spec['env']}").task_cls


TIME_LIMIT = "max_episode_steps"
"""The ``env_kwargs`` key that is ``gymnasium.make``'s time limit, not an env parameter: RL Zoo passes ``env_kwargs``
to ``gymnasium.make`` as they are, so an entry that changes a planned episode length gives it too, the same value
(checked; vegym adds it where missing, :func:`make_kwargs`)."""


def env_params(env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """The params dataclass ``gymnasium.make(env_id, **env_kwargs)`` would build (TypeError for an unknown
    parameter, ValueError for a value out of range), without making the env."""
    registered = dict(gym.spec(env_id).kwargs)
    return _task_class(env_id).params_cls.of(**{**registered, **env_kwargs})


def make_kwargs(env_id: str, env_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """Keyword arguments of ``gymnasium.make`` and ``make_vec`` for ``env_id`` with the parameters ``env_kwargs``
    (and the time limit ``max_episode_steps`` where they give one): those, and ``max_episode_steps`` where they set
    the episode length the task plans for (``episode_steps``, ``episode_bounces``) without a time limit, which the
    registered one would otherwise cut short without a word."""
    kwargs = dict(env_kwargs)
    planned = _task_class(env_id).planned_length_param
    if planned is not None and planned in kwargs and TIME_LIMIT not in kwargs:
        kwargs[TIME_LIMIT] = kwargs[planned]
    return kwargs


class _UniqueKeyLoader(yaml.SafeLoader):
    """PyYAML's safe loader refusing a key given twice in one mapping (PyYAML keeps the last one silently). Merge
    keys (``<<: *defaults``, as RL Zoo's files use them) still merge: a key written in the mapping overrides a
    merged one."""


_MERGE_TAG = "tag:yaml.org,2002:merge"


def _unique_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
    seen = set()
    for key_node, _ in node.value:
        if key_node.tag == _MERGE_TAG:
            continue  # construct_mapping merges it
        key = loader.construct_object(key_node, deep=deep)
        if not isinstance(key, Hashable):
            continue  # construct_mapping refuses it
        if key in seen:
            raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _unique_mapping)


def read_yaml(path: Path) -> Any:
    """A YAML file's content; ConfigError if it is missing, not YAML or gives a key twice."""
    try:
        return yaml.load(Path(path).read_text(), Loader=_UniqueKeyLoader)  # noqa: S506 (a safe loader)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None


def load_configs(path: Path, algo: str | None = None) -> dict[str, TrainConfig]:
    """Every entry of a config file, by env id; ``algo`` defaults to the file's name (``ppo.yml`` -> ppo)."""
    path = Path(path)
    algo = algo or path.stem
    data = read_yaml(path)
    if not isinstance(data, Mapping) or not data:
        raise ConfigError(f"{path}: expected a mapping of env ids to settings")
    return {env_id: config_from_entry(entry, str(env_id), algo, str(path)) for env_id, entry in data.items()}


def load_config(
    path: Path, env_id: str, algo: str | None = None, overrides: Mapping[str, Any] | None = None
) -> TrainConfig:
    """The entry of ``env_id`` in a config file, with ``overrides`` (e.g. ``seed``, ``n_timesteps``) applied."""
    path = Path(path)
    data = read_yaml(path)
    if not isinstance(data, Mapping) or env_id not in data:
        entries = ", ".join(map(str, data)) if isinstance(data, Mapping) else "none"
        raise ConfigError(
            f"{path}: no entry for {env_id}; entries: {entries}. Add one, here or in a file of your own "
            "(vegym train --config FILE)"
        )
    for key in data:
        if isinstance(key, str) and key.startswith("vegym/") and key not in vegym.ENVS:
            close = difflib.get_close_matches(key, list(vegym.ENVS), n=1)
            warnings.warn(
                f"{path}: its entry {key!r} is no registered env{f' (did you mean {close[0]!r}?)' if close else ''}; "
                "nothing trains it",
                stacklevel=2,
            )
    entry = data[env_id]
    if isinstance(entry, Mapping):  # else config_from_entry refuses it
        entry = {**entry, **(overrides or {})}
    return config_from_entry(entry, env_id, algo or path.stem, str(path))


def save_resolved(config: TrainConfig, path: Path) -> None:
    """Write the resolved config (every field, with ``env_id`` and ``algo``) as YAML."""
    Path(path).write_text(yaml.safe_dump(config.to_entry(), sort_keys=False))


def load_resolved(path: Path) -> TrainConfig:
    """Read a config written by :func:`save_resolved`."""
    data = read_yaml(path)
    if not isinstance(data, Mapping) or "env_id" not in data or "algo" not in data:
        raise ConfigError(f"{path}: not a resolved config (it needs env_id and algo)")
    entry = dict(data)
    return config_from_entry(entry, str(entry.pop("env_id")), str(entry.pop("algo")), str(path))


def with_overrides(config: TrainConfig, overrides: Mapping[str, Any], source: str) -> TrainConfig:
    """``config`` with some entry keys changed (e.g. ``seed``, ``n_timesteps``), checked again."""
    entry = {**config.to_entry(), **overrides}
    return config_from_entry(entry, str(entry.pop("env_id")), str(entry.pop("algo")), source)

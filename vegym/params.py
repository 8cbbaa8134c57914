"""Frozen, self-validating parameter dataclasses.

Every physical or task parameter in vegym is a field of a frozen dataclass built with :func:`param`,
which records the allowed range and a one-line description. :class:`Params` checks types and ranges in
``__post_init__`` and raises ``ValueError`` naming the parameter, its value and the allowed range.
Derived quantities are properties, never stored fields, so they cannot go stale.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import numbers
import typing
from typing import Any, ClassVar

import numpy as np

LARGEST = 1e9
"""The largest magnitude of a float parameter whose range names no finite end on that side (SI units)."""
SMALLEST = 1e-9
"""The smallest value of a float parameter whose range is open at 0, a positive quantity (SI units)."""


def param(
    default: Any,
    doc: str,
    *,
    low: float = -math.inf,
    high: float = math.inf,
    low_open: bool = False,
    high_open: bool = False,
    infinite: bool = False,
) -> Any:
    """A dataclass field with a default, a description and an allowed interval.

    ``low_open``/``high_open`` exclude the bound itself (``(low, high]`` etc.). An infinite bound is open (the
    values are finite) unless ``infinite``: then ``inf`` (or ``-inf``) is allowed there, e.g. "no ceiling". A float
    field (one with a float default) is held to magnitudes the models compute with: an infinite end of its range
    is ``LARGEST`` instead (``-LARGEST`` below), unless ``infinite``, and an end open at 0 is ``SMALLEST``, closed;
    beyond them the models' squares, products and quotients overflowed or underflowed into inf or NaN
    observations (gravity 1e-200, speeds 1e155, a yaw rate of 1e25 rad/s).
    """
    if isinstance(default, float):
        if high == math.inf and not infinite:
            high, high_open = LARGEST, False
        if low == -math.inf and not infinite:
            low, low_open = -LARGEST, False
        if low == 0.0 and low_open:
            low, low_open = SMALLEST, False
    return dataclasses.field(
        default=default,
        metadata={
            "doc": doc, "low": low, "high": high, "low_open": low_open or (low == -math.inf and not infinite),
            "high_open": high_open or (high == math.inf and not infinite),
        },
    )  # fmt: skip


def interval_text(meta: typing.Mapping[str, Any]) -> str:
    """The allowed interval of a field as text, e.g. ``(0, inf)`` or ``[0, 1]``."""
    return f"{_low_end(meta)}, {_high_end(meta)}"


def _low_end(meta: typing.Mapping[str, Any]) -> str:
    """The opening bracket and lower bound of a field's interval, e.g. ``(0``."""
    return f"{'(' if meta['low_open'] else '['}{meta['low']:g}"


def _high_end(meta: typing.Mapping[str, Any]) -> str:
    """The upper bound and closing bracket of a field's interval, e.g. ``inf)``."""
    return f"{meta['high']:g}{')' if meta['high_open'] else ']'}"


def outside(values: Any, meta: typing.Mapping[str, Any]) -> Any:
    """Whether ``values`` (a number, or elementwise for an array) are NaN or outside the interval of ``meta``
    (``low``, ``high``, ``low_open``, ``high_open``, as :func:`param` records it)."""
    low, high = meta["low"], meta["high"]
    too_low = values <= low if meta["low_open"] else values < low
    too_high = values >= high if meta["high_open"] else values > high
    return (values != values) | too_low | too_high  # NaN: not np.isnan, 3 us on a Python float


ParamsT = typing.TypeVar("ParamsT", bound="Params")

Bound = str | float | tuple[str, float] | None
"""An end of a cross-field range (:meth:`Params.between`): a field's name (shown with its value), a constant, the
text and value of a bound computed from fields (``("arena_size / 2 = 10", 10.0)``; the text before `` = `` names
it), or None for the field's own end."""

INT64_RANGE = (-(2**63), 2**63 - 1)
"""The integers a parameter may hold: those of the kernels' int64."""


class Params:
    """Mixin for ``@dataclass(frozen=True)`` parameter sets: type and range checks on construction.

    Subclasses add cross-field checks by overriding :meth:`validate` (raise :meth:`between` or :func:`invalid`).
    """

    _hints: ClassVar[dict[type, dict[str, Any]]] = {}

    def __post_init__(self) -> None:
        hints = Params._hints.get(type(self))
        if hints is None:
            hints = Params._hints[type(self)] = typing.get_type_hints(type(self))
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            kind = hints[f.name]
            if kind is bool:
                if not isinstance(value, bool | np.bool_):
                    raise ValueError(f"{f.name}={value!r} must be a bool (True or False)")
                object.__setattr__(self, f.name, bool(value))
                continue
            if kind is int:
                if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
                    raise ValueError(f"{f.name}={value!r} must be an integer in {interval_text(f.metadata)}")
                value = int(value)
                if not INT64_RANGE[0] <= value <= INT64_RANGE[1]:
                    low = f"{_low_end(f.metadata)}" if f.metadata["low"] > -math.inf else f"[{INT64_RANGE[0]}"
                    high = f"{_high_end(f.metadata)}" if f.metadata["high"] < math.inf else f"{INT64_RANGE[1]}]"
                    raise ValueError(
                        f"{f.name}={value!r} is outside the allowed range {low}, {high} (of the kernels' 64-bit "
                        "integers)"
                    )
            elif kind is float:
                if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
                    raise ValueError(f"{f.name}={value!r} must be a real number in {interval_text(f.metadata)}")
                try:
                    value = float(value)
                except OverflowError:  # an integer beyond the floats
                    raise ValueError(
                        f"{f.name}={value!r} is outside the allowed range {interval_text(f.metadata)}"
                    ) from None
            else:
                continue
            object.__setattr__(self, f.name, value)
            if "low" in f.metadata:
                self._check_range(f.name, value, f.metadata)
        self.validate()

    @staticmethod
    def _check_range(name: str, value: float, meta: typing.Mapping[str, Any]) -> None:
        if outside(value, meta):
            raise ValueError(f"{name}={value!r} is outside the allowed range {interval_text(meta)}")

    def validate(self) -> None:
        """Cross-field checks; the default has none."""

    @classmethod
    def of(cls: type[ParamsT], **values: Any) -> ParamsT:
        """The parameter set of ``values`` (keyword arguments by field name, the rest at their defaults); a name
        that is no field raises ``TypeError`` naming the closest field, if one is close, and listing them all."""
        names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
        unknown = next((name for name in values if name not in names), None)
        if unknown is not None:
            close = difflib.get_close_matches(unknown, names, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise TypeError(f"{cls.__name__} has no parameter {unknown!r}{hint}; its parameters: {', '.join(names)}")
        return cls(**values)

    def as_dict(self) -> dict[str, Any]:
        """The parameters as plain keyword arguments."""
        return dataclasses.asdict(self)  # type: ignore[call-overload]

    def subset(self, cls: type[ParamsT], **given: Any) -> ParamsT:
        """The parameter set ``cls`` (a task's physics, say) of this set's fields of the same names, and ``given``
        for the others; ``TypeError`` names a field of ``cls`` that neither has (none is left at its default
        unseen), a name in ``given`` that ``cls`` lacks, or one that this set has (its own value is taken)."""
        own = {f.name for f in dataclasses.fields(self)}  # type: ignore[arg-type]
        names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
        for name in given:
            if name not in names:
                raise TypeError(f"{cls.__name__} has no parameter {name!r}")
            if name in own:
                raise TypeError(f"{name!r} is a parameter of {type(self).__name__}: its value is taken, not given")
        missing = next((name for name in names if name not in own and name not in given), None)
        if missing is not None:
            raise TypeError(f"{type(self).__name__} has no parameter {missing!r} of {cls.__name__}: give it")
        return cls(**{name: given[name] if name in given else getattr(self, name) for name in names})

    def between(
        self,
        name: str,
        low: Bound = None,
        high: Bound = None,
        *,
        low_open: bool = False,
        high_open: bool = False,
        reason: str = "",
    ) -> ValueError:
        """The ``ValueError`` for field ``name`` outside a range that other fields set: ``low`` to ``high``, each
        a :data:`Bound` (None: the field's own end, and whether it is open), then ``reason``. Where those ends
        leave no value (``floor_altitude`` above ``altitude_max``, say: the user changed a bound, not ``name``),
        the message says so and which ends conflict."""
        meta = self._metadata(name)
        ends = []
        for bound, is_open, side in ((low, low_open, "low"), (high, high_open, "high")):
            if bound is None:
                if is_open:
                    raise TypeError(f"{side}_open applies to a {side} bound given; the field's own end has its own")
                bound, is_open = meta[side], meta[f"{side}_open"]
            if isinstance(bound, str):
                ends.append((f"{bound}={getattr(self, bound)!r}", bound, getattr(self, bound), is_open))
            elif isinstance(bound, tuple):
                text, value = bound
                ends.append((text, text.split(" = ")[0], value, is_open))
            else:
                ends.append((f"{bound:g}", f"{bound:g}", bound, is_open))
        (low_text, low_label, low_value, low_open), (high_text, high_label, high_value, high_open) = ends
        allowed = f"{'(' if low_open else '['}{low_text}, {high_text}{')' if high_open else ']'}"
        empty = empty_range(low_label, low_value, high_label, high_value, low_open or high_open)
        return invalid(name, getattr(self, name), allowed + empty + reason)

    @classmethod
    def _metadata(cls, name: str) -> typing.Mapping[str, Any]:
        return next(f.metadata for f in dataclasses.fields(cls) if f.name == name)  # type: ignore[arg-type]

    def named(self, *names: str) -> str:
        """``"name=value, ..."`` of the fields ``names`` (numbers as ``:g``), for errors that name the parameters a
        bound depends on."""
        return ", ".join(f"{name}={getattr(self, name):g}" for name in names)

    @classmethod
    def describe(cls) -> str:
        """One line per field: name, default, allowed range, description (listed in each env's docstring)."""
        lines = []
        for f in dataclasses.fields(cls):  # type: ignore[arg-type]
            rng = f" in {interval_text(f.metadata)}" if "low" in f.metadata else ""
            lines.append(f"{f.name} (default {f.default!r}{rng}): {f.metadata.get('doc', '')}")
        return "\n".join(lines)


def with_arguments(doc: str, params_cls: type[Params]) -> str:
    """``doc`` with :meth:`Params.describe`'s lines added as a list to its ``## Arguments`` section (unchanged
    without one)."""
    lines = doc.splitlines()
    header = next((i for i, line in enumerate(lines) if line.strip() == "## Arguments"), None)
    if header is None:
        return doc
    indent = lines[header][: len(lines[header]) - len(lines[header].lstrip())]
    end = next((i for i in range(header + 1, len(lines)) if lines[i].lstrip().startswith("## ")), len(lines))
    while not lines[end - 1].strip():
        end -= 1
    listed = [
        "",
        f"{indent}The parameters (default, allowed range; limits that depend on other parameters are checked too):",
        "",
        *(f"{indent}* {line}" for line in params_cls.describe().splitlines()),
    ]
    return "\n".join([*lines[:end], *listed, *lines[end:]])


def empty_range(low_label: str, low: float, high_label: str, high: float, open_end: bool = False) -> str:
    """``" (an empty range: low_label must not exceed high_label)"`` (``be below`` with an ``open_end``) where
    the ends ``low`` and ``high`` of a range leave no value, else ``""``: for an error that names a parameter whose
    range other parameters set, which are then what to change."""
    if low < high or (low == high and not open_end):
        return ""
    return f" (an empty range: {low_label} must {'be below' if open_end else 'not exceed'} {high_label})"


def invalid(name: str, value: Any, allowed: str) -> ValueError:
    """The ``ValueError`` for a parameter that fails a cross-field check."""
    return ValueError(f"{name}={value!r} is outside the allowed range {allowed}")


def check_values(
    name: str, values: Any, low: float, high: float, *, low_open: bool = False, high_open: bool = False
) -> None:
    """Raise ``ValueError`` naming ``name``, its first offending value and the allowed interval if any of ``values``
    (a number or an array) is NaN or outside ``[low, high]`` (the ends excluded where open): the check of
    :class:`Params` for the parameters that the physics functions take as arguments."""
    meta = {"low": low, "high": high, "low_open": low_open, "high_open": high_open}
    if isinstance(values, float | int) and not outside(values, meta):  # a scalar argument: no array (5-7 us)
        return
    array = np.asarray(values, dtype=np.float64)
    bad = outside(array, meta)
    if np.any(bad):
        raise ValueError(f"{name}={float(array[bad].flat[0])!r} is outside the allowed range {interval_text(meta)}")


def check_positive(name: str, values: Any) -> None:
    """:func:`check_values` for a quantity that must be positive and finite, in ``(0, inf)``."""
    check_values(name, values, 0.0, math.inf, low_open=True, high_open=True)

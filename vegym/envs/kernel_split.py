"""A large vector env's step kernel run over chunks of rows by the calling thread and helper threads at once.

The calling thread writes the arrays' addresses and shapes into a table, posts a job, runs its first chunk and
then takes any chunk left, one at a time, while the helpers take the others; it returns when every chunk is done.
The first chunk is always the calling thread's, so that from step to step each thread finds its rows of the state
in its own cache (where either could take it, 8,192 Aircraft envs stepped in 153-169 us, 151-162 us since); a call
with ``then`` runs it in the calling thread before the wait for the helpers, and sizes the first chunk to match
(:meth:`SplitKernel.__call__`). The other chunks are taken by an atomic compare-and-swap on one counter that also
names the job, so a chunk runs once, and a helper that is late, napping or stopped only leaves more chunks to the
caller: results never depend on the helpers (a helper that has taken a chunk is waited for, and one descheduled
then delays the step). A helper is a compiled loop that never takes the GIL. Handing work to a sleeping thread took
60-130 us on the 2-core VM this was measured on, about half of an 8,192-env step, so a helper spins between jobs,
for ``SPIN_S`` (0.2 ms, in rounds timed once), then naps in ``usleep`` calls that double from ``MIN_NAP_US`` to
``MAX_NAP_US``, which hand its core back; a job posted while it naps (the calling thread takes its chunks) starts
the spin again. Where the calls go at least 15% faster in the calling thread alone than over the threads (on a host
that shares the cores' time, say), they run alone, the helpers napping: :class:`ModeChooser` times both ways.
Splitting needs POSIX ``usleep`` and numba's type fingerprints; without them kernels run unsplit.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import math
import operator
import os
import platform
import statistics
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from typing import Any

import llvmlite.ir as ir
import numpy as np
from numba import carray, literally, njit, types
from numba.core import cgutils
from numba.core.extending import intrinsic, overload

from vegym.envs import kernel_call

try:
    from numba._dispatcher import compute_fingerprint
except ImportError:  # a numba without it: kernels run unsplit
    compute_fingerprint = None
_USLEEP = 0
"""Address of the C library's ``usleep``, 0 where there is none (then kernels run unsplit)."""
with contextlib.suppress(AttributeError, OSError, TypeError):
    _USLEEP = ctypes.cast(ctypes.CDLL(None).usleep, ctypes.c_void_p).value or 0

SPLIT_MIN_ROWS = 4096
"""Rows per chunk at least: a vector env's step kernel runs in ``min(threads, num_envs // SPLIT_MIN_ROWS)``
chunks, one per thread, where that is two or more. (With fewer rows a step is mostly Python, which a spinning
helper slows; and more chunks than threads were slower, each chunk costing a few microseconds.)"""
SPIN_S = 2e-4
"""Seconds a helper spins after each job posted before it naps, and the calling thread waits for a helper's chunk
before it naps between looks: :func:`spin_rounds` rounds, each an x86 ``pause`` (elsewhere the rounds' reads
alone, spinning as long)."""
MIN_NAP_US, MAX_NAP_US = 50, 10_000
"""A napping helper's first and longest ``usleep`` (us); the longest also bounds how long stopping it takes."""
PROBE_INTERVAL_S, MAX_PROBE_INTERVAL_S = 0.5, 4.0
"""Seconds of stepping (pauses not counted) between trials of the way of running a split's calls not in use
(:class:`ModeChooser`): the first, and the longest, to which each trial alone that keeps the split doubles it."""
PROBE_CALLS = 16
"""Calls timed in each way for a comparison: the trial's, and the latest ones of the way in use."""
PROBE_MARGIN = 0.85
"""A trial alone is kept where its median call time is below this fraction of the split's (a trial of the split,
where below the time alone: the split is the way to expect on an idle machine)."""
PAUSE = 10.0
"""An interval this many times the way in use's median is a pause of the caller's (between bursts of steps, say):
not timed, and not counted as stepping."""
SOLO_SETTLE_S = 1e-3
"""Seconds after a change to running in the calling thread alone not timed: the helpers spin after the last job
posted (``SPIN_S``)."""
SPLIT_SETTLE_S = 2e-6 * MAX_NAP_US
"""Seconds after a change to running over threads not timed: twice the longest nap a helper may be in then."""

_TICKET, _FINISHED, _FAILED, _STOP, _KIND, _CUT = (8 * k for k in range(6))
"""Slots of the control array (int64), each in a 64-byte cache line of its own: the ticket ``job << 32 | chunk``,
the next chunk of the current job to take; how many of its chunks are finished; whether a helper's kernel raised;
whether the helpers are to stop (after the chunk they hold); which of the split's calls the current job runs (0 the
first, 1 the second); the rows of the current job's first chunk, the others sharing the rest evenly (0: every chunk
an even share)."""
_SLOTS = _CUT + 8
_CHUNK_MASK = (1 << 32) - 1
_JOB_MASK = (1 << 31) - 1
"""Job numbers wrap around at 2**31."""
FLAGGED = "flagged"
"""A call's mark (in place of True, see :data:`Call`) for a bool argument split by rows, of which each chunk passes
the kernel the indices, within the chunk, of its rows that are true (:func:`flagged_rows`): the rows whose episodes
restart, say."""
Call = tuple[Callable[..., Any], tuple[Any, ...], Sequence[bool | str]]
"""A call that a split makes besides its kernel's: ``(kernel, arguments, marks)``, each argument's mark true where it
is split by rows (or :data:`FLAGGED`), false where it is passed whole."""
_X86 = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686", "x86")


def _slot_pointer(context: Any, builder: Any, signature: Any, args: Any) -> Any:
    array_type = signature.args[0]
    array = context.make_array(array_type)(context, builder, args[0])
    return cgutils.get_item_pointer(context, builder, array_type, array, [args[1]])


@intrinsic
def _load_acquire(typingctx: Any, array: types.Array, index: types.Integer) -> tuple[Any, Callable[..., Any]]:
    """``array[index]`` (int64), read with acquire ordering."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.load_atomic(_slot_pointer(context, builder, signature, args), "acquire", 8)

    return types.int64(array, index), codegen


@intrinsic
def _store_release(
    typingctx: Any, array: types.Array, index: types.Integer, value: types.Integer
) -> tuple[Any, Callable[..., Any]]:
    """``array[index] = value`` (int64), written with release ordering."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        builder.store_atomic(args[2], _slot_pointer(context, builder, signature, args), "release", 8)
        return context.get_dummy_value()

    return types.void(array, index, types.int64), codegen


@intrinsic
def _compare_exchange(
    typingctx: Any, array: types.Array, index: types.Integer, expected: types.Integer, new: types.Integer
) -> tuple[Any, Callable[..., Any]]:
    """Atomically ``array[index] = new`` if it holds ``expected`` (int64); whether it did."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        pointer = _slot_pointer(context, builder, signature, args)
        return builder.extract_value(builder.cmpxchg(pointer, args[2], args[3], "acq_rel", "acquire"), 1)

    return types.boolean(array, index, types.int64, types.int64), codegen


@intrinsic
def _atomic_update(
    typingctx: Any, array: types.Array, index: types.Integer, value: types.Integer, operation: types.StringLiteral
) -> tuple[Any, Callable[..., Any]] | None:
    """Atomically ``array[index] = array[index] <operation> value`` (int64; ``operation`` ``"add"`` or ``"or"``),
    release ordering."""
    if not isinstance(operation, types.StringLiteral):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        pointer = _slot_pointer(context, builder, signature, args)
        builder.atomic_rmw(operation.literal_value, pointer, args[2], "release")
        return context.get_dummy_value()

    return types.void(array, index, types.int64, operation), codegen


@intrinsic
def _pause(typingctx: Any) -> tuple[Any, Callable[..., Any]]:
    """A spin-wait hint to the CPU (x86 ``pause``; nothing elsewhere)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        if _X86:
            function_type = ir.FunctionType(ir.VoidType(), [])
            builder.call(cgutils.get_or_insert_function(builder.module, function_type, "llvm.x86.sse2.pause"), [])
        return context.get_dummy_value()

    return types.void(), codegen


@intrinsic
def _usleep(typingctx: Any, address: types.Integer, microseconds: types.Integer) -> tuple[Any, Callable[..., Any]]:
    """``usleep(microseconds)``, the C function at ``address`` (passed in, so the compiled code caches)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        function_type = ir.FunctionType(ir.IntType(32), [ir.IntType(32)])
        function = builder.inttoptr(args[0], function_type.as_pointer())
        builder.call(function, [builder.trunc(args[1], ir.IntType(32))])
        return context.get_dummy_value()

    return types.void(types.intp, types.int64), codegen


@njit(cache=True, nogil=True, inline="always")
def _copy(source: np.ndarray, destination: np.ndarray) -> None:
    """``destination[...] = source`` for C-contiguous arrays of one shape, element by element: numba's slice
    assignment first copies a source that may overlap the destination (which it cannot rule out for arrays
    rebuilt from addresses), at twice the cost."""
    flat = destination.reshape(-1)
    for i, value in enumerate(source.reshape(-1)):
        flat[i] = value


@njit(cache=True, nogil=True)
def flagged_rows(mask: np.ndarray) -> np.ndarray:
    """The rows (int indices, ascending) where ``mask`` (bool, C-contiguous) is true. It reads the mask eight rows
    (an aligned word) at a time and looks into the words with a row set only: a step ends few episodes (1.1 us for
    30 of 8,192 rows, where a pass over every row took 3.1)."""
    n = len(mask)
    head = min((-mask.ctypes.data) % 8, n)  # the rows before the first word's boundary
    whole = head + (n - head) // 8 * 8
    words = mask[head:whole].view(np.uint64)
    flagged = 0
    for w in range(len(words)):
        flagged += words[w] != 0
    rows = np.empty(head + 8 * flagged + n - whole, np.intp)
    j = 0
    for i in range(head):  # branch-free: the next row overwrites it if not in mask
        rows[j] = i
        j += mask[i]
    if flagged:
        for w in range(len(words)):
            if words[w] != 0:
                for i in range(head + 8 * w, head + 8 * w + 8):
                    rows[j] = i
                    j += mask[i]
    for i in range(whole, n):
        rows[j] = i
        j += mask[i]
    return rows[:j]


def _caller_side(
    control: np.ndarray,
    table: np.ndarray,
    args: tuple[Any, ...],
    chunks: int,
    spin_rounds: int,
    naps: tuple[int, int, int],
    kind: int,
    solo: bool,
    wait: bool,
    layout: str,
    batch: str,
) -> bool:
    """Numba-only: the calling thread's side of one split call (see the overload)."""
    raise NotImplementedError("only callable inside numba-compiled code")


def _helper_side(
    table: np.ndarray, scalars: tuple[Any, ...], chunk: int, chunks: int, cut: int, layout: str, batch: str
) -> None:
    """Numba-only: a helper's run of one chunk (see the overload)."""
    raise NotImplementedError("only callable inside numba-compiled code")


def _fields(
    layout: types.StringLiteral, batch: types.StringLiteral
) -> tuple[list[tuple[str, int, bool]], list[tuple[Any, list[int], list[tuple[int, int]]]], set[int]]:
    """A job's arguments and calls from its ``layout`` and ``batch`` (:meth:`_Job.__init__`): each argument's
    ``(field, ndim, split by rows)`` (ndim 0 for a scalar), in the order of the job's argument tuple; each call
    in order as ``(kernel, its arguments' positions, its copies)``, each copy ``(source, destination)`` positions;
    and the positions of the :data:`FLAGGED` arguments. ``layout`` joins with ``";"`` each call's
    :func:`kernel_call.packed_layout` (of its arguments, then its copies' destinations); ``batch`` joins each
    call's marks: ``"b"`` for each argument split by rows, ``"r"`` for a flagged one, ``"-"`` for the others, then
    ``">"`` and the copies' sources (positions among the call's arguments), comma-separated."""
    fields: list[tuple[str, int, bool]] = []
    calls, flagged = [], set()
    for call_layout, marks in zip(layout.literal_value.split(";"), batch.literal_value.split(";"), strict=True):
        target, _, *call_fields = call_layout.split("|")
        flags, _, sources = marks.partition(">")
        module, name = target.split(":")
        kernel = getattr(__import__(module, fromlist=[name]), name)
        copied = [int(k) for k in sources.split(",")] if sources else []
        start, arity = len(fields), len(call_fields) - len(copied)
        fields += [
            (field, 0 if field == "s" else int(field.split(":")[1]), flag != "-")
            for field, flag in zip(call_fields, flags, strict=True)
        ]
        flagged.update(start + k for k, flag in enumerate(flags) if flag == "r")
        copies = [(start + source, start + arity + k) for k, source in enumerate(copied)]
        calls.append((kernel, list(range(start, start + arity)), copies))
    return fields, calls, flagged


def _compile(source: str, kernels: list[Any], **names: Any) -> Callable[..., Any]:
    namespace = {**{f"kernel_{j}": kernel for j, kernel in enumerate(kernels)}, "carray": carray, **names}
    exec(source, namespace)  # noqa: S102
    return namespace["generated"]


def _chunk_body(calls: list[tuple[Any, list[int], list[tuple[int, int]]]], argument: Callable[[int], str]) -> str:
    """One chunk's statements, on one line: each call in turn, then its copies; ``argument(k)`` is the code of
    argument ``k`` in the chunk."""
    return "; ".join(
        f"kernel_{j}({', '.join(map(argument, positions))})"
        + "".join(f"; _copy({argument(source)}, {argument(to)})" for source, to in copies)
        for j, (_, positions, copies) in enumerate(calls)
    )


_BOUNDS = (
    "lo, hi = (n * chunk // chunks, n * (chunk + 1) // chunks) if cut == 0 else (0, cut) if chunk == 0 else "
    "(cut + (n - cut) * (chunk - 1) // (chunks - 1), cut + (n - cut) * chunk // (chunks - 1))"
)
"""A chunk's rows ``lo:hi`` of ``n``: the first ``cut`` rows for the first chunk and even shares of the rest for the
others, or even shares of all where ``cut`` is 0."""


@overload(_caller_side)
def _caller_side_impl(control, table, args, chunks, spin_rounds, naps, kind, solo, wait, layout, batch):  # noqa: ANN001, ANN202
    """Write the arrays' addresses and shapes into ``table`` (``[address, *shape]`` per array), post a job of
    ``chunks`` chunks of the split's call ``kind`` (0 or 1), run the first, take the others until none is left,
    then wait for the helpers' chunks: ``spin_rounds`` rounds, then naps of ``naps[1]`` us (``usleep`` at address
    ``naps[0]``) between looks, unless not ``wait`` (then :func:`_finish` waits). With ``solo``, run every chunk in
    this thread instead and post nothing. The chunks' rows as ``_BOUNDS`` says, by the ``_CUT`` slot. Returns
    whether a helper's kernel raised."""
    if not (isinstance(layout, types.StringLiteral) and isinstance(batch, types.StringLiteral)):
        return None
    fields, calls, flagged = _fields(layout, batch)
    writes, position = [], 0
    for k, (_, ndim, _) in enumerate(fields):
        if ndim:
            writes.append(f"table[{position}] = args[{k}].ctypes.data")
            writes += [f"table[{position + 1 + d}] = args[{k}].shape[{d}]" for d in range(ndim)]
            position += 1 + ndim
    parts = {k: f"args[{k}][lo:hi]" if split else f"args[{k}]" for k, (_, _, split) in enumerate(fields)}
    chunk = _chunk_body(calls, lambda k: f"flagged_rows({parts[k]})" if k in flagged else parts[k])
    first = next(k for k, (_, _, split) in enumerate(fields) if split)
    source = f"""
def generated(control, table, args, chunks, spin_rounds, naps, kind, solo, wait, layout, batch):
    n = args[{first}].shape[0]
    cut = control[{_CUT}]
    if solo:
        for chunk in range(chunks):
            {_BOUNDS}
            {chunk}
        return False
    {"; ".join(writes)}
    control[{_KIND}] = kind
    control[{_FINISHED}] = 0
    _store_release(control, {_TICKET}, (((_load_acquire(control, {_TICKET}) >> 32) + 1) & {_JOB_MASK}) << 32 | 1)
    chunk = 0
    {_BOUNDS}
    {chunk}
    _atomic_update(control, {_FINISHED}, 1, "add")
    while True:
        ticket = _load_acquire(control, {_TICKET})
        chunk = ticket & {_CHUNK_MASK}
        if chunk >= chunks:
            break
        if _compare_exchange(control, {_TICKET}, ticket, ticket + 1):
            {_BOUNDS}
            {chunk}
            _atomic_update(control, {_FINISHED}, 1, "add")
    return _finish(control, chunks, spin_rounds, naps)[0] if wait else False
"""
    return _compile(
        source, [kernel for kernel, _, _ in calls], _store_release=_store_release, _load_acquire=_load_acquire,
        _compare_exchange=_compare_exchange, _atomic_update=_atomic_update, _copy=_copy, _finish=_finish,
        flagged_rows=flagged_rows,
    )  # fmt: skip


@overload(_helper_side)
def _helper_side_impl(table, scalars, chunk, chunks, cut, layout, batch):  # noqa: ANN001, ANN202
    """Run chunk ``chunk`` of ``chunks`` (its rows as ``_BOUNDS`` says, by ``cut``) on the arrays of ``table`` and
    ``scalars``."""
    if not (isinstance(layout, types.StringLiteral) and isinstance(batch, types.StringLiteral)):
        return None
    fields, calls, flagged = _fields(layout, batch)
    names, arrays, position, scalar = {}, [], 0, 0
    for k, (field, ndim, split) in enumerate(fields):
        if not ndim:
            arrays.append(f"scalars[{scalar}]")
            scalar += 1
            continue
        dtype, _, access = field.split(":")
        names[f"dtype_{k}"] = np.dtype(dtype).type
        shape = "".join(f"table[{position + 1 + d}], " for d in range(ndim))
        array = f"carray(_pointer(table[{position}]), ({shape}), dtype_{k})"
        array = array if access == "w" else f"_read_only({array})"
        arrays.append(f"{array}[lo:hi]" if split else array)
        position += 1 + ndim
    first = next(k for k, (_, _, split) in enumerate(fields) if split)
    rows_at = sum(1 + ndim for _, ndim, _ in fields[:first] if ndim) + 1  # the first batch array's row count
    source = f"""
def generated(table, scalars, chunk, chunks, cut, layout, batch):
    n = table[{rows_at}]
    {_BOUNDS}
    {"; ".join(f"a{k} = {array}" for k, array in enumerate(arrays))}
    {_chunk_body(calls, lambda k: f"flagged_rows(a{k})" if k in flagged else f"a{k}")}
"""
    return _compile(
        source,
        [kernel for kernel, _, _ in calls],
        _pointer=kernel_call._pointer,
        _read_only=kernel_call._read_only,
        _copy=_copy,
        flagged_rows=flagged_rows,
        **names,
    )


@njit(cache=True, nogil=True)
def _split_call(
    control: np.ndarray,
    table: np.ndarray,
    args: tuple[Any, ...],
    chunks: int,
    spin_rounds: int,
    naps: tuple[int, int, int],
    kind: int,
    solo: bool,
    wait: bool,
    layout: str,
    batch: str,
) -> bool:
    return _caller_side(
        control, table, args, chunks, spin_rounds, naps, kind, solo, wait, literally(layout), literally(batch)
    )


@njit(cache=True, nogil=True)
def _finish(control: np.ndarray, chunks: int, spin_rounds: int, naps: tuple[int, int, int]) -> tuple[bool, bool]:
    """Wait for the helpers' chunks of the job posted (by a call that did not ``wait``), as the calling side waits:
    whether a helper's kernel raised, and whether every chunk was done already."""
    done = _load_acquire(control, _FINISHED) == chunks
    rounds = 0
    while _load_acquire(control, _FINISHED) != chunks:
        if _load_acquire(control, _FAILED) != 0:
            return True, done
        rounds += 1
        if rounds < spin_rounds:
            _pause()
        else:  # the helper holding the chunk may need this core
            _usleep(naps[0], naps[1])
    return False, done


@njit(cache=True, nogil=True, inline="always")
def _idle_round(
    job: int, seen: int, idle: int, nap: int, spin_rounds: int, naps: tuple[int, int, int]
) -> tuple[int, int, int, int]:
    """A helper's round with no chunk to take, the current job numbered ``job``: ``(seen, idle, nap, sleep)`` after
    it, from the job ``seen`` last, the ``idle`` rounds since and the ``nap`` (us) due. It spins (``sleep`` 0: a
    ``pause``) for ``spin_rounds`` rounds, then naps ``sleep`` us, ``naps[1]`` doubling up to ``naps[2]``. A job
    posted since it last looked, even one whose chunks the calling thread took while it napped, starts the spin
    again: in a loop of steps the next job likely comes as soon, and naps that kept doubling would miss it."""
    if job != seen:
        return job, 1, naps[1], 0
    if idle < spin_rounds:
        return seen, idle + 1, nap, 0
    return seen, idle, min(2 * nap, naps[2]), nap


@njit(cache=True, nogil=True)
def _serve(
    control: np.ndarray,
    tables: tuple[np.ndarray, np.ndarray],
    scalars: tuple[Any, ...],
    second_scalars: tuple[Any, ...],
    chunks: int,
    spin_rounds: int,
    naps: tuple[int, int, int],
    layout: str,
    batch: str,
    second_layout: str,
    second_batch: str,
) -> None:
    """A helper's loop until its ``_STOP`` slot is set: take chunks of the jobs posted in ``control`` and run them,
    by the first call's ``tables[0]``, ``scalars``, ``layout`` and ``batch``, or where the ``_KIND`` slot says so
    the second's; between them, spin and nap as :func:`_idle_round` says (``naps[0]`` is the address of
    ``usleep``)."""
    seen, idle, nap = _load_acquire(control, _TICKET) >> 32, 0, naps[1]
    while _load_acquire(control, _STOP) == 0:
        ticket = _load_acquire(control, _TICKET)
        chunk = ticket & _CHUNK_MASK
        if chunk < chunks:
            if _compare_exchange(control, _TICKET, ticket, ticket + 1):  # the job's kind was stored before its ticket
                cut = control[_CUT]
                if control[_KIND] == 0:
                    _helper_side(tables[0], scalars, chunk, chunks, cut, literally(layout), literally(batch))
                else:
                    _helper_side(
                        tables[1], second_scalars, chunk, chunks, cut, literally(second_layout), literally(second_batch)
                    )
                _atomic_update(control, _FINISHED, 1, "add")
                seen, idle, nap = ticket >> 32, 0, naps[1]
            continue
        seen, idle, nap, sleep = _idle_round(ticket >> 32, seen, idle, nap, spin_rounds, naps)
        if sleep:
            _usleep(naps[0], sleep)
        else:
            _pause()


def _compiled(dispatcher: Any, signature: tuple[Any, ...]) -> Callable[..., Any] | None:
    """The entry point of ``dispatcher`` compiled for ``signature`` (cached on disk), or None where numba's cache
    gave code saved for another literal layout (see :func:`kernel_call.bind_kernel`)."""
    if signature not in dispatcher.overloads:
        with kernel_call._compile_lock():
            dispatcher.compile(signature)
    compiled = dispatcher.overloads.get(signature)
    return None if compiled is None else compiled.entry_point


def _marks(batch: Sequence[bool | str], copies: Sequence[int] = ()) -> str:
    """A call's marks in a job's ``batch`` literal (:func:`_fields`)."""
    marks = ("r" if split == FLAGGED else "b" if split else "-" for split in batch)
    return "".join(marks) + ">" + ",".join(map(str, copies))


class _Job:
    """One job that a split runs over chunks: its ``calls`` made in turn on each chunk, each ``(kernel, arguments,
    marks)`` (marks as in :func:`_fields`), of which the call ``main`` names the job (:meth:`fits`); their packed
    layout and scalars, the ``batch`` literal, the table of their arrays' addresses and shapes and the calling
    thread's compiled side. The job's argument tuple is the calls' arguments, one call's after another's."""

    def __init__(
        self, calls: Sequence[tuple[Callable[..., Any], tuple[Any, ...], str]], main: int, control: np.ndarray,
        naps: tuple,
    ) -> None:  # fmt: skip
        layouts, scalars = [], []
        for kernel, call_args, _ in calls:
            packed = kernel_call.packed_layout(kernel, call_args)
            if packed is None:
                raise ValueError(f"{kernel!r} cannot be split over these arguments")
            layouts.append(packed[0])
            scalars += packed[1]
        args = tuple(arg for _, call_args, _ in calls for arg in call_args)
        self.kernel = calls[main][0]
        self.layout, self.batch = ";".join(layouts), ";".join(marks for _, _, marks in calls)
        self.scalars = tuple(scalars)
        self.fingerprint, self._scalars_text = compute_fingerprint(args), repr(self.scalars)
        self._scalar_positions = tuple(k for k, arg in enumerate(args) if not isinstance(arg, np.ndarray))
        self.table = np.zeros(sum(1 + arg.ndim for arg in args if isinstance(arg, np.ndarray)), np.intp)
        typeof = _split_call.typeof_pyval
        self.call = _compiled(
            _split_call,
            (
                typeof(control), typeof(self.table), typeof(args), types.intp, types.intp, typeof(naps), types.intp,
                types.boolean, types.boolean, types.literal(self.layout), types.literal(self.batch),
            ),
        )  # fmt: skip
        if self.call is None:
            raise ValueError(f"{self.kernel!r} cannot be split: numba's cache has no code for its layout")

    def fits(self, kernel: Callable[..., Any], args: tuple[Any, ...]) -> bool:
        """Whether this job, named by ``kernel``, makes its calls on ``args`` (see :meth:`SplitKernel.fits`): the
        scalars the very objects of its own (the helpers hold those), or of the same text."""
        if kernel is not self.kernel or compute_fingerprint(args) != self.fingerprint:
            return False
        scalars = tuple(args[k] for k in self._scalar_positions)
        return all(map(operator.is_, scalars, self.scalars)) or repr(scalars) == self._scalars_text


class ModeChooser:
    """Chooses, call by call, whether a split runs its chunks over its threads or all in the calling thread
    ("solo", the helpers left to nap), from the times between the starts of its first call's runs: each counts for
    the way the earlier run went, with what the calling thread did before the next (the rest of an env's step,
    which a helper spinning on a shared core slows).

    It starts split. After ``PROBE_INTERVAL_S`` seconds of stepping it tries the other way for ``PROBE_CALLS`` timed
    calls and keeps to it where their median is below that of the latest ``PROBE_CALLS`` calls the way in use, times
    ``PROBE_MARGIN`` for a trial alone. A trial alone that keeps the split doubles the interval to the next, up to
    ``MAX_PROBE_INTERVAL_S``; otherwise it starts again from ``PROBE_INTERVAL_S``. After each change of way the
    calls of the first ``SOLO_SETTLE_S`` or ``SPLIT_SETTLE_S`` are not timed (the helpers still spin, or nap).
    Intervals of more than ``PAUSE`` times the way in use's median (the caller paused) count for nothing.

    On the 2-core VM this was measured on (at 04b4bf1, when ProjectileAdjust's restarts ran after its split step),
    8,192 ProjectileAdjust envs stepped 1.25x as fast as with the split always on beside a busy process, and 1.10x
    idle; SteerableWheel 0.97x and AircraftGusty 0.99x idle."""

    def __init__(self) -> None:
        self.solo = False
        """Whether calls run in the calling thread alone."""
        self._latest: list[float] = []
        """Times (s) between the latest calls the way in use, at most ``PROBE_CALLS``."""
        self._counted = 0
        """Calls of the way in use timed since the last trial."""
        self._typical = math.inf
        """The median of ``_latest`` when it was last full of fresh times (inf before)."""
        self._stepping = 0.0
        """Seconds of stepping the way in use since the last trial."""
        self._interval = PROBE_INTERVAL_S
        self._trial: list[float] | None = None
        """Times (s) between the trial's calls so far, None between trials."""
        self._settled = 0.0
        """When the helpers have settled into the way of the calls since the last change of way: calls that start
        sooner are not timed."""
        self._last: float | None = None
        """When the previous call started."""

    def choose(self, now: float) -> bool:
        """Whether a call starting at ``now`` (``time.perf_counter`` seconds) runs solo; the time since the
        previous call's start counts for the way that call ran."""
        last, self._last = self._last, now
        if last is None or last < self._settled:
            return self.solo
        if self._trial is not None:
            self._trial.append(now - last)
            if len(self._trial) == PROBE_CALLS:
                self._end_trial(now)
            return self.solo
        if now - last > PAUSE * self._typical:
            return self.solo
        self._latest.append(now - last)
        if len(self._latest) > PROBE_CALLS:
            del self._latest[0]
        self._counted += 1
        self._stepping += now - last
        if self._counted % PROBE_CALLS == 0:
            self._typical = statistics.median(self._latest)
            if self._stepping >= self._interval:
                self._trial = []
                self._change_way(now)
        return self.solo

    def _change_way(self, now: float) -> None:
        self.solo = not self.solo
        self._settled = now + (SOLO_SETTLE_S if self.solo else SPLIT_SETTLE_S)

    def _end_trial(self, now: float) -> None:
        """Keep the trial's way or go back, and set the interval to the next trial."""
        trial = statistics.median(self._trial)
        if trial < (PROBE_MARGIN if self.solo else 1.0) * self._typical:
            self._latest, self._typical, self._interval = self._trial, trial, PROBE_INTERVAL_S
        else:
            self._change_way(now)
            self._interval = PROBE_INTERVAL_S if self.solo else min(2.0 * self._interval, MAX_PROBE_INTERVAL_S)
        self._trial, self._counted, self._stepping = None, 0, 0.0


class SplitKernel:
    """``kernel(*args)`` over chunks of rows, one per thread: the calling thread and ``helpers`` helper threads,
    for calls whose arguments have the types of ``args`` (:meth:`fits`). The ``batch`` arguments (true) are arrays
    with a row per episode on their first axis, all of the same length, split between the chunks; the others are
    passed whole to each chunk, which must only read them, and each row's results may depend on its own rows and
    those only. With ``copies``, the positions of batch arguments, the last ``len(copies)`` arguments are not the
    kernel's but arrays of the same dtypes and shapes, batch arguments too, into which each chunk copies its rows
    of those arguments after its kernel (by the thread that wrote them, while they are in its cache; ``TypeError``
    for copies of other arguments or into other arrays). ``before`` and the calls ``after``, each ``(kernel, args,
    batch)`` (:data:`Call`) whose batch arguments have the rows of ``kernel``'s, are made on each chunk before
    ``kernel`` and after it (and its copies), in turn: the split's calls then take ``(*before_args, *args,
    *after_args...)``. Their :data:`FLAGGED` arguments, bool batch arrays, reach the kernel as the indices of the
    chunk's rows set in them, in the chunk's arrays (:func:`flagged_rows`). With ``second``, a call
    ``(kernel, args, batch)`` that the same helpers run too (``job=1``): its batch arguments, all of one length,
    are split by their first axis in the same way, but the others may have as many rows (row indices split between
    chunks that write those rows of whole arrays, say); each chunk must write what no other chunk writes or reads.
    A second call that cannot be split is left out (no call fits ``job=1``). Both jobs run over the threads or all
    in the calling thread, as :attr:`chooser` decides from the first's times. :meth:`close` (or dropping it) stops
    the helpers. ``ValueError`` where the kernel cannot be split (then call it unsplit): not a kernel numba caches
    on disk, arguments the shim cannot take, a whole argument with as many rows as the batch ones (a row array
    that is not marked), no ``usleep``, or no thread to be had."""

    def __init__(
        self,
        kernel: Callable[..., Any],
        args: tuple[Any, ...],
        batch: Sequence[bool],
        helpers: int,
        copies: Sequence[int] = (),
        second: Call | None = None,
        before: Call | None = None,
        after: Sequence[Call] = (),
    ) -> None:
        around = [*([] if before is None else [before]), *after]
        marked = [(args, batch), *((call_args, call_batch) for _, call_args, call_batch in around)]
        pairs = [pair for call_args, call_batch in marked for pair in zip(call_args, call_batch, strict=True)]
        rows = {len(arg) for arg, split in pairs if split}
        whole = [arg for arg, split in pairs if isinstance(arg, np.ndarray) and not split]
        if compute_fingerprint is None or not _USLEEP or len(rows) != 1 or helpers < 1:
            raise ValueError(f"{kernel!r} cannot be split over these arguments on this platform")
        if any(arg.shape[0] in rows for arg in whole):
            raise ValueError(f"{kernel!r} cannot be split: a whole argument has as many rows as the split ones")
        self.arity = len(args) - len(copies)
        """The kernel's argument count."""
        for k, source in enumerate(copies):
            copy = args[self.arity + k]
            if not (0 <= source < self.arity and batch[source]):
                raise TypeError(f"copies={tuple(copies)!r}: argument {source} is not a batch argument of the kernel")
            if not (
                batch[self.arity + k]
                and copy.flags.writeable
                and (copy.dtype, copy.shape) == (args[source].dtype, args[source].shape)
            ):
                raise TypeError(
                    f"copies={tuple(copies)!r}: argument {self.arity + k}, argument {source}'s copy, is not a "
                    "writeable batch array of its dtype and shape"
                )
        self.kernel, self.chunks, self.copies = kernel, helpers + 1, tuple(copies)
        (rows_count,) = rows
        self._cuts = (rows_count // (2 * self.chunks), 3 * rows_count // (2 * self.chunks), max(1, rows_count // 512))
        """The fewest and most rows of the first job's first chunk, and the step by which :meth:`__call__` moves it."""
        self.cut = rows_count // self.chunks
        """Rows of the first job's first chunk, the calling thread's: an even share, until calls with ``then``
        move it (:meth:`__call__`)."""
        self.pid = os.getpid()
        self.control = _aligned_zeros(_SLOTS)
        self.control[_TICKET] = self.chunks  # job 0, every chunk taken: nothing to do until the first call
        self._naps = (_USLEEP, MIN_NAP_US, MAX_NAP_US)
        self._spin_rounds = spin_rounds()
        self.chooser = ModeChooser()
        """Whether calls run over the threads or in the calling thread alone, chosen from the first call's
        times."""
        calls = [(kernel, args, _marks(batch, copies))]
        if before is not None:
            calls.insert(0, (before[0], before[1], _marks(before[2])))
        calls += [(call[0], call[1], _marks(call[2])) for call in after]
        self.jobs = [_Job(calls, int(before is not None), self.control, self._naps)]
        """The jobs this split runs: ``kernel``'s (with ``before`` and ``after``), and ``second``'s if given."""
        second_rows = second is not None and {len(a) for a, split in zip(*second[1:], strict=True) if split}
        if second_rows and len(second_rows) == 1:
            with contextlib.suppress(ValueError):  # left out: that call runs unsplit (its job never fits)
                self.jobs.append(_Job([(second[0], second[1], _marks(second[2]))], 0, self.control, self._naps))
        first, last = self.jobs[0], self.jobs[-1]
        typeof = _split_call.typeof_pyval
        serve = _compiled(
            _serve,
            (
                typeof(self.control), typeof((first.table, last.table)), typeof(first.scalars),
                typeof(last.scalars), types.intp, types.intp, typeof(self._naps), types.literal(first.layout),
                types.literal(first.batch), types.literal(last.layout), types.literal(last.batch),
            ),
        )  # fmt: skip
        if serve is None:
            raise ValueError(f"{kernel!r} cannot be split: numba's cache has no code for its layout")
        self.errors: list[BaseException] = []
        self.done = False
        """Whether every chunk of the last call ran to its end, also where the call raised after them (an interrupt,
        or an error of ``then``)."""
        threads: list[threading.Thread] = []
        self.close = weakref.finalize(self, _stop, self.control, threads)
        """Stop the helpers (each after the chunk it holds; later calls run every chunk in the calling thread)."""
        serve_args = (
            self.control, (first.table, last.table), first.scalars, last.scalars, self.chunks, self._spin_rounds,
            self._naps, first.layout, first.batch, last.layout, last.batch,
        )  # fmt: skip
        try:
            for k in range(helpers):
                threads.append(
                    threading.Thread(
                        target=_help, args=(serve, serve_args, self.errors), name=f"vegym-helper-{k}", daemon=True
                    )
                )
                threads[-1].start()
        except RuntimeError as error:  # no thread to be had
            threads.pop()
            self.close()
            raise ValueError(f"{kernel!r} cannot be split: {error}") from error

    def fits(self, kernel: Callable[..., Any], args: tuple[Any, ...], job: int = 0) -> bool:
        """Whether this split makes the call ``kernel(*args)`` as its job ``job`` (0: the first call, with
        ``before``'s arguments ahead of ``args`` and ``after``'s behind where given; 1: the second): the same
        kernel, arguments of the same types (numba's fingerprint: dtype, dimensions, layout, writability), scalars
        of the same types and values, and this process (a forked child has none of its parent's helpers)."""
        return job < len(self.jobs) and self.jobs[job].fits(kernel, args) and self.pid == os.getpid()

    def __call__(self, args: tuple[Any, ...], job: int = 0, then: Callable[[], Any] | None = None) -> Any:
        """Its job ``job``'s calls over the chunks of ``args`` (which must :meth:`fit <fits>`); the kernels' results
        are not kept. With ``then``, the calling thread calls it after its own chunks and before it waits for the
        helpers' (it must not touch what they write), and returns its result; and after each such call of the first
        job the first chunk gains ``self._cuts[2]`` rows where the calling thread waited, or loses as many where
        the helpers were done first, within ``self._cuts[:2]``, so that its chunk and ``then`` take as long as a
        helper's chunk. A kernel's error is raised here: from the calling thread's chunk at once (a helper may
        still be running its chunk then, and chunks that no thread had taken are not run), from a helper's once the
        others are done; then the helpers stop, and later calls run in the calling thread. Either way the call is
        incomplete, as after an error in one thread. An interrupt (Ctrl-C) during the call is raised once the
        helpers' chunks are done too."""
        self.done = False
        target = self.jobs[job]
        solo = self.chooser.choose(time.perf_counter()) if job == 0 else self.chooser.solo
        control = self.control
        control[_CUT] = self.cut if job == 0 else 0
        try:
            failed = target.call(
                control, target.table, args, self.chunks, self._spin_rounds, self._naps, job, solo, then is None,
                target.layout, target.batch,
            )  # fmt: skip
        except Exception:  # the calling thread's chunk raised
            self.close()
            raise
        except BaseException:  # a Ctrl-C during the call, raised as it returned: wait for the helpers' chunks
            if then is not None and not solo:
                _finish(control, self.chunks, self._spin_rounds, self._naps)
            self.done = not self.errors
            raise
        if then is None or solo:
            self.done = not failed
            result = None if then is None else then()
        else:
            try:
                result = then()
            finally:  # the helpers' chunks are waited for whatever then() did
                failed, done = _finish(control, self.chunks, self._spin_rounds, self._naps)
                self.done = not failed
                if failed:
                    self.close()
                elif job == 0:
                    fewest, most, step = self._cuts
                    self.cut = min(max(self.cut - step if done else self.cut + step, fewest), most)
        if failed:
            self.close()
            raise self.errors[0]
        return result


@njit(cache=True, nogil=True)
def _spin(control: np.ndarray, rounds: int) -> int:
    """``rounds`` idle rounds as a helper spins through them: two acquire loads of ``control`` and a ``pause``."""
    seen = 0
    for _ in range(rounds):
        seen += _load_acquire(control, _STOP) + _load_acquire(control, _TICKET)
        _pause()
    return seen


@functools.cache
def spin_rounds() -> int:
    """The idle rounds that last ``SPIN_S`` on this CPU, timed once per process: the fastest of five runs of 4,096
    (a run the host interrupts looks slower; more rounds only spin longer). A ``pause`` takes 10-140 cycles across
    x86 generations: 26 ns on one host of the VM this was measured on and 9 ns on another, where the fixed 8,192
    rounds used before spun for 70 us, less than the Python between two steps of 8,192 envs, so that helpers napped
    and one step in ten waited for one to wake."""
    control = _aligned_zeros(_SLOTS)
    _spin(control, 1)
    fastest = math.inf
    for _ in range(5):
        start = time.perf_counter()
        _spin(control, 4096)
        fastest = min(fastest, time.perf_counter() - start)
    return max(1, math.ceil(SPIN_S * 4096 / max(fastest, 1e-6)))  # a coarse clock's 0: at most 0.8M rounds


def _aligned_zeros(count: int) -> np.ndarray:
    """``count`` int64 zeros starting on a 64-byte boundary (a cache line)."""
    padded = np.zeros(count + 8, np.int64)
    start = (-padded.ctypes.data % 64) // 8
    return padded[start : start + count]


def _help(serve: Callable[..., None], args: tuple[Any, ...], errors: list[BaseException]) -> None:
    """A helper thread: ``serve(*args)`` (:func:`_serve`, whose first argument is the control array) until stopped;
    a kernel's error goes into ``errors`` and the ``_FAILED`` slot."""
    try:
        serve(*args)
    except BaseException as error:  # noqa: BLE001  (handed to the calling thread, which raises it)
        errors.append(error)
        args[0][_FAILED] = 1


def _stop(control: np.ndarray, threads: list[threading.Thread]) -> None:
    """Stop and join the helpers of ``control``: each stops after the chunk it holds (a call in flight takes the
    chunks left) and within a nap (``MAX_NAP_US``)."""
    control[_STOP] = 1
    for thread in threads:
        if thread is not threading.current_thread():
            thread.join()

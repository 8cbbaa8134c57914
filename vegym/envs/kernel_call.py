"""A kernel call bound once to fixed arrays, for the single env's steps: numba's per-call argument handling left out.

Calling a numba kernel from Python costs about 40 ns per argument for the dispatcher's type matching and 60-90 ns
per array for unboxing it (a reference-counted wrapper made and released around every call); a single env's step
kernel takes 10-21 arrays, so that was 1-2 us of a 5-10 us step. :func:`bind_kernel` instead hands the compiled
code one table of the arrays' addresses and shapes, from which a generated shim rebuilds the arrays inside numba
(``numba.carray``) and calls the kernel. The shim is specialised on a literal string naming the kernel, numba's
stamp of its module's source and its argument layout, so numba caches it on disk like the kernels themselves, and
a changed kernel module gets a new one (a changed helper in another module does not, as with numba's own cache of
the kernel: clear ``__pycache__``). The bound function keeps the arrays alive.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib
import os
import tempfile
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numba import carray, literally, njit, types
from numba.core import cgutils
from numba.core.dispatcher import Dispatcher
from numba.core.extending import intrinsic, overload
from numba.core.imputils import impl_ret_borrowed


@intrinsic
def _read_only(typingctx: Any, array: types.Array) -> tuple[types.Signature, Callable[..., Any]]:
    """The same array typed read-only (the type a read-only numpy argument has: the kernel's compiled one)."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return impl_ret_borrowed(context, builder, signature.return_type, args[0])

    return array.copy(readonly=True)(array), codegen


@intrinsic
def _pointer(typingctx: Any, address: types.Type) -> tuple[types.Signature, Callable[..., Any]]:
    """The address (intp) as a ``void*``, for ``numba.carray``."""

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return types.voidptr(types.intp), codegen


def _call_with_layout(table: np.ndarray, scalars: tuple[Any, ...], layout: str) -> Any:
    """Numba-only: call the kernel that ``layout`` names with arrays rebuilt from ``table``."""
    raise NotImplementedError("only callable inside numba-compiled code")


@overload(_call_with_layout)
def _call_with_layout_impl(table, scalars, layout):  # noqa: ANN001, ANN202  (numba matches these names to the shim's)
    """The shim for one layout ``"module:kernel|source hash|field|..."``, a field being ``"s"`` (the next of
    ``scalars``) or ``"dtype:ndim:w"`` (the next array, ``r`` for read-only: its address, then its shape, in
    ``table``)."""
    if not isinstance(layout, types.StringLiteral):
        return None
    target, _, *fields = layout.literal_value.split("|")
    module, name = target.split(":")
    namespace = {
        "kernel": getattr(importlib.import_module(module), name),
        "carray": carray,
        "_pointer": _pointer,
        "_read_only": _read_only,
    }
    args, position, scalar = [], 0, 0
    for k, field in enumerate(fields):
        if field == "s":
            args.append(f"scalars[{scalar}]")
            scalar += 1
            continue
        dtype, ndim, access = field.split(":")
        namespace[f"dtype_{k}"] = np.dtype(dtype).type
        shape = "".join(f"table[{position + 1 + d}], " for d in range(int(ndim)))
        array = f"carray(_pointer(table[{position}]), ({shape}), dtype_{k})"
        args.append(array if access == "w" else f"_read_only({array})")
        position += 1 + int(ndim)
    exec(f"def shim(table, scalars, layout):\n    return kernel({', '.join(args)})\n", namespace)  # noqa: S102
    return namespace["shim"]


@njit(cache=True, nogil=True)
def _call_packed(table: np.ndarray, scalars: tuple[Any, ...], layout: str) -> Any:
    return _call_with_layout(table, scalars, literally(layout))


@functools.cache
def _kernel_name(kernel: Dispatcher) -> str | None:
    """``"module:name|source stamp"`` of a kernel importable by that name and cached by numba on disk, the stamp
    being a digest of numba's own (its hash of the module's source as imported: the code the shim links), else
    None."""
    module, name = kernel.py_func.__module__, kernel.py_func.__qualname__
    stamp = getattr(getattr(getattr(kernel, "_cache", None), "_cache_file", None), "_source_stamp", None)
    try:
        if stamp is None or getattr(importlib.import_module(module), name, None) is not kernel:
            return None
    except ImportError:
        return None
    return f"{module}:{name}|{hashlib.sha256(repr(stamp).encode()).hexdigest()[:16]}"


@contextlib.contextmanager
def _compile_lock() -> Iterator[None]:
    """Serialise compiling shims across processes: numba reads, changes and rewrites ``_call_packed``'s one cache
    index without a lock, so two processes saving different layouts at once could pair one layout with the other's
    code. A file lock where the platform has one (POSIX); elsewhere :func:`bind_kernel` still finds such code out
    (numba registers it under its own layout's signature), as it does when the lock file cannot be opened: another
    user's file of that name in a shared temporary directory, say, which made every single env's reset raise
    PermissionError."""
    try:
        import fcntl
    except ImportError:
        fcntl = None
    lock = None
    if fcntl is not None:
        user = os.getuid() if hasattr(os, "getuid") else 0
        with contextlib.suppress(OSError):
            lock = open(os.path.join(tempfile.gettempdir(), f"vegym-kernel-call-{user}.lock"), "a")
    if lock is None:  # outside the except clauses: an error while compiling is not chained to theirs
        yield
        return
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


_SCALAR_RESULTS = (types.NoneType, types.Boolean, types.Integer, types.Float)
"""Kernel results the shim may return (an array would be a view of memory that the bound function owns)."""


def _packable(arg: Any) -> bool:
    """Whether the shim can take ``arg``: an array (C-contiguous, aligned, of native numbers), a number or a tuple
    of numbers."""
    if isinstance(arg, np.ndarray):
        flags = arg.flags
        return arg.ndim > 0 and flags.c_contiguous and flags.aligned and arg.dtype.isnative and arg.dtype.kind in "biuf"
    if isinstance(arg, tuple):
        return all(_packable(item) and not isinstance(item, np.ndarray) for item in arg)
    return isinstance(arg, bool | int | float | np.bool_ | np.integer | np.floating)


def packed_layout(kernel: Callable[..., Any], args: tuple[Any, ...]) -> tuple[str, tuple[Any, ...]] | None:
    """The shim's layout string for ``kernel(*args)`` and the scalars among ``args`` (the table holds the rest), or
    None where the shim cannot make the call: ``kernel`` is not a numba kernel cached on disk, or an argument is not
    a C-contiguous array, a number or a tuple of numbers."""
    name = _kernel_name(kernel) if isinstance(kernel, Dispatcher) else None
    if name is None or not all(_packable(arg) for arg in args):
        return None
    scalars, fields = [], []
    for arg in args:
        if isinstance(arg, np.ndarray):
            fields.append(f"{arg.dtype.name}:{arg.ndim}:{'w' if arg.flags.writeable else 'r'}")
        else:
            scalars.append(arg)
            fields.append("s")
    return "|".join([name, *fields]), tuple(scalars)


def bind_kernel(kernel: Callable[..., Any], args: tuple[Any, ...]) -> Callable[[], Any]:
    """``kernel(*args)`` as a function of no arguments, for arguments that stay the same objects with the same
    contents' types and shapes (a single env's own arrays): a numba kernel (a dispatcher) whose arguments are
    C-contiguous arrays, numbers and tuples of numbers is called through the packed shim (first use of a kernel
    layout: compiled, then cached), other calls as they are."""
    packed = packed_layout(kernel, args)
    if packed is None:
        return functools.partial(kernel, *args)
    layout, packed_scalars = packed
    addresses = [number for arg in args if isinstance(arg, np.ndarray) for number in (arg.ctypes.data, *arg.shape)]
    table = np.array(addresses, np.intp)
    signature = (_call_packed.typeof_pyval(table), _call_packed.typeof_pyval(packed_scalars), types.literal(layout))
    if signature not in _call_packed.overloads:
        with _compile_lock():
            _call_packed.compile(signature)
    # None: numba's cache gave code saved for another layout (registered under that layout's signature)
    overload = _call_packed.overloads.get(signature)
    if overload is None or not isinstance(overload.signature.return_type, _SCALAR_RESULTS):
        return functools.partial(kernel, *args)
    bound = functools.partial(overload.entry_point, table, packed_scalars, layout)
    bound.arrays = args  # type: ignore[attr-defined]  # the table holds their addresses: keep them alive
    return bound

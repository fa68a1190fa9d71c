"""Numba kernels compiled at their first call, so that importing the core does not import numba.

An FLS in a process of its own imports the core's models but runs few of its
kernels, and numba alone is 60 MB and 0.2 s of a process (BENCHMARKS.md).
:func:`kernel` wraps a function in a :class:`Kernel`, which compiles it with
``numba.njit`` at its first call (from numba's cache on disk after the first
run) and keeps the compiled function on itself; a kernel that calls another
is compiled against the other's compiled function, so it calls it compiled.
Kernel bodies and callers reach numba's own names through this module
(``jit.prange``, ``jit.get_num_threads()``), which imports numba when one
is first used.

A process started with ``NUMBA_DISABLE_JIT=1`` in its environment (numba's
own switch, read once here, at import) runs its kernels as plain Python and
never imports numba: the ``fls`` program does (scripts/nodes/fls,
app/per_fls.py), as an FLS relaxes a few labels a round, where numba's import
and compiled code cost 100 MB (BENCHMARKS.md).
"""

from __future__ import annotations

import functools
import importlib
import os
import types
from collections.abc import Callable
from typing import Any, Generic, ParamSpec, TypeVar

Params = ParamSpec("Params")
Result = TypeVar("Result")

#: Whether this process runs its kernels as Python (NUMBA_DISABLE_JIT, as numba reads it).
INTERPRET = os.environ.get("NUMBA_DISABLE_JIT", "0").strip() not in ("", "0")


class Kernel(Generic[Params, Result]):
    """A function that ``numba.njit(**options)`` compiles at its first call."""

    def __init__(self, function: Callable[Params, Result], options: dict[str, Any]) -> None:
        functools.update_wrapper(self, function)
        self.function = function
        self.options = options
        # The module files of the kernels it calls, however deep (known once compiled).
        self.sources: tuple[str, ...] = ()
        self._compiled: Callable[Params, Result] | None = None

    def compiled(self) -> Callable[Params, Result]:
        """The compiled function (the plain one, interpreted), made at the first ask."""
        if self._compiled is None:
            resolved = _with_kernels_resolved(self.function, self)
            self.sources = getattr(resolved, "_kernel_sources", ())
            if INTERPRET:
                self._compiled = resolved
            else:
                numba = importlib.import_module("numba")
                _stamp_caches_with_callees(numba)
                self._compiled = numba.njit(**self.options)(resolved)
        return self._compiled

    def __call__(self, *args: Params.args, **kwargs: Params.kwargs) -> Result:
        compiled = self._compiled
        if compiled is None:
            compiled = self.compiled()
        return compiled(*args, **kwargs)


def kernel(
    **options: Any,
) -> Callable[[Callable[Params, Result]], Kernel[Params, Result]]:
    """``numba.njit(**options)``, applied at the kernel's first call.

    One source may make several kernels with different options:
    ``kernel(parallel=True)(function)``.

    Parameters
    ----------
    **options
        ``numba.njit``'s options (``cache``, ``parallel``, ``nogil``, ...).

    Returns
    -------
    callable
        A decorator that wraps a function in a :class:`Kernel`.
    """

    def decorate(function: Callable[Params, Result]) -> Kernel[Params, Result]:
        return Kernel(function, options)

    return decorate


#: numba's threading layers that parallel kernels may be started from several threads at
#: once on; its own ``workqueue`` ends the process when two threads start one together.
THREADSAFE_LAYERS = ("omp", "tbb")


def concurrent_kernels() -> bool:
    """Whether parallel kernels may run on several Python threads at once.

    Returns
    -------
    bool
        True when kernels are interpreted, or numba's threading layer, loaded
        by a parallel kernel already, is one of :data:`THREADSAFE_LAYERS`;
        False under ``workqueue`` or before any parallel kernel has run (the
        layer is not chosen yet, and may be ``workqueue``).
    """
    if INTERPRET:
        return True
    numba = importlib.import_module("numba")
    try:
        return numba.threading_layer() in THREADSAFE_LAYERS
    except ValueError:  # no parallel kernel has run: the layer is not loaded
        return False


def _with_kernels_resolved(function: Callable[..., Any], own: Kernel[Any, Any]) -> Any:
    """``function`` over a copy of its globals in which each other kernel is its compiled one.

    numba reads a kernel's callees from its globals at compilation; the
    module's own globals stay as they are. The code object is the same, so
    numba's cache on disk (keyed by file, line and bytecode) finds it.
    """
    namespace = dict(function.__globals__)
    sources: set[str] = set()
    for name in _names_read(function.__code__):
        value = namespace.get(name)
        if isinstance(value, Kernel) and value is not own:
            namespace[name] = value.compiled()
            sources |= {value.function.__code__.co_filename, *value.sources}
    copy = types.FunctionType(
        function.__code__,
        namespace,
        function.__name__,
        function.__defaults__,
        function.__closure__,
    )
    copy.__kwdefaults__ = function.__kwdefaults__
    copy.__qualname__ = function.__qualname__
    copy.__doc__ = function.__doc__
    # Read by kernel_cache's locators: the callees' code is compiled into this kernel's, and
    # one source may be compiled with other options into another kernel, cached apart.
    copy._kernel_sources = tuple(sorted(sources))  # type: ignore[attr-defined]
    copy._kernel_options = _options_tag(own.options)  # type: ignore[attr-defined]
    return copy


def _options_tag(options: dict[str, Any]) -> str:
    """:func:`.kernel_cache.options_tag`, without importing numba where kernels are Python."""
    if INTERPRET:
        return ""
    from . import kernel_cache

    return kernel_cache.options_tag(options)


def _stamp_caches_with_callees(numba: Any) -> None:
    """Have numba stamp our kernels' caches with their callees' sources too (kernel_cache)."""
    from . import kernel_cache

    config = numba.config
    if config.CACHE_LOCATOR_CLASSES.startswith(kernel_cache.LOCATORS[0]):
        return
    # numba's own locators after ours, or the ones the user named in its place.
    theirs = config.CACHE_LOCATOR_CLASSES or ",".join(_NUMBA_LOCATORS)
    config.CACHE_LOCATOR_CLASSES = ",".join((*kernel_cache.LOCATORS, theirs))


#: numba's own cache locators, in its order (numba.core.caching._CacheImpl).
_NUMBA_LOCATORS = (
    "UserProvidedCacheLocator",
    "InTreeCacheLocator",
    "UserWideCacheLocator",
    "IPythonCacheLocator",
    "ZipCacheLocator",
)


def _names_read(code: types.CodeType) -> set[str]:
    """The global names that ``code`` and the functions defined in it read."""
    names = set(code.co_names)
    for constant in code.co_consts:
        if isinstance(constant, types.CodeType):
            names |= _names_read(constant)
    return names


def __getattr__(name: str) -> Any:
    """numba's own names (prange, get_num_threads, ...), importing numba at first use.

    Interpreted, ``prange`` is ``range`` and ``get_num_threads()`` is 1.
    """
    if name.startswith("__"):
        raise AttributeError(name)
    if INTERPRET and name == "prange":
        return range
    if INTERPRET and name == "get_num_threads":
        return lambda: 1
    return getattr(importlib.import_module("numba"), name)

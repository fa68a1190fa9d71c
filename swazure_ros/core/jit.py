"""Numba kernels compiled at their first call, so that importing the core does not import numba.

An FLS in a process of its own imports the core's models but runs few of its
kernels, and numba alone is 60 MB and 0.2 s of a process (BENCHMARKS.md).
:func:`kernel` marks a function for ``numba.njit``; the first call of any
kernel of a module compiles every kernel of that module (from numba's cache
on disk after the first run) and puts the compiled ones in the module in
place of the markers, so a kernel that calls another calls it compiled.
Kernel bodies and callers reach numba's own names through this module
(``jit.prange``, ``jit.get_num_threads()``), which imports numba when one
is first used.
"""

from __future__ import annotations

import functools
import importlib
import sys
from collections.abc import Callable
from typing import Any, TypeVar

Function = TypeVar("Function", bound=Callable[..., Any])

#: Module name -> its kernels not compiled yet: (name, function, njit options).
_pending: dict[str, list[tuple[str, Callable[..., Any], dict[str, Any]]]] = {}
#: The process's choice (:func:`interpret`): run kernels as Python, never import numba.
_settings = {"interpret": False}


def interpret() -> None:
    """Run this process's kernels as plain Python from now on; numba is never imported.

    For a process whose kernels see little data: an FLS in its own process
    relaxes a few labels a round, where numba's import and compiled code cost
    100 MB (BENCHMARKS.md). Kernels compiled before the call stay compiled.
    """
    _settings["interpret"] = True


def kernel(name: str | None = None, **options: Any) -> Callable[[Function], Function]:
    """``numba.njit(**options)``, applied at the first call of a kernel of the module.

    ``name``: the module attribute the kernel is bound to, when not the
    function's own name (one source compiled twice, with different options).
    """

    def decorate(function: Function) -> Function:
        module, bound = function.__module__, name or function.__name__
        _pending.setdefault(module, []).append((bound, function, options))

        @functools.wraps(function)
        def first_call(*args: Any) -> Any:
            compile_module(module)
            return getattr(sys.modules[module], bound)(*args)

        first_call.lazy_module = module  # type: ignore[attr-defined]
        first_call.lazy_name = bound  # type: ignore[attr-defined]
        return first_call  # type: ignore[return-value]

    return decorate


def compile_module(module: str) -> None:
    """Compile every pending kernel of ``module`` and of the modules whose kernels it calls."""
    kernels = _pending.pop(module, [])
    if not kernels:
        return
    namespace = sys.modules[module].__dict__
    if _settings["interpret"]:
        for name, function, _ in kernels:
            namespace[name] = function
        return
    numba = importlib.import_module("numba")
    for _, function, _ in kernels:
        for name, value in list(function.__globals__.items()):
            other = getattr(value, "lazy_module", None)
            if other is not None and other != module:
                compile_module(other)
                namespace[name] = getattr(sys.modules[other], value.lazy_name)
    for name, function, options in kernels:
        namespace[name] = numba.njit(**options)(function)


def __getattr__(name: str) -> Any:
    """numba's own names (prange, get_num_threads, ...), importing numba at first use.

    Interpreted, ``prange`` is ``range`` and ``get_num_threads()`` is 1.
    """
    if name.startswith("__"):
        raise AttributeError(name)
    if _settings["interpret"] and name == "prange":
        return range
    if _settings["interpret"] and name == "get_num_threads":
        return lambda: 1
    return getattr(importlib.import_module("numba"), name)

"""numba's cache on disk, stamped with every source file a kernel's compiled code comes from.

numba stamps a cached kernel with its own module's source only. A kernel
compiled against a kernel of another module (:mod:`.jit` resolves callees to
their compiled functions) carries the callee's code inlined, so an edit of the
callee's module alone would leave the caller's cache valid and the old code
running: ``paths._search_kernel`` kept the search of ``search.py`` as it was
before an edit, silently. Here each kernel's stamp is its own module's content
and the content of every module whose kernels it calls, however deep, so an
edit of any of them compiles it again.

Imported by :mod:`.jit` when it first compiles (this module imports numba), and
named to numba by ``numba.config.CACHE_LOCATOR_CLASSES``; functions that are
not :class:`.jit.Kernel` bodies fall through to numba's own locators.
"""

from __future__ import annotations

import functools
import hashlib
import os
from typing import Any

from numba.core.caching import (
    InTreeCacheLocator,
    UserProvidedCacheLocator,
    UserWideCacheLocator,
)

#: The attribute :mod:`.jit` sets on a kernel body it compiles: the module files of every
#: kernel it calls, however deep.
SOURCES = "_kernel_sources"
#: And the kernel's ``numba.njit`` options, as :func:`options_tag` names them.
OPTIONS = "_kernel_options"


@functools.cache
def _digest(path: str, modified: int, size: int) -> str:
    """sha256 of a file's bytes; keyed by its time stamp and size, so an edit reads it again."""
    with open(path, "rb") as source:
        return hashlib.sha256(source.read()).hexdigest()


def source_stamp(paths: tuple[str, ...]) -> str:
    """One stamp for the contents of ``paths``: any edit of any of them changes it.

    Parameters
    ----------
    paths : tuple of str
        Source files.

    Returns
    -------
    str
        A sha256 over each path and its content's sha256, in sorted order.
    """
    stamp = hashlib.sha256()
    for path in sorted(set(paths)):
        status = os.stat(path)
        stamp.update(path.encode())
        stamp.update(_digest(path, status.st_mtime_ns, status.st_size).encode())
    return stamp.hexdigest()


def options_tag(options: dict[str, Any]) -> str:
    """A short name for a kernel's ``numba.njit`` options, ``cache`` aside.

    Parameters
    ----------
    options : dict
        The options (``parallel``, ``nogil``, ...).

    Returns
    -------
    str
        Eight hex digits of a sha256 over the sorted options; the same options, the
        same tag.
    """
    named = sorted((key, repr(value)) for key, value in options.items() if key != "cache")
    return hashlib.sha256(repr(named).encode()).hexdigest()[:8]


class _Stamped:
    """A locator mixin whose stamp covers the kernel's module and its callees' modules, and
    whose cache files are named for the kernel's options too.

    numba names a cache by the function's module, name and first line, and keys its
    entries by signature and bytecode, not by ``parallel`` or ``nogil``: one source made
    into a parallel and a serial kernel (``sight._obstructed_kernel`` and ``_serial``)
    shared one entry, and the kernel compiled second loaded the first one's code
    (numba issue 6845). Whichever a process ran first decided, for every later run,
    whether the parallel kernel ran on one core.
    """

    _py_file: str
    _sources: tuple[str, ...]
    _options: str

    def get_source_stamp(self) -> str:
        return source_stamp((self._py_file, *self._sources))

    def get_disambiguator(self) -> str:
        return f"{super().get_disambiguator()}-{self._options}"  # type: ignore[misc]

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> Any:
        if not hasattr(py_func, SOURCES):
            return None  # not a kernel body of ours: numba's own locators take it
        locator = super().from_function(py_func, py_file)  # type: ignore[misc]
        if locator is not None:
            locator._sources = tuple(getattr(py_func, SOURCES))
            locator._options = getattr(py_func, OPTIONS, "")
        return locator


class KernelCacheLocator(_Stamped, InTreeCacheLocator):
    """numba's cache in ``__pycache__`` beside the module, stamped as :func:`source_stamp`."""


class KernelCacheDirLocator(_Stamped, UserProvidedCacheLocator):
    """The same, in ``NUMBA_CACHE_DIR`` when the user names one (numba's order)."""


class KernelUserCacheLocator(_Stamped, UserWideCacheLocator):
    """The same, in the user's cache folder when the package's own is not writable."""


#: What ``numba.config.CACHE_LOCATOR_CLASSES`` names, before numba's own: the user's
#: cache folder first, as numba orders its own.
LOCATORS = (
    f"{__name__}.KernelCacheDirLocator",
    f"{__name__}.KernelCacheLocator",
    f"{__name__}.KernelUserCacheLocator",
)

"""Running a core function as a process that runs its kernels as Python does."""

from swazure_ros.core import jit


def interpreted(function, *args):
    """``function(*args)`` as a process that runs its kernels as Python (the fls program)
    does; the process's own mode is given back after."""
    was, jit.INTERPRET = jit.INTERPRET, True
    try:
        return function(*args)
    finally:
        jit.INTERPRET = was

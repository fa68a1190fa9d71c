"""Where a `swazure evaluate` run's time goes: start-up, kernels loaded, engine, writing.

Run as ``python -m bench.phases evaluate ARGS...``: runs the command in this
process and prints one JSON object of wall seconds per phase (the Speed
targets section of BENCHMARKS.md reads it). Phases:

- ``imports``: the interpreter's own start is outside (the caller's wall less
  the rest); this is importing the command line and the evaluate verb;
- ``kernels``: numba's first dispatch of each kernel, from its cache on disk
  (importing numba and its typing context on the first one);
- ``tables``: the pairs' pyarrow tables (pyarrow's import with the first);
- ``csv``: pairs.csv's text formatted and written, on the writer thread, so
  partly beside the engine;
- ``engine``: the rest of the run (the kernels' own work, numpy, the summary),
  less the CSV's seconds, part of which ran beside it: a lower bound;
- ``run``: the verb's wall, from its arguments to its exit.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import time
from collections.abc import Callable
from typing import Any

_INSIDE: dict[str, list[int]] = {}


def _timed(seconds: dict[str, float], phase: str, function: Callable[..., Any]) -> Any:
    """``function`` that adds its outermost calls' wall seconds to ``seconds[phase]``."""
    depth = _INSIDE.setdefault(phase, [0])

    def timed(*args: Any, **kwargs: Any) -> Any:
        depth[0] += 1
        began = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            depth[0] -= 1
            if depth[0] == 0:
                seconds[phase] += time.perf_counter() - began

    return timed


def measure(arguments: list[str]) -> dict[str, float]:
    """Run ``swazure`` with ``arguments`` here; wall seconds per phase."""
    seconds = dict.fromkeys(("imports", "kernels", "tables", "csv", "engine"), 0.0)
    began = time.perf_counter()
    from swazure_ros.cli import evaluate, main  # noqa: F401 (the verb's imports)

    seconds["imports"] = time.perf_counter() - began
    from swazure_ros.files import results

    began = time.perf_counter()
    import numba.core.dispatcher as dispatcher  # the run would import it at its first kernel

    seconds["kernels"] = time.perf_counter() - began
    dispatcher.Dispatcher.compile = _timed(seconds, "kernels", dispatcher.Dispatcher.compile)  # type: ignore[method-assign]
    results.pairs_table = _timed(seconds, "tables", results.pairs_table)
    results.write_csv = _timed(seconds, "csv", results.write_csv)
    began = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        code = main.main(arguments)
    if code != 0:
        raise SystemExit(f"bench.phases: swazure {' '.join(arguments)} exited {code}")
    run = time.perf_counter() - began
    seconds["engine"] = run - seconds["kernels"] - seconds["tables"] - seconds["csv"]
    seconds["run"] = run
    return seconds


if __name__ == "__main__":
    print(json.dumps(measure(sys.argv[1:])))

"""Every public function of swazure_ros.core has numpydoc sections, and its examples run."""

from __future__ import annotations

import doctest
import importlib
import inspect
import pkgutil
import types

import pytest

from swazure_ros import core
from swazure_ros.core import jit


def core_modules() -> list[types.ModuleType]:
    """Every module of the core, its packages' modules included."""
    names = [info.name for info in pkgutil.walk_packages(core.__path__, "swazure_ros.core.")]
    return [importlib.import_module(name) for name in sorted(set(names))]


def public_functions() -> dict[str, object]:
    """The public functions (compiled kernels included) defined in each core module."""
    found: dict[str, object] = {}
    for module in core_modules():
        for name, member in vars(module).items():
            routine = inspect.isfunction(member) or isinstance(member, jit.Kernel)
            if routine and not name.startswith("_") and member.__module__ == module.__name__:
                found[f"{module.__name__.removeprefix('swazure_ros.core.')}.{name}"] = member
    return found


def expected_sections(function: object) -> list[str]:
    """Parameters when it takes any, Returns when it returns something (numpydoc's rule;
    Yields for a generator), Raises when its own code raises."""
    plain = function.function if isinstance(function, jit.Kernel) else function
    signature = inspect.signature(plain)
    sections = ["Parameters"] if signature.parameters else []
    if inspect.isgeneratorfunction(plain):
        sections.append("Yields")
    elif signature.return_annotation not in ("None", None):
        sections.append("Returns")
    if "raise " in inspect.getsource(inspect.unwrap(plain)):
        sections.append("Raises")
    return sections


@pytest.mark.parametrize("name", sorted(public_functions()))
def test_a_public_function_has_the_numpydoc_sections(name):
    function = public_functions()[name]
    text = inspect.getdoc(function) or ""
    missing = [s for s in expected_sections(function) if f"{s}\n{'-' * len(s)}\n" not in text]
    assert missing == [], f"{name}: no {', '.join(missing)}"
    plain = function.function if isinstance(function, jit.Kernel) else function
    described = text.partition("\nParameters\n")[2].partition("\nReturns\n")[0]
    unnamed = [p for p in inspect.signature(plain).parameters if p not in described]
    assert unnamed == [], f"{name}: parameters not described: {', '.join(unnamed)}"


def test_the_core_has_public_functions_to_check():
    # A discovery that found nothing would pass every check above.
    assert len(public_functions()) > 100


# The modules a first-time user calls first: each shows how in examples that run.
WITH_EXAMPLES = {
    "clouds", "geometry", "sensor", "neighbours", "sight", "metrics", "fusion", "spacing",
    "swarm_fit", "swarm_edges", "conjugate_gradients", "circles", "segments",
    "heuristics.folding", "heuristics.obstructing", "heuristics.source",
}  # fmt: skip


@pytest.mark.parametrize("module", core_modules(), ids=lambda module: module.__name__)
def test_the_examples_of_a_core_module_run_as_written(module):
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    failed, tried = doctest.testmod(module, optionflags=flags)
    assert failed == 0
    if module.__name__.removeprefix("swazure_ros.core.") in WITH_EXAMPLES:
        assert tried > 0, f"{module.__name__} has no example"

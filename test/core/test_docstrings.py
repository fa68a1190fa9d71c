"""The numpydoc of the core's path, evaluation and fit modules: sections present, examples run."""

from __future__ import annotations

import doctest
import inspect
from types import ModuleType

import pytest

from swazure_ros.core import (
    evaluate,
    evaluation,
    fit,
    fit_measurements,
    graph,
    hops,
    jit,
    least_squares,
    neighbourhood,
    pair_fits,
    pair_statistics,
    path_arrays,
    paths,
    progress,
    search,
    window_fit,
)

#: The modules whose every public function documents its parameters, returns and errors.
DOCUMENTED: tuple[ModuleType, ...] = (
    graph,
    path_arrays,
    search,
    paths,
    progress,
    neighbourhood,
    hops,
    evaluation,
    pair_statistics,
    evaluate,
    least_squares,
    fit_measurements,
    window_fit,
    pair_fits,
    fit,
)


#: The record of evaluate_pairs from its parts: its example would take a whole evaluation's.
WITHOUT_EXAMPLE = (evaluate.pair_results,)


def public_functions(module: ModuleType) -> dict[str, object]:
    """The functions (numba kernels included) that ``module`` defines and names without ``_``."""
    return {
        name: member
        for name, member in vars(module).items()
        if not name.startswith("_")
        and callable(member)
        and not inspect.isclass(member)
        and getattr(member, "__module__", None) == module.__name__
    }


FUNCTIONS = {
    f"{module.__name__.rsplit('.', 1)[-1]}.{name}": function
    for module in DOCUMENTED
    for name, function in public_functions(module).items()
}


def sections_wanted(function: object) -> list[str]:
    """The numpydoc sections ``function``'s docstring needs, by what it takes, gives and raises."""
    signature = inspect.signature(function)  # type: ignore[arg-type]
    wanted = ["Parameters"] if signature.parameters else []
    wanted += ["Returns"] if signature.return_annotation not in ("None", None) else []
    wanted += ["Raises"] if "raise " in inspect.getsource(inspect.unwrap(function)) else []
    # A numba kernel is called by the other kernels alone: no example.
    example = not isinstance(function, jit.Kernel) and function not in WITHOUT_EXAMPLE
    return [*wanted, "Examples"] if example else wanted


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_a_public_function_documents_its_parameters_returns_and_errors(name):
    function = FUNCTIONS[name]
    text = inspect.getdoc(function) or ""
    missing = [section for section in sections_wanted(function) if f"\n{section}\n---" not in text]
    assert missing == [], f"{name}: no {', '.join(missing)}"
    unnamed = [
        parameter
        for parameter in inspect.signature(function).parameters  # type: ignore[arg-type]
        if parameter not in text.partition("\nParameters\n")[2].partition("\nReturns\n")[0]
    ]
    assert unnamed == [], f"{name}: parameters not described: {', '.join(unnamed)}"


def test_the_modules_have_public_functions_to_check():
    assert len(FUNCTIONS) >= 20


@pytest.mark.parametrize("module", DOCUMENTED, ids=lambda module: module.__name__)
def test_the_examples_run_as_written(module):
    failed, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    examples = [
        name
        for name, one in public_functions(module).items()
        if "Examples" in sections_wanted(one)
    ]
    assert failed == 0 and (tried > 0 or not examples)

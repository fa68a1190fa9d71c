"""The numpydoc of the core's path, evaluation and fit modules: sections present, examples run."""

from __future__ import annotations

import doctest
import inspect
from types import ModuleType

import pytest

from swazure_ros.core import graph, path_arrays, paths, search

#: The modules whose every public function documents its parameters, returns and errors.
DOCUMENTED: tuple[ModuleType, ...] = (graph, path_arrays, paths, search)


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


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_a_public_function_documents_its_parameters_returns_and_errors(name):
    text = inspect.getdoc(FUNCTIONS[name]) or ""
    parameters = inspect.signature(FUNCTIONS[name]).parameters
    wanted = ["Parameters\n"] if parameters else []
    returns = inspect.signature(FUNCTIONS[name]).return_annotation not in ("None", None)
    wanted += ["Returns\n"] if returns else []
    raises = "raise " in inspect.getsource(inspect.unwrap(FUNCTIONS[name]))
    wanted += ["Raises\n"] if raises else []
    missing = [section.strip() for section in wanted if section not in text]
    assert missing == [], f"{name}: no {', '.join(missing)}"
    assert all(f"{parameter}" in text for parameter in parameters), f"{name}: a parameter unnamed"


def test_the_modules_have_public_functions_to_check():
    assert len(FUNCTIONS) >= len(DOCUMENTED)


@pytest.mark.parametrize("module", DOCUMENTED, ids=lambda module: module.__name__)
def test_the_examples_run_as_written(module):
    failed, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert failed == 0 and (tried > 0 or module is search)

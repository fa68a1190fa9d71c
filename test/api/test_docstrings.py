"""Every public function of swazure_ros.api has numpydoc sections, and its examples run."""

from __future__ import annotations

import doctest
import inspect

import pytest

from swazure_ros import api
from swazure_ros.api import client, engine

SECTIONS = ("Parameters\n", "Returns\n", "Raises\n", "Examples\n")


def public_functions():
    """The API's functions and the client's public methods, by name."""
    found = {
        name: getattr(api, name) for name in api.__all__ if inspect.isfunction(getattr(api, name))
    }
    for name, member in vars(api.SwarmClient).items():
        if inspect.isfunction(member) and not name.startswith("_") and name != "close":
            found[f"SwarmClient.{name}"] = member
    return found


@pytest.mark.parametrize("name", sorted(public_functions()))
def test_a_public_function_has_the_numpydoc_sections(name):
    text = inspect.getdoc(public_functions()[name]) or ""
    missing = [section.strip() for section in SECTIONS if section not in text]
    assert missing == [], f"{name}: no {', '.join(missing)}"


@pytest.mark.parametrize("module", [engine, client], ids=["engine", "client"])
def test_the_examples_of_the_engine_run_as_written(module):
    # The client's examples need a running swarm: marked to skip, they are only parsed.
    failed, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert failed == 0 and (tried > 0 or module is client)

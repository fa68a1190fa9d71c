"""ROS 2 message and service classes by their type names (``pkg/msg/Type``).

rosidl_runtime_py's ``get_message`` does this job in a full ROS install, but
it is not on PyPI, and a user's machine has only what requirements.lock
installs: the generated packages themselves are all the lookup needs.
"""

from __future__ import annotations

import importlib
from typing import Any

from ...core.errors import SwazureError

#: The kinds of interface a type name may name, as rosidl lays out their modules.
KINDS = ("msg", "srv", "action")


def message_class(type_name: str) -> Any:
    """The Python class of ``pkg/msg/Type`` (or ``pkg/srv/Type``; ``pkg/Type`` means a msg)."""
    parts = type_name.split("/")
    if len(parts) == 2:
        parts.insert(1, "msg")
    if len(parts) != 3 or parts[1] not in KINDS or not all(p.isidentifier() for p in parts):
        raise SwazureError(f"message type must be pkg/msg/Type, got {type_name!r}")
    package, kind, name = parts
    try:
        module = importlib.import_module(f"{package}.{kind}")
    except ImportError as err:
        raise SwazureError(
            f"unknown message type {type_name!r}: no interface package {package!r} here"
        ) from err
    found = getattr(module, name, None)
    if not isinstance(found, type):
        raise SwazureError(f"unknown message type {type_name!r}: {package} has no {kind} {name}")
    return found

"""The parameter overrides a process was started with, read without a node.

rcl parses a process's ``--ros-args`` (``-p name:=value``, ``--params-file``)
once, into its context's global arguments; every node of the process takes
its overrides from there: the sections of parameter files whose name
(``/**``, ``/swarm/coordinator``, ``/*/coordinator``) matches the node's name, as
remapped by ``-r __node:=`` and ``-r __ns:=``, and every ``-p``.
:func:`node_overrides` reads them from the same place
(``rcl_arguments_get_param_overrides``, ``rcl_remap_node_name``, by ctypes),
so that a program can learn its FLS id and its swarm before it makes its
first node. A node made only to read them would create the process's DDS
participant, and deleting it while peers are being discovered can deadlock
Fast DDS 2.14 (docs/swarm.md, "One process per FLS").
"""

from __future__ import annotations

import ctypes
import re
from typing import Any

from rclpy.context import Context


class _Allocator(ctypes.Structure):
    """rcutils_allocator_t, passed by value: four functions and their state."""

    _fields_ = [(name, ctypes.c_void_p) for name in ("allocate", "deallocate", "reallocate",
                                                      "zero_allocate", "state")]  # fmt: skip


class _Variant(ctypes.Structure):
    """rcl_variant_t: one parameter value, the member of its type set (rcl_yaml_param_parser)."""

    _fields_ = [
        ("bool_value", ctypes.POINTER(ctypes.c_bool)),
        ("integer_value", ctypes.POINTER(ctypes.c_int64)),
        ("double_value", ctypes.POINTER(ctypes.c_double)),
        ("string_value", ctypes.c_char_p),
        ("byte_array_value", ctypes.c_void_p),
        ("bool_array_value", ctypes.c_void_p),
        ("integer_array_value", ctypes.c_void_p),
        ("double_array_value", ctypes.c_void_p),
        ("string_array_value", ctypes.c_void_p),
    ]


class _NodeParams(ctypes.Structure):
    """rcl_node_params_t: the parameters of one node name (or pattern)."""

    _fields_ = [
        ("parameter_names", ctypes.POINTER(ctypes.c_char_p)),
        ("parameter_values", ctypes.POINTER(_Variant)),
        ("num_params", ctypes.c_size_t),
        ("capacity_params", ctypes.c_size_t),
    ]


class _Params(ctypes.Structure):
    """rcl_params_t: parameters by node name; the allocator's five pointers are not used here."""

    _fields_ = [
        ("node_names", ctypes.POINTER(ctypes.c_char_p)),
        ("params", ctypes.POINTER(_NodeParams)),
        ("num_nodes", ctypes.c_size_t),
        ("capacity_nodes", ctypes.c_size_t),
        ("allocator", ctypes.c_void_p * 5),
    ]


def _array(address: int, item: Any) -> list[Any]:
    """The values of an rcl array struct ``{item * values; size_t size;}`` at ``address``."""
    values = ctypes.cast(address, ctypes.POINTER(ctypes.POINTER(item))).contents
    size = ctypes.cast(address + ctypes.sizeof(ctypes.c_void_p), ctypes.POINTER(ctypes.c_size_t))
    return [values[index] for index in range(size.contents.value)]


def _value(variant: _Variant) -> Any:
    """The Python value of an rcl_variant_t (bytes arrays are not made by rcl's parser)."""
    if variant.bool_value:
        return bool(variant.bool_value[0])
    if variant.integer_value:
        return int(variant.integer_value[0])
    if variant.double_value:
        return float(variant.double_value[0])
    if variant.string_value is not None:
        return variant.string_value.decode()
    if variant.bool_array_value:
        return [bool(value) for value in _array(variant.bool_array_value, ctypes.c_bool)]
    if variant.integer_array_value:
        return [int(value) for value in _array(variant.integer_array_value, ctypes.c_int64)]
    if variant.double_array_value:
        return [float(value) for value in _array(variant.double_array_value, ctypes.c_double)]
    if variant.string_array_value:
        # rcutils_string_array_t is {size_t size; char ** data; ...}: size first.
        address = variant.string_array_value
        size = ctypes.cast(address, ctypes.POINTER(ctypes.c_size_t)).contents.value
        strings = ctypes.POINTER(ctypes.POINTER(ctypes.c_char_p))
        data = ctypes.cast(address + ctypes.sizeof(ctypes.c_size_t), strings).contents
        return [data[index].decode() for index in range(size)]
    raise ValueError("a parameter override of a type rcl does not parse (byte array)")


def _section_pattern(section: str) -> re.Pattern[str]:
    """The node names a parameter file's section name matches (``*``: one token, ``**``: any)."""
    name = section if section.startswith("/") else "/" + section
    tokens = re.split(r"(\*\*|\*)", name)
    wildcards = {"**": ".*", "*": "[^/]*"}
    return re.compile("".join(wildcards.get(token, re.escape(token)) for token in tokens))


class _Rcl:
    """The rcl functions this module calls, with their C signatures."""

    def __init__(self) -> None:
        # rclpy has loaded librcl and its YAML parser: these find the loaded copies.
        rcl = ctypes.CDLL("librcl.so")
        self.overrides = rcl.rcl_arguments_get_param_overrides
        self.overrides.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.POINTER(_Params))]
        self.overrides.restype = ctypes.c_int
        self.remap_name = rcl.rcl_remap_node_name
        self.remap_namespace = rcl.rcl_remap_node_namespace
        for remap in (self.remap_name, self.remap_namespace):
            remap.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_char_p, _Allocator,
                              ctypes.POINTER(ctypes.c_void_p)]  # fmt: skip
            remap.restype = ctypes.c_int
        allocator = ctypes.CDLL("librcutils.so").rcutils_get_default_allocator
        allocator.restype = _Allocator
        self.allocator = allocator()
        self.free = ctypes.CDLL(None).free  # rcutils' default allocator is malloc's
        self.free.argtypes = [ctypes.c_void_p]
        self.fini = ctypes.CDLL("librcl_yaml_param_parser.so").rcl_yaml_node_struct_fini
        self.fini.argtypes = [ctypes.POINTER(_Params)]
        self.fini.restype = None

    def remapped(self, remap: Any, arguments: int, name: str) -> str | None:
        """What ``remap`` (node name or namespace) makes of node ``name``; None: no rule."""
        output = ctypes.c_void_p()
        code = remap(None, arguments, name.encode(), self.allocator, ctypes.byref(output))
        if code != 0:
            raise RuntimeError(f"rcl could not remap node {name!r} (rcl code {code})")
        if not output.value:
            return None
        try:
            return ctypes.string_at(output.value).decode()
        finally:
            self.free(output)


def node_overrides(context: Context, name: str) -> dict[str, Any]:
    """The parameter overrides a node ``name`` in ``/`` of ``context`` would get, by name."""
    handle = context.handle
    if handle is None:
        raise RuntimeError("the context is not initialized")
    rcl = _Rcl()
    overrides = ctypes.POINTER(_Params)()
    with handle:
        # rcl_context_t's first member is its global rcl_arguments_t.
        arguments = handle.pointer  # type: ignore[attr-defined]
        node_name = rcl.remapped(rcl.remap_name, arguments, name) or name
        namespace = rcl.remapped(rcl.remap_namespace, arguments, name) or "/"
        code = rcl.overrides(ctypes.c_void_p(arguments), ctypes.byref(overrides))
    if code != 0:
        raise RuntimeError(f"rcl_arguments_get_param_overrides failed (rcl code {code})")
    if not overrides:
        return {}  # no parameter on the command line
    fully_qualified = namespace.rstrip("/") + "/" + node_name
    try:
        params = overrides.contents
        values: dict[str, Any] = {}
        # Sections in rcl's order, a later one's value over an earlier one's, as rclpy's nodes.
        for node_index in range(params.num_nodes):
            section = params.node_names[node_index].decode()
            if not _section_pattern(section).fullmatch(fully_qualified):
                continue
            node = params.params[node_index]
            for index in range(node.num_params):
                values[node.parameter_names[index].decode()] = _value(node.parameter_values[index])
        return values
    finally:
        rcl.fini(overrides)

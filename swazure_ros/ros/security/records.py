"""A flat message read from its CDR bytes into arrays, with what its tag covers.

A packed process hears thousands of small messages a second (a round's
offers, one per FLS of the other processes). rclpy makes a message object of
each, a Python object per field, and the tag's check then walks those
objects to write the bytes it covers (:func:`~.auth.content`).
:func:`record_parser` reads the same fields straight from the CDR bytes: a
primitive as a Python number, a string as text, a sequence of primitives as a
read-only numpy view of the bytes (no copy), and nested messages (a header's
stamp) as records of their own; and it writes the covered bytes in the same
pass, so that the guard checks the tag without a message object
(:meth:`~.guard.Guard.record_reader`). What a callback reads of a
record is what it would read of the message: a record has the message's
field names, and the arrays their values. :func:`record_writer` is the
other way: a message's fields, given by name, written as the CDR bytes that
:func:`~..plumbing.cdr.serialize` makes of the message, its tag made in the same pass.

Flat types only: fields of primitives, strings, arrays of primitives and
nested messages of those. Little-endian CDR only, as every process of a swarm
writes it (on these machines); any other bytes are refused in one line.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable, Mapping
from types import SimpleNamespace
from typing import Any, NamedTuple

import numpy as np

from ...core.errors import MessageError
from ..plumbing.cdr import ENCAPSULATION, LENGTH_BYTES, PRIMITIVE_BYTES, aligned
from ..plumbing.interfaces import message_class
from .auth import AUTH_FIELD, content_of

__all__ = ["Fields", "Record", "record_parser", "record_writer"]

#: The encapsulation header of plain little-endian CDR (XCDR1), options zero.
LITTLE_ENDIAN = b"\x00\x01"
#: struct codes (little-endian) and numpy types of the primitives, by ROS type name.
_CODES = {
    "boolean": "?", "octet": "B", "char": "B", "byte": "B", "uint8": "B", "int8": "b",
    "uint16": "H", "int16": "h", "uint32": "I", "int32": "i", "float": "f", "double": "d",
    "uint64": "Q", "int64": "q",
}  # fmt: skip
_DTYPES = {name: np.dtype("<" + code) for name, code in _CODES.items()}
#: An empty read-only array of each type, for empty sequences (most of a PathOffer's).
_EMPTY = {dtype: np.frombuffer(b"", dtype) for dtype in _DTYPES.values()}
_LENGTH = struct.Struct("<I")
#: Zero bytes of padding, by how many (at most 7, before an 8-byte value).
_PADDING = tuple(bytes(n) for n in range(8))


class Record(SimpleNamespace):
    """A message's fields by name, ``auth`` its tag and ``content`` the bytes the tag covers."""

    auth: bytes
    content: bytes


class _Step(NamedTuple):
    """One field in CDR order: where it goes in the record, and how it lies."""

    path: tuple[str, ...]  # the record's attribute, nested messages first
    kind: str  # "scalar", "string", "sequence" or "array"
    type_name: str  # the primitive's ROS type name ("" for strings)
    fixed: int  # a fixed array's length (0 otherwise)


@functools.cache
def _steps(kind: Any) -> tuple[_Step, ...]:
    """The :class:`_Step` of each field of message type ``kind``, nested ones inline."""
    steps: list[_Step] = []

    def walk(of: Any, prefix: tuple[str, ...]) -> None:
        for name, text in of.get_fields_and_field_types().items():
            path = (*prefix, name)
            if text.startswith("sequence<"):
                inner = text[len("sequence<") : -1].split(",")[0].strip()
                steps.append(_Step(path, "sequence", _primitive(inner, kind), 0))
            elif text.endswith("]"):
                inner, _, size = text[:-1].rpartition("[")
                steps.append(_Step(path, "array", _primitive(inner, kind), int(size)))
            elif text in _CODES:
                steps.append(_Step(path, "scalar", text, 0))
            elif text == "string" or text.startswith("string<"):
                steps.append(_Step(path, "string", "", 0))
            elif "/" in text:
                walk(message_class(text), path)
            else:
                raise MessageError(f"{kind.__name__}: no record of a field of type {text!r}")

    walk(kind, ())
    return tuple(steps)


def _primitive(name: str, kind: Any) -> str:
    if name not in _CODES:
        raise MessageError(f"{kind.__name__}: no record of an array of {name!r}")
    return name


class _Scalars(NamedTuple):
    """Primitives one after the other: by where the first lies modulo 8, one struct for all
    of them with CDR's padding, and its size (alignment goes to 8 bytes at most)."""

    by_residue: tuple[struct.Struct, ...]
    primitives: int  # how many in the run


class _Array(NamedTuple):
    """A string (``dtype`` None), or an array of primitives: its length first unless fixed."""

    dtype: np.dtype[Any] | None
    size: int  # bytes a value
    fixed: int  # a fixed array's length; -1: a sequence, its length in the bytes


def _scalars(type_names: list[str]) -> _Scalars:
    structs = []
    for residue in range(8):
        at, codes = residue, ["<"]
        for name in type_names:
            size = PRIMITIVE_BYTES[name]
            codes.append("x" * (aligned(at, size) - at) + _CODES[name])
            at = aligned(at, size) + size
        structs.append(struct.Struct("".join(codes)))
    return _Scalars(tuple(structs), len(type_names))


@functools.cache
def _program(kind: Any) -> tuple[tuple[_Scalars | _Array, ...], tuple[tuple[str, ...], ...]]:
    """How to read ``kind``: runs of primitives and arrays in CDR order, and the record's
    attribute of each value read (a run gives one value a primitive)."""
    steps = _steps(kind)
    if steps[-1:] != (_Step((AUTH_FIELD,), "sequence", "uint8", 0),):
        raise MessageError(f"{kind.__name__}: its last field is not {AUTH_FIELD} (uint8[])")
    program: list[_Scalars | _Array] = []
    paths: list[tuple[str, ...]] = []
    run: list[str] = []
    for step in steps:
        if step.kind == "scalar":
            run.append(step.type_name)
        else:
            if run:
                program.append(_scalars(run))
                run = []
            dtype = _DTYPES[step.type_name] if step.type_name else None
            size = PRIMITIVE_BYTES[step.type_name] if step.type_name else 1
            program.append(_Array(dtype, size, step.fixed if step.kind == "array" else -1))
        paths.append(step.path)
    if run:
        program.append(_scalars(run))
    return tuple(program), tuple(paths)


def record_parser(kind: type) -> Callable[[bytes], Record]:
    """A function of a message's CDR bytes: its :class:`Record`.

    Parameters
    ----------
    kind : type
        A flat ROS 2 message type whose last field is ``auth`` (``uint8[]``).

    Returns
    -------
    callable
        ``parse(data)``: the record of ``data``; MessageError when the bytes
        are not a little-endian CDR message of ``kind``.

    Raises
    ------
    MessageError
        ``kind`` has a field no record holds (a sequence of strings or of messages).
    """
    _program(kind)  # refused here, not at the first message, if no record holds it
    name = kind.__name__

    def parse(data: bytes) -> Record:
        if data[:2] != LITTLE_ENDIAN:
            raise MessageError(f"not a {name} in little-endian CDR")
        try:
            return _read(memoryview(data)[ENCAPSULATION:], kind)
        except (struct.error, ValueError, UnicodeDecodeError) as err:
            raise MessageError(f"CDR bytes end inside their {name}, or are not one") from err

    return parse


def _read(body: memoryview, kind: type) -> Record:
    """The record of a message of ``kind`` whose CDR (after the encapsulation) is ``body``."""
    program, paths = _program(kind)
    values: list[Any] = []
    scalars: list[Any] = []
    others: list[Any] = []  # bytes-like, each after its length (8 bytes) as the tag covers it
    at, end = 0, len(body)
    for part in program:
        if isinstance(part, _Scalars):
            unpack = part.by_residue[at % 8]
            read = unpack.unpack_from(body, at)
            at += unpack.size
            values += read
            scalars += read
            continue
        dtype, size, count = part
        if count < 0:  # a sequence or a string: its length first
            at += -at % LENGTH_BYTES
            (count,) = _LENGTH.unpack_from(body, at)
            at += LENGTH_BYTES
        if count and size > 1:  # Fast CDR aligns an array of primitives once, not when empty
            at += -at % size
        stop = at + count * size
        if stop > end:
            raise ValueError("an array or string past the end")
        raw: bytes | memoryview = body[at:stop]
        at = stop
        if dtype is None:
            # The wire ends a string at its first NUL: so do the message and the tag.
            raw = bytes(raw).partition(b"\0")[0]
            values.append(raw.decode("utf-8"))
        else:
            values.append(np.frombuffer(raw, dtype) if count else _EMPTY[dtype])
        others += (len(raw).to_bytes(8, "little"), raw)
    auth = bytes(others[-1])  # the last field, which the tag leaves out
    del others[-2:], values[-1]
    return _record(paths, values, auth, content_of(kind, scalars, others))


def _record(
    paths: tuple[tuple[str, ...], ...], values: list[Any], auth: bytes, content: bytes
) -> Record:
    """A Record of ``values``, each at its path: a nested message's fields on a record of its
    own (a header's stamp)."""
    record = Record(auth=auth, content=content)
    fields = record.__dict__
    for path, value in zip(paths, values, strict=False):
        if len(path) == 1:
            fields[path[0]] = value
            continue
        at = fields
        for name in path[:-1]:
            inner = at.get(name)
            if inner is None:
                inner = at[name] = SimpleNamespace()
            at = inner.__dict__
        at[path[-1]] = value
    return record


#: A writer's fields: values by field name, a nested message's as ``header.frame_id``.
Fields = Mapping[str, Any]


def record_writer(kind: type) -> Callable[[Fields, Callable[[bytes], bytes]], bytes]:
    """A function that writes a message of ``kind`` from its fields, signed: its CDR bytes.

    Parameters
    ----------
    kind : type
        A flat ROS 2 message type whose last field is ``auth`` (``uint8[]``).

    Returns
    -------
    callable
        ``write(fields, auth)``: the bytes :func:`~..plumbing.cdr.serialize` makes of the
        message whose fields are ``fields`` (a field not named is zero, empty
        or ""; arrays of any numeric type, cast to the field's), with ``auth``
        set to ``auth(covered)``, where ``covered`` is what its tag covers
        (:meth:`~.auth.SwarmKey.auth`).

    Raises
    ------
    MessageError
        ``kind`` has a field no record holds (a sequence of strings or of messages).
    """
    program, paths = _program(kind)
    names = [".".join(path) for path in paths]

    def write(fields: Fields, auth: Callable[[bytes], bytes]) -> bytes:
        return _write(kind, program, [fields.get(name) for name in names], auth)

    return write


def _write(
    kind: type,
    program: tuple[_Scalars | _Array, ...],
    values: list[Any],
    auth: Callable[[bytes], bytes],
) -> bytes:
    """The CDR bytes of a message of ``kind`` whose values (None: the default) are ``values``."""
    parts: list[bytes] = [LITTLE_ENDIAN, b"\0\0"]
    scalars: list[Any] = []
    others: list[bytes] = []
    at, next_value = 0, 0
    for part in program:
        if isinstance(part, _Scalars):
            pack = part.by_residue[at % 8]
            count = part.primitives
            run = [
                0 if value is None else value for value in values[next_value : next_value + count]
            ]
            next_value += count
            parts.append(pack.pack(*run))
            at += pack.size
            scalars += run
            continue
        value = values[next_value]
        next_value += 1
        if part.dtype is None:
            text = ("" if value is None else str(value)).encode("utf-8").partition(b"\0")[0]
            raw, written = text, text + b"\0"
        elif next_value == len(values):  # auth, the last field: made of what came before
            raw = written = auth(content_of(kind, scalars, others))
        elif value is None:
            raw = written = b""
        else:
            if not (isinstance(value, np.ndarray) and value.dtype == part.dtype):
                value = np.asarray(value, part.dtype)
            raw = written = value.tobytes()  # C order, whatever its strides
        length = len(written) // part.size
        if part.fixed < 0:  # a sequence or a string: its length first
            pad = -at % LENGTH_BYTES
            parts.append(_PADDING[pad] + _LENGTH.pack(length))
            at += pad + LENGTH_BYTES
        elif length != part.fixed:
            raise MessageError(f"{kind.__name__}: {length} values for an array of {part.fixed}")
        if length and part.size > 1:
            align = -at % part.size
            parts.append(_PADDING[align])
            at += align
        parts.append(written)
        at += len(written)
        others += (len(raw).to_bytes(8, "little"), raw)
    return b"".join(parts)

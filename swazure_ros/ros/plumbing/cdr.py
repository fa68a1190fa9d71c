"""A message's CDR bytes, exactly: what rclpy's serialize_message returns, less what it leaks.

rmw_fastrtps's ``rmw_serialize`` (what ``rclpy.serialization.serialize_message``
calls; Jazzy) sizes a fresh heap buffer by the type support's estimate of the
message's size, lets Fast CDR write the message into it, and reports the
estimate as the message's length. The estimate counts alignment padding for
an empty sequence of 8-byte values that Fast CDR never writes, so a
``PathOffer`` (whose optional ``float64[]`` fields are mostly empty) comes out
4 to 28 bytes longer than its last field; and Fast CDR steps over alignment
padding without writing it. Those bytes are whatever the heap held (pointers,
other messages' numbers, ``fls_`` of a frame id), and a publisher of the
bytes sends them on the wire; rosbags then refuses the message ("CDR message
size mismatch"). rmw_fastrtps's own path for a message object writes neither.

:func:`serialize` is ``serialize_message`` with the bytes after the last field
cut off and every padding byte zero: the message's CDR (XCDR1, plain), the
same bytes each time for the same message, and the length rmw_fastrtps sends
for a message object (no padding to a multiple of 4 at the end). It walks the
bytes by the type's field definitions; alignment counts from the end of the
4-byte encapsulation header, at most 8, as Fast CDR's XCDR1 does.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Literal

from rclpy.serialization import serialize_message

from ...core.errors import SwazureError
from .interfaces import message_class

__all__ = ["serialize"]

#: Bytes of the CDR encapsulation header (representation id, options) before the message.
ENCAPSULATION = 4
#: Bytes of each primitive field type, which are also its alignment in XCDR1.
PRIMITIVE_BYTES = {
    "boolean": 1, "octet": 1, "char": 1, "byte": 1, "uint8": 1, "int8": 1,
    "uint16": 2, "int16": 2, "uint32": 4, "int32": 4, "float": 4,
    "uint64": 8, "int64": 8, "double": 8,
}  # fmt: skip
#: A sequence's length and a string's length are uint32s.
LENGTH_BYTES = 4
#: The byte order of a CDR message, from its encapsulation header.
Order = Literal["little", "big"]
#: More zeros than any padding has (at most 7 bytes, before an 8-byte value).
_ZEROS = bytes(8)


@dataclass(frozen=True)
class _Field:
    """How one field lies in CDR: a primitive, a string or a nested message, alone or many.

    ``count`` is None for one value, -1 for a sequence (its length first),
    or a fixed array's length. ``size`` is a primitive's bytes (0 for a
    string), ``nested`` a message's fields.
    """

    size: int
    count: int | None
    nested: tuple[_Field, ...] | None = None


def serialize(message: Any) -> bytes:
    """``message``'s CDR bytes: serialize_message's, cut at the last field, padding zeroed.

    Parameters
    ----------
    message : a ROS 2 message object

    Returns
    -------
    bytes
        The encapsulation header and the message, the same bytes for the same message.
    """
    data = serialize_message(message)
    end, padding = _layout(data, type(message))
    exact = bytearray(memoryview(data)[:end])
    for start, stop in padding:
        exact[start:stop] = _ZEROS[: stop - start]
    return bytes(exact)


def _layout(data: bytes, kind: Any) -> tuple[int, list[tuple[int, int]]]:
    """(end, padding): the end of the message in ``data``, and its padding's (start, stop)s."""
    order: Order = "little" if data[1:2] == b"\x01" else "big"  # the representation id's low byte
    padding: list[tuple[int, int]] = []
    end = _walk(data, ENCAPSULATION, _fields(kind), order, padding)
    # The walk only moves on: a length read past the end leaves it past the end too.
    if end > len(data):
        raise SwazureError(f"CDR bytes end inside their {kind.__name__}")
    return end, padding


def _walk(
    data: bytes, at: int, fields: tuple[_Field, ...], order: Order, padding: list[tuple[int, int]]
) -> int:
    """The index after ``fields`` written from ``at`` in ``data``; padding noted on the way."""
    for field in fields:
        count = 1 if field.count is None else field.count
        if count < 0:
            at = _align(at, LENGTH_BYTES, padding)
            count = int.from_bytes(data[at : at + LENGTH_BYTES], order)
            at += LENGTH_BYTES
        if field.nested is not None:
            for _ in range(count):
                at = _walk(data, at, field.nested, order, padding)
        elif field.size == 0:  # strings, each its length (with its NUL) and its bytes
            for _ in range(count):
                at = _align(at, LENGTH_BYTES, padding)
                at += LENGTH_BYTES + int.from_bytes(data[at : at + LENGTH_BYTES], order)
        elif count:  # Fast CDR aligns an array of primitives once, and not when empty
            at = _align(at, field.size, padding) + count * field.size
    return at


def _align(at: int, size: int, padding: list[tuple[int, int]]) -> int:
    """``at`` moved on to the next multiple of ``size`` (at most 8) after the header."""
    skip = -(at - ENCAPSULATION) % (size if size < 8 else 8)
    if skip:
        padding.append((at, at + skip))
    return at + skip


@functools.cache
def _fields(kind: Any) -> tuple[_Field, ...]:
    """The :class:`_Field` of each field of message type ``kind``, in order."""
    fields: list[_Field] = []
    for text in kind.get_fields_and_field_types().values():
        field = _field(text, kind)
        if field.nested is not None and field.count is None:
            fields += field.nested  # one nested message lies as its fields would, inline
        else:
            fields.append(field)
    return tuple(fields)


def _field(text: str, kind: Any) -> _Field:
    """The :class:`_Field` of a field of type ``text`` (``sequence<double, 3>``, ``T[2]``)."""
    count: int | None = None
    if text.startswith("sequence<"):
        text, count = text[len("sequence<") : -1].split(",")[0].strip(), -1
    elif text.endswith("]"):
        text, _, size = text[:-1].rpartition("[")
        count = int(size)
    if text in PRIMITIVE_BYTES:
        return _Field(PRIMITIVE_BYTES[text], count)
    if text == "string" or text.startswith("string<"):
        return _Field(0, count)
    if "/" in text:
        return _Field(0, count, _fields(message_class(text)))
    # wstring and long double: written differently by different CDR writers; none of ours.
    raise SwazureError(f"{kind.__name__}: no exact CDR layout for a field of type {text!r}")

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
import struct
from typing import Any, NamedTuple

from rclpy.serialization import serialize_message

from ...core.errors import SwazureError
from .interfaces import message_class

__all__ = ["aligned", "serialize"]

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
#: A length in CDR of each byte order (the encapsulation header's).
_LENGTH = {"little": struct.Struct("<I"), "big": struct.Struct(">I")}
#: More zeros than any padding has (at most 7 bytes, before an 8-byte value).
_ZEROS = bytes(8)


class _Field(NamedTuple):
    """How one field lies in CDR: a primitive, a string or a nested message, alone or many.

    ``repeat`` is None for one value, -1 for a sequence (its length first),
    or a fixed array's length. ``size`` is a primitive's bytes (0 for a
    string), ``nested`` a message's fields.
    """

    size: int
    repeat: int | None
    nested: tuple[_Field, ...] | None = None


def aligned(at: int, size: int) -> int:
    """``at`` moved on to a multiple of ``size``: where a CDR value of ``size`` bytes starts."""
    return -(-at // size) * size


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
    kind: Any = type(message)
    # The message after its header, with positions counted from there as CDR aligns them.
    body = bytearray(memoryview(data)[ENCAPSULATION:])
    length = _LENGTH["little" if data[1:2] == b"\x01" else "big"]  # the header's byte order
    try:
        end = _walk(body, 0, _fields(kind), length)
    except struct.error as err:
        raise SwazureError(f"CDR bytes end inside their {kind.__name__}") from err
    # The walk only moves on: a length read past the end leaves it past the end too.
    if end > len(body):
        raise SwazureError(f"CDR bytes end inside their {kind.__name__}")
    del body[end:]
    return data[:ENCAPSULATION] + body


def _walk(body: bytearray, at: int, fields: tuple[_Field, ...], length: struct.Struct) -> int:
    """The index after ``fields`` written from ``at`` in ``body``, its padding zeroed."""
    for size, count, nested in fields:
        if count is None:
            count = 1
        elif count < 0:  # a sequence: its length first
            skip = -at % LENGTH_BYTES
            if skip:
                body[at : at + skip] = _ZEROS[:skip]
            (count,) = length.unpack_from(body, at + skip)
            at += skip + LENGTH_BYTES
        if nested is not None:
            for _ in range(count):
                at = _walk(body, at, nested, length)
        elif not size:  # strings, each its length (with its NUL) and its bytes
            for _ in range(count):
                skip = -at % LENGTH_BYTES
                if skip:
                    body[at : at + skip] = _ZEROS[:skip]
                at += skip
                at += LENGTH_BYTES + length.unpack_from(body, at)[0]
        elif count:  # Fast CDR aligns an array of primitives once, and not when empty
            skip = -at % size  # size is at most 8, CDR's largest alignment
            if skip:
                body[at : at + skip] = _ZEROS[:skip]
            at += skip + count * size
    return at


@functools.cache
def _fields(kind: Any) -> tuple[_Field, ...]:
    """The :class:`_Field` of each field of message type ``kind``, in order."""
    fields: list[_Field] = []
    for text in kind.get_fields_and_field_types().values():
        field = _field(text, kind)
        if field.nested is not None and field.repeat is None:
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

"""Hypothesis strategies of ROS messages of any type, built from the type's own field list.

Numbers come from the edges a hostile peer would try (0, the swarm's ids and
one past them, the type's largest value, NaN, infinities, 1e300) as well as
anywhere in range; sequences are short, so that lengths disagree often.
"""

from __future__ import annotations

from typing import Any

from hypothesis import strategies as st

from swazure_ros.ros.plumbing.interfaces import message_class

UNSIGNED = {"uint8": 8, "uint16": 16, "uint32": 32, "uint64": 64, "octet": 8, "char": 8}
SIGNED = {"int8": 8, "int16": 16, "int32": 32, "int64": 64}
FLOATS = ("float", "double")


def _unsigned(bits: int, ids: list[int]) -> st.SearchStrategy[int]:
    top = 2**bits - 1
    edges = sorted({value for value in (*ids, 0, 1, 2, 3, top, top - 1) if value <= top})
    return st.one_of(st.sampled_from(edges), st.integers(0, top))


def field(kind: str, ids: list[int]) -> st.SearchStrategy[Any]:
    """Values of a field of ROS type ``kind`` (as get_fields_and_field_types names it)."""
    if kind.startswith("sequence<"):
        inner = kind[len("sequence<") : -1].split(",")[0]
        return st.lists(field(inner, ids), max_size=7)
    if "[" in kind:  # fixed-size arrays: double[9] and the like
        inner, _, size = kind.partition("[")
        count = int(size.rstrip("]"))
        return st.lists(field(inner, ids), min_size=count, max_size=count)
    if kind in UNSIGNED:
        return _unsigned(UNSIGNED[kind], ids)
    if kind in SIGNED:
        bits = SIGNED[kind]
        return st.integers(-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
    if kind in FLOATS:
        edges = st.sampled_from([0.0, -0.0, 1.0, -1.0, 7.0, 1e300, -1e300, float("nan")])
        return st.one_of(edges, st.floats(allow_nan=True, allow_infinity=True, width=64))
    if kind == "boolean":
        return st.booleans()
    if kind.startswith("string"):
        return st.text(max_size=30)
    return message(message_class(kind), ids)


def message(cls: type, ids: list[int]) -> st.SearchStrategy[Any]:
    """Messages of type ``cls`` whose every field is drawn by :func:`field`."""
    fields = cls.get_fields_and_field_types()

    def build(**values: Any) -> Any:
        built = cls()
        for name, value in values.items():
            setattr(built, name, value)
        return built

    return st.builds(build, **{name: field(kind, ids) for name, kind in fields.items()})


def well_formed_offer(cls: type, ids: list[int]) -> st.SearchStrategy[Any]:
    """PathOffers whose arrays agree and whose ids are the swarm's: past the shape checks.

    Their labels are made up (any path through the swarm, any finite costs),
    so they reach what a receiver checks of a label's meaning.
    """

    @st.composite
    def offers(draw: st.DrawFn) -> Any:
        sender = draw(st.sampled_from(ids))
        count = draw(st.integers(0, 4))
        sources, paths = [], []
        for _ in range(count):
            inner = draw(st.lists(st.sampled_from(ids), max_size=3))
            source = draw(st.sampled_from(ids))
            sources.append(source)
            paths.append([source, *inner, sender] if source != sender else [sender])
        finite = st.floats(0.0, 1e3, allow_nan=False)
        offsets = [0]
        for path in paths:
            offsets.append(offsets[-1] + len(path))
        return cls(
            run_id=draw(st.sampled_from([1, 2, 3])),
            phase=draw(st.integers(0, 2)),
            round=draw(st.integers(0, 5)),
            sender_id=sender,
            source_ids=sources,
            hops=[len(path) - 1 for path in paths],
            lengths=[draw(finite) for _ in paths],
            errors=[draw(finite) for _ in paths],
            vectors=[draw(st.floats(-1e3, 1e3)) for _ in range(3 * count)],
            path_offsets=offsets,
            path_ids=[fls for path in paths for fls in path],
        )

    return offers()

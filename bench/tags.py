"""The swarm key's cost: signing and checking one offer, beside the same bytes unsigned.

The `tags` section of BENCHMARKS.md (`python -m bench --sections tags`).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

#: The tags section: labels per offer measured, and how many times each message is timed.
TAG_LABELS = (0, 10, 100, 1000)


TAG_REPEATS = 2000


def offer_of(labels: int, hops: int = 3) -> Any:
    """A PathOffer of ``labels`` labels of ``hops`` hops each, as an FLS sends it."""
    import numpy as np
    from builtin_interfaces.msg import Time

    from swazure_ros.protocol.discovery.messages import Broadcast, Offer
    from swazure_ros.ros.convert.offers import offer_message

    rng = np.random.default_rng(7)
    sources = np.arange(labels, dtype=np.int64) + 10
    middle = rng.integers(1, 10, (labels, hops - 1))
    paths = np.column_stack([sources, middle, np.zeros(labels, dtype=np.int64)])
    offer = Offer(
        source_ids=sources,
        hops=np.full(labels, hops, dtype=np.int64),
        lengths=rng.uniform(2, 20, labels),
        errors=rng.uniform(0, 1, labels),
        vectors=rng.normal(0, 5, (labels, 3)),
        path_offsets=np.arange(labels + 1, dtype=np.int64) * (hops + 1),
        path_ids=paths.astype(np.int64).reshape(-1),
    )
    return offer_message(Broadcast(1, 0, 3, 0, offer), Time())


def tags_section(args: argparse.Namespace) -> list[str]:
    """The swarm key's cost: signing and checking one offer, beside the same bytes unsigned."""
    from swazure_ros.ros.plumbing.interfaces import message_class
    from swazure_ros.ros.security.auth import SwarmKey

    kind = message_class("swazure_interfaces/msg/PathOffer")
    keyed, plain = SwarmKey(bytes(range(32))), SwarmKey(None)
    rows = []
    for labels in TAG_LABELS:
        timing = {}
        for name, key in (("keyed", keyed), ("plain", plain)):
            message = offer_of(labels)
            key.deserialize(key.serialize(message), kind)  # warm: the type's plan, once
            sent_bytes = []
            started = time.perf_counter()
            for index in range(TAG_REPEATS):
                message.round = index  # a new message each time: a key remembers bytes checked
                sent_bytes.append(key.serialize(message))
            sent = (time.perf_counter() - started) / TAG_REPEATS * 1e6
            started = time.perf_counter()
            for data in sent_bytes:
                key.deserialize(data, kind)
            heard = (time.perf_counter() - started) / TAG_REPEATS * 1e6
            timing[name] = (sent, heard, len(sent_bytes[0]))
        rows.append((labels, timing))
    lines = [
        "## The swarm key's cost per message",
        "",
        "One PathOffer of L labels (3 hops each), signed and serialised (`SwarmKey.serialize`)",
        "and deserialised and checked (`SwarmKey.deserialize`; each message a new round, so",
        "that no check is remembered), with the swarm's key and with `--no-key`; the mean",
        f"of {TAG_REPEATS} in one process. The auth field is the sender's id and counter (16",
        "bytes) and an HMAC-SHA256 of the instance, them and the fields' values",
        "(ros/security/auth.py).",
        "The receive cost is the key's check; a subscription's replay check (`Freshness`)",
        "is not in it. Per round, a process pays the receive cost once per offer it hears",
        "over DDS (the cells section's offers per process, divided by its rounds) and the",
        "send cost once per offer of its own that someone else reads.",
        "",
        "| labels | bytes keyed | bytes plain | send us keyed | send us plain | receive us keyed "
        "| receive us plain | tag's share of send | tag's share of receive |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for labels, timing in rows:
        (ks, kr, kb), (ps, pr, pb) = timing["keyed"], timing["plain"]
        lines.append(
            f"| {labels} | {kb} | {pb} | {ks:.1f} | {ps:.1f} | {kr:.1f} | {pr:.1f} "
            f"| {(ks - ps) / ks:.0%} | {(kr - pr) / kr:.0%} |"
        )
    return lines

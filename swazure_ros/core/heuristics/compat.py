"""Where the heuristics follow the published reference code instead of the text.

:class:`Compat` holds one switch per difference; :data:`TEXT` (every switch
off) and :data:`PUBLISHED` (every switch on) are the two behaviours a run
chooses between (``--compat``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


def _switch(doc: str) -> Any:
    """A :class:`Compat` switch, off by default, with what it changes in ``doc``."""
    return field(default=False, metadata={"doc": doc})


@dataclass(frozen=True)
class Compat:
    """Where the heuristics follow the published reference code instead of the text.

    Every switch off is the text (spec, sections 7 and 8), the default;
    :data:`PUBLISHED` turns every one on, which is how the paper's Tables 2-4
    were computed (github.com/flyinglightspeck/Swazure, src/orchestrator.py
    and src/swarm_locator.py). Each switch's ``doc`` metadata says what it
    changes; the study's report prints them beside the two sets of numbers.
    """

    independent_moves: bool = _switch(
        "Move Obstructing: each obstructer's destination is found in the original shape, "
        "so no obstructer sees where another went, and no line of sight is checked after "
        "the moves (the text makes the moves of a pair in sequence, each collision check "
        "seeing the earlier moves, and then checks every hop). Its collision check of the "
        "ideal move looks only at FLSs within a tracking distance |o - ideal| of the "
        "obstructer, with the FLS's index o standing for its position."
    )
    last_neighbour_circle: bool = _switch(
        "Move Obstructing: when the ideal move collides, the candidate destinations are the "
        "points where the obstruction-free circle crosses the collision sphere of the LAST "
        "neighbour within 4r (by distance) only: the loop overwrites the list of crossings "
        "for every neighbour. A pair fails when that one sphere misses the circle."
    )
    clear_of_any_one: bool = _switch(
        "Move Obstructing: a crossing is accepted as a destination when it is clear of ANY "
        "ONE neighbour within 4r, not of all of them, so the FLS may move into another."
    )
    last_hop_decides: bool = _switch(
        "Move Obstructing: a pair is judged by its last obstructed hop only: the success "
        "flag is overwritten per hop, so a pair whose earlier hop cannot be cleared counts "
        "as resolved when its last obstructed hop can."
    )
    grid_steps: bool = _switch(
        "Move Source: the 26 probe directions are grid offsets times r, not unit vectors: "
        "plane diagonals step sqrt(2) r and space diagonals sqrt(3) r, so the probes reach "
        "farther than T r."
    )
    collisions_near_origin: bool = _switch(
        "Move Source: a probe collides only with FLSs within (T + 2) r of the source's "
        "original position (the text: with any FLS)."
    )
    occlusion_near_origin: bool = _switch(
        "Move Source: the line of sight from a probe q to a helper h is checked only against "
        "FLSs within |q - p_h| + 2r of the source's original position."
    )
    sweet_max_inclusive: bool = _switch(
        "Move Source: a helper exactly at the sweet range's upper bound counts as sweet at a "
        "probe (the text's ranges are half-open)."
    )
    first_helper: bool = _switch(
        "Move Source: among the target's visible sweet neighbours, the first that works at a "
        "probe is taken, in order of distance from the target; the text's engine takes the "
        "one of the shortest path t(q, h) + t(h, j)."
    )
    published_flown: bool = _switch(
        "Move Source: the flown distance adds |(q_prev - p) + delta u| per probe, where "
        "q_prev is the previous probe, and counts the probes that collided; the text adds "
        "the distance between consecutive positions actually reached."
    )

    def __post_init__(self) -> None:
        dependent = ("last_neighbour_circle", "clear_of_any_one", "last_hop_decides")
        for name in dependent:
            if getattr(self, name) and not self.independent_moves:
                raise ValueError(f"compat switch {name} needs independent_moves")

    @staticmethod
    def describe(name: str) -> str:
        """What switch ``name`` changes, one paragraph."""
        return str(Compat.__dataclass_fields__[name].metadata["doc"])

    def switches_on(self) -> list[str]:
        """The names of the switches that are on, in declaration order."""
        return [name for name in self.__dataclass_fields__ if getattr(self, name)]


#: The text's heuristics (spec, sections 7 and 8).
TEXT = Compat()


#: The published reference code's heuristics: every switch on.
PUBLISHED = Compat(**{name: True for name in Compat.__dataclass_fields__})


#: ``--compat`` choices.
COMPAT_MODES = {"text": TEXT, "published": PUBLISHED}

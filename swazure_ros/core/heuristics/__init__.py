"""Move Obstructing and Move Source (spec, sections 7 and 8), a room each.

Both are tried on every ordered blind pair whose status is BLOCKED, each
from the original shape (moves are temporary), and return a
:class:`~.result.HeuristicResult`: per pair whether it was tried and
resolved, the new path and estimate, and every individual move (which FLS
went from where to where), so that a coordinator can issue the same moves as
commands.

- :mod:`.compat`: the text's behaviour and the published code's, switch by switch;
- :mod:`.result`: the techniques' names and what a heuristic returns;
- :mod:`.obstructing`: Move Obstructing, as the text and as published;
- :mod:`.source`: Move Source and its probe;
- :mod:`.folding`: a result folded into the plain run (:func:`~.folding.run_technique`);
- :mod:`.regions`: a heuristic on a run made block by block (:class:`~.regions.TechniqueBlocks`).

The circle and sphere geometry they use lives in :mod:`..circles` and
:mod:`..segments`; the order in which a swarm makes the moves in
:mod:`swazure_ros.protocol.schedule`.
"""

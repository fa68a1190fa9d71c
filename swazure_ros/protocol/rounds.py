"""The coordinator's round clock of one discovery run, as a state machine (docs/protocol.md).

:class:`RoundClock` STARTs each phase, opens rounds one by one while FLSs
broadcast their labels, closes a round when every FLS has broadcast and
every process has delivered, and ENDs the run to collect the sources'
estimates. Every wait has a deadline: ``round_timeout`` seconds without
progress, or more once the swarm's rounds are slow. The FLSs still silent
then have departed, and the phase restarts without them; a source that
never reports at the END has departed too.

The deadlines follow the swarm's measured round times (:class:`RoundTimes`),
and a process that says it is alive but behind is given more time
(:meth:`RoundClock.on_alive`), within bounds: slow is not dead.

The clock only counts. Events go in (:meth:`RoundClock.on_sent`,
:meth:`~RoundClock.on_ack`, :meth:`~RoundClock.on_estimates`,
:meth:`~RoundClock.on_tick`, each with the time ``now`` in seconds) and the
controls to send come out; the coordinator node and the in-memory loop
(:mod:`.loops`) both drive it.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field

from ..core.fit import PATH, SWARM_FIT
from .discovery.estimate import Estimate
from .discovery.messages import END, FIT, PHASES, ROUND, START, Control, FitStep
from .radio import Sent
from .swarm_fit import FitSchedule, FitTally

#: Phases of one run a lossy radio may spoil (and restart) before the run ends incomplete.
MAX_LOSS_RESTARTS = 10
#: A wait's deadline, in multiples of the slow end of the swarm's recent rounds: a round
#: ten times slower than those of late is taken for silence, not for a busy machine.
PATIENCE = 10.0
#: Rounds the deadlines follow: a few runs' worth (grid25's discovery has 13 rounds).
ROUNDS_KEPT = 64
#: Which of the rounds kept the deadlines follow: the slow end, past one held-up round.
SLOW_QUANTILE = 0.9
#: The longest deadline, in round timeouts: rounds held up for long (a forged heartbeat
#: under --no-key holds one MAX_STRETCH deadlines) cannot make every wait longer for ever.
MOST_PATIENCE = 10.0
#: A wait that a process alive but behind keeps asking more time for lasts at most this
#: many deadlines after the last progress (RoundClock.on_alive).
MAX_STRETCH = 3.0


@dataclass
class RoundTally:
    """What the coordinator knows of one round: who broadcast, what they hold, who delivered."""

    expected: frozenset[int]  # FLS ids that take part
    hosts: int  # processes whose radio must acknowledge the round
    senders: set[int] = field(default_factory=set)
    labels: int = 0
    pending: bool = False
    finished: set[int] = field(default_factory=set)
    acks: set[str] = field(default_factory=set)
    lost: int = 0  # deliveries lost for good, as the processes acknowledged
    fit: FitTally = field(default_factory=FitTally)  # the FIT phase's sums and say
    beyond: set[int] = field(default_factory=set)  # sources cut short by the pass's reach
    searching: set[int] = field(default_factory=set)  # sources that searched in the pass
    label_bytes: int = 0  # the memory the senders' labels take, summed

    def hear(
        self, senders: Collection[int], pending: Collection[int], finished: Collection[int]
    ) -> frozenset[int]:
        """Count the broadcasts of ``senders`` in this round, of which ``pending`` hold labels
        due later and ``finished`` ended their search; returns those counted now: the
        FLSs the round expects, once each (a late or repeated report adds nothing)."""
        new = self.expected.intersection(senders) - self.senders
        self.senders |= new
        self.pending |= not new.isdisjoint(pending)
        self.finished |= new.intersection(finished)
        return new

    def ack(self, host: str) -> None:
        """Count one process's acknowledgement that it delivered every broadcast."""
        self.acks.add(host)

    @property
    def complete(self) -> bool:
        """Every FLS broadcast and every process delivered."""
        return len(self.senders) == len(self.expected) and len(self.acks) >= self.hosts

    @property
    def silent(self) -> frozenset[int]:
        """FLSs that have not broadcast (yet)."""
        return self.expected - self.senders

    @property
    def quiet(self) -> bool:
        """Nothing was sent and nothing is due later: the phase is over."""
        return self.labels == 0 and not self.pending


class StallClock:
    """The time the coordinator's deadlines run on: it stands still while its process stalls.

    The coordinator looks at its deadlines every ``tick`` seconds. A look that
    comes more than ``stall`` seconds late means its process was busy (one long
    callback of its FLS nodes) and heard nothing meanwhile, whatever was sent:
    that time is left out, so that a busy process is not taken for silent FLSs.
    Times in seconds, on any monotonic clock.
    """

    def __init__(self, tick: float, stall: float, now: float) -> None:
        self.tick_period = tick
        self.stall = stall
        self._last_tick = now
        self.stalled = 0.0  # seconds left out so far

    def __call__(self, now: float) -> float:
        """The deadlines' time at monotonic time ``now``."""
        return now - self.stalled

    def tick(self, now: float) -> bool:
        """A look at the deadlines at ``now``; False when it came late (hear what waits first)."""
        late = now - self._last_tick - self.tick_period
        self._last_tick = now
        if late > self.stall:
            self.stalled += late
            return False
        return True


class RoundTimes:
    """How long the swarm's rounds took, measured: what the coordinator's deadlines follow.

    A wait's deadline is :data:`PATIENCE` times the slow end
    (:data:`SLOW_QUANTILE`) of the last ``kept`` rounds that completed, never
    less than ``floor`` (the coordinator's ``round_timeout``) and never more
    than :data:`MOST_PATIENCE` times it. Rounds of 0.15 s (grid25, one
    process per FLS, on a quiet machine; 0.2-1.5 s under a load of 30) keep
    a floor of 10 s; rounds whose slow end takes 2 s make it 20 s. A
    quantile and not the slowest: one round held up by a process behind
    (:meth:`RoundClock.on_alive`) must not make every later wait ten times
    its length, while rounds that are all slow (a big packed process that
    is behind in every round) do. A round that timed out is no measure: its
    length is the deadline itself. Seconds, on the deadlines' clock
    (:class:`StallClock`).
    """

    def __init__(self, kept: int = ROUNDS_KEPT, patience: float = PATIENCE) -> None:
        if kept < 1:
            raise ValueError(f"kept must be at least 1 round, got {kept}")
        if not (math.isfinite(patience) and patience > 0.0):
            raise ValueError(f"patience must be a positive number, got {patience}")
        self.patience = patience
        self._took: deque[float] = deque(maxlen=kept)

    def add(self, seconds: float) -> None:
        """A round that completed in ``seconds`` (a negative or not finite one is no measure)."""
        if math.isfinite(seconds) and seconds >= 0.0:
            self._took.append(seconds)

    @property
    def slow(self) -> float:
        """How long the slow rounds kept took (their SLOW_QUANTILE), s; 0 before the first."""
        if not self._took:
            return 0.0
        ordered = sorted(self._took)
        return ordered[min(int(SLOW_QUANTILE * len(ordered)), len(ordered) - 1)]

    def deadline(self, floor: float) -> float:
        """Seconds a wait may last without progress: ``floor``, or more after slow rounds."""
        return min(max(floor, self.patience * self.slow), MOST_PATIENCE * floor)


class Absences:
    """Who has been off the graph for ``grace`` seconds without a break.

    A participant whose lease lapses under load (its announcements late) drops
    off everyone's graph and comes back with its next announcement; a dead one
    stays off. Only an absence that lasts ``grace`` counts.
    """

    def __init__(self, grace: float) -> None:
        self.grace = grace
        self._since: dict[int, float] = {}

    def gone(self, missing: set[int], now: float) -> set[int]:
        """Of ``missing`` (off the graph now), those off for ``grace`` s; they are forgotten."""
        self._since = {key: self._since.get(key, now) for key in missing}
        done = {key for key, since in self._since.items() if now - since >= self.grace}
        for key in done:
            del self._since[key]
        return done


@dataclass(frozen=True)
class Outcome:
    """How a run ended: every source's estimates, the departed FLSs, rounds and restarts."""

    estimates: dict[int, Sequence[Estimate]]  # source id -> its estimates
    departed: frozenset[int]  # every FLS known gone at the end, earlier runs' included
    rounds: int
    restarts: int
    warnings: tuple[str, ...] = ()
    repairs: int = 0  # a lossy radio's repair requests and resends
    incomplete: bool = False  # deliveries kept being lost; the estimates are left out
    # A swarm-fit run: per fit, the iterations of each solve, the covariance's last.
    fit_iterations: tuple[tuple[int, ...], ...] = ()
    # The most memory the swarm's labels took in a round, all processes together, bytes.
    label_bytes: int = 0


class RoundClock:
    """The round clock of run ``run_id`` over the FLSs ``fls_ids``, hosted by ``hosts`` processes.

    ``departed`` FLSs are gone from the start; ``sources`` (with ``targets``,
    one per source) restrict the run to those pairs, else every FLS searches
    for every blind neighbour. ``estimator``: how sources make their
    estimates (``core.fit.SWARM_ESTIMATORS``); a swarm-fit run solves its
    ``fit_layers`` (``core.fit_measurements.fit_layers`` of the swarm's sensor) in the FIT
    phase after discovery's. :attr:`times`: the round times its deadlines
    follow and it adds its own to (a coordinator sets its own, which every
    one of its runs shares).
    """

    def __init__(
        self,
        run_id: int,
        policy: str,
        fls_ids: Iterable[int],
        hosts: int,
        round_timeout: float,
        *,
        departed: Iterable[int] = (),
        sources: Iterable[int] = (),
        targets: Iterable[int] = (),
        estimator: str = PATH,
        fit_layers: tuple[bool, ...] = (True,),
    ) -> None:
        self.run_id = run_id
        self.policy = policy
        self.estimator = estimator
        self.fls_ids = frozenset(fls_ids)
        self.hosts = hosts
        self.repairs = 0
        self.label_bytes = 0  # the most the labels took in a round (Outcome.label_bytes)
        self.loss_restarts = 0
        self.incomplete = False
        self.round_timeout = round_timeout
        self.times = RoundTimes()
        self.departed = set(departed)
        self.sources = tuple(sources)
        self.targets = tuple(targets)
        self.round = 0
        self.restarts = 0
        self.warnings: list[str] = []
        self.outcome: Outcome | None = None
        self._phases = PHASES + ((FIT,) if estimator == SWARM_FIT else ())
        self._fit = FitSchedule(fit_layers) if estimator == SWARM_FIT else None
        self._phase = 0  # index into _phases; len(_phases) while collecting estimates
        self._tally: RoundTally | None = None
        self._finished: set[int] = set()
        # The phase's pass (buckets.reach_rounds), the sources it has cut short so far, and
        # those that searched in it.
        self._pass = 0
        self._beyond: set[int] = set()
        self._searching: set[int] = set()
        self._collecting: frozenset[int] = frozenset()
        self._collected: dict[int, Sequence[Estimate]] = {}
        # The sources of _collecting not heard yet: one look per report, not one per source.
        self._uncollected: set[int] = set()
        self._deadline = float("inf")
        self._progress_at = 0.0  # when the wait last moved on (deadlines' clock, s)
        self._opened_at = 0.0  # when the open round opened
        self._stretched: set[str] = set()  # processes given more time in this wait
        # The waits each process was given more time in, this run: said once, counted at
        # the end (one process of a large shape is behind in every START and END).
        self._behind: Counter[str] = Counter()

    @property
    def done(self) -> bool:
        """True once the run has ended (:attr:`outcome` holds it)."""
        return self.outcome is not None

    @property
    def progress(self) -> str:
        """How far the run is, for a person watching."""
        return f"discovery round {self.round}"

    @property
    def patience(self) -> float:
        """Seconds a wait may last without progress: the round timeout, or more after slow
        rounds (:class:`RoundTimes`)."""
        return self.times.deadline(self.round_timeout)

    @property
    def live(self) -> frozenset[int]:
        """The FLSs that take part now."""
        return self.fls_ids - self.departed

    def start(self, now: float) -> list[Control]:
        """Begin the run: START the first phase and open its first round."""
        return self._start_phase(now)

    def on_sent(self, round_: int, sent: Sent, now: float) -> list[Control]:
        """A process's FLSs broadcast ``sent`` in round ``round_``: as if each offer were heard.

        So the coordinator need not hear the swarm's every offer: each process
        tells it who of its own FLSs spoke.
        """
        tally = self._tally
        if tally is None or round_ != self.round:
            return []
        if tally.hear(sent.senders, sent.pending, sent.finished):
            tally.labels += sent.labels
            tally.fit.add(sent.fit_sums, sent.fit_moved, sent.fit_same)
            tally.beyond.update(sent.beyond)
            tally.searching.update(sent.searching)
            tally.label_bytes += sent.label_bytes
        self._moved_on(now)
        return self._close_round(now, timed_out=False) if tally.complete else []

    def on_ack(
        self, round_: int, host: str, now: float, repairs: int = 0, lost: int = 0
    ) -> list[Control]:
        """Process ``host`` delivered every offer of round ``round_`` (``lost`` for good)."""
        tally = self._tally
        if tally is None or round_ != self.round:
            return []
        tally.ack(host)
        self.repairs += repairs
        tally.lost += lost
        self._moved_on(now)
        return self._close_round(now, timed_out=False) if tally.complete else []

    def on_estimates(
        self, source: int, estimates: Sequence[Estimate], now: float
    ) -> list[Control]:
        """Source ``source`` reported at the END."""
        if source not in self._collecting or self.done:
            return []
        self._collected[source] = estimates
        self._uncollected.discard(source)
        self._moved_on(now)
        if not self._uncollected:
            self._finish()
        return []

    def on_gone(self, gone: Iterable[int], now: float, radios: int = 0) -> list[Control]:
        """FLSs known dead (their nodes left the graph): they depart now, with no deadline.

        As after a timeout: an open round's phase restarts without them; at the
        END, the run stops waiting for their estimates. ``radios``: processes
        gone with them (an FLS that was a process of its own), whose
        acknowledgements no round waits for any more.
        """
        newly = (frozenset(gone) & self.fls_ids) - self.departed
        self.hosts = max(self.hosts - radios, 0)
        if self.done or not (newly or radios):
            return []
        self.departed |= newly
        self.warnings.append(f"run {self.run_id}: FLS {sorted(newly)} gone, departed")
        if self._tally is not None:
            self._tally = None
            self.round += 1
            self.restarts += 1
            return self._start_phase(now)
        if self._collecting:
            self._collecting -= newly
            self._uncollected -= newly
            if not self._uncollected:
                self._finish()
        return []

    def on_alive(self, host: str, fls_ids: Iterable[int], now: float) -> list[Control]:
        """Process ``host`` (a radio, hosting ``fls_ids``) says it is alive but behind.

        A wait for it (a round it has not acknowledged, or in which one of
        its FLSs is silent; an END one of them has not answered) is given a
        deadline from ``now``, but never past :data:`MAX_STRETCH` deadlines
        after the wait last moved on: a process that keeps saying so and never
        answers (a forgery, under --no-key) holds a wait that long and no
        longer, and an FLS whose node leaves the graph departs at once
        whatever its process says (:meth:`on_gone`). Nothing to send.
        """
        if self.done or not self._waits_on(host, frozenset(fls_ids)):
            return []
        patience = self.patience
        limit = self._progress_at + MAX_STRETCH * patience
        if self._deadline < limit:
            self._deadline = min(max(self._deadline, now + patience), limit)
            if host not in self._stretched:
                self._stretched.add(host)
                self._behind[host] += 1
                if self._behind[host] == 1:
                    self.warnings.append(
                        f"run {self.run_id}: {host} is behind, alive: round {self.round} "
                        f"waits for it up to {self._deadline - self._progress_at:.3g} s "
                        "(said once a run)"
                    )
        return []

    def _waits_on(self, host: str, fls_ids: frozenset[int]) -> bool:
        """Whether the open wait waits for process ``host`` or one of its FLSs ``fls_ids``."""
        tally = self._tally
        if tally is not None:
            # A radio that speaks for departed FLSs alone is waited for no more (on_gone).
            theirs = not fls_ids or not fls_ids <= self.departed
            unacked = theirs and host not in tally.acks and len(tally.acks) < tally.hosts
            return unacked or bool(fls_ids & tally.silent)
        return bool(fls_ids & self._uncollected)

    def on_tick(self, now: float) -> list[Control]:
        """The time is ``now``: end a wait whose deadline has passed."""
        if self.done or now <= self._deadline:
            return []
        if self._tally is not None:
            return self._close_round(now, timed_out=True)
        gone = frozenset(self._uncollected)
        self.departed |= gone
        self.warnings.append(f"run {self.run_id}: no estimates from FLS {sorted(gone)}")
        self._finish()
        return []

    def _moved_on(self, now: float) -> None:
        """The wait moved on at ``now``: its deadline is a patience from now."""
        self._progress_at = now
        self._deadline = now + self.patience

    def _control(self, command: int, now: float, **fields: object) -> Control:
        self._moved_on(now)
        self._stretched.clear()
        phase = self._phases[self._phase] if self._phase < len(self._phases) else 0
        fit = self._fit.step if phase == FIT and self._fit is not None else FitStep()
        return Control(
            self.run_id,
            command,
            phase,
            self.policy,
            self.round,
            len(self.live),
            departed_ids=tuple(sorted(self.departed)),
            estimator=self.estimator,
            fit=fit,
            **fields,  # type: ignore[arg-type]
        )

    def _start_phase(self, now: float, reach_pass: int = 0) -> list[Control]:
        """START pass ``reach_pass`` of the phase: the first (as after a restart), or the
        next, told whose searches the pass before ran to their end (searched, none of their
        labels beyond its reach, not closed once finished)."""
        exhausted = self._searching - self._beyond - self._finished if reach_pass else set()
        self._pass, self._beyond = reach_pass, set()
        if not reach_pass:  # a later pass goes on with the searches, those closed stay so
            self._searching, self._finished = set(), set()
        if self._fit is not None and self._phases[self._phase] == FIT:
            self._fit.first()
        start = self._control(
            START,
            now,
            source_ids=self.sources,
            target_ids=self.targets,
            reach_pass=reach_pass,
            exhausted_ids=tuple(sorted(exhausted)),
        )
        return [start, self._open_round(now, finished=())]

    def _open_round(self, now: float, finished: tuple[int, ...]) -> Control:
        self._tally = RoundTally(self.live, self.hosts)
        self._opened_at = now
        return self._control(ROUND, now, finished_ids=finished)

    def _close_round(self, now: float, timed_out: bool) -> list[Control]:
        tally = self._tally
        assert tally is not None
        self._tally = None
        self.round += 1
        if not timed_out:
            self.times.add(now - self._opened_at)
        waited = f"{now - self._progress_at:.1f} s"
        if timed_out and tally.silent:
            self.departed |= tally.silent
            self.restarts += 1
            self.warnings.append(
                f"run {self.run_id}: FLS {sorted(tally.silent)} silent for {waited}, "
                f"departed; phase {self._phases[self._phase]} restarts"
            )
            return self._start_phase(now)
        # A process that never acknowledged may have missed offers (a radio that had
        # not matched every transmitter yet, on another host): as lost for good.
        unheard = self.hosts - len(tally.acks) if timed_out else 0
        if tally.lost or unheard > 0:
            # A label missed for good could make some path worse: do the phase again.
            self.loss_restarts += 1
            self.restarts += 1
            if self.loss_restarts > MAX_LOSS_RESTARTS:
                self.warnings.append(
                    f"run {self.run_id}: deliveries lost for good in {self.loss_restarts} "
                    "tries of a phase; the run ends incomplete"
                )
                self.incomplete = True
                self._collecting = frozenset()
                self._uncollected = set()
                end = self._control(END, now)
                self._finish()
                return [end]
            what = (
                f"{tally.lost} deliveries lost for good"
                if tally.lost
                else f"{unheard} process(es) silent for {waited}"
            )
            self.warnings.append(
                f"run {self.run_id}: {what} in round {self.round - 1}; "
                f"phase {self._phases[self._phase]} restarts"
            )
            return self._start_phase(now)
        newly = tuple(sorted(tally.finished - self._finished))
        self._finished |= tally.finished
        self._beyond |= tally.beyond
        self._searching |= tally.searching
        self.label_bytes = max(self.label_bytes, tally.label_bytes)
        if self._fit is not None and self._phases[self._phase] == FIT:
            if self._fit.after(tally.fit, tally.quiet) is not None:
                return [self._open_round(now, newly)]
        elif not tally.quiet:
            return [self._open_round(now, newly)]
        elif self._beyond:  # searches cut short by the reach: a pass twice as far
            return self._start_phase(now, self._pass + 1)
        self._phase += 1
        if self._phase < len(self._phases):
            return self._start_phase(now)
        live = self.live
        self._collecting = frozenset(self.sources) & live if self.sources else live
        self._collected = {}
        self._uncollected = set(self._collecting)
        end = self._control(END, now)
        if not self._collecting:
            self._finish()
        return [end]

    def _finish(self) -> None:
        self._deadline = float("inf")
        for host, waits in sorted(self._behind.items()):
            if waits > 1:
                self.warnings.append(
                    f"run {self.run_id}: {host} was behind, alive, in {waits} waits, "
                    "each given more time"
                )
        self.outcome = Outcome(
            {} if self.incomplete else self._collected,
            frozenset(self.departed),
            self.round,
            self.restarts,
            tuple(self.warnings),
            self.repairs,
            self.incomplete,
            tuple(tuple(one) for one in self._fit.iterations) if self._fit is not None else (),
            self.label_bytes,
        )

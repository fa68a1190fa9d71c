"""A running swarm from Python, in the manner of Crazyswarm2's ``crazyflie_py``.

:func:`connect` gives a :class:`SwarmClient` of a swarm started elsewhere
(``swazure spawn``, ``ros2 launch swazure_ros swarm.launch.py``), found by its
namespace and ROS domain: an FLS's neighbours, the coordinator's pose of a
source relative to a target, a topic's messages as records. The client owns
its node and rclpy context, and is a context manager: leaving the ``with``
block leaves nothing running.

:func:`spawn` brings a swarm up in this process, as ``swazure spawn`` does,
and gives a client of it that serves it while it waits and stops it when it
closes; such a client also runs :meth:`SwarmClient.compute_all`, ``swazure
spawn --compute-all``: the coordinator that runs a discovery for every FLS at
once belongs to the process that brought the swarm up (it signs the runs with
the swarm's key), so a swarm found by :func:`connect` answers one pair at a
time. :func:`compute_all` is spawn, compute_all and stop in one call.

rclpy loads when a client connects or a swarm comes up, not when this module
is imported.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..core.errors import OptionError, RunError, SwazureError
from ..core.fit import PATH, SWARM_ESTIMATORS
from ..core.heuristics.result import PLAIN, TECHNIQUES
from ..core.paths import POLICIES, SHORTEST_LENGTH
from ..sim.world import WorldSpec

if TYPE_CHECKING:
    from ..app.compute import SwarmComputation
    from ..app.swarm import RunningSwarm
    from ..protocol.discovery.estimate import Estimate
    from ..ros.clients.query import Neighbours, SwarmQueries

#: A record of a message: its fields by name in declaration order, nested messages as
#: records, arrays as lists (``ros2 topic echo``'s YAML, as Python values).
Record = dict[str, Any]

__all__ = ["SwarmClient", "compute_all", "connect", "spawn"]


class SwarmClient:
    """A running swarm, found by its namespace and ROS domain: ask it, listen to it.

    Parameters
    ----------
    namespace : str, default "swarm"
        The swarm's ROS namespace (``swazure spawn --namespace``).
    domain_id : int, optional
        The ROS domain, 0 to 232. Default: ``$ROS_DOMAIN_ID``, else 0.
    timeout : float, default 60
        Seconds each question waits for its answer, at most.
    swarm : RunningSwarm, optional
        A swarm this process runs (:func:`spawn` passes it): served while the
        client waits, stopped when it closes.

    Raises
    ------
    OptionError
        A namespace that is not a ROS namespace, a timeout that is not a
        positive number.
    SwazureError
        ROS 2 cannot start here (no rclpy).
    """

    def __init__(
        self,
        namespace: str = "swarm",
        domain_id: int | None = None,
        timeout: float = 60.0,
        swarm: RunningSwarm | None = None,
    ) -> None:
        from ..ros.clients.query import SwarmQueries
        from ..ros.plumbing.names import namespace_problem

        problem = namespace_problem("/" + namespace.strip("/"))
        if problem is not None:
            raise OptionError(f"namespace {namespace!r}: {problem}")
        self.timeout = _seconds("timeout", timeout)
        #: A swarm this process runs (:func:`spawn`): served while the client waits,
        #: stopped when the client closes. None: the swarm runs elsewhere.
        self._swarm = swarm
        serve = None if swarm is None else swarm.spin
        self._queries: SwarmQueries | None = SwarmQueries(
            namespace, domain_id, None if serve is None else lambda: serve(0.01)
        )

    @property
    def namespace(self) -> str:
        """The swarm's namespace, without slashes (``swarm``)."""
        return self._asking().namespace

    @property
    def domain_id(self) -> int:
        """The ROS domain this client talks on."""
        return int(self._asking().context.get_domain_id())

    def __enter__(self) -> SwarmClient:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Destroy the client's node and shut its context down, and stop a swarm it brought up
        (:func:`spawn`); closing again does nothing."""
        if self._queries is not None:
            self._queries.close()
            self._queries = None
        if self._swarm is not None:
            swarm, self._swarm = self._swarm, None
            swarm.__exit__(None, None, None)

    def _asking(self) -> SwarmQueries:
        if self._queries is None:
            raise RunError("this swarm client is closed")
        return self._queries

    def neighbours(self, fls_id: int) -> Neighbours:
        """FLS ``fls_id``'s neighbours, as the FLS itself knows them.

        Parameters
        ----------
        fls_id : int
            The FLS's id: its row in the swarm's point cloud.

        Returns
        -------
        Neighbours
            Sorted FLS ids: ``blind`` (closer than the sensor sees, known by
            radio), ``sweet`` (sweet range, by radio), ``visible_sweet`` and
            ``decaying`` (in sight), and ``gone`` (those whose nodes left).

        Raises
        ------
        RunError
            No such FLS node answered within the timeout (no swarm, or no FLS
            ``fls_id`` in it).
        OptionError
            ``fls_id`` is not a whole number 0 to 2**32 - 1.

        Examples
        --------
        >>> with connect("swarm", domain_id=201) as swarm:  # doctest: +SKIP
        ...     swarm.neighbours(0).blind
        (3, 17)
        """
        return self._asking().neighbours(_fls_id("fls_id", fls_id), self.timeout)

    def compute_pose(
        self, source: int, target: int, policy: str = SHORTEST_LENGTH, estimator: str = PATH
    ) -> Estimate:
        """``source``'s pose relative to ``target``, found by one discovery run of the swarm.

        Parameters
        ----------
        source, target : int
            FLS ids; ``target`` a blind neighbour of ``source``.
        policy : {"shortest-length", "fewest-hops", "least-error"}
            The path policy.
        estimator : {"path", "local-least-squares", "swarm-fit"}
            The path's sum of measured hops, or a least-squares fit with a
            covariance.

        Returns
        -------
        Estimate
            ``status`` and ``reason`` (codes of ``core.evaluation.STATUS_NAMES``
            and ``REASON_NAMES``), ``path`` (FLS ids), ``hops``, ``vector``
            (3,) cm in ``source``'s frame, ``length`` cm, and with a fit its
            ``covariance`` (3, 3) cm^2.

        Raises
        ------
        RunError
            No coordinator answered within the timeout.
        SwazureError
            The coordinator refused: no such FLS, not a blind pair, a policy
            the sensor cannot serve.
        OptionError
            An id or option that is none of its values.

        Examples
        --------
        >>> with connect("swarm", domain_id=201) as swarm:  # doctest: +SKIP
        ...     swarm.compute_pose(0, 3).vector
        array([ 1.49, -0.62,  0.  ])
        """
        if policy not in POLICIES:
            raise OptionError(f"policy {policy!r}: expected one of {', '.join(POLICIES)}")
        if estimator not in SWARM_ESTIMATORS:
            choices = ", ".join(SWARM_ESTIMATORS)
            raise OptionError(f"estimator {estimator!r}: expected one of {choices}")
        source, target = _fls_id("source", source), _fls_id("target", target)
        return self._asking().compute_pose(source, target, policy, estimator, self.timeout)

    def echo(
        self,
        topic: str,
        count: int | None = 1,
        on_message: Callable[[Record], object] | None = None,
        message_type: str | None = None,
    ) -> list[Record]:
        """The next ``count`` messages of ``topic`` as records, as ``swazure echo`` reads them.

        Parameters
        ----------
        topic : str
            A topic name; a relative one (``"estimates"``) is the swarm's
            (``/swarm/estimates``).
        count : int or None, default 1
            How many messages to wait for; None: until the timeout passes
            with no message at all, then for ever (``on_message`` hears them).
        on_message : callable, optional
            Called with each record as it arrives.
        message_type : str, optional
            ``pkg/msg/Type``; default: found on the graph.

        Returns
        -------
        list of dict
            The records received: each message's fields by name, nested
            messages as dicts, arrays as lists (SI units as the message says:
            ``docs/protocol.md``).

        Raises
        ------
        RunError
            No message within the client's timeout.
        SwazureError
            The topic carries another type than ``message_type``.
        OptionError
            A topic name that is not one, a count below 1.

        Examples
        --------
        >>> with connect("swarm", domain_id=201) as swarm:  # doctest: +SKIP
        ...     swarm.echo("measurements")[0]["fls_id"]
        0
        """
        from ..ros.clients.echo import echo, message_to_dict
        from ..ros.plumbing.names import topic_problem

        queries = self._asking()
        name = topic if topic.startswith("/") else f"/{queries.namespace}/{topic}"
        problem = topic_problem(name)
        if problem is not None:
            raise OptionError(f"topic {topic!r}: {problem}")
        if count is None and on_message is None:
            raise OptionError("count None listens for ever: give on_message to hear the records")
        if count is not None:
            _fls_id("count", count)
            if count < 1:
                raise OptionError(f"count {count}: must be at least 1")
        received: list[Record] = []

        def take(message: Any) -> None:
            record = message_to_dict(message)
            received.append(record)
            if on_message is not None:
                on_message(record)

        domain = queries.context.get_domain_id()
        ended = echo(name, message_type, count, self.timeout, domain, _nowhere, take, queries.step)
        if ended != 0:
            raise RunError(f"{name}: no message within {self.timeout:g} s")
        return received

    def compute_all(
        self,
        policy: str = SHORTEST_LENGTH,
        *,
        technique: str = PLAIN,
        threshold: int = 10,
        estimator: str = PATH,
    ) -> SwarmComputation:
        """Every FLS's pose relative to every blind neighbour, found by the swarm's messages.

        ``swazure spawn --compute-all`` on a swarm that :func:`spawn` brought up:
        its coordinator runs discovery for every FLS at once (then a
        heuristic's moves, with ``technique``), beside the engine's evaluation
        of the same work.

        Parameters
        ----------
        policy : {"shortest-length", "fewest-hops", "least-error"}
            The path policy.
        technique : {"plain", "move-obstructing", "move-source"}
            Then a heuristic's moves, made by the swarm.
        threshold : int, default 10
            Move Source: steps of r probed per direction.
        estimator : {"path", "local-least-squares", "swarm-fit"}
            How each source estimates.

        Returns
        -------
        SwarmComputation
            ``evaluation`` (what the swarm found), ``engine`` (the engine's
            evaluation of the same work), ``heuristic``, and ``record``
            (``files.record.RunRecord``: summaries, traffic, and ``comparison``,
            whose ``identical`` is True when every pair is the engine's).

        Raises
        ------
        SwazureError
            A swarm found by :func:`connect`: its coordinator belongs to the
            process that brought it up, which signs the runs with the swarm's key.
        OptionError
            An option that is none of its values.

        Examples
        --------
        >>> with spawn(WorldSpec("torus:120", scale=2.5, beta=0.5)) as swarm:  # doctest: +SKIP
        ...     swarm.compute_all().record.comparison.identical
        True
        """
        from ..app.compute import compute_all as run_all

        for name, value, choices in (
            ("policy", policy, POLICIES),
            ("technique", technique, TECHNIQUES),
            ("estimator", estimator, SWARM_ESTIMATORS),
        ):
            if value not in choices:
                raise OptionError(f"{name} {value!r}: expected one of {', '.join(choices)}")
        self._asking()
        if self._swarm is None:
            raise SwazureError(
                "compute_all runs the coordinator of a swarm this process brought up "
                "(api.spawn); a connected swarm's runs belong to the process that started it "
                "(swazure spawn --compute-all there)"
            )
        return run_all(self._swarm, policy, technique, threshold, estimator=estimator)


def _nowhere(text: str) -> None:
    """Where the echo's YAML would go: records are taken instead."""


def _fls_id(name: str, value: object) -> int:
    if isinstance(value, bool) or not hasattr(value, "__index__"):
        raise OptionError(f"{name} must be a whole number, got {value!r}")
    number = int(value)
    if not 0 <= number < 2**32:
        raise OptionError(f"{name} {number}: outside 0..{2**32 - 1}")
    return number


def _seconds(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise OptionError(f"{name} must be a positive number of seconds, got {value!r}")
    if value == float("inf"):
        raise OptionError(f"{name} must be finite, got {value!r}")
    return float(value)


def connect(
    namespace: str = "swarm", domain_id: int | None = None, timeout: float = 60.0
) -> SwarmClient:
    """A client of the swarm running under ``namespace`` on ROS domain ``domain_id``.

    Parameters
    ----------
    namespace : str, default "swarm"
        The swarm's ROS namespace (``swazure spawn --namespace``).
    domain_id : int, optional
        The ROS domain, 0 to 232. Default: ``$ROS_DOMAIN_ID``, else 0.
    timeout : float, default 60
        Seconds each question waits for its answer, at most.

    Returns
    -------
    SwarmClient
        Use it in a ``with`` block, or ``close()`` it.

    Raises
    ------
    OptionError
        A namespace that is not a ROS namespace, a bad timeout.

    Examples
    --------
    >>> from swazure_ros import api
    >>> with api.connect("swarm", domain_id=201) as swarm:  # doctest: +SKIP
    ...     print(swarm.neighbours(0))
    """
    return SwarmClient(namespace, domain_id, timeout)


def spawn(
    world: WorldSpec,
    namespace: str = "swarm",
    domain_id: int | None = None,
    timeout: float = 60.0,
    bring_up_timeout: float = 600.0,
) -> SwarmClient:
    """A swarm brought up in this process, as ``swazure spawn`` does, and a client of it.

    The swarm is served while the client waits for an answer; closing the client
    (or leaving its ``with`` block) stops the swarm.

    Parameters
    ----------
    world : WorldSpec
        The swarm (``swazure_ros.sim.world.WorldSpec``: cloud name or file,
        scale, beta or radius in cm, sensor file, accurate, seed).
    namespace : str, default "swarm"
        The swarm's ROS namespace.
    domain_id : int, optional
        The ROS domain. Default: ``$ROS_DOMAIN_ID``, else 0.
    timeout : float, default 60
        Seconds each question waits for its answer, at most.
    bring_up_timeout : float, default 600
        Seconds the swarm may take to come up.

    Returns
    -------
    SwarmClient
        With :meth:`SwarmClient.compute_all` too.

    Raises
    ------
    OptionError
        A world that is not a WorldSpec, a bad namespace or timeout.
    RunError
        The swarm did not come up in time, or a process of it failed.
    CloudError
        The cloud cannot be used.

    Examples
    --------
    >>> from swazure_ros import api
    >>> spec = api.WorldSpec("torus:120", scale=2.5, beta=0.5)
    >>> with api.spawn(spec, domain_id=201) as swarm:  # doctest: +SKIP
    ...     swarm.compute_pose(0, 1).path
    (0, 35, 1)
    """
    from ..app.config import SwarmConfig
    from ..app.swarm import RunningSwarm

    if not isinstance(world, WorldSpec):
        raise OptionError(f"world must be a WorldSpec, got {type(world).__name__}")
    config = SwarmConfig(
        world,
        namespace=namespace.strip("/") or "swarm",
        domain_id=domain_id,
        discovery_timeout=_seconds("bring_up_timeout", bring_up_timeout),
    )
    running = RunningSwarm.start(config)
    try:
        return SwarmClient(config.namespace, domain_id, timeout, running)
    except BaseException:
        running.close()
        raise


def compute_all(
    world: WorldSpec,
    policy: str = SHORTEST_LENGTH,
    *,
    technique: str = PLAIN,
    threshold: int = 10,
    estimator: str = PATH,
    namespace: str = "swarm",
    domain_id: int | None = None,
    timeout: float = 600.0,
) -> SwarmComputation:
    """``swazure spawn --compute-all``: a swarm brought up here finds every pose, then stops.

    :func:`spawn`, :meth:`SwarmClient.compute_all`, and the swarm stopped.

    Parameters
    ----------
    world : WorldSpec
        The swarm (``swazure_ros.sim.world.WorldSpec``: cloud name or file,
        scale, beta or radius in cm, sensor file, accurate, seed).
    policy : {"shortest-length", "fewest-hops", "least-error"}
        The path policy.
    technique : {"plain", "move-obstructing", "move-source"}
        Then a heuristic's moves, made by the swarm.
    threshold : int, default 10
        Move Source: steps of r probed per direction.
    estimator : {"path", "local-least-squares", "swarm-fit"}
        How each source estimates.
    namespace : str, default "swarm"
        The swarm's ROS namespace.
    domain_id : int, optional
        The ROS domain. Default: ``$ROS_DOMAIN_ID``, else 0.
    timeout : float, default 600
        Seconds the swarm may take to come up.

    Returns
    -------
    SwarmComputation
        As :meth:`SwarmClient.compute_all`.

    Raises
    ------
    OptionError
        An option that is none of its values.
    RunError
        The swarm did not come up in time, or a process of it failed.
    CloudError
        The cloud cannot be used.

    Examples
    --------
    >>> from swazure_ros import api
    >>> spec = api.WorldSpec("torus:120", scale=5, beta=0.5)
    >>> computed = api.compute_all(spec, domain_id=201)  # doctest: +SKIP
    >>> computed.record.comparison.identical  # doctest: +SKIP
    True
    """
    with spawn(world, namespace, domain_id, bring_up_timeout=timeout) as swarm:
        return swarm.compute_all(
            policy, technique=technique, threshold=threshold, estimator=estimator
        )

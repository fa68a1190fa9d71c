"""The node every swarm's node is: lean, guarded, with parameters checked by their specs.

A :class:`SwarmNode` has no rosout publisher and no type description
service, and parameter services only where asked, because each endpoint
costs discovery time in a swarm of thousands of nodes. What its timers and
services raise is counted and logged, never raised into the executor; the
parameters it declares from a :class:`~.parameters.ParameterSpec` are checked
by the spec's rule, at the start and when set while it runs.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rcl_interfaces.msg import (
    ParameterDescriptor,
    ParameterEvent,
    ParameterType,
    SetParametersResult,
)
from rclpy.context import Context
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import qos_profile_parameter_events
from rclpy.service import Service
from rclpy.timer import Timer

from .parameters import ParameterError, ParameterSpec

#: Off for every node of a swarm: the ``~/get_type_description`` service is two
#: more endpoints per node, and endpoints cost discovery time (docs/swarm.md).
#: Tools that need a type find it from the interface package instead.
NO_TYPE_DESCRIPTION_SERVICE = Parameter("start_type_description_service", value=False)


#: Where rclpy's nodes publish their parameter changes.
PARAMETER_EVENTS_TOPIC = "/parameter_events"


#: Seconds between two log lines of a callback that keeps failing.
FAILURE_LOG_EVERY = 5.0


class SwarmNode(Node):
    """A node of a swarm: no rosout, no type description service, parameter services if asked.

    A process that hosts one node (an FLS of its own, the world, the
    coordinator) turns its parameter services on, so that ``ros2 param``
    answers; a packed process of hundreds of FLSs leaves them off unless asked
    (``parameter_services``): they are six services a node (docs/swarm.md).
    """

    def __init__(
        self,
        name: str,
        *,
        namespace: str = "",
        context: Context | None = None,
        parameter_overrides: list[Parameter] | None = None,
        parameter_services: bool = False,
        parameter_events: Publisher | None = None,
    ) -> None:
        # Set before Node's constructor, which makes the events publisher (create_publisher).
        self._shared_parameter_events = parameter_events
        # Parameters a running node takes new values of: their specs and what applies them.
        self._live: dict[str, tuple[ParameterSpec, Callable[[Any], None]]] = {}
        #: Timer and service callbacks that raised, by where: counted, logged, never raised.
        self.failures: Counter[str] = Counter()
        super().__init__(
            name,
            namespace=namespace,
            context=context,
            parameter_overrides=[NO_TYPE_DESCRIPTION_SERVICE, *(parameter_overrides or [])],
            enable_rosout=False,
            start_parameter_services=parameter_services,
        )

    def create_publisher(self, msg_type: Any, topic: str, *args: Any, **kwargs: Any) -> Publisher:
        """Node's, but a node given ``parameter_events`` publishes its parameter events there.

        Every endpoint of a process makes rmw_fastrtps republish the process's
        whole entity list (docs/swarm.md): a packed process of thousands of FLS
        nodes shares its host's one /parameter_events writer instead of making
        one per node. The events say which node they are from, as before.
        """
        if topic == PARAMETER_EVENTS_TOPIC and self._shared_parameter_events is not None:
            return self._shared_parameter_events
        publisher: Publisher = super().create_publisher(msg_type, topic, *args, **kwargs)
        return publisher

    def create_timer(
        self, timer_period_sec: float, callback: Callable[[], Any], *args: Any, **kwargs: Any
    ) -> Timer:
        """Node's, with ``callback`` guarded: what it raises (a publish that DDS refuses, a
        defect of ours) is counted in :attr:`failures` and logged, never raised into the
        executor, which would end the process with every node in it."""
        timer: Timer = super().create_timer(
            timer_period_sec, self.guarded(callback), *args, **kwargs
        )
        return timer

    def guarded(self, callback: Callable[[], Any]) -> Callable[[], None]:
        """``callback`` as this node's timers call it: what it raises is counted in
        :attr:`failures` and logged, never raised (a timer another node runs for it too)."""
        name = getattr(callback, "__name__", "timer")

        def guarded() -> None:
            try:
                callback()
            except Exception as err:
                self._failed(f"timer {name}", err)

        return guarded

    def create_service(
        self, srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any], **kwargs: Any
    ) -> Service:
        """Node's, with ``callback`` guarded: a request it fails on is answered with
        ``success: false`` and a one-line ``message`` (where the service has them),
        counted in :attr:`failures`; the node keeps serving."""

        def guarded(request: Any, response: Any) -> Any:
            try:
                return callback(request, response)
            except Exception as err:
                self._failed(f"service {srv_name}", err)
                if hasattr(response, "success") and hasattr(response, "message"):
                    response.success = False
                    response.message = f"internal error: {type(err).__name__}: {err}"
                return response

        service: Service = super().create_service(srv_type, srv_name, guarded, **kwargs)
        return service

    def _failed(self, where: str, err: Exception) -> None:
        self.failures[where] += 1
        self.get_logger().error(  # type: ignore[no-untyped-call]
            f"{where} failed ({self.failures[where]} so far): {type(err).__name__}: {err}",
            throttle_duration_sec=FAILURE_LOG_EVERY,
        )

    def create_parameter_events_publisher(self) -> Publisher:
        """A /parameter_events writer that packed nodes can share (``parameter_events``)."""
        return self.create_publisher(
            ParameterEvent, PARAMETER_EVENTS_TOPIC, qos_profile_parameter_events
        )

    def declare(self, spec: ParameterSpec, apply: Callable[[Any], None] | None = None) -> Any:
        """Declare ``spec``'s parameter and return its value; ParameterError if it is refused.

        With ``apply``, a value set while the node runs (``ros2 param set``) is
        checked by the spec's rule, refused with its reason, or handed to
        ``apply``; without, the parameter is read-only once declared.
        """
        (value,) = self.declare_all([spec], {spec.name: apply} if apply is not None else None)
        return value

    def declare_all(
        self,
        specs: Sequence[ParameterSpec],
        apply: Mapping[str, Callable[[Any], None]] | None = None,
    ) -> list[Any]:
        """Declare the parameters of ``specs`` at once and return their values, in order.

        As :meth:`declare` each, ``apply`` giving what applies a parameter's
        new value by its name, but with one ParameterEvent for them all:
        rclpy's ``declare_parameters`` publishes one per parameter, and those
        were most of what a packed process spent making its FLS nodes (18
        parameters each). A value of the wrong type is refused as
        ``declare_parameter`` refuses it. ParameterError if one is refused.
        """
        apply = apply or {}
        descriptors = {
            spec.name: ParameterDescriptor(
                description=spec.description,
                read_only=spec.name not in apply,
                type=_TYPES[type(spec.default)],
            )
            for spec in specs
        }
        overrides = self._parameter_overrides
        wanted = [
            Parameter(spec.name, value=overrides[spec.name].value)
            if spec.name in overrides
            else Parameter(spec.name, value=spec.default)
            for spec in specs
        ]
        declared = [spec.name for spec in specs if self.has_parameter(spec.name)]
        result = None
        if not declared:
            # rclpy's own declare (Node._declare_parameter_common) in one call for all.
            result = self._set_parameters_atomically_common(
                wanted, descriptors, allow_not_set_type=True
            )
        if result is None or not result.successful:
            # Declared one by one, for rclpy's own account of the one refused (rclpy
            # takes the override itself, and the type from the default).
            for spec in specs:
                try:
                    self.declare_parameter(spec.name, spec.default, descriptors[spec.name])
                except ParameterException as err:
                    raise ParameterError(f"{self.get_fully_qualified_name()}: {err}") from err
        values = [self._parameters[spec.name].value for spec in specs]
        for spec, value in zip(specs, values, strict=True):
            reason = spec.refuses(value)
            if reason is not None:
                raise ParameterError(
                    f"{self.get_fully_qualified_name()}: parameter {spec.name} {reason}"
                )
            if spec.name in apply:
                if not self._live:
                    self.add_on_set_parameters_callback(self._check_set)
                    self.add_post_set_parameters_callback(self._apply_set)
                self._live[spec.name] = (spec, apply[spec.name])
        return values

    def _check_set(self, parameters: list[Parameter]) -> SetParametersResult:
        """Refuse a value set while the node runs that its spec's rule refuses, saying why."""
        for parameter in parameters:
            live = self._live.get(parameter.name)
            reason = live[0].refuses(parameter.value) if live is not None else None
            if reason is not None:
                return SetParametersResult(successful=False, reason=f"{parameter.name} {reason}")
        return SetParametersResult(successful=True)

    def _apply_set(self, parameters: list[Parameter]) -> None:
        for parameter in parameters:
            live = self._live.get(parameter.name)
            if live is not None:
                live[1](parameter.value)


#: The descriptor's type of a parameter, by its default's Python type.
_TYPES = {
    bool: ParameterType.PARAMETER_BOOL,
    int: ParameterType.PARAMETER_INTEGER,
    float: ParameterType.PARAMETER_DOUBLE,
    str: ParameterType.PARAMETER_STRING,
}

"""Domain exceptions of the Swazure core, under one base class."""


class SwazureError(Exception):
    """Base of every error the Swazure core raises about its input."""


class RunError(SwazureError):
    """A run that started and could not finish: a swarm that stalled, a process that
    died, no answer in time. The command line exits 1 for it, 2 for any other error
    (the command line or its files are unusable)."""


class CloudError(SwazureError, ValueError):
    """A point cloud that cannot be read or used (file, format, values)."""


class OptionError(SwazureError, ValueError):
    """A run's option that is none of its choices, out of its range, or of the wrong kind."""


class SensorError(SwazureError, ValueError):
    """A sensor description that does not parse or is inconsistent."""


class OutputError(SwazureError, OSError):
    """A result that cannot be written (folder, permissions, disk)."""


class UnknownFlsError(SwazureError, KeyError):
    """An FLS id that does not exist in the swarm."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "unknown FLS"


class MessageError(SwazureError, ValueError):
    """A message from the network that is dropped: its ``reason`` in one short phrase."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason

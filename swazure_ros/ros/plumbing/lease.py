"""The DDS lease of this process's participant: how long its peers wait for its announcements.

Fast DDS drops a peer it has not heard from for the peer's lease (20 s by
default, announced every 3 s). A process that knows its own lease knows when
a stall of its own was long enough for its peers to have dropped it
(docs/protocol.md, "Coming back"). The lease is Fast DDS's default, or the
default participant profile's of the XML file Fast DDS loads
(``FASTRTPS_DEFAULT_PROFILES_FILE``, else ``DEFAULT_FASTRTPS_PROFILES.xml`` in
the working folder), as ``config/fastdds.xml`` sets it. Every participant of
a swarm must have the same (../shared/notes/liveness-and-apis.md).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

#: Fast DDS's own lease and announcement period, s, where no profile sets them.
DEFAULT_LEASE = 20.0
DEFAULT_ANNOUNCEMENT = 3.0
#: Where Fast DDS 2.x finds its XML profiles.
PROFILES_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"
PROFILES_IN_FOLDER = "DEFAULT_FASTRTPS_PROFILES.xml"
_PROFILES = "{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}"


@dataclass(frozen=True)
class Lease:
    """A participant's lease and how often it announces itself, s (inf: never dropped)."""

    duration: float = DEFAULT_LEASE
    announcement: float = DEFAULT_ANNOUNCEMENT

    @property
    def silence(self) -> float:
        """Seconds of silence after which a peer may have dropped it: the lease less the
        time its last announcement can have come before the silence began."""
        return max(self.duration - self.announcement, 0.0)


def profiles_file(environ: Mapping[str, str] = os.environ, folder: Path | None = None) -> Path:
    """The XML profiles file Fast DDS 2.x loads: ``environ``'s PROFILES_VARIABLE, else
    PROFILES_IN_FOLDER in ``folder`` (default the working folder), which may not exist."""
    named = environ.get(PROFILES_VARIABLE)
    return Path(named) if named else (folder or Path.cwd()) / PROFILES_IN_FOLDER


def participant_lease(
    environ: Mapping[str, str] = os.environ, folder: Path | None = None
) -> Lease:
    """The lease this process's participants have: the profiles file's, or Fast DDS's default.

    A file that cannot be read or does not set them leaves Fast DDS's
    defaults (Fast DDS itself says what is wrong with a bad file).
    """
    path = profiles_file(environ, folder)
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError):
        return Lease()
    for profile in root.iter():
        if _tag(profile) == "participant" and profile.get("is_default_profile") == "true":
            return Lease(
                _duration(profile, "leaseDuration", DEFAULT_LEASE),
                _duration(profile, "leaseAnnouncement", DEFAULT_ANNOUNCEMENT),
            )
    return Lease()


def _tag(element: ElementTree.Element) -> str:
    return element.tag.removeprefix(_PROFILES)


def _duration(profile: ElementTree.Element, name: str, default: float) -> float:
    """The duration ``name`` (sec, nanosec; DURATION_INFINITY) under ``profile``, s."""
    found = next((one for one in profile.iter() if _tag(one) == name), None)
    if found is None:
        return default
    parts = {_tag(one): (one.text or "").strip() for one in found}
    if "DURATION_INFINITY" in parts.values():
        return math.inf
    try:
        seconds = float(parts.get("sec", "0") or 0) + float(parts.get("nanosec", "0") or 0) / 1e9
    except ValueError:
        return default
    return seconds if math.isfinite(seconds) and seconds > 0.0 else default

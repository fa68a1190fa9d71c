"""Many DDS participants of one domain on one host: unicast ports for each.

Fast DDS opens a participant's unicast ports at its participant id's place in
the domain's port range and, where another process holds them, tries the next
id, at most ``mutation_tries`` times (100 by default). A domain's 102nd
participant on a host therefore opens no metatraffic port: it hears no
endpoint discovery, and through a discovery server nothing at all. Measured on
2026-12-05: of 102 FLS processes on one host the last two never got a camera
frame, and ``ss -uln`` showed their user ports but no metatraffic ports.

Every process of a swarm loads :data:`PROFILE`, which tries 1000 ids, unless
the user names profiles of their own; ``config/fastdds.xml`` tries as many.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from .lease import PROFILES_VARIABLE, profiles_file

#: The swarm's Fast DDS profile: more participant ids tried, nothing else changed.
PROFILE = Path(__file__).with_name("participants.xml")


def profile_environment(
    environ: Mapping[str, str] = os.environ, folder: Path | None = None
) -> dict[str, str]:
    """The environment that makes Fast DDS load :data:`PROFILE`, where it would load none.

    Parameters
    ----------
    environ : mapping of str to str, optional
        The process's environment (default ``os.environ``).
    folder : Path, optional
        The process's working folder (default the current one).

    Returns
    -------
    dict of str to str
        ``{PROFILES_VARIABLE: PROFILE}``; empty where ``environ`` names a
        profiles file or ``folder`` holds Fast DDS's default one: the user's
        profiles are loaded as they are.
    """
    if environ.get(PROFILES_VARIABLE) or profiles_file(environ, folder).exists():
        return {}
    if not PROFILE.exists():  # an installation without its package data: Fast DDS's defaults
        return {}
    return {PROFILES_VARIABLE: str(PROFILE)}


def load_with_swarm_profile() -> None:
    """Set this process's environment so that its participants load :data:`PROFILE`.

    Called before this process's first participant: Fast DDS reads its
    profiles once, when it makes the first.
    """
    os.environ.update(profile_environment())

"""The lease a process's participant has: Fast DDS's default, or its profiles file's."""

from __future__ import annotations

import math

from swazure_ros.ros.plumbing.lease import (
    DEFAULT_ANNOUNCEMENT,
    DEFAULT_LEASE,
    PROFILES_IN_FOLDER,
    PROFILES_VARIABLE,
    Lease,
    participant_lease,
)

from ...conftest import REPO

PROFILE = """<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <participant profile_name="other"><rtps><builtin><discovery_config>
      <leaseDuration><sec>99</sec></leaseDuration>
    </discovery_config></builtin></rtps></participant>
    <participant profile_name="ours" is_default_profile="true"><rtps><builtin><discovery_config>
      <leaseDuration><sec>{sec}</sec><nanosec>500000000</nanosec></leaseDuration>
      {announcement}
    </discovery_config></builtin></rtps></participant>
  </profiles>
</dds>
"""


def test_the_projects_short_lease_profile_reads_as_five_seconds_announced_every_second():
    lease = participant_lease({PROFILES_VARIABLE: str(REPO / "config" / "fastdds.xml")})
    assert lease == Lease(5.0, 1.0) and lease.silence == 4.0


def test_without_a_profile_the_lease_is_fast_ddss_default(tmp_path):
    assert participant_lease({}, folder=tmp_path) == Lease(DEFAULT_LEASE, DEFAULT_ANNOUNCEMENT)
    assert Lease().silence == DEFAULT_LEASE - DEFAULT_ANNOUNCEMENT


def test_the_default_profile_of_the_file_is_read_with_its_nanoseconds(tmp_path):
    (tmp_path / PROFILES_IN_FOLDER).write_text(PROFILE.format(sec=7, announcement=""))
    assert participant_lease({}, folder=tmp_path) == Lease(7.5, DEFAULT_ANNOUNCEMENT)


def test_an_infinite_lease_is_never_dropped(tmp_path):
    path = tmp_path / "p.xml"
    path.write_text(PROFILE.format(sec="DURATION_INFINITY", announcement=""))
    lease = participant_lease({PROFILES_VARIABLE: str(path)})
    assert math.isinf(lease.duration) and math.isinf(lease.silence)


def test_a_file_that_cannot_be_read_leaves_the_defaults(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text("<dds><profiles>")
    for path in (bad, tmp_path / "absent.xml"):
        assert participant_lease({PROFILES_VARIABLE: str(path)}) == Lease()
    worse = tmp_path / "worse.xml"
    worse.write_text(PROFILE.format(sec="soon", announcement="<leaseAnnouncement/>"))
    assert participant_lease({PROFILES_VARIABLE: str(worse)}) == Lease()

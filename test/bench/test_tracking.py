"""bench.tracking: one scenario's core tracks and the trio's track over ROS 2."""

from argparse import Namespace

from bench.tracking import TRACK_RUNS, TRACK_SCENARIOS, tracking_section

from .tables import check_shape


def test_the_tracking_section_gives_each_estimators_errors_and_the_ros_tracks_identity(domain):
    trio = [run for run in TRACK_RUNS if run[3] == "trio"]
    lines = tracking_section(
        Namespace(beta=0.5), scenarios=TRACK_SCENARIOS[:1], runs=trio, domain=domain
    )
    (header, core), (_, [ros]) = check_shape(lines)
    assert header[:4] == ["trajectory", "error model", "delay s", "model"]
    assert len(core) == 8 and {row[0] for row in core} == {"constant velocity"}
    means = {row[1]: [float(cell.split(" (")[0]) for cell in row[4:]] for row in core}
    assert all(mean >= 0 for mean in means["off"]) and any(mean > 0 for mean in means["on"])
    assert ros[0] == "trio" and ros[2] == "3" and ros[-1] == "yes", ros

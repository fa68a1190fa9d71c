"""bench.scale: one small evaluation timed, pairs written in blocks, and the section's tables."""

from bench.scale import (
    SCALE_FIXED_CLOUDS,
    SCALE_FIXED_MEMORY,
    scale_figure,
    scale_identity,
    scale_lines,
    scale_run,
)

from .tables import check_shape


def test_the_scale_section_times_an_evaluation_checks_blocks_and_renders_its_targets(tmp_path):
    row = scale_run("torus:200", None, tmp_path)
    assert row["flss"] == 200 and row["pairs"] > 0 and row["csv_bytes"] > 0 and row["peak"] > 0
    identity = scale_identity(("torus:200",), tmp_path)
    assert identity == [("torus:200", True, True)]
    # The targets name the clouds the whole section measures: this row stands in for each.
    named = ("racecar_3720", "torus:65536", "racecar_65536")
    rows = [{**row, "cloud": cloud} for cloud in named]
    rows += [{**row, "cloud": cloud, "memory": SCALE_FIXED_MEMORY} for cloud in SCALE_FIXED_CLOUDS]
    lines = scale_lines(rows, identity)
    timed, blocks = check_shape(lines)
    assert len(timed[1]) == 7 and timed[1][0][:2] == ["racecar_3720", "200"]
    assert blocks[1] == [["torus:200", "yes", "yes"]]
    assert sum(line.startswith("- ") for line in lines) == 5  # the targets
    scale_figure(rows, tmp_path / "engine-scale.png")
    assert (tmp_path / "engine-scale.png").read_bytes().startswith(b"\x89PNG")

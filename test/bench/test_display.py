"""bench.display: a small swarm's runs timed, compared with the held run, tabled and plotted."""

import argparse
import json

import pytest

from bench.display import (
    display_cloud,
    display_figure,
    display_lines,
    display_run,
    display_section,
)

from .tables import check_shape


@pytest.mark.bench_section
def test_the_display_section_times_each_run_and_finds_it_identical_to_the_held_one(tmp_path):
    # Two of the section's runs (each is a process and its held twin): plain and a heuristic.
    rows = [display_run("torus", 200, run, tmp_path) for run in ("plain", "move-obstructing")]
    assert all(row.exit_code == 0 and row.flss == 200 and row.pairs > 0 for row in rows)
    # Each run made in blocks equals the same run with every pair held at once.
    assert [row.identical for row in rows] == ["yes", "yes"]
    assert rows[0].pairs_sha != rows[1].pairs_sha  # the heuristic moved FLSs
    # Above the held size no reference is made, and the row says so.
    assert display_run("torus", 200, "plain", tmp_path, held_up_to=100).identical == "-"
    lines = display_lines(rows)
    [(_header, table)] = check_shape(lines)
    assert len(table) == 2 and table[0][:3] == ["torus", "200", "plain"]
    assert sum(line.startswith("- ") and "not measured" in line for line in lines) == 3
    display_figure(rows, tmp_path / "display-scale.png")
    assert (tmp_path / "display-scale.png").read_bytes().startswith(b"\x89PNG")


def test_the_race_car_is_the_published_cloud_at_its_size_and_resampled_at_the_others():
    assert display_cloud("racecar", 3720) == ("--cloud", "racecar")
    assert display_cloud("racecar", 65536) == ("--cloud", "racecar", "--resample", "65536")
    assert display_cloud("torus", 30000) == ("--cloud", "torus:30000")


@pytest.mark.bench_section
def test_the_section_runs_the_sizes_asked_for_and_records_each_row_as_it_is_made(tmp_path):
    args = argparse.Namespace(beta=0.5, display_sizes=[150, 200])
    lines = display_section(args, shapes=("torus",), runs=("plain",), figures=tmp_path,
                            records_dir=tmp_path, held_up_to=0)  # fmt: skip
    records = json.loads((tmp_path / "display.json").read_text())
    assert [(row["shape"], row["size"], row["run"]) for row in records] == [
        ("torus", 150, "plain"),
        ("torus", 200, "plain"),
    ]
    [(_header, table)] = check_shape(lines)
    # A torus of about the size asked for: the table gives the FLSs it has.
    assert [row[1] for row in table] == [str(row["flss"]) for row in records] == ["147", "200"]
    assert (tmp_path / "display-scale.png").read_bytes().startswith(b"\x89PNG")


def test_two_runs_compare_their_summaries_without_time_or_the_folder_of_their_cloud(tmp_path):
    from bench.display import summary_to_compare

    def summary(folder, seconds, pairs):
        cloud = f"/{folder}/racecar_3720_resampled_10000.xyz"
        document = {"seconds": seconds, "parameters": {"cloud_source": cloud}, "pairs": pairs}
        path = tmp_path / f"{folder}-{seconds}-{pairs}.json"
        path.write_text(json.dumps(document))
        return summary_to_compare(path)

    # Each run writes the resampled cloud into its own --out: the same cloud, the same run.
    assert summary("blocks", 1.0, 7) == summary("held", 2.5, 7)
    assert summary("blocks", 1.0, 7) != summary("held", 1.0, 8)

"""bench.labels: what each FLS of a small spread-out torus holds in one discovery."""

from argparse import Namespace

import pytest

from bench.labels import labels_lines, labels_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_labels_section_measures_two_small_spread_out_tori(tmp_path):
    lines = labels_section(
        Namespace(beta=0.5), runs=(("torus:120", 3.0), ("torus:400", 3.0)), figures=tmp_path,
        records_dir=tmp_path,
    )  # fmt: skip
    [(header, rows)] = check_shape(lines)
    assert header[:3] == ["shape", "scale", "FLSs"] and header[-1] == "identical"
    assert [row[0] for row in rows] == ["torus:120", "torus:400"]
    for row in rows:
        flss, fullest = int(row[2].replace(",", "")), int(row[8].replace(",", ""))
        assert 0 < fullest <= flss and int(row[5]) > 0  # labels, rounds
        assert row[-1] == "yes"
    assert (tmp_path / "labels-reach.png").read_bytes().startswith(b"\x89PNG")


def test_a_stopped_labels_run_says_why_in_its_row():
    stopped = {"cloud": "torus:30000", "scale": 3.0, "stopped": "exit -9: killed"}
    [(_, [row])] = check_shape(labels_lines([stopped]))
    assert row[:3] == ["torus:30000", "3.0", "stopped: exit -9: killed"]

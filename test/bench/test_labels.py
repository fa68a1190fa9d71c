"""bench.labels: what each FLS of a small spread-out torus and pendant grid holds in one
discovery, and the pendant grid itself."""

from argparse import Namespace

import numpy as np
import pytest

from bench.labels import LabelRun, labels_lines, labels_section, pendant_grid
from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.core.evaluation import DECAYING_PATH, REASON_NO_SWEET_PATH
from swazure_ros.core.sensor import BLIND, SWEET
from swazure_ros.sim.world import WorldSpec

from .tables import check_shape


@pytest.mark.bench_section
def test_the_labels_section_measures_a_spread_out_torus_and_a_pendant_grid(tmp_path):
    runs = (LabelRun("torus:120", 3.0), LabelRun("pendant-grid:10", 1.0, 0.5))
    lines = labels_section(Namespace(beta=0.5), runs, figures=tmp_path, records_dir=tmp_path)
    [(header, rows)] = check_shape(lines)
    assert header[:3] == ["shape", "scale", "FLSs"] and header[-1] == "identical"
    assert [row[0] for row in rows] == ["torus:120", "pendant-grid:10"]
    for row in rows:
        flss, fullest = int(row[2].replace(",", "")), int(row[8].replace(",", ""))
        assert 0 < fullest <= flss and int(row[5]) > 0  # labels, rounds
        assert row[-1] == "yes"
    assert (tmp_path / "labels-reach.png").read_bytes().startswith(b"\x89PNG")


def test_a_stopped_labels_run_says_why_in_its_row():
    stopped = {"cloud": "torus:30000", "scale": 3.0, "stopped": "exit -9: killed"}
    [(_, [row])] = check_shape(labels_lines([stopped]))
    assert row[:3] == ["torus:30000", "3.0", "stopped: exit -9: killed"]


def test_a_pendant_grid_s_pendants_have_no_sweet_hop_and_are_blind_to_the_fls_below(tmp_path):
    world = WorldSpec(str(pendant_grid(10, tmp_path / "grid.xyz")), scale=1.0, radius=0.5).build()
    assert world.swarm.size == 100 + 9  # every third FLS of every third row has a pendant
    pairs = world.hood.pairs
    sweet = pairs.range_class == SWEET
    pendant = np.arange(world.swarm.size) >= 100
    # Grid FLSs are sweet to their four neighbours only; no pendant is sweet to any FLS.
    assert (
        sweet.sum() == 2 * 10 * 9
        and not (pendant[pairs.first] | pendant[pairs.second])[sweet].any()
    )
    blind = pairs.range_class == BLIND
    assert blind.sum() == 9 and (pendant[pairs.first] ^ pendant[pairs.second])[blind].all()
    engine = evaluate_pairs(world.hood, "shortest-length")
    assert len(engine) == 18
    assert (engine.status == DECAYING_PATH).all() and (engine.reason == REASON_NO_SWEET_PATH).all()

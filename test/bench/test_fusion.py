"""bench.fusion: multi-path fusion on a small torus, and a row without fused pairs."""

from argparse import Namespace
from dataclasses import replace

from bench.fusion import fusion_row, fusion_section
from bench.policies import POLICY_SENSORS
from swazure_ros import api

from .tables import cells, check_shape


def test_the_fusion_section_fuses_up_to_k_paths_on_a_small_torus():
    published = {"published": POLICY_SENSORS["published"]}
    lines = fusion_section(
        Namespace(beta=0.5), shapes=("torus:200",), sensors=published,
        policies=("shortest-length",), fused=(2,),
    )  # fmt: skip
    [(header, [row])] = check_shape(lines)
    assert header[:4] == ["shape", "sensor", "policy", "K"]
    assert row[:4] == ["torus:200", "published", "shortest-length", "2"]
    assert int(row[4].replace(",", "")) > 0 and " -> " in row[5]  # pairs fused
    assert 0 <= float(row[7]) <= 100 and float(row[8]) > 0


def test_a_run_without_fusion_leaves_its_cells_blank():
    plain = api.evaluate(api.build_swarm("torus:120", scale=1.6, beta=0.5)).summary
    summary = replace(plain, seconds=1.5, pairs=replace(plain.pairs, within_predicted_pct=71.25))
    row = cells(fusion_row("chess_408", "published", "least-error", 1, summary))
    assert row == ["chess_408", "published", "least-error", "1", "-", "-", "-", "71.2", "1.50",
                   "-"]  # fmt: skip

"""bench.least_squares: the fit beside the path sums on a small torus, and each source's own."""

from argparse import Namespace

import pytest

from bench.least_squares import FIT_SENSORS, least_squares_section

from .tables import check_shape, tables


@pytest.mark.bench_section
def test_the_least_squares_section_measures_a_small_torus_globally_and_locally(tmp_path):
    wide = {"wide, calibrated": FIT_SENSORS["wide, calibrated"]}
    lines = least_squares_section(
        Namespace(beta=0.5), shapes=("torus:150",), sensors=wide, betas=(0.5,),
        local_sources=5, figures=tmp_path, records_dir=tmp_path,
    )  # fmt: skip
    # The targets' table is left out: a cell of it holds "|NEES - 3|", pipes and all.
    end = lines.index("Against issue 33's targets, over every cell above:")
    fits, outliers, local = check_shape(lines[:end])
    [targets] = tables(lines[end:])
    assert fits[0][:3] == ["shape", "sensor", "beta"]
    [fit] = fits[1]
    assert fit[:3] == ["torus:150", "wide, calibrated", "0.5"]
    # NEES %, then two times in s, shown to 0.1 s: on a small torus one may show as 0.0.
    assert float(fit[9]) > 0 and float(fit[10]) >= 0 and float(fit[11]) >= 0
    [outlier] = outliers[1]
    assert outlier[0] == "torus:150" and int(outlier[-1].replace(",", "")) > 0  # down-weighted
    [own] = local[1]
    assert own[0] == "torus:150" and float(own[1].split(" / ")[0]) > 1  # FLSs in a window
    assert len(targets[1]) == 11 and all(" of " in row[1] for row in targets[1])
    assert (tmp_path / "least-squares.json").exists()
    assert (tmp_path / "least-squares.png").read_bytes().startswith(b"\x89PNG")

"""bench.policies: the three path policies' errors and times on a small torus."""

from argparse import Namespace

import pytest

from bench.policies import POLICY_SENSORS, policies_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_policies_section_sets_least_error_beside_the_papers_two_policies():
    published = {"published": POLICY_SENSORS["published"]}
    lines = policies_section(
        Namespace(beta=0.5), shapes=("torus:200",), betas=(0.5,), sensors=published
    )
    [(header, [row])] = check_shape(lines)
    assert header[:3] == ["shape", "β", "sensor"]
    assert row[:3] == ["torus:200", "0.5", "published"]
    errors = [float(one) for one in row[3].split(" / ")]
    assert len(errors) == 3 and all(one > 0 for one in errors)  # FH, SL, LE
    assert row[5] in ("yes", "**no**") and float(row[7]) > 0

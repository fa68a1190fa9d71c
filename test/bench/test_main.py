"""python -m bench: every section has its module and a smoke test of its own."""

from pathlib import Path

import bench.__main__ as cli

HERE = Path(__file__).parent


def test_every_section_of_the_bench_has_its_module_and_a_smoke_test():
    for name, section in cli.SECTIONS.items():
        assert section.__module__ == f"bench.{name}", name
        assert (HERE / f"test_{name}.py").exists(), name

"""bench.compat: a narrow study's heuristics as the text has them beside the published code."""

from argparse import Namespace

from bench.compat import compat_section

from .tables import check_shape


def test_the_compat_section_sets_the_texts_numbers_beside_the_published_codes(tmp_path):
    narrow = ["--clouds", "torus:200", "--heuristic-betas", "0.5", "--techniques", "move-source:2"]
    lines = compat_section(Namespace(beta=0.5), betas=("0.5",), options=narrow,
                           records_dir=tmp_path)  # fmt: skip
    assert "--compat published" in lines[2] and "torus:200" in lines[2]
    [(header, rows)] = check_shape(lines)
    assert header[:3] == ["shape", "β", "heuristic"]
    assert rows and all(row[0] == "torus_200" and row[1] == "0.5" for row in rows)
    assert all(len(row[3].split(" / ")) == 2 for row in rows)  # text / published

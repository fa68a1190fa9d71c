"""Clouds by name, by file and resampled: a name is not hidden by a folder, a resampled
cloud written in its original's format reads back as the same points."""

import numpy as np
import pytest

from swazure_ros.core.clouds import Cloud
from swazure_ros.core.errors import CloudError
from swazure_ros.files.cloud_files import (
    load_cloud,
    read_resampled,
    resampled_cloud,
    write_cloud,
)


@pytest.mark.parametrize("suffix", [".xyz", ".txt", ".csv", ".npy", ".ply"])
def test_a_resampled_cloud_is_written_in_its_original_s_format_and_reads_back_exactly(
    tmp_path, suffix
):
    points = load_cloud("torus:120").points * 3.0
    original = Cloud("shape", points, 3.0, str(tmp_path / f"shape{suffix}"))
    grown = resampled_cloud(original, 300, seed=4)
    path = write_cloud(tmp_path / "out", grown)
    assert path == tmp_path / "out" / f"shape_resampled_300{suffix}"
    back = load_cloud(path)
    assert (back.scale, back.name) == (1.0, "shape_resampled_300")
    np.testing.assert_array_equal(back.points, grown.points)
    again = read_resampled(original, 300, 4, path)
    assert again.resampled == grown.resampled and again.source == str(path)


def test_a_built_in_shape_resampled_is_written_as_xyz(tmp_path):
    grown = resampled_cloud(load_cloud("sphere:100"), 120)
    assert write_cloud(tmp_path, grown).name == "sphere_100_resampled_120.xyz"
    assert grown.resampled is not None and grown.resampled.cloud_source == "builtin"


def test_a_folder_named_like_a_cloud_does_not_hide_the_cloud(tmp_path, monkeypatch):
    # `swazure evaluate --cloud chess --out chess` makes a folder `chess`: running
    # `--cloud chess` there again must read the chess piece, not refuse the folder.
    published = tmp_path / "published"
    published.mkdir()
    (published / "chess_408.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    monkeypatch.setenv("SWAZURE_DATASETS", str(published))
    here = tmp_path / "here"
    for name in ("chess", "chess_408", "chess_408.xyz", "torus"):
        (here / name).mkdir(parents=True)
    monkeypatch.chdir(here)
    for name in ("chess", "chess_408", "chess_408.xyz"):
        cloud = load_cloud(name)
        assert (cloud.name, cloud.source) == ("chess_408", str(published / "chess_408.xyz"))
    torus = load_cloud("torus")
    assert (torus.name, torus.source) == ("torus", "builtin")


def test_a_folder_that_names_no_cloud_is_still_refused_as_a_folder(tmp_path, monkeypatch):
    (tmp_path / "runs").mkdir()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(CloudError, match=r"^runs: is a folder, expected a point cloud file$"):
        load_cloud("runs")

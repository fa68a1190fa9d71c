import numpy as np
import pytest
from scipy.spatial import cKDTree

from swazure_ros.core.clouds import BUILTIN_SHAPES, PUBLISHED_DENSITY
from swazure_ros.core.errors import CloudError
from swazure_ros.files.cloud_files import load_cloud, read_points

from ..conftest import dataset

POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [4.0, 5.0, 6.5]])


def test_xyz_csv_npy_and_ply_read_the_same_points(tmp_path):
    (tmp_path / "c.xyz").write_text("\n".join(" ".join(map(str, p)) for p in POINTS))
    (tmp_path / "c.csv").write_text("x,y,z\n" + "\n".join(",".join(map(str, p)) for p in POINTS))
    np.save(tmp_path / "c.npy", POINTS)
    from plyfile import PlyData, PlyElement

    vertex = np.array([tuple(p) for p in POINTS], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    PlyData([PlyElement.describe(vertex, "vertex")], text=False).write(str(tmp_path / "b.ply"))
    PlyData([PlyElement.describe(vertex, "vertex")], text=True).write(str(tmp_path / "a.ply"))
    for name in ("c.xyz", "c.csv", "c.npy", "b.ply", "a.ply"):
        np.testing.assert_array_equal(read_points(tmp_path / name, scale=2.0), POINTS * 2.0)


def test_published_scale_is_the_default_for_published_files():
    cloud = load_cloud(dataset("chess_408.xyz"))
    assert cloud.scale == 13.6
    assert cloud.points.shape == (408, 3)


@pytest.mark.parametrize("name", sorted(BUILTIN_SHAPES))
def test_builtin_shapes_have_the_published_density(name):
    points = load_cloud(name).points
    distances, _ = cKDTree(points).query(points, k=2)
    assert distances[:, 1].mean() == pytest.approx(PUBLISHED_DENSITY, rel=1e-9)


def test_builtin_shape_with_a_count():
    assert len(load_cloud("sphere:123").points) == 123


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("1 2 3\n4 5\n", "line 2 has 2 columns, expected 3"),
        ("1 2 3 4\n", "has 4 columns, expected 3"),
        ("1 2 3\nnan 1 1\n", "point 1 has a NaN or infinite coordinate"),
        ("1 2 3\n1 inf 1\n", "point 1 has a NaN or infinite coordinate"),
        ("1 2 3\n", "at least two points, got 1"),
        ("", "no points in file"),
        ("1 2 x\n3 4 5\n", "line 1: could not convert"),
    ],
)
def test_bad_text_clouds(tmp_path, content, message):
    path = tmp_path / "bad.xyz"
    path.write_text(content)
    with pytest.raises(CloudError, match=message):
        read_points(path)


def test_missing_file_and_unknown_shape(tmp_path):
    with pytest.raises(CloudError, match="no such file"):
        read_points(tmp_path / "absent.xyz")
    with pytest.raises(CloudError, match="unknown shape 'dodecahedron'"):
        load_cloud("dodecahedron")


def test_a_resampled_cloud_has_the_count_and_spacing_asked_for_and_is_the_same_each_time():

    from swazure_ros.core.clouds import mean_spacing, resample

    points = load_cloud("sphere:200").points
    grown = resample(points, 1000, seed=3)
    assert grown.shape == (1000, 3)
    assert mean_spacing(grown) == pytest.approx(mean_spacing(points), rel=1e-12)
    # Poisson-disk thinning: no two points much closer than the original's spacing allows.
    nearest, _ = cKDTree(grown).query(grown, k=2)
    assert nearest[:, 1].min() > 0.6 * mean_spacing(points)
    # The shape grew: a larger sphere, its points still on one shell around the centre.
    radii = np.linalg.norm(grown - grown.mean(axis=0), axis=1)
    assert radii.mean() > 2 * np.linalg.norm(points - points.mean(axis=0), axis=1).mean()
    assert radii.std() < 0.05 * radii.mean()
    np.testing.assert_array_equal(resample(points, 1000, seed=3), grown)


@pytest.mark.parametrize("shape", ["random", "lattice"])
def test_thinning_over_listed_pairs_keeps_what_thinning_over_the_grid_keeps(shape):
    from swazure_ros.core import clouds
    from swazure_ros.core.grid import grid_of

    rng = np.random.default_rng(7)
    if shape == "random":
        points = rng.uniform(0.0, 6.0, size=(2000, 3))
    else:
        # Whole-number places: many pairs exactly a spacing apart, a tie both must keep.
        points = np.argwhere(np.ones((9, 9, 9))).astype(float)
    order = rng.permutation(len(points))
    earlier = clouds._earlier_within(points, order, 1.5)
    kept = {}
    for spacing in (0.3, 0.7, 1.0, 1.2, 1.49):
        expected = clouds._apart(points, order, spacing, grid_of(points, spacing))
        listed = np.empty(len(points), dtype=bool)
        listed[order[::-1]] = clouds._apart_listed(earlier.points, *earlier.pairs, spacing)
        np.testing.assert_array_equal(listed, expected)
        kept[spacing] = int(expected.sum())
    assert kept[1.49] < kept[1.2] < kept[0.3]
    if shape == "lattice":
        assert kept[1.0] == len(points)  # points exactly a spacing apart are apart


def test_a_resampled_cloud_is_the_same_whether_its_close_points_are_listed_or_not(monkeypatch):
    from swazure_ros.core import clouds

    points = load_cloud("sphere:200").points
    listed = clouds.resample(points, 1500, seed=5)
    # A bracket never that close: every bisection thins over the grid.
    monkeypatch.setattr(clouds, "LISTED_RATIO", 0.0)
    np.testing.assert_array_equal(clouds.resample(points, 1500, seed=5), listed)


def test_sphere_shell_is_the_sphere_by_the_name_display_studies_use():
    np.testing.assert_array_equal(
        load_cloud("sphere_shell:300").points, load_cloud("sphere:300").points
    )


def test_a_published_cloud_by_name_is_read_from_the_published_folder(monkeypatch):
    path = dataset("dragon_1147.xyz")
    monkeypatch.setenv("SWAZURE_DATASETS", str(path.parent))
    for name in ("dragon", "dragon_1147", "dragon_1147.xyz"):
        cloud = load_cloud(name)
        assert (cloud.name, cloud.source, cloud.scale) == ("dragon_1147", str(path), 40.0)
        np.testing.assert_array_equal(cloud.points, load_cloud(path).points)


def test_nearest_distances_pair_by_pair_are_the_k_d_trees_to_the_last_bit():
    from swazure_ros.core.clouds import nearest_distances

    rng = np.random.default_rng(7)
    sizes = (8, 100, 700)
    clouds = [load_cloud(f"{shape}:{size}").points for shape in BUILTIN_SHAPES for size in sizes]
    for count in (2, 3, 50, 300, 513):
        points = rng.normal(size=(count, 3)) * 37.0
        points[-1] = points[0]  # a repeated point is 0 from its twin
        clouds += [points, np.round(points, 1)]  # rounded: ties
    for points in clouds:
        expected, _ = cKDTree(points).query(points, k=2)
        np.testing.assert_array_equal(nearest_distances(points, rows=64), expected[:, 1])


def test_a_process_that_makes_a_small_built_in_shape_never_imports_scipy():
    # Every process of one FLS makes its swarm's shape; scipy.spatial's import alone
    # would cost it about 0.45 CPU-s and 35 MB.
    import subprocess
    import sys

    program = (
        "import sys; from swazure_ros.files.description import SwarmDescription; "
        "swarm = SwarmDescription('torus:100', scale=1.6, beta=0.5).assigned(); "
        "print(len(swarm.points), sum(m.startswith('scipy') for m in sys.modules))"
    )
    run = [sys.executable, "-c", program]
    out = subprocess.run(run, capture_output=True, text=True, check=True)
    # torus:100 makes 102 points; no module of scipy loaded (before: 196).
    assert out.stdout.split() == ["102", "0"], out.stdout + out.stderr

"""Point clouds from files (.xyz, .csv, .npy, .ply) or built-in shapes, by name.

Every loader returns an ``(N, 3)`` float array in centimetres (file
coordinates times ``scale``) and raises :class:`CloudError` with a one-line
message naming the file when the input cannot be used. A cloud resampled to
another size (``--resample``: :func:`resampled_cloud`) is written by
:func:`write_cloud` in its original's format, exactly, to be read back with
``--cloud FILE``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..core.arrays import FloatArray
from ..core.clouds import (
    BUILTIN_SHAPES,
    PUBLISHED_SCALES,
    Cloud,
    Resampled,
    builtin_points,
    mean_spacing,
    resample,
    validate_points,
)
from ..core.errors import CloudError
from .atomic import atomic_write
from .reading import regular_file

SUFFIXES = (".xyz", ".txt", ".csv", ".npy", ".ply")
#: Bytes of a point cloud file, at most (MAX_POINTS points take a few MB as text).
MAX_CLOUD_BYTES = 256 * 2**20


#: Where the six published clouds come from: the reference implementation's repository
#: (README, "The published clouds").
PUBLISHED_CLOUDS_URL = "https://github.com/flyinglightspeck/Swazure/tree/HEAD/src/assets"
#: The folder beside the source checkout where they are looked for, after $SWAZURE_DATASETS.
_BESIDE_CHECKOUT = Path(__file__).resolve().parents[3] / "shared" / "datasets" / "swazure-paper"


def _dataset_candidates() -> list[Path]:
    """The folders the published clouds are looked for in, in order."""
    if "SWAZURE_DATASETS" in os.environ:
        # Set, it is the one place: a study or a test can say "no published clouds".
        return [Path(os.environ["SWAZURE_DATASETS"])]
    relative = Path("shared", "datasets", "swazure-paper")
    return [_BESIDE_CHECKOUT, Path.cwd().parent / relative]


def published_dataset_dir() -> Path | None:
    """The folder of the six published clouds, or None when this machine has none.

    ``$SWAZURE_DATASETS`` when set (and only it); otherwise
    ``../shared/datasets/swazure-paper`` beside the source checkout, then
    beside the working directory.
    """
    for candidate in _dataset_candidates():
        if candidate.is_dir() and any(candidate.glob("*.xyz")):
            return candidate
    return None


def published_stem(name: str) -> str | None:
    """The published cloud's file stem that ``name`` names (``dragon``, ``dragon_1147``,
    ``dragon_1147.xyz``), or None."""
    stem = Path(name).name.removesuffix(".xyz")
    for published in PUBLISHED_SCALES:
        if stem in (published, published.rsplit("_", 1)[0]):
            return published
    return None


def download_hint(what: str = "them") -> str:
    """Where to download the published clouds, and the folder to put them in."""
    chosen = "SWAZURE_DATASETS" in os.environ
    return (
        f"download {what} from {PUBLISHED_CLOUDS_URL} into {_dataset_candidates()[0]} "
        + ("(the folder SWAZURE_DATASETS names)" if chosen else "(or set SWAZURE_DATASETS "
           "to another folder)")
    )  # fmt: skip


def where_to_get(stem: str) -> str:
    """One line: a published cloud is not here; where to download it, and where to put it."""
    return f"the published cloud {stem}.xyz is not on this machine: {download_hint('it')}"


def cloud_files(directory: Path) -> list[Path]:
    """Point cloud files in ``directory``, sorted by name."""
    return sorted(p for p in directory.iterdir() if p.is_file() and p.suffix.lower() in SUFFIXES)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_text(path: Path, delimiter: str | None) -> FloatArray:
    lines = [
        (number, line.strip())
        for number, line in enumerate(path.read_text().splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise CloudError(f"{path}: no points in file")
    header: list[str] | None = None
    first = lines[0][1].split(delimiter)
    if not any(_is_number(field) for field in first):
        header = [field.strip().lower() for field in first]
        lines = lines[1:]
        if not lines:
            raise CloudError(f"{path}: no points in file")
    columns = [0, 1, 2]
    if header is not None:
        if all(name in header for name in "xyz"):
            columns = [header.index(name) for name in "xyz"]
        elif len(header) != 3:
            raise CloudError(f"{path}: header has no x, y, z columns: {','.join(header)}")
    width = len(header) if header is not None else len(lines[0][1].split(delimiter))
    if header is None and width != 3:
        raise CloudError(f"{path}: line {lines[0][0]} has {width} columns, expected 3 (x y z)")
    rows = np.empty((len(lines), 3))
    for row, (number, line) in enumerate(lines):
        fields = line.split(delimiter)
        if len(fields) != width:
            raise CloudError(f"{path}: line {number} has {len(fields)} columns, expected {width}")
        try:
            rows[row] = [float(fields[column]) for column in columns]
        except ValueError as err:
            raise CloudError(f"{path}: line {number}: {err}") from err
    return rows


def _read_ply(path: Path) -> FloatArray:
    from plyfile import PlyData  # local: only PLY users pay for the import

    try:
        ply = PlyData.read(str(path))
        vertex = ply["vertex"]
        return np.column_stack([vertex[axis] for axis in "xyz"]).astype(np.float64)
    except KeyError as err:
        raise CloudError(f"{path}: PLY file has no vertex element with x, y, z") from err
    except Exception as err:  # plyfile raises several kinds for a broken file
        raise CloudError(f"{path}: not a readable PLY file ({err})") from err


def read_points(path: str | Path, scale: float = 1.0) -> FloatArray:
    """Read an (N, 3) point cloud from a file and multiply it by ``scale`` (to cm)."""
    path = Path(path)
    if not math.isfinite(scale) or scale <= 0:
        raise CloudError(f"scale must be a positive number, got {scale}")
    if not path.exists():
        stem = published_stem(path.name)
        if stem is not None and path.suffix.lower() == ".xyz":
            folder = published_dataset_dir()
            found = folder is not None and (folder / f"{stem}.xyz").is_file()
            hint = f"--cloud {stem} reads it from {folder}" if found else where_to_get(stem)
            raise CloudError(f"{path}: no such file; {hint}")
        raise CloudError(f"{path}: no such file")
    if path.is_dir():
        raise CloudError(f"{path}: is a folder, expected a point cloud file")
    regular_file(path, "point cloud", MAX_CLOUD_BYTES, CloudError)
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            try:
                raw: FloatArray = np.load(path, allow_pickle=False)
            except ValueError as err:
                raise CloudError(f"{path}: not a readable .npy array ({err})") from err
        elif suffix == ".ply":
            raw = _read_ply(path)
        elif suffix == ".csv":
            raw = _read_text(path, ",")
        elif suffix in (".xyz", ".txt"):
            raw = _read_text(path, None)
        else:
            raise CloudError(f"{path}: unknown file type {suffix!r}; use one of {SUFFIXES}")
    except OSError as err:
        raise CloudError(f"{path}: cannot read ({err.strerror or err})") from err
    except UnicodeDecodeError as err:
        raise CloudError(f"{path}: not a text file") from err
    return validate_points(validate_points(raw, str(path)) * scale, f"{path} at scale {scale:g}")


def _names_a_cloud(spec: str) -> bool:
    """True when ``spec`` is a published cloud's name or a built-in shape's."""
    return published_stem(spec) is not None or spec.partition(":")[0] in BUILTIN_SHAPES


def is_cloud_path(spec: str) -> bool:
    """True when ``spec`` names a file rather than a built-in shape or a published cloud.

    A folder does not hide a cloud's name: ``--out chess`` makes a folder ``chess``,
    and ``--cloud chess`` run there again must still read the chess piece.
    """
    path = Path(spec)
    if "/" in spec or path.suffix.lower() in SUFFIXES or path.is_file():
        return True
    return path.exists() and not _names_a_cloud(spec)


def load_cloud(spec: str | Path, scale: float | None = None) -> Cloud:
    """Resolve ``spec`` (a file path, a published cloud's name, or a built-in shape's) into a
    :class:`Cloud`.

    A published cloud's name (``dragon``, ``dragon_1147`` or ``dragon_1147.xyz``, where
    no such file is in the working folder) is read from
    :func:`published_dataset_dir`; CloudError says where to get it when it
    is not there. ``scale`` defaults to the published scale for the six published files
    (by file stem) and to 1 otherwise. Built-in shapes are already in cm.
    """
    text = str(spec)
    stem = published_stem(text)
    # A bare name that is no file here (dragon, dragon_1147.xyz) is a published cloud's,
    # even where a folder of that name is (an earlier run's --out dragon).
    by_name = stem is not None and "/" not in text and not Path(text).is_file()
    if not by_name and (isinstance(spec, Path) or is_cloud_path(text)):
        path = Path(text)
        if scale is None:
            scale = PUBLISHED_SCALES.get(path.stem, 1.0)
        return Cloud(path.stem, read_points(path, scale), scale, str(path))
    if stem is not None:
        # A published cloud by name (--cloud dragon): from the folder that holds them.
        folder = published_dataset_dir()
        if folder is None or not (folder / f"{stem}.xyz").is_file():
            raise CloudError(f"{text}: {where_to_get(stem)}")
        return load_cloud(folder / f"{stem}.xyz", scale)
    if text.partition(":")[0] not in BUILTIN_SHAPES:
        shapes, published = ", ".join(sorted(BUILTIN_SHAPES)), ", ".join(PUBLISHED_SCALES)
        raise CloudError(
            f"unknown shape {text!r}: use a file path, a built-in shape ({shapes}) or a "
            f"published cloud ({published})"
        )
    points = builtin_points(text)
    if scale is not None:
        if not math.isfinite(scale) or scale <= 0:
            raise CloudError(f"scale must be a positive number, got {scale}")
        points = validate_points(points * scale, f"{text} at scale {scale:g}")
    return Cloud(text.replace(":", "_"), points, 1.0 if scale is None else scale, "builtin")


def resampled_cloud(cloud: Cloud, count: int, seed: int = 0) -> Cloud:
    """``cloud`` resampled to ``count`` points at its own mean spacing
    (:func:`~swazure_ros.core.clouds.resample`, seeded): a display-size version.

    Parameters
    ----------
    cloud : Cloud
        The original, in cm.
    count : int
        Points wanted, ``core.clouds.MIN_RESAMPLE`` to ``MAX_POINTS``.
    seed : int, default 0
        Seed of the resampling's thinning order and choice of points.

    Returns
    -------
    Cloud
        Named ``NAME_resampled_COUNT``, in cm (scale 1), its ``resampled``
        saying what it came from; its source is the original's until
        :func:`write_cloud` writes it.

    Raises
    ------
    CloudError
        ``count`` out of range, or an original of fewer than seven points.
    """
    return _resampled(cloud, resample(cloud.points, count, seed), seed, cloud.source)


def read_resampled(cloud: Cloud, count: int, seed: int, path: Path) -> Cloud:
    """``cloud`` resampled as :func:`resampled_cloud` makes it, read from ``path``, where
    :func:`write_cloud` wrote it; CloudError when the file holds another number of points."""
    points = read_points(path)
    if len(points) != count:
        raise CloudError(f"{path}: {len(points)} points, the cloud resampled has {count}")
    return _resampled(cloud, points, seed, str(path))


def _resampled(cloud: Cloud, points: FloatArray, seed: int, source: str) -> Cloud:
    """The Cloud of ``cloud`` resampled to ``points`` (cm) with ``seed``, from ``source``."""
    count = len(points)
    origin = Resampled(cloud.name, cloud.source, cloud.scale, len(cloud.points), count, seed)
    return Cloud(f"{cloud.name}_resampled_{count}", points, 1.0, source, origin)


def cloud_file_suffix(source: str) -> str:
    """The suffix a resampled cloud is written with: its original file's, else .xyz."""
    suffix = Path(source).suffix.lower()
    return suffix if suffix in SUFFIXES else ".xyz"


def write_cloud(folder: Path, cloud: Cloud) -> Path:
    """Write a resampled ``cloud`` into ``folder`` as ``NAME.SUFFIX``, atomically, exactly.

    The format is the original file's (.xyz, .txt, .csv, .npy or .ply; a
    built-in shape's is .xyz), in cm, so that ``--cloud`` that file (scale 1)
    gives the same points to the last bit: text holds 17 significant digits.

    Parameters
    ----------
    folder : Path
        Made when absent.
    cloud : Cloud
        From :func:`resampled_cloud`.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputError
        The file cannot be written.
    """
    if cloud.resampled is None:
        raise ValueError(f"{cloud.name} is no resampled cloud")
    suffix = cloud_file_suffix(cloud.resampled.cloud_source)
    path = folder / f"{cloud.name}{suffix}"
    origin = cloud.resampled
    about = (
        f"{origin.cloud} ({origin.points} points, {origin.cloud_source}, scale "
        f"{origin.scale:g}) resampled to {origin.count} points at its mean spacing "
        f"{mean_spacing(cloud.points):.6g} cm, seed {origin.seed} (swazure --resample); cm"
    )
    atomic_write(path, lambda temporary: _write_points(temporary, suffix, cloud.points, about))
    return path


def _write_points(path: Path, suffix: str, points: FloatArray, about: str) -> None:
    """``points`` (N, 3), cm, in the format of ``suffix``, with ``about`` where it has room."""
    with path.open("wb") as out:
        if suffix == ".npy":
            np.save(out, points, allow_pickle=False)
        elif suffix == ".ply":
            from plyfile import PlyData, PlyElement  # local: only PLY users pay for the import

            vertex = np.empty(len(points), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
            vertex["x"], vertex["y"], vertex["z"] = points.T
            PlyData([PlyElement.describe(vertex, "vertex")], comments=[about]).write(out)
        else:
            # %.17g: every float64 read back as itself.
            comma = suffix == ".csv"
            np.savetxt(
                out,
                points,
                fmt="%.17g",
                delimiter="," if comma else " ",
                header=f"# {about}\nx,y,z" if comma else f"# {about}",
                comments="",
            )

"""Generated files at every reader: one SwazureError line or a valid result, never another error.

Sensor, camera, swarm and ROS parameter files are the shipped ones with one
value swapped for a generated one (a wrong type, a huge or non-finite
number, a nested list), or generated YAML from scratch, aliases and deep
nesting included; clouds are generated arrays (NaN, infinities, 1e300,
complex numbers, duplicates) in each supported format.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from swazure_ros.app.config import load_swarm_file
from swazure_ros.core.errors import SwazureError
from swazure_ros.core.geometry import make_swarm
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_camera, load_sensor

from ..conftest import FUZZ as BASE_FUZZ

CONFIG = config_dir()
FILES = {
    "sensor": (CONFIG / "sensor.yaml", load_sensor),
    "stochastic sensor": (CONFIG / "cameras" / "sensor-wide-calibrated.yaml", load_sensor),
    "camera": (CONFIG / "cameras" / "rpi-camera-module-3-wide.yaml", load_camera),
    "swarm": (CONFIG / "swarms" / "torus.yaml", load_swarm_file),
}
FUZZ = settings(BASE_FUZZ, max_examples=150)

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e300, -1e300, "", "abc", "1e9", ".inf"]),
    st.text(max_size=12),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)


def leaves(document: Any, path: tuple = ()) -> list[tuple]:
    """The key paths of every leaf of a parsed YAML document."""
    if isinstance(document, dict):
        return [leaf for key, value in document.items() for leaf in leaves(value, (*path, key))]
    if isinstance(document, list):
        return [leaf for i, value in enumerate(document) for leaf in leaves(value, (*path, i))]
    return [path]


def swapped(document: Any, path: tuple, value: Any) -> Any:
    """``document`` with the leaf at ``path`` replaced by ``value``."""
    if not path:
        return value
    head, rest = path[0], path[1:]
    copy = dict(document) if isinstance(document, dict) else list(document)
    copy[head] = swapped(document[head], rest, value)
    return copy


def outcome(read, path: Path) -> str:
    """ "ok" or "refused": anything else a reader raises fails the test."""
    try:
        read(path)
    except SwazureError as err:
        assert "\n" not in str(err), str(err)
        return "refused"
    return "ok"


@pytest.mark.parametrize("kind", FILES)
@FUZZ
@given(data=st.data())
def test_a_shipped_file_with_one_value_swapped_is_read_or_refused_in_one_line(
    tmp_path, kind, data
):
    original, read = FILES[kind]
    document = yaml.safe_load(original.read_text())
    where = data.draw(st.sampled_from(leaves(document)))
    changed = swapped(document, where, data.draw(values))
    path = tmp_path / original.name
    path.write_text(yaml.safe_dump(changed))
    outcome(read, path)


@pytest.mark.parametrize("kind", FILES)
@FUZZ
@given(document=values)
def test_generated_yaml_is_read_or_refused_in_one_line(tmp_path, kind, document):
    path = tmp_path / "generated.yaml"
    path.write_text(yaml.safe_dump(document))
    assert outcome(FILES[kind][1], path) == "refused"


def alias_bomb(depth: int, width: int) -> str:
    """YAML whose last key expands to width**depth scalars through aliases."""
    lines = [f"l0: &l0 [{', '.join(['x'] * width)}]"]
    for level in range(1, depth + 1):
        lines.append(f"l{level}: &l{level} [{', '.join([f'*l{level - 1}'] * width)}]")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("kind", FILES)
@pytest.mark.parametrize(
    "text",
    [
        alias_bomb(9, 9),
        "swarm:\n  parameters:\n"
        + "\n".join(f"    {line}" for line in alias_bomb(9, 9).split("\n")),
        "a: " + "[" * 5000 + "]" * 5000 + "\n",
    ],
    ids=["alias-bomb", "alias-bomb-under-parameters", "nested-5000-deep"],
)
def test_alias_bombs_and_deep_nesting_are_refused_at_once(tmp_path, kind, text):
    path = tmp_path / "bomb.yaml"
    path.write_text(text)
    with pytest.raises(SwazureError, match=r"alias bomb|nested more than"):
        FILES[kind][1](path)


coordinates = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, 1.0, 1e300, -1e300, 1e6, 1e7, math.nan]),
)


@FUZZ
@given(
    points=hnp.arrays(
        np.float64, st.tuples(st.integers(0, 12), st.integers(1, 4)), elements=coordinates
    ),
    suffix=st.sampled_from([".xyz", ".csv", ".npy"]),
    complex_values=st.booleans(),
)
def test_a_generated_cloud_is_a_swarm_or_refused_in_one_line(
    tmp_path, points, suffix, complex_values
):
    path = tmp_path / f"cloud{suffix}"
    if suffix == ".npy":
        np.save(path, points.astype(np.complex128) if complex_values else points)
    else:
        delimiter = "," if suffix == ".csv" else " "
        path.write_text("\n".join(delimiter.join(repr(v) for v in row) for row in points) + "\n")
    try:
        cloud = load_cloud(path)
        swarm = make_swarm(cloud.points, beta=0.5)
    except SwazureError as err:
        assert "\n" not in str(err)
        return
    assert np.isfinite(swarm.points).all() and swarm.radius > 0
    assert np.abs(cloud.points).max() <= 1e6 and len(cloud.points) >= 2

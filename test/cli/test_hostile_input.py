"""Hostile files and options at every verb, in a real process: one line, exit 2, no hang.

The inputs of the hostile-input report (issue "Hostile peers and hostile
input"): coordinates of 1e300, a complex .npy, a FIFO where a file belongs,
shapes of billions of points, alias bombs, sensors whose error reverses
every estimate or reaches every FLS, camera files of absurd sizes, negative
seeds, thresholds and rates and periods that would run for ever. Each runs
in a folder holding only its inputs; nothing else may be left there.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from swazure_ros.files.reading import config_dir

from ..waits import PATIENCE

CONFIG = config_dir()
TORUS = ["--cloud", "torus:60", "--beta", "0.5"]
TRIO = ["--cloud", str(CONFIG / "track" / "trio.xyz"), "--scale", "1", "--radius", "0.5"]
TRACK = [
    "track",
    *TRIO,
    "--engine",
    "--source",
    "0",
    "--target",
    "2",
    "--trajectory",
    "linear:1,0,0",
]


def alias_bomb(under: str = "") -> str:
    lines = ["l0: &l0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"l{k}: &l{k} [{', '.join([f'*l{k - 1}'] * 9)}]" for k in range(1, 10)]
    indent = "    " if under else ""
    return under + "".join(f"{indent}{line}\n" for line in lines)


def sensor_with(old: str, new: str) -> str:
    return (CONFIG / "sensor.yaml").read_text().replace(old, new)


def camera_with(old: str, new: str) -> str:
    return (CONFIG / "cameras" / "rpi-camera-module-3-wide.yaml").read_text().replace(old, new)


COEFFICIENTS = "coefficients: [0.00180987, -0.02756392, 0.11561755]"
FILES = {
    "big.xyz": "0 0 0\n1 0 0\n0 1 1e300\n0 0 1\n",
    "bomb.yaml": alias_bomb(),
    "bomb-swarm.yaml": alias_bomb("swarm:\n  cloud: torus\n  beta: 0.5\n  parameters:\n"),
    "huge-error.yaml": sensor_with(COEFFICIENTS, "coefficients: [1.0e+300, 0, 0]"),
    "negative-error.yaml": sensor_with(COEFFICIENTS, "coefficients: [0, 0, -3]"),
    "far-reach.yaml": sensor_with("decaying_max: 30.0", "decaying_max: 1.0e+9"),
    "no-blind.yaml": sensor_with("sweet_min: 6.0", "sweet_min: 0"),
    "typo-sensor.yaml": sensor_with("  ranges:", "  colour: red\n  ranges:"),
    "string-fx.yaml": camera_with("fx: 836.8", 'fx: "abc"'),
    "zero-fy.yaml": camera_with("fx: 836.8", "fy: 0\n    fx: 836.8"),
    "negative-noise.yaml": camera_with("read_noise: 2.0", "read_noise: -1.0"),
    "null-id.yaml": camera_with("    id: 0", "    id: null"),
    "huge-window.yaml": camera_with("corner_window_px: 11", "corner_window_px: 1000000"),
    "huge-image.yaml": camera_with("width: 1280", "width: 100000000"),
    "nested-parameters.yaml": "swarm:\n  cloud: torus\n  beta: 0.5\n  parameters:\n"
    "    period: [[1, 2], [3]]\n",
    "short.mcap": "x",
    # Bag folders whose metadata says too little, or names a file that is not there.
    "bag/metadata.yaml": "rosbag2_bagfile_information: {version: 9}\n",
    "lost/metadata.yaml": "rosbag2_bagfile_information:\n  version: 9\n"
    "  storage_identifier: mcap\n  relative_file_paths: [../../etc/lost_0.mcap]\n",
    # A bag whose metadata names its MCAP file, a FIFO (_inputs makes it).
    "piped/metadata.yaml": "rosbag2_bagfile_information:\n  version: 9\n"
    "  storage_identifier: mcap\n  relative_file_paths: [piped_0.mcap]\n",
}
#: FIFOs where a file belongs: a reader that opens one waits for a writer for ever.
FIFOS = ("fifo.xyz", "fifobag/fifobag_0.mcap", "piped/piped_0.mcap")
WIDE = str(CONFIG / "cameras" / "rpi-camera-module-3-wide.yaml")
NO_BLIND = "no-blind.yaml: sensor raspberry-pi-wide-aruco: sweet_min must be above 0"
ROWS = [
    (["evaluate", "--cloud", "big.xyz", "--beta", "0.5"], "beyond 1e+06 cm"),
    (["evaluate", "--cloud", "complex.npy", "--beta", "0.5"], "must be real numbers"),
    (["evaluate", "--cloud", "fifo.xyz", "--beta", "0.5"], "not a regular file"),
    (["evaluate", "--cloud", "torus:99999999999", "--beta", "0.5"], "more than 100000"),
    (["evaluate", *TORUS, "--scale", "1e300"], "beyond 1e+06 cm"),
    (["evaluate", *TORUS, "--sensor", "bomb.yaml"], "alias bomb"),
    (["evaluate", *TORUS, "--sensor", "fifo.xyz"], "not a regular file"),
    (["evaluate", *TORUS, "--sensor", "huge-error.yaml", "--out", "out"], "relative error"),
    (["evaluate", *TORUS, "--sensor", "negative-error.yaml"], "must stay above -1"),
    (["evaluate", *TORUS, "--sensor", "far-reach.yaml"], "beyond 1000 cm"),
    (["evaluate", *TORUS, "--sensor", "typo-sensor.yaml"], "unknown key 'colour'"),
    # Issue 66: evaluate took a sensor without a blind range that spawn refused; every
    # verb that reads a sensor file now says the same line (spawn's: test/ros/test_launcher).
    (["evaluate", *TORUS, "--sensor", "no-blind.yaml"], NO_BLIND),
    ([*TRACK, "--sensor", "no-blind.yaml"], NO_BLIND),
    (["study", "--sensor", "no-blind.yaml", "--out", "s"], NO_BLIND),
    (["evaluate", *TORUS, "--seed", "-1"], "outside 0..2**63-1"),
    (["evaluate", *TORUS, "--technique", "move-source", "--threshold", "100000000"], "1 to 1000"),
    (["spawn", "bomb-swarm.yaml"], "alias bomb"),
    (["spawn", "nested-parameters.yaml"], "a list of one of those"),
    (["spawn", "fifo.xyz"], "not a regular file"),
    (["spawn", *TORUS, "--no-key", "--key-file", "big.xyz"], "choose one"),
    (["spawn", *TORUS, "--key-file", "big.xyz"], "64 hexadecimal digits"),
    (["replay", "short.mcap"], "not an MCAP recording"),
    (["replay", "short.mcap", "--rate", "1e-300"], "a rate must be from 0.001"),
    (["replay", "bag"], "not a rosbag2 bag (metadata.yaml lacks 'storage_identifier')"),
    # A bag's files are read beside its metadata, by name, wherever the metadata points.
    (["replay", "lost"], "lost/lost_0.mcap: no such recording file"),
    (["camera", "calibrate", "--camera", "string-fx.yaml"], "fx must be a finite number"),
    # Divided by in the projection: a ZeroDivisionError's traceback before (issue 36).
    (["camera", "calibrate", "--camera", "zero-fy.yaml"], "(fx, fy, focal_length_mm)"),
    (["camera", "calibrate", "--camera", "negative-noise.yaml"], "blur and noise must be 0"),
    (["camera", "calibrate", "--camera", "null-id.yaml"], "id must be a finite number"),
    (["camera", "calibrate", "--camera", "huge-window.yaml"], "corner_window_px must be"),
    (["camera", "calibrate", "--camera", "huge-image.yaml"], "more than 8192 px"),
    (["camera", "calibrate", "--camera", "fifo.xyz"], "not a regular file"),
    # Issue 66: each hung, or (/dev/zero) filled memory for 38 s to a MemoryError.
    (["replay", "fifo.xyz"], "fifo.xyz: not a regular file"),
    (["replay", "fifobag"], "fifobag_0.mcap: not a regular file"),
    (["replay", "piped"], "piped_0.mcap: not a regular file"),
    ([*TRACK[:-1], "fifo.xyz"], "fifo.xyz: not a regular file"),
    (["camera", "calibrate", "--camera", WIDE, "--measured", "/dev/zero"], "not a regular file"),
    (["camera", "calibrate", "--camera", WIDE, "--measured", "fifo.xyz"], "not a regular file"),
    ([*TRACK, "--frame-period", "1e-9"], "frame_period must be 0.001 to"),
    ([*TRACK, "--duration", "1e300"], "at most 86400 s"),
    ([*TRACK, "--timeout", "inf"], "timeout must be above 0"),
]


def _inputs(folder: Path) -> list[str]:
    for name, text in FILES.items():
        (folder / name).parent.mkdir(exist_ok=True)
        (folder / name).write_text(text)
    np.save(folder / "complex.npy", np.array([[1 + 2j, 0, 0], [0, 1, 0], [0, 0, 1]]))
    for fifo in FIFOS:
        (folder / fifo).parent.mkdir(exist_ok=True)
        os.mkfifo(folder / fifo)
    return sorted(path.name for path in folder.iterdir())


def _run(folder: Path, arguments: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *arguments],
        capture_output=True,
        text=True,
        timeout=PATIENCE,  # a hang fails here
        cwd=folder,
    )


@pytest.mark.parametrize(
    ("row", "message"),
    [(row, message) for row, (_, message) in enumerate(ROWS)],
    ids=[" ".join(arguments)[:70] for arguments, _ in ROWS],
)
def test_hostile_input_is_one_line_exit_2_and_leaves_nothing(tmp_path, row, message):
    # A row a test, not the table in a module fixture: pytest-xdist's workers would each
    # run the whole table for their share of the rows.
    folder, inputs = tmp_path, _inputs(tmp_path)
    run = _run(folder, ROWS[row][0])
    assert run.returncode == 2, run.stderr
    assert "Traceback" not in run.stderr + run.stdout
    assert run.stderr.count("\n") == 1, run.stderr
    assert message in run.stderr
    assert sorted(path.name for path in folder.iterdir()) == inputs

"""Generated options, clouds and sensors at `swazure evaluate`, in this process.

The property: exit code 0 with a summary, or 2 with one line on stderr;
never another exception, never a half-written --out folder.
"""

from __future__ import annotations

import json

import yaml
from hypothesis import event, given, settings
from hypothesis import strategies as st

from swazure_ros.cli.main import main
from swazure_ros.files.reading import config_dir

from ..conftest import FUZZ

numbers = st.one_of(
    st.sampled_from(["0", "-1", "0.5", "1", "1e300", "-1e300", "nan", "inf", "-inf", "x", ""]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(2**70), 2**70).map(str),
)
#: Mostly the values a person would give, so that runs get past the options too.
betas = st.one_of(st.sampled_from(["0.3", "0.5", "1"]), st.sampled_from(["0.4", "0.45"]), numbers)
clouds = st.one_of(
    st.sampled_from(["torus:60", "helix:40"]),
    st.sampled_from(["cube:27", "torus:80"]),
    st.sampled_from(["torus:60", "helix:40", "cube:27", "sphere:0", "torus:99999999999", "nope"]),
    st.builds(lambda n: f"torus:{n}", st.integers(-5, 200)),
)


@settings(FUZZ, max_examples=100)
@given(
    cloud=clouds,
    beta=betas,
    scale=st.one_of(st.none(), st.none(), st.sampled_from(["1", "2.5"]), numbers),
    seed=st.one_of(st.none(), st.none(), st.sampled_from(["0", "7"]), numbers),
    threshold=st.one_of(st.none(), st.none(), st.sampled_from(["2", "10"]), numbers),
    technique=st.sampled_from([None, "move-source", "move-obstructing"]),
    sensor_value=st.one_of(
        st.none(), st.none(), st.none(), st.sampled_from([0, -3, 1e300, 1e9, "x", [1, 2], None])
    ),
    sensor_key=st.sampled_from(["sweet_min", "sweet_max", "decaying_max", "coefficients"]),
)
def test_generated_options_are_a_summary_or_one_line(
    tmp_path_factory, capsys, cloud, beta, scale, seed, threshold, technique, sensor_value,
    sensor_key,
):  # fmt: skip
    folder = tmp_path_factory.mktemp("options")
    out = folder / "out"
    arguments = ["evaluate", "--cloud", cloud, "--beta", beta, "--quiet", "--out", str(out)]
    for flag, value in (("--scale", scale), ("--seed", seed), ("--threshold", threshold)):
        if value is not None:
            arguments += [flag, value]
    if technique is not None:
        arguments += ["--technique", technique]
    if sensor_value is not None:
        document = yaml.safe_load((config_dir() / "sensor.yaml").read_text())
        body = document["sensor"]
        where = body["error_model"] if sensor_key == "coefficients" else body["ranges"]
        where[sensor_key] = sensor_value
        (folder / "sensor.yaml").write_text(yaml.safe_dump(document))
        arguments += ["--sensor", str(folder / "sensor.yaml")]
    try:
        code = main(arguments)
    except SystemExit as stop:  # argparse's own refusals
        code = stop.code
    err = capsys.readouterr().err
    assert code in (0, 2), (arguments, err)
    event(f"exit {code}")
    if code == 2:
        assert err.count("\n") == 1, err
        assert not out.exists() or not any(out.iterdir())
    else:
        summary = json.loads((out / "summary.json").read_text())
        assert summary["flss"] >= 8 and (out / "pairs.csv").is_file()

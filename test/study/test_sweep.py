"""The study's sweep: plan of runs, cache keys, resuming, and parallel runs equal to serial."""

import json
from dataclasses import replace

import pytest

from swazure_ros.core.errors import SwazureError
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.results import PAIRS_PARQUET_FILE, SUMMARY_FILE
from swazure_ros.study.plan import PLAIN_TECHNIQUE, StudyPlan, Technique
from swazure_ros.study.sweep import SweepProgress, read_summary, sweep


def small_plan(sensor, **options):
    """Two small built-in shapes, one beta, one heuristic: four runs."""
    defaults = {
        "betas": (0.5,),
        "policies": ("shortest-length",),
        "techniques": (Technique("move-obstructing"),),
        "heuristic_betas": (0.5,),
    }
    defaults.update(options)
    clouds = defaults.pop("clouds", None) or [load_cloud("torus:120"), load_cloud("helix:60")]
    return StudyPlan(clouds, sensor, **defaults)


class Recorder(SweepProgress):
    def __init__(self):
        self.total, self.cached, self.done = None, None, []

    def start(self, total, cached):
        self.total, self.cached = total, cached

    def run_done(self, spec, seconds):
        self.done.append(spec)


def without_timing(summary):
    return replace(summary, seconds=None)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("plain", Technique("plain")),
        ("move-obstructing", Technique("move-obstructing")),
        ("move-source", Technique("move-source", 10)),
        ("move-source:2", Technique("move-source", 2)),
    ],
)
def test_technique_parse(text, expected):
    assert Technique.parse(text) == expected


@pytest.mark.parametrize("text", ["move-source:0", "move-source:x", "teleport", "plain:3"])
def test_technique_parse_rejects(text):
    with pytest.raises(SwazureError, match="technique"):
        Technique.parse(text)


def test_plan_holds_plain_runs_for_every_beta_and_policy_and_heuristics_at_their_betas(sensor):
    plan = small_plan(
        sensor,
        betas=(0.3, 0.5),
        policies=("fewest-hops", "shortest-length"),
        techniques=(Technique("move-obstructing"), Technique("move-source", 2)),
        heuristic_betas=(0.5,),
    )
    runs = plan.runs()
    plain = [spec for spec in runs if spec.technique == PLAIN_TECHNIQUE]
    moved = [spec for spec in runs if spec.technique != PLAIN_TECHNIQUE]
    assert len(plain) == 2 * 2 * 2  # clouds x betas x policies
    assert len(moved) == 2 * 1 * 2  # clouds x heuristic betas x heuristics
    assert {spec.policy for spec in moved} == {"shortest-length"}
    assert len({spec.key for spec in runs}) == len(runs)
    assert len({spec.folder for spec in runs}) == len(runs)
    assert [cloud.name for cloud in plan.clouds] == ["helix_60", "torus_120"]  # smallest first


def test_keys_are_stable_and_depend_on_every_input(sensor):
    keys = [spec.key for spec in small_plan(sensor).runs()]
    assert keys == [spec.key for spec in small_plan(sensor).runs()]
    assert not set(keys) & {spec.key for spec in small_plan(sensor.error_free()).runs()}
    assert not set(keys) & {spec.key for spec in small_plan(sensor, seed=1).runs()}
    torus, helix = load_cloud("torus:120"), load_cloud("helix:60")
    stretched = replace(torus, points=torus.points * 1.01)
    moved = small_plan(sensor, clouds=[stretched, helix])
    assert {spec.key for spec in moved.runs() if spec.cloud == "helix_60"} <= set(keys)
    assert not {spec.key for spec in moved.runs() if spec.cloud == "torus_120"} & set(keys)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"betas": (0.0,)}, "beta"),
        ({"policies": ("longest",)}, "policy"),
    ],
)
def test_plan_rejects_bad_parameters(sensor, options, message):
    with pytest.raises(SwazureError, match=message):
        small_plan(sensor, **options)


def test_second_sweep_computes_nothing_and_returns_the_same_summaries(sensor, tmp_path):
    plan = small_plan(sensor)
    first = sweep(plan, tmp_path, progress=(recorder := Recorder()))
    assert (first.computed, first.cached) == (4, 0)
    assert recorder.total == 4 and len(recorder.done) == 4
    for spec in plan.runs():
        folder = tmp_path / spec.folder
        assert (folder / PAIRS_PARQUET_FILE).is_file() == (plan.pairs_kept(spec) != "none")
        assert json.loads((folder / SUMMARY_FILE).read_text())["study"]["key"] == spec.key
    second = sweep(plan, tmp_path, progress=(recorder := Recorder()))
    assert (second.computed, second.cached) == (0, 4)
    assert recorder.done == []
    assert second.summaries == first.summaries


def test_a_changed_parameter_recomputes_only_the_runs_it_touches(sensor, tmp_path):
    sweep(small_plan(sensor), tmp_path)
    result = sweep(small_plan(sensor, betas=(0.4, 0.5)), tmp_path)
    assert (result.computed, result.cached) == (2, 4)  # plain at 0.4 for each shape
    result = sweep(small_plan(sensor.error_free()), tmp_path)
    assert (result.computed, result.cached) == (4, 0)


def test_an_interrupted_run_is_recomputed_and_its_temporary_file_removed(sensor, tmp_path):
    plan = small_plan(sensor)
    sweep(plan, tmp_path)
    broken, half = plan.runs()[0], plan.runs()[1]
    (tmp_path / broken.folder / SUMMARY_FILE).unlink()  # killed before its summary
    (tmp_path / half.folder / SUMMARY_FILE).write_text('{"study": ')  # not JSON
    stale = tmp_path / broken.folder / ".pairs.parquet.k1ll3d"
    stale.write_bytes(b"partial")
    assert read_summary(tmp_path, broken, plan.pairs) is None
    result = sweep(plan, tmp_path)
    assert result.computed == 2
    assert not stale.exists()
    assert read_summary(tmp_path, broken, plan.pairs) is not None


def test_parallel_sweep_gives_the_serial_numbers(sensor, tmp_path):
    plan = small_plan(sensor)
    serial = sweep(plan, tmp_path / "serial", jobs=1)
    parallel = sweep(plan, tmp_path / "parallel", jobs=2)
    assert parallel.computed == 4
    for spec in plan.runs():
        assert without_timing(parallel.summaries[spec]) == without_timing(serial.summaries[spec])


def test_compact_pairs_keep_integer_paths_and_what_nothing_else_reproduces(sensor, tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from swazure_ros.files.results import DERIVED_COLUMNS

    compact = sweep(small_plan(sensor, keep_pairs=True), tmp_path / "compact")
    full = sweep(small_plan(sensor, pairs="full", keep_pairs=True), tmp_path / "full")
    for spec in small_plan(sensor).runs():
        kept = pq.read_table(tmp_path / "compact" / spec.folder / PAIRS_PARQUET_FILE)
        every = pq.read_table(tmp_path / "full" / spec.folder / PAIRS_PARQUET_FILE)
        assert set(every.column_names) - set(kept.column_names) == set(DERIVED_COLUMNS)
        assert kept.schema.field("path").type == pa.large_list(pa.uint32())
        assert kept.column("path").equals(every.column("path"))
        # The summaries (every table's numbers) do not depend on what the pairs keep.
        summary, other = compact.summaries[spec], full.summaries[spec]
        assert without_timing(summary) == replace(without_timing(other), study=summary.study)
        # A path's hops are its list's length less one: the dropped column follows.
        assert (pa.compute.list_value_length(kept.column("path")).to_numpy() - 1).clip(
            0
        ).tolist() == every.column("hops").to_numpy().tolist()


def test_a_run_kept_compact_is_computed_again_when_full_pairs_are_asked(sensor, tmp_path):
    sweep(small_plan(sensor, keep_pairs=True), tmp_path)
    again = sweep(small_plan(sensor, pairs="full", keep_pairs=True), tmp_path)
    assert (again.computed, again.cached) == (4, 0)
    assert sweep(small_plan(sensor, pairs="full", keep_pairs=True), tmp_path).cached == 4
    with pytest.raises(SwazureError, match="per-pair output"):
        small_plan(sensor, pairs="some")


def test_by_default_only_the_runs_a_figure_reads_keep_their_pairs(sensor, tmp_path):
    """The error histogram's shape (the smallest here) at beta 0.5 for each policy, and with
    least squares its fitted and plain runs at the largest beta: nothing else is read."""
    plan = small_plan(sensor, policies=("fewest-hops", "shortest-length"), least_squares=True)
    helix = plan.histogram_shape
    assert helix == "helix_60" and plan.histogram_beta == 0.5
    fit = Technique("least-squares")
    assert plan.figure_runs() == {
        (helix, 0.5, "fewest-hops", PLAIN_TECHNIQUE),
        (helix, 0.5, "shortest-length", PLAIN_TECHNIQUE),
        (helix, 0.5, "shortest-length", fit),
    }
    result = sweep(plan, tmp_path)
    kept = sorted(path.parent for path in tmp_path.rglob(PAIRS_PARQUET_FILE))
    read = [("fewest-hops", "plain"), ("shortest-length", "plain"),
            ("shortest-length", "least-squares")]  # fmt: skip
    beta = tmp_path / "runs" / helix / "beta-0.5"
    assert kept == sorted(beta / policy / technique for policy, technique in read)
    assert len(result.summaries) == 8
    for spec, summary in result.summaries.items():
        assert summary.study.pairs == ("compact" if (tmp_path / spec.folder) in kept
                                       else "none")  # fmt: skip
    # Asked for, every run keeps its pairs: those that kept none are computed again.
    again = sweep(replace(plan, keep_pairs=True), tmp_path)
    assert (again.computed, again.cached) == (5, 3)
    assert len(list(tmp_path.rglob(PAIRS_PARQUET_FILE))) == 8
    # A study that needs fewer pairs takes the runs as they are.
    assert sweep(plan, tmp_path).computed == 0

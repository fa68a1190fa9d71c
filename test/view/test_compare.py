"""The compared runs' error figure (view.compare): panels by class, curves ending at coverage."""

from dataclasses import replace

import numpy as np

from swazure_ros.core.compare import compare
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.pair_classes import PairErrors
from swazure_ros.core.summary import Source
from swazure_ros.view.compare import error_figure, figure_size, grid, write_error_figure
from swazure_ros.view.png import DPI

from ..conftest import scene


def comparison_of(sensor):
    summary = evaluate(scene(0, 1, 2, 3, 4), sensor, "fewest-hops").summary
    source = Source("scene", "hand-built", 1.0, 0, "config/sensor.yaml")
    summary = replace(summary, parameters=replace(summary.parameters, source=source))
    # Reason codes: 0 sweet path, 1 blocked. Run a estimates no blocked pair, run b half.
    classes = np.array([0, 0, 1, 1], np.uint8)
    a = PairErrors(classes, np.array([0.1, 0.2, np.nan, np.nan]), "cm")
    b = PairErrors(classes, np.array([0.1, 0.3, 0.5, np.nan]), "cm")
    return compare([("a", summary, a), ("b", summary, b)])


def test_one_panel_per_class_and_one_curve_per_run_up_to_its_coverage(sensor):
    figure = error_figure(comparison_of(sensor))
    panels = [ax for ax in figure.axes if ax.get_visible()]
    assert [ax.get_title() for ax in panels] == [
        "all pairs (4 pairs)",
        "sweet path (2 pairs)",
        "blocked (2 pairs)",
    ]
    curves = {ax.get_title().split(" (")[0]: ax.lines for ax in panels}
    assert [line.get_label() for line in curves["sweet path"]] == ["a: plain", "b: plain"]
    assert [line.get_label() for line in curves["blocked"]] == ["b: plain"]
    # A curve ends at the share of the class's pairs the run estimates.
    ends = {line.get_label(): line.get_ydata()[-1] for line in curves["all pairs"]}
    assert ends == {"a: plain": 50.0, "b: plain": 75.0}
    assert curves["blocked"][0].get_xdata()[-1] == 0.5
    notes = [text.get_text() for text in panels[2].texts]
    assert notes == ["none estimated:\na"]
    assert [text.get_text() for text in figure.legends[0].texts] == ["a: plain", "b: plain"]


def test_the_png_has_the_figures_size(tmp_path, sensor):
    comparison = comparison_of(sensor)
    path = write_error_figure(comparison, tmp_path / "errors.png")
    width, height = figure_size(comparison)
    assert grid(3) == (1, 3) and grid(4) == (2, 2) and grid(5) == (2, 3)
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    assert int.from_bytes(head[16:20], "big") == round(width * DPI)
    assert int.from_bytes(head[20:24], "big") == round(height * DPI)

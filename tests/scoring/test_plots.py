"""tracking.png names what it draws (the reference, the true angle, the sensor's readings, the controller's
estimate) and draws every error whole; the live view's series carry the same names. Fast, no ROS."""

import matplotlib
import numpy as np
import pytest

from robot_controller.scoring import plots
from robot_controller.view import layout
from tests.scoring.test_per_joint import synthetic_recording

matplotlib.use("Agg")


def drawn_figure(monkeypatch, recording, **options):
    import matplotlib.figure

    drawn = []
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda fig, *a, **k: drawn.append(fig))
    plots.plot_tracking(recording, "unused.png", **options)
    return drawn[0]


def legend(ax):
    return [text.get_text() for text in ax.get_legend().get_texts()]


def pushed_recording(push_rad=0.065, noise_rad=0.005, seed=0):
    """One joint tracking with a 1 mrad error, a push of ``push_rad`` at 3 s, noisy readings and a filtered estimate."""
    recording = synthetic_recording([0.001])
    t = recording.true_time_s
    bump = push_rad * np.exp(-(((t - 3.0) / 0.1) ** 2))[:, None]
    recording.true_position = recording.true_position - bump
    noise = np.random.default_rng(seed).normal(0.0, noise_rad, recording.true_position.shape)
    recording.reading_position = recording.true_position + noise
    recording.state["measured"] = recording.true_position + 0.0002  # the estimate: close to the truth, not a reading
    return recording


def test_each_trace_is_named_as_what_it_is(monkeypatch):
    fig = drawn_figure(monkeypatch, pushed_recording())
    position, error, torque = fig.axes
    assert legend(position) == [
        "reference",
        "sensor readings (/joint_states, noisy)",
        "true angle (/sim/joint_states)",
        "controller's estimate (/controller/state)",
    ]
    assert legend(error) == ["reference − true angle (scored)", "reference − estimate (the controller's error)"]
    assert legend(torque) == ["commanded", "applied (/sim/joint_states)"]
    assert [ax.get_ylabel() for ax in fig.axes] == ["position [rad]", "error [mrad]", "torque [N·m]"]


def test_without_an_estimator_the_readings_are_the_controller_s_input_drawn_once(monkeypatch):
    recording = pushed_recording()
    recording.state["measured"] = recording.reading_position.copy()  # estimator: none, as the tutorial's
    assert plots.estimate_is_the_reading(recording)
    position, error, _ = drawn_figure(monkeypatch, recording).axes
    assert legend(position)[1] == plots.UNFILTERED["readings"] and len(legend(position)) == 3
    assert legend(error)[1] == plots.UNFILTERED["error_estimate"]


@pytest.mark.parametrize("push_rad", [0.065, 0.4, 0.002])
def test_the_error_panel_draws_a_push_whole_however_large(monkeypatch, push_rad):
    """The panel was scaled to the estimate's error (±16 mrad on the default run) and cut a 65 mrad push."""
    _, error, _ = drawn_figure(monkeypatch, pushed_recording(push_rad)).axes
    low, high = error.get_ylim()
    drawn = np.concatenate([line.get_ydata() for line in error.get_lines()])
    assert low <= np.min(drawn) and np.max(drawn) <= high
    assert high >= push_rad * 1e3 and high <= 1.2 * np.max(np.abs(drawn))  # whole, and no larger than needed


@pytest.mark.parametrize("units", [["rad"], ["rad", "rad", "m"]])
def test_the_live_view_names_its_series_as_the_plot_does(units):
    same = {"true": "true", "measured": "readings", "error_true": "error_true", "error_controller": "error_estimate"}
    for series, trace in (same | {"reference": "reference", "commanded": "commanded", "applied": "applied"}).items():
        assert layout.series_label(series, units) == plots.trace_name(trace, units)
    assert layout.series_label("error_controller", units) == "reference − estimate (the controller's error)"
    assert layout.series_label("true", units).startswith("true angle" if units == ["rad"] else "true position")

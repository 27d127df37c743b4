"""A campaign's spec: refused whole, naming the key and the reason, before any run; run k's draws the same wherever
it runs; the report's interval and ranking. No ROS, no loop."""

from pathlib import Path

import pytest
import yaml

from robot_controller.core.errors import ConfigError
from robot_controller.experiments.campaign import report
from robot_controller.experiments.campaign.spec import columns, draw, load_spec, parse_spec, run_seed

GOOD = {
    "robot": "one_dof",
    "duration_s": 3,
    "runs": 4,
    "seed": 7,
    "vary": {
        "sensor_node.delay_s": {"uniform": [0.0, 0.02]},
        "sensor_node.position_noise_std": {"loguniform": [0.001, 0.01]},
        "motor_node.lag_time_constant_s": {"normal": [0.005, 0.01]},
        "pid_controller.estimator": {"choice": ["none", "kalman"]},
    },
    "pass": {"tracking_rms_rad": 0.005},
}


def spec_of(tmp_path: Path, **changes):
    body = {**GOOD, **changes}
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(body, sort_keys=False))
    return load_spec(path)


def refusal(tmp_path: Path, **changes) -> str:
    with pytest.raises(ConfigError) as caught:
        spec_of(tmp_path, **changes)
    return str(caught.value)


def test_a_good_spec_reads_whole(tmp_path):
    spec = spec_of(tmp_path)
    assert [v.key for v in spec.vary] == list(GOOD["vary"])
    assert spec.pass_bounds == {"tracking_rms_rad": 0.005} and spec.joint_count == 1


@pytest.mark.parametrize(
    ("vary", "named", "reason"),
    [
        ({"sensor_node.delay": {"uniform": [0, 1]}}, "vary.sensor_node.delay", "did you mean sensor_node.delay_s"),
        ({"sensr_node.delay_s": {"uniform": [0, 1]}}, "vary.sensr_node.delay_s", "did you mean 'sensor_node'"),
        ({"sensor_node.delay_s": {"uniform": [0.02, 0.01]}}, "vary.sensor_node.delay_s.uniform", "lo <= hi"),
        ({"sensor_node.delay_s": {"uniform": [0, 5]}}, "vary.sensor_node.delay_s.uniform", "must be <= 1"),
        ({"sensor_node.delay_s": {"loguniform": [0, 0.1]}}, "vary.sensor_node.delay_s.loguniform", "lo must be > 0"),
        ({"sensor_node.delay_s": {"normal": [0.01, -1]}}, "vary.sensor_node.delay_s.normal", "must be >= 0"),
        ({"sensor_node.delay_s": {"gauss": [0, 1]}}, "vary.sensor_node.delay_s", "exactly one of uniform"),
        ({"sensor_node.delay_s": 0.01}, "vary.sensor_node.delay_s", "expected one of"),
        ({"sensor_node.delay_s": {"uniform": [0, 0.1], "per_joint": True}}, "per_joint", "one value for the whole arm"),
        ({"pid_controller.estimator": {"uniform": [0, 1]}}, "vary.pid_controller.estimator", "use choice"),
        ({"pid_controller.estimator": {"choice": ["kalman", "ukf"]}}, "choice", "'ukf' is not one of"),
        ({"sensor_node.seed": {"choice": [1, 2]}}, "vary.sensor_node.seed", "derived from the campaign's seed"),
    ],
)
def test_a_bad_vary_entry_is_refused_naming_its_key_and_why(tmp_path, vary, named, reason):
    said = refusal(tmp_path, vary=vary)
    assert named in said and reason in said, said


@pytest.mark.parametrize(
    ("changes", "named", "reason"),
    [
        ({"runs": 0}, "runs", "whole number >= 1"),
        ({"duration_s": -1}, "duration_s", "seconds > 0"),
        ({"robot": "no_such_arm"}, "no_such_arm", ""),
        ({"controller": "nowhere.py:Law"}, "controller", "nowhere.py"),
        ({"config": "missing.yaml"}, "config", "no such file"),
        ({"pass": {"tracking_rms": 0.005}}, "pass.tracking_rms", "not a run's figure"),
        ({"varry": {}}, "varry", "did you mean 'vary'"),
        ({"identify": "yes"}, "identify", "expected true or false"),
        ({"identify": True, "tune": "fast"}, "tune", "expected one of tracking, robust, effort"),
        ({"tune": "tracking"}, "tune", "give identify: true with it"),
    ],
)
def test_a_bad_top_level_key_is_refused(tmp_path, changes, named, reason):
    said = refusal(tmp_path, **changes)
    assert named in said and reason in said, said


def test_a_config_file_with_a_bad_key_is_refused_in_its_own_words(tmp_path):
    (tmp_path / "mine.yaml").write_text("sensor_node:\n  ros__parameters:\n    noise: 1.0\n")
    said = refusal(tmp_path, config="mine.yaml")
    assert "mine.yaml" in said and "sensor_node.noise: unknown parameter" in said, said


def test_per_joint_draws_one_value_per_joint_of_the_robot(tmp_path):
    spec = spec_of(
        tmp_path, robot="planar2", vary={"simulator.initial_position": {"uniform": [0, 0.1], "per_joint": True}}
    )
    drawn = draw(spec, 0)["simulator.initial_position"]
    assert len(drawn) == 2 and drawn[0] != drawn[1]
    assert set(columns({"simulator.initial_position": drawn})) == {
        "simulator.initial_position[0]",
        "simulator.initial_position[1]",
    }


def test_run_k_draws_the_same_whatever_came_before_and_a_new_key_leaves_the_others(tmp_path):
    spec = spec_of(tmp_path)
    again = parse_spec(yaml.safe_load(spec.text), spec.path, spec.text)
    assert [draw(spec, k) for k in (3, 0, 2)] == [draw(again, k) for k in (3, 0, 2)]
    assert draw(spec, 0) != draw(spec, 1)
    assert run_seed(spec.seed, 5) == run_seed(7, 5) != run_seed(7, 6)
    fewer = spec_of(tmp_path, vary={"sensor_node.delay_s": GOOD["vary"]["sensor_node.delay_s"]})
    assert draw(fewer, 2)["sensor_node.delay_s"] == draw(spec, 2)["sensor_node.delay_s"]


def test_draws_keep_to_their_ranges_and_a_normal_draw_to_the_parameters(tmp_path):
    spec = spec_of(tmp_path)
    values = [draw(spec, k) for k in range(200)]
    assert all(0 <= v["sensor_node.delay_s"] <= 0.02 for v in values)
    assert all(0.001 <= v["sensor_node.position_noise_std"] <= 0.01 for v in values)
    lags = [v["motor_node.lag_time_constant_s"] for v in values]
    assert min(lags) == 0.0 and max(lags) > 0.01  # σ 0.01 about 0.005: a fifth or more below 0, clipped there
    assert {v["pid_controller.estimator"] for v in values} == {"none", "kalman"}


def test_wilson_interval_matches_its_textbook_values():
    lo, hi = report.wilson_interval(57, 60)
    assert lo == pytest.approx(0.8628, abs=1e-3) and hi == pytest.approx(0.9829, abs=1e-3)
    assert report.wilson_interval(0, 10)[0] == 0.0 and report.wilson_interval(10, 10)[1] == pytest.approx(1.0)


def test_sensitivity_ranks_the_parameter_that_drives_the_figure_first(tmp_path):
    spec = spec_of(tmp_path, vary={k: GOOD["vary"][k] for k in list(GOOD["vary"])[:3]})
    rows = []
    for k in range(40):
        drawn = draw(spec, k)
        rows.append(
            {
                **drawn,
                "run_id": k,
                "controller": "",
                "status": "ok",
                "tracking_rms_rad": 0.001 + drawn["sensor_node.position_noise_std"] ** 2,
            }
        )
    ranked = report.sensitivity(spec, rows, "tracking_rms_rad")
    assert ranked[0]["parameter"] == "sensor_node.position_noise_std" and ranked[0]["rho"] == pytest.approx(1.0)
    assert abs(ranked[1]["rho"]) < 0.5

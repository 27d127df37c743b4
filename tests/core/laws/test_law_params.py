"""A plugin law's parameters as pid_controller's law.NAME, without ROS: read from --config (flat or
nested), checked at load time against what the law declares (one line naming the key, exit 2),
listed by ``params``; controller_type's relative file path made absolute; the extra terms'
blocks on /controller/state."""

from pathlib import Path

import numpy as np
import pytest

from robot_controller import cli
from robot_controller import parameters as cfg
from robot_controller.core.controller import state_layout
from robot_controller.core.errors import ConfigError
from robot_controller.parameters import consistency

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = "examples/own_controller.py:PDWithGravity"


def config(tmp_path, body: str, name: str = "law.yaml") -> Path:
    path = tmp_path / name
    path.write_text("pid_controller:\n  ros__parameters:\n" + body)
    return path


@pytest.fixture
def in_repo(monkeypatch):
    monkeypatch.chdir(ROOT)  # controller_type's relative path is from where robot-controller runs


@pytest.mark.parametrize(
    "law_lines",
    ["    law.natural_frequency_hz: 5\n", "    law:\n      natural_frequency_hz: 5.0\n"],
    ids=["flat", "nested"],
)
def test_law_values_load_flat_or_nested_with_the_defaults_for_the_rest(tmp_path, in_repo, law_lines):
    path = config(tmp_path, f"    controller_type: {EXAMPLE}\n" + law_lines)
    ctrl = cfg.load_stack(config=[path])["pid_controller"]
    assert ctrl["controller_type"] == f"{ROOT / 'examples' / 'own_controller.py'}:PDWithGravity"
    assert ctrl["law.natural_frequency_hz"] == 5.0 and ctrl["law.damping_ratio"] == 1.0
    consistency.check_stack(cfg.load_stack(config=[path]))  # the whole configuration, the law built
    # What the run writes for its nodes reads back the same (rcl reads the flat names too).
    written = cfg.write_params_file(cfg.load_stack(config=[path]), tmp_path / "params.yaml")
    assert cfg.read_params_file(written)["pid_controller"]["law.natural_frequency_hz"] == 5.0


def test_a_later_file_sets_a_law_value_an_earlier_one_chose_the_law_for(tmp_path, in_repo):
    first = config(tmp_path, f"    controller_type: {EXAMPLE}\n", "a.yaml")
    second = config(tmp_path, "    law.damping_ratio: 0.7\n", "b.yaml")
    assert cfg.load_stack(config=[first, second])["pid_controller"]["law.damping_ratio"] == 0.7


@pytest.mark.parametrize(
    "body, says",
    [
        (
            f"    controller_type: {EXAMPLE}\n    law.natural_frequncy_hz: 5.0\n",
            "law.yaml: pid_controller.law.natural_frequncy_hz: the law PDWithGravity declares no such parameter "
            "(did you mean 'law.natural_frequency_hz'?)",
        ),
        (
            f"    controller_type: {EXAMPLE}\n    law:\n      damping_ratio: 9\n",
            "law.yaml: pid_controller.law.damping_ratio: must be <= 3, got 9",
        ),
        (
            f"    controller_type: {EXAMPLE}\n    law.damping_ratio: fast\n",
            "pid_controller.law.damping_ratio: expected a number, got 'fast'",
        ),
        ("    controller_type: examples/no_such_law.py:Law\n", "pid_controller: controller_type: no such file"),
        ("    controller_type: lqr\n    law.natural_frequency_hz: 5.0\n", "lqr is built in and takes no law.*"),
    ],
    ids=["unknown", "out_of_range", "wrong_type", "unresolved", "builtin"],
)
def test_run_refuses_a_bad_law_configuration_in_one_line_before_starting(tmp_path, in_repo, capsys, body, says):
    out = tmp_path / "run"
    path = config(tmp_path, body)
    code = cli.main(["run", "--sim-time", "--duration", "1", "--config", str(path), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and says in err[0], err
    assert "Traceback" not in err[0] and not out.exists()


def test_the_whole_configuration_check_refuses_law_values_the_law_does_not_take(tmp_path, in_repo):
    params = cfg.load_stack(config=[config(tmp_path, f"    controller_type: {EXAMPLE}\n")])
    params["pid_controller"]["law.natural_frequency_hz"] = 0.1  # values set in code, not from a file
    with pytest.raises(ConfigError, match=r"pid_controller.law.natural_frequency_hz: must be >= 0.5"):
        consistency.check_stack(params)
    del params["pid_controller"]["law.natural_frequency_hz"]
    params["pid_controller"]["law.gain"] = 1.0
    with pytest.raises(ConfigError, match="pid_controller.law.gain: the law PDWithGravity declares no such"):
        consistency.check_stack(params)


def test_params_lists_the_laws_parameters_with_default_range_and_description(tmp_path, in_repo, capsys):
    path = config(tmp_path, f"    controller_type: {EXAMPLE}\n    law.natural_frequency_hz: 5.0\n")
    assert cli.main(["params", "--config", str(path)]) == 0
    lines = {line.split(" = ")[0].strip(): line for line in capsys.readouterr().out.splitlines() if " = " in line}
    frequency = lines["law.natural_frequency_hz"]
    assert "= 5.0" in frequency and "closed-loop bandwidth" in frequency and "[>= 0.5; <= 30]" in frequency
    assert "default 4.0" in frequency and "PDWithGravity" in frequency
    assert "law.damping_ratio" in lines
    assert cli.main(["params"]) == 0  # a built-in law: no law.* at all
    assert "law.natural_frequency_hz" not in capsys.readouterr().out


def test_the_extra_terms_follow_the_standard_blocks_and_old_readers_still_read_them():
    n = 2
    values = {name: np.full(n, k, dtype=float) for k, name in enumerate(state_layout.FIELDS)}
    row = state_layout.encode(1.0, "law_fault", 0.99, n, values, (np.array([7.0, 8.0]), np.array([9.0, 10.0])))
    assert len(row) == state_layout.width(n) + 2 * n and state_layout.fits(len(row), n)
    assert not state_layout.fits(len(row) - 1, n)
    decoded = state_layout.decode(np.asarray(row), n)
    assert decoded["status"] == state_layout.STATUS_CODES["law_fault"] and decoded["saturated"].tolist() == [8, 8]
    assert list(state_layout.standard(row, n)) == row[: state_layout.width(n)]
    extra = state_layout.extra(row, n, ["gravity", "friction"])
    assert extra["gravity"].tolist() == [7.0, 8.0] and extra["friction"].tolist() == [9.0, 10.0]
    assert state_layout.extra(row, n, ["gravity"]) == {}  # labels that do not match the blocks: none read

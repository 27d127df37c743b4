"""Whatever a verb raises ends in one line on stderr and an exit code, never a traceback: a failed run
exit 1, Ctrl-C 130, a fault of ours exit 1 with its traceback written into the run's folder."""

import importlib

import pytest

from robot_controller.cli.args import Parser
from robot_controller.core.errors import RunFailed

cli_main = importlib.import_module("robot_controller.cli.main")  # the package's ``main`` is the function


def verb_raising(monkeypatch, exc: BaseException) -> None:
    def build_parser() -> Parser:
        parser = Parser(prog="robot-controller")
        sub = parser.add_subparsers(dest="verb", required=True, parser_class=Parser)
        verb = sub.add_parser("boom")
        verb.add_argument("--out")
        verb.set_defaults(handler=lambda args: (_ for _ in ()).throw(exc))
        return parser

    monkeypatch.setattr(cli_main, "build_parser", build_parser)


def one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize(
    "exc, code, said",
    [
        (RunFailed("run in runs/x failed: node(s) exited"), 1, "robot-controller boom: run in runs/x failed"),
        (KeyboardInterrupt(), 130, "robot-controller boom: interrupted"),
    ],
)
def test_a_failed_run_and_ctrl_c_are_one_line(monkeypatch, capsys, exc, code, said):
    verb_raising(monkeypatch, exc)
    assert cli_main.main(["boom"]) == code
    assert one_line(capsys).startswith(said)


def test_a_fault_of_ours_is_one_line_with_its_traceback_in_the_run_folder(monkeypatch, capsys, tmp_path):
    verb_raising(monkeypatch, TypeError("joint\nnames"))
    assert cli_main.main(["boom", "--out", str(tmp_path / "run")]) == 1
    line = one_line(capsys)
    log = tmp_path / "run" / "error.log"
    assert line == f"robot-controller boom: TypeError: joint names (traceback in {log})"
    assert "Traceback" in log.read_text() and "TypeError" in log.read_text()


def test_identify_whose_run_failed_is_one_line_exit_1(monkeypatch, capsys, tmp_path):
    from robot_controller.experiments import identify

    def fails(params, out, **_):
        raise RunFailed(f"run in {out}/run failed: node(s) exited with an error on shutdown: recorder (-9)")

    monkeypatch.setattr(identify, "identify", fails)
    assert cli_main.main(["identify", "--out", str(tmp_path / "id")]) == 1
    assert "recorder (-9)" in one_line(capsys)

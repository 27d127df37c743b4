"""The reference pages in docs/ are what the code writes: a parameter or an
option changed without regenerating its page fails here, naming the command
that regenerates it. Fast, no ROS."""

from pathlib import Path

import pytest

from robot_controller import cli
from robot_controller.cli import docs

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.parametrize(
    "page, args, command",
    [
        ("parameters.md", ["params", "--markdown"], docs.PARAMS_COMMAND),
        ("cli.md", ["help", "--markdown"], docs.CLI_COMMAND),
    ],
)
def test_the_committed_reference_page_is_what_the_command_writes(tmp_path, page, args, command):
    written = tmp_path / page
    assert cli.main([*args, str(written)]) == 0
    committed = DOCS / page
    assert committed.is_file(), f"docs/{page} is missing; write it with: {command}"
    assert (
        committed.read_text() == written.read_text()
    ), f"docs/{page} differs from what the code writes; regenerate it with: {command}"


def test_the_markdown_goes_to_stdout_without_a_path(capsys):
    assert cli.main(["params", "--markdown"]) == 0
    assert capsys.readouterr().out == docs.parameters_markdown()


def test_the_parameter_reference_refuses_options_it_would_ignore(capsys):
    assert cli.main(["params", "--markdown", "--preset", "tutorial"]) == 2
    assert "--markdown documents the schema" in capsys.readouterr().err


def test_every_parameter_and_every_verb_is_in_its_page():
    from robot_controller import parameters as cfg

    params = docs.parameters_markdown()
    for node in cfg.NODES:
        assert f"## {node}" in params
        for spec in cfg.SCHEMA[node]:
            assert f"| `{spec.name}` |" in params, (node, spec.name)
    text = docs.cli_markdown(cli.build_parser())
    for name, _, _ in docs.subcommands(cli.build_parser()):
        assert f"\n## {name}\n" in text, name


def test_help_verb_prints_that_verb_s_help_as_verb_help_does(capsys):
    assert cli.main(["help", "faults"]) == 0
    said = capsys.readouterr().out
    assert said.startswith("usage: robot-controller faults")
    faults = next(sub for name, _, sub in docs.subcommands(cli.build_parser()) if name == "faults")
    assert said == faults.format_help()
    assert "--- run ---" not in said  # that verb alone


@pytest.mark.parametrize(
    "args, said",
    [
        (["help", "fault"], "robot-controller help: no verb 'fault'; the verbs: run, score"),
        (["help", "faults", "--markdown"], "--markdown writes every verb's page: give no VERB with it"),
    ],
)
def test_help_of_an_unknown_verb_is_one_line_naming_the_verbs(capsys, args, said):
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert said in err and len(err.strip().splitlines()) == 1

"""Every verb that runs the loop says once what loading the arm's description changed (fingers held still,
meshes dropped), before it writes anything."""

from __future__ import annotations

import pytest

from robot_controller import cli, robots

EXAMPLE = str(robots.__file__).rpartition("/robot_controller/")[0] + "/examples/own_controller.py:PDWithGravity"


@pytest.mark.parametrize(
    "argv",
    [
        ["run"],
        ["step", "--amplitude", "0.05"],
        ["compare"],
        ["identify"],
        ["faults"],
        ["tune", "--controller", EXAMPLE],
    ],
    ids=lambda argv: argv[0],
)
def test_each_verb_says_the_arms_note_once(argv, tmp_path, capsys):
    note = robots.robot("z1").note
    assert "held still" in note  # the gripper: a verb has something to say
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    assert cli.main([*argv, "--robot", "z1", "--out", str(not_a_folder)]) == 2  # refused: nothing runs
    said = capsys.readouterr()
    assert said.out.count(note) == 1 and "is not a directory" in said.err, said

"""An output folder replaces only an earlier result: ``--out`` naming the current folder (``.``, ``""``), its
parent, the home folder, the folder holding the scenario, a symbolic link to any of them, or a non-empty
folder without the result mark is refused before any work (exit 1, one ``error:`` line) and nothing in it
changes; the same through plan, simulate, sweep, corners, demo, report and import-rapid."""

import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pathmotion.cli import PROGRESS_LINE, app
from pathmotion.errors import OutputError
from pathmotion.io import atomic
from pathmotion.io.files import RESULT_MARK, check_replaceable

from reliability_cases import JOINT

runner = CliRunner()
RAPID = Path(__file__).parent / "data" / "abb_cycle.mod"


def snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in sorted(folder.rglob("*"))}


@pytest.fixture
def project(tmp_path, monkeypatch):
    """A working folder (the current folder) under a fake home, holding the scenario and a user's file."""
    home = tmp_path / "home"
    work = home / "work"
    work.mkdir(parents=True)
    (work / "scenario.toml").write_text(JOINT)
    (work / "notes.txt").write_text("the user's own file")
    (home / "thesis.tex").write_text("months of work")
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(work)
    return work


def refused(args, *words):
    res = runner.invoke(app, args)
    lines = [ln for ln in res.output.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert res.exit_code == 1, (args, res.exit_code, res.output)
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    for w in words:
        assert w in res.output, (w, res.output)


def outs(project: Path) -> dict:
    """Every --out that would lose the user's files, with a word the refusal must hold."""
    home = project.parent
    for name, target in {"link_here": project, "link_home": home, "link_up": home.parent}.items():
        os.symlink(target, project.parent / name)
    return {".": "current folder", "": "current folder", "..": "current folder", str(home): "current folder",
            str(project): "current folder", str(home / "link_here"): "symbolic link",
            str(home / "link_home"): "symbolic link", str(home / "link_up"): "symbolic link"}


@pytest.mark.parametrize("command", ["plan", "simulate", "sweep"])
def test_run_commands_refuse_folders_that_are_not_results(project, command):
    cases = outs(project)
    before = snapshot(project.parent)
    extra = ["--set", "plan.grid_points=60,70"] if command == "sweep" else ["--no-figures"]
    for out, word in cases.items():
        refused([command, "scenario.toml", "--out", out, *extra], word, "--out")
    assert snapshot(project.parent) == before
    assert (project / "notes.txt").read_text() == "the user's own file"
    assert (project.parent / "thesis.tex").read_text() == "months of work"


def test_corners_and_demo_refuse_folders_that_are_not_results(project):
    for out, word in outs(project).items():
        refused(["corners", "--angles", "90", "--tolerances", "0.001", "--out", out], word)
        refused(["demo", "--out", out, "--no-study"], word)
    assert (project / "notes.txt").read_text() == "the user's own file"


def test_the_scenarios_folder_is_refused_even_when_it_is_not_the_current_folder(project, tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    refused(["plan", str(project / "scenario.toml"), "--out", str(project), "--no-figures"], "the input")
    assert (project / "notes.txt").exists() and (project / "scenario.toml").exists()


def test_a_non_empty_folder_without_the_mark_is_refused_and_a_result_is_replaced(project):
    other = project / "other"
    other.mkdir()
    (other / "data.csv").write_text("1,2\n")
    refused(["plan", "scenario.toml", "--out", "other", "--no-figures"], "not a pathmotion result", RESULT_MARK)
    assert (other / "data.csv").read_text() == "1,2\n"
    empty = project / "empty"
    empty.mkdir()
    for out in ("empty", "new/run"):  # an empty or missing folder becomes a result; a result is replaced
        for _ in range(2):
            res = runner.invoke(app, ["plan", "scenario.toml", "--out", out, "--no-figures"])
            assert res.exit_code == 0, res.output
            assert (project / out / RESULT_MARK).is_file() and (project / out / "summary.json").is_file()


def test_report_and_import_rapid_refuse_folders_and_their_input_as_the_output_file(project, tmp_path):
    rapid = project / "cycle.mod"
    rapid.write_bytes(RAPID.read_bytes())
    before = snapshot(project)
    for out in (".", "", "..", str(project.parent)):
        refused(["import-rapid", "cycle.mod", "--out", out], "--out" if out in ("", ".") else "is a folder")
        refused(["report", ".", "--out", out])
    refused(["import-rapid", "cycle.mod", "--out", "cycle.mod"], "the input")
    assert snapshot(project) == before


def test_result_folder_itself_refuses_what_it_may_not_replace(project):
    """The API's own guard, for callers that do not go through the command line's check."""
    for out in (Path("."), project, project.parent):
        with pytest.raises(OutputError, match="current folder"):
            with atomic.result_folder(out):
                pass
    with pytest.raises(OutputError, match="not a pathmotion result"):
        (project / "x").mkdir()
        (project / "x" / "f").write_text("")
        check_replaceable(project / "x")
    assert (project / "notes.txt").exists()

"""Every class of bad input (tests/reliability_cases.py, listed in docs/bad-inputs.md) raises its
PathmotionError subclass with a message that says what, where and what to change, through the API and
through the command line (exit 1, one ``error:`` line, no traceback, no temporary file left)."""

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pathmotion import api
from pathmotion.cli import PROGRESS_LINE, app
from pathmotion.errors import PathmotionError

from reliability_cases import CASES, CLASSES

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def write_case(case, folder: Path) -> Path:
    for name, text in case.files.items():
        (folder / name).write_text(text)
    path = folder / "scenario.toml"
    path.write_bytes(case.text.encode("utf-8", "surrogateescape"))
    return path


def run_api(case, folder: Path) -> tuple[str, PathmotionError]:
    """(stage reached, error) of the flow load -> plan -> write (plan files) -> simulate (its settings)."""
    path = write_case(case, folder)
    stage = "load"
    try:
        setup = api.load(path, dict(case.overrides))
        if case.stage == "simulate":
            stage = "simulate"
            api.simulation_settings(setup)
        else:
            stage = "plan"
            result = api.plan_scenario(setup)
            stage = "write"
            api.write_plan(setup, result, folder / "out")
    except PathmotionError as exc:
        return stage, exc
    raise AssertionError(f"{case.id}: no error at any stage")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_raises_its_error_saying_what_where_and_what_to_change(case, tmp_path):
    stage, exc = run_api(case, tmp_path)
    assert type(exc) is case.error, f"{case.id}: {type(exc).__name__}: {exc}"
    assert stage == case.stage, f"{case.id}: failed at {stage}, expected at {case.stage}: {exc}"
    message = str(exc)
    for pattern in case.says:
        assert re.search(pattern, message), f"{case.id}: {pattern!r} not in {message!r}"


CLI_CASES = [c for c in CASES if c.stage == "load" or c.id in ("every_limit_off", "start_velocity_too_high",
                                                                 "sample_time_far_too_small")]


@pytest.mark.parametrize("case", CLI_CASES, ids=[c.id for c in CLI_CASES])
def test_command_line_prints_one_error_line_and_exits_1(case, tmp_path):
    path = write_case(case, tmp_path)
    sets = [f"--set={k}={v}" for k, v in case.overrides.items()]
    out = tmp_path / "out"
    res = runner.invoke(app, ["plan", str(path), "--out", str(out), "--no-figures", *sets])
    lines = [ln for ln in res.output.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert res.exit_code == 1, f"{case.id}: exit {res.exit_code}: {res.output}"
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert "Traceback" not in res.output
    if not case.overrides:  # (--set parses values itself: an inf is refused before the scenario sees it)
        again = tmp_path / "again"
        again.mkdir()
        first = str(run_api(case, again)[1]).splitlines()[0].replace(str(again), str(tmp_path))
        assert lines[0] == f"error: {first}"  # the message, unchanged (no markup eaten)
    assert not list(tmp_path.rglob("*.tmp"))


def test_the_catalogue_covers_the_issue_classes():
    wanted = {"malformed file", "wrongly typed value", "unknown key", "wrong units", "wrong joint count",
              "NaN or inf", "unreachable or singular path", "zero-length or degenerate segment",
              "180 degree reversal", "limit zero or of the wrong sign", "gravity torque above a limit",
              "impossible boundary velocity", "blend that does not fit", "URDF loop or missing joint"}
    assert wanted <= set(CLASSES)
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids))


def test_docs_list_every_case_and_no_other():
    doc = (ROOT / "docs" / "bad-inputs.md").read_text()
    listed = set(re.findall(r"^\| `([a-z0-9_]+)` \|", doc, flags=re.M))
    assert listed == {c.id for c in CASES}
    for klass in CLASSES:
        assert f"### {klass}" in doc, klass

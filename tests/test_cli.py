"""The command line as a user meets it: every subcommand, its files, and one-line errors (never a traceback)."""

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from pathmotion.cli import app
from pathmotion.scenarios import scenario_names, scenario_path
from reliability_cases import _then

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]


def run(*args):
    result = runner.invoke(app, [str(a) for a in args])
    return result.exit_code, result.output


def test_help_of_every_command_shows_an_example():
    import typer.main

    commands = set(typer.main.get_group(app).commands)
    assert {"robots", "init", "schema", "check", "plan", "simulate", "sweep", "corners", "report", "demo"} <= commands
    for cmd in sorted(commands):
        code, out = run(cmd, "--help")
        assert code == 0 and "Example" in out, cmd


def test_help_markup_only_styles_and_never_eats_text():
    """Rich reads [word] in help text as a tag and drops it ('pathmotion[optimal]' became 'pathmotion'):
    every docstring and option help renders to its source text with only the style tags removed."""
    import re

    import typer.main
    from rich.text import Text

    style = re.compile(r"\[/?(bold|yellow|red|green|dim|italic)?\]")
    group = typer.main.get_group(app)
    texts = [group.help]
    for name, command in group.commands.items():
        texts.append(command.help)
        texts += [p.help for p in command.params if getattr(p, "help", None)]
    for text in filter(None, texts):
        assert Text.from_markup(text).plain == style.sub("", text).replace("\\[", "["), text


def test_paths_with_brackets_are_printed_as_they_are(tmp_path):
    """A folder named like a Rich tag ('[ab]') is printed, not dropped as markup."""
    target = tmp_path / "[ab]" / "s.toml"
    target.parent.mkdir()
    code, out = run("init", target)
    assert code == 0 and target.exists()
    assert f"wrote {target}" in out.replace("\n", ""), out
    code, out = run("schema", "--out", tmp_path / "[ab]" / "schema.json")
    assert code == 0 and "[ab]" in out, out


def test_robots_lists_the_irb140_with_official_speeds():
    code, out = run("robots")
    assert code == 0
    assert "IRB140" in out and "200" in out and "450" in out and "official" in out and "estimate" in out


def test_init_writes_a_scenario_that_checks(tmp_path):
    target = tmp_path / "s.toml"
    code, out = run("init", target)
    assert code == 0 and target.exists()
    code, out = run("init", target)
    assert code == 1 and "exists" in out and "--force" in out
    code, out = run("check", target)
    assert code == 0, out
    assert "min_singular_value" in out


def test_init_template_uses_the_given_file_name(tmp_path):
    import tomllib

    target = tmp_path / "my_corner.toml"
    code, _ = run("init", target)
    assert code == 0
    text = target.read_text()
    assert tomllib.loads(text)["name"] == "my_corner"
    assert f"pathmotion check {target}" in text and "example" not in text and "{" not in text.split("\n\n")[0]


def test_init_from_a_shipped_scenario(tmp_path):
    code, _ = run("init", tmp_path / "c.toml", "--from", "corner_g2")
    assert code == 0
    assert (tmp_path / "c.toml").read_text() == scenario_path("corner_g2").read_text()
    code, out = run("init", tmp_path / "d.toml", "--from", "nonsense")
    assert code == 1 and "corner_g2" in out


def test_schema_is_valid_json_with_the_top_level_tables(tmp_path):
    code, _ = run("schema", "--out", tmp_path / "schema.json")
    assert code == 0
    schema = json.loads((tmp_path / "schema.json").read_text())
    assert {"robot", "path", "limits", "plan", "simulate"} <= set(schema["properties"])


def test_plan_writes_the_contract_files(tmp_path):
    out = tmp_path / "plan"
    code, text = run("plan", scenario_path("circle_max"), "--out", out, "--set", "plan.grid_points=400")
    assert code == 0, text
    for name in ("trajectory.csv", "trajectory.parquet", "summary.json", "phase_plane.csv", "trajectory_ros2.yaml",
                 "trajectory_egm.csv", "trajectory_rapid.mod", "phase_plane.png", "joints.png", "scenario.toml"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    for key in ("duration_s", "solve_time_s", "grid_points", "max_velocity_ratio", "max_acceleration_ratio",
                "max_torque_ratio", "baseline_constant_speed_duration_s", "fitted_profile_duration_s"):
        assert key in summary, key
    assert summary["max_acceleration_ratio"] <= 1.001 and summary["max_torque_ratio"] <= 1.001
    assert summary["baseline_constant_speed_duration_s"] > summary["duration_s"]
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert header == (["t", "theta", "theta_dot", "theta_ddot"] + [f"{p}{j}" for p in ("q", "qd", "qdd", "tau")
                                                                    for j in range(1, 7)])
    data = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(np.diff(data[:-1, 0]), 0.004, atol=1e-12)
    assert data[-1, 0] == pytest.approx(summary["duration_s"], abs=1e-9)
    ros = yaml.safe_load((out / "trajectory_ros2.yaml").read_text())
    assert len(ros["points"]) == len(data)
    # circle_max starts at speed: every export says so, with the speeds of trajectory.csv's first row
    qd0 = data[0, 10:16]
    assert np.max(np.abs(qd0)) > 0.1
    first = (out / "trajectory_ros2.yaml").read_text().splitlines()[0]
    assert "the arm must already move at" in first and f"{qd0[0]:.4g}" in first
    egm_first = (out / "trajectory_egm.csv").read_text().splitlines()[0]
    assert "must already move at" in egm_first and f"[{np.degrees(qd0[0]):.4g}, " in egm_first
    assert "must already move at" in text


def test_simulate_writes_results_and_the_plan(tmp_path):
    out = tmp_path / "sim"
    code, text = run("simulate", scenario_path("corner_g2"), "--out", out, "--set", "plan.grid_points=400")
    assert code == 0, text
    summary = json.loads((out / "summary.json").read_text())
    for key in ("planned_duration_s", "cycle_time_s", "settle_time_s", "max_joint_deviation_rad", "rms_joint_deviation_rad",
                "path_accuracy_m", "max_sharp_deviation_m", "max_torque_ratio", "max_commanded_torque_ratio",
                "tracking_ok"):
        assert key in summary, key
    assert summary["tracking_ok"] is True
    assert summary["max_sharp_deviation_m"] <= 0.0051
    header = (out / "simulation.csv").read_text().splitlines()[0].split(",")
    assert header[:2] == ["t", "theta"] and "q_desired6" in header and "tcp_desired_z" in header
    assert (out / "plan" / "trajectory.csv").is_file()
    assert (out / "tracking_task.png").is_file() and (out / "tracking_joints.png").is_file()
    assert _in_order(text, [f"simulate: {stage} (stage {k}/4)" for k, stage in
                            enumerate(("load and search", "plan", "closed loop", "writing"), 1)])


def _in_order(text: str, lines: list[str]) -> bool:
    """Every one of ``lines`` is a line of ``text``, in that order."""
    got = [line.strip() for line in text.splitlines()]
    return all(line in got for line in lines) and [got.index(line) for line in lines] == sorted(
        got.index(line) for line in lines)


EXPORTS = ("trajectory_ros2.yaml", "trajectory_egm.csv", "trajectory_rapid.mod")


def test_tracking_failure_exits_4_writes_every_file_and_refuses_exports(tmp_path):
    code, text = run("simulate", scenario_path("corner_max"), "--out", tmp_path / "m")
    assert code == 4, text
    assert "tracking failed" in text and "--force" in text
    summary = json.loads((tmp_path / "m" / "summary.json").read_text())
    assert summary["tracking_ok"] is False and summary["failure"]["reason"]
    for name in ("simulation.csv", "tracking_task.png", "plan/trajectory.csv", "plan/summary.json"):
        assert (tmp_path / "m" / name).is_file(), name
    assert not any((tmp_path / "m" / "plan" / name).exists() for name in EXPORTS)
    failures = json.loads((tmp_path / "m" / "plan" / "summary.json").read_text())["failures"]
    assert any(f["kind"] == "tracking" and f["message"].startswith("tracking failed") for f in failures)


def test_failed_plan_exits_4_and_forced_exports_carry_a_warning(tmp_path):
    """corner_max crosses its corner at speed: the plan itself fails (a velocity jump)."""
    args = ("plan", scenario_path("corner_max"), "--set", "plan.grid_points=200", "--no-figures")
    code, text = run(*args, "--out", tmp_path / "a")
    assert code == 4, text
    assert (tmp_path / "a" / "trajectory.csv").is_file()
    assert not any((tmp_path / "a" / name).exists() for name in EXPORTS)
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["failures"]
    code, text = run(*args, "--out", tmp_path / "b", "--force")
    assert code == 4, text
    first = {name: (tmp_path / "b" / name).read_text().splitlines()[:2] for name in EXPORTS}
    assert first["trajectory_ros2.yaml"][0].startswith("# WARNING: exported with --force although the plan failed")
    assert first["trajectory_egm.csv"][0].startswith("# WARNING")
    assert first["trajectory_rapid.mod"][1].startswith("  ! WARNING")
    lines = (tmp_path / "b" / "trajectory_egm.csv").read_text().splitlines()
    body = [line for line in lines if not line.startswith("#")]
    assert body[0].startswith("t,j1,") and np.loadtxt(body[1:], delimiter=",").shape[1] == 13


def test_exit_codes_are_distinct():
    from pathmotion.cli import EXIT_FAILED_RESULT

    code, _ = run("plan", "--no-such-option")
    assert code == 2  # Click's usage error
    assert EXIT_FAILED_RESULT not in (0, 1, 2, 3, 130)


@pytest.mark.parametrize("args, expected", [
    (["check", "missing.toml"], "does not exist"),
    (["plan", "{bad}", "--out", "{tmp}/o"], "not valid TOML"),
    (["plan", "{circle}", "--out", "{tmp}/o", "--set", "plan.grid_points=abc"], "plan.grid_points"),
    (["plan", "{circle}", "--out", "{tmp}/o", "--set", "plan.start=fast"], "plan.start"),
    (["plan", "{circle}", "--out", "{tmp}/o", "--set", "limits.torque_scale=0.01"], "gravity torque"),
    (["plan", "{circle}", "--out", "{tmp}/o", "--set", "path.segments[0].center=[2.0, 0.0, 0.5]"], "theta"),
    (["simulate", "{circle}", "--out", "{tmp}/o", "--set", "simulate.controller=magic"], "simulate.controller"),
    (["plan", "{circle}", "--out", "{tmp}/o", "--set", "plan.typo=1"], "unknown key"),
])
def test_bad_input_is_one_line_and_exit_1(tmp_path, args, expected):
    bad = tmp_path / "bad.toml"
    bad.write_text("[path\ntype = 'task'")
    fill = {"{bad}": str(bad), "{tmp}": str(tmp_path), "{circle}": str(scenario_path("circle_max"))}
    args = [a for a in args]
    for i, a in enumerate(args):
        for k, v in fill.items():
            a = a.replace(k, v)
        args[i] = a
    if "center=[2.0, 0.0, 0.5]" in " ".join(args):  # --set takes scalars; use a scenario file instead
        text = scenario_path("circle_max").read_text().replace("center = [0.5, 0.0, 0.5]", "center = [2.0, 0.0, 0.5]")
        moved = tmp_path / "far.toml"
        moved.write_text(text)
        args = ["plan", str(moved), "--out", str(tmp_path / "o")]
    code, out = run(*args)
    assert code == 1, out
    assert "Traceback" not in out
    assert expected in out
    assert len(out.strip().splitlines()) <= 3


def _cli_process(*args, tmp_path):
    """The real command in a process, stderr apart from stdout; a wide terminal so log lines do not wrap."""
    env = {**os.environ, "COLUMNS": "250"}
    return subprocess.run([sys.executable, "-m", "pathmotion.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=600, env=env, cwd=tmp_path)


def test_verbose_shows_the_stages_on_stderr_and_the_default_shows_none(tmp_path):
    args = ("simulate", scenario_path("corner_g2"), "--set", "plan.grid_points=300", "--no-figures")
    stages = ("robot IRB140 loaded", "lift: IK along the task path", "grid: 3", "solve pass 1", "verify pass 1",
              "planned:", "baselines:", "closed-loop design: orbital", "loop start: orbital controller, builtin plant",
              "loop end at t =", "arrived, cycle time", "writing the plan to", "writing the simulation to")
    quiet = _cli_process(*args, "--out", tmp_path / "quiet", tmp_path=tmp_path)
    assert quiet.returncode == 0, quiet.stderr
    assert not any(s in quiet.stderr for s in stages) and "INFO" not in quiet.stderr, quiet.stderr
    loud = _cli_process("-v", *args, "--out", tmp_path / "loud", tmp_path=tmp_path)
    assert loud.returncode == 0, loud.stderr
    missing = [s for s in stages if s not in loud.stderr]
    assert not missing and "DEBUG" not in loud.stderr, (missing, loud.stderr)
    assert not any(s in loud.stdout for s in stages)  # the results stay on stdout, the stages on stderr
    assert json.loads((tmp_path / "quiet" / "summary.json").read_text())["tracking_ok"] is True
    details = _cli_process("-vv", "check", scenario_path("corner_g2"), tmp_path=tmp_path)
    assert details.returncode == 0, details.stderr
    assert "DEBUG" in details.stderr and "lifted joint path" in details.stderr


# a 90 degree corner, then back along the last line: a pick point left the way it was approached
PICK_AND_BACK = _then('[[path.segments]]\ntype = "line"\nend = [0.6, 0.1, 0.5]\n[[path.segments]]\ntype = "line"\n'
                      'end = [0.5, 0.1, 0.5]\n[[path.blends]]\ncorner = "all"\ntype = "g2"\ntolerance = 0.004')


def test_corner_all_leaves_a_reversal_sharp_and_the_default_output_says_so(tmp_path):
    """corner = "all" blends every corner a blend can round; where the path turns back it stays sharp (the
    motion stops), and that warning reaches stderr without -v, as one line beside the progress line of each stage
    (the stages' INFO log lines do not reach it)."""
    (tmp_path / "s.toml").write_text(PICK_AND_BACK)
    run = _cli_process("plan", "s.toml", "--out", tmp_path / "out", "--no-figures", tmp_path=tmp_path)
    assert run.returncode == 0, run.stderr
    progress = [line for line in run.stderr.splitlines() if re.fullmatch(r"plan: [a-z -]+ \(stage \d/3\)", line)]
    assert len(progress) == 3
    lines = [line for line in run.stderr.splitlines() if line not in progress]  # one line, never wrapped at the
    # console's width: what a CI log greps
    assert len(lines) == 1 and lines[0].startswith('warning: path.blends[0] (corner = "all"): the path turns back at '
                                                   "connection 1") and lines[0].endswith("the motion stops there")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert len(summary["kinks_theta"]) == 1 and 0.0 < summary["blend_max_deviation_m"] <= 0.004 * (1 + 1e-6)
    explicit = PICK_AND_BACK.replace('corner = "all"', "corner = 2")  # named, the reversal is an error
    (tmp_path / "e.toml").write_text(explicit)
    refused = _cli_process("plan", "e.toml", "--out", tmp_path / "e", tmp_path=tmp_path)
    assert refused.returncode == 1 and "path.blends[0] (corner 2)" in refused.stderr
    assert "reverses direction" in refused.stderr


def test_real_process_prints_no_traceback_and_exits_nonzero(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "pathmotion.cli", "plan", str(tmp_path / "none.toml"), "--out",
                           str(tmp_path / "o")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr + proc.stdout
    assert "does not exist" in proc.stderr


def test_every_shipped_scenario_checks():
    for name in scenario_names():
        code, out = run("check", scenario_path(name))
        assert code == 0, (name, out)
    assert (ROOT / "scenarios").resolve() == scenario_path("corner_g2").parent.resolve()


def test_version_is_the_installed_distribution_version():
    from importlib.metadata import version

    code, out = run("--version")
    assert code == 0 and out.strip() == f"pathmotion {version('pathmotion')}"


def test_plan_defaults_out_to_out_slash_the_scenario_name_and_report_takes_out(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, text = run("plan", scenario_path("circle_zero"), "--set", "plan.grid_points=100", "--no-figures")
    assert code == 0, text
    assert (tmp_path / "out" / "circle_zero" / "summary.json").is_file()
    stages = ["plan: load and search (stage 1/3)", "plan: time-optimal profile (stage 2/3)", "plan: writing (stage 3/3)"]
    assert _in_order(text, stages)  # not a terminal: one progress line per stage
    code, text = run("report", tmp_path / "out" / "circle_zero", "--out", tmp_path / "elsewhere" / "r.html")
    assert code == 0, text
    assert (tmp_path / "elsewhere" / "r.html").read_text().startswith("<!DOCTYPE html>")
    assert not (tmp_path / "out" / "circle_zero" / "report.html").exists()


def test_robots_shows_units_on_every_column_and_the_sources_once():
    code, out = run("robots")
    assert code == 0
    for unit in ("range [deg]", "speed [deg/s]", "accel [rad/s^2]", "torque [N m]"):
        assert unit in out, unit
    assert out.count("sources:") == 1 and out.count("official") <= 3
    assert "velocity official" in out and "torque estimate" in out


@pytest.mark.parametrize("width", [40, 60, 120])
def test_tables_never_cut_numbers_on_narrow_or_piped_consoles(width):
    import io

    from rich.console import Console
    from rich.table import Table

    from pathmotion.cli import _format_cell, _print_table, _summary_table

    summary = {"max_path_deviation_m": 0.022123456789, "a_rather_long_key_name_for_the_table": 1234567.891,
               "failures": ["the path speed jumps at theta = 0.628319", "a limit is exceeded"],
               "connections": {"kind": "corner", "angle_deg": 90.0}, "ok": True}
    table = Table("scenario", "planned [s]", "simulated [s]", "joint dev [mrad]", "path dev [mm]", "sharp dev [mm]")
    table.add_row("corner_transition_long_name", *[_format_cell(v) for v in (1.33123, 1.33145, 0.0541, 0.02212, 18.7)])
    # every number each table holds (written out here, so that a change of the formatting fails the test
    # instead of skipping the check) must appear whole in the printed text
    expected = {"summary": ("0.0221235", "1.23457e+06", "90"), "columns": ("1.331", "0.0541", "0.02212", "18.7")}
    for (kind, numbers), tab in zip(expected.items(), (_summary_table("t", summary), table)):
        buf = io.StringIO()
        _print_table(tab, Console(file=buf, width=width, force_terminal=False))
        text = buf.getvalue()
        assert "…" not in text and "..." not in text
        cells = " ".join(str(c) for col in tab.columns for c in col.cells)
        for number in numbers:
            assert number in cells, (kind, number, cells)
            assert number in text, (kind, number, text)
    assert "the path speed jumps at theta = 0.628319; a limit is exceeded" in list(
        _summary_table("t", summary).columns[1].cells)[2]


def test_check_reports_a_full_circle_as_closed_and_explains_periodic():
    code, out = run("check", scenario_path("circle_max"))
    assert code == 0, out
    row = next(line for line in out.splitlines() if " closed " in line)
    assert "True" in row and "ends where it starts" in out and "plan.periodic" in out
    code, out = run("check", scenario_path("corner_g2"))
    assert "False" in next(line for line in out.splitlines() if " closed " in line)
    assert "items)" not in out and "connection 0 (after segment 1) at theta" in out


def test_plan_explains_the_reported_grid_points():
    from pathmotion import api
    from pathmotion.cli import _grid_note

    setup = api.load(scenario_path("circle_zero"), {"plan.grid_points": 100})
    assert _grid_note(setup, {"grid_points": 100}) == {}
    note = _grid_note(setup, {"grid_points": 117})["grid_points"]
    assert note.startswith("plan.grid_points = 100 uniform points, plus the path's connections")
    adaptive = api.load(scenario_path("circle_zero"))
    assert adaptive.scenario.plan.grid_points is None
    assert _grid_note(adaptive, {"grid_points": 517})["grid_points"].startswith("adaptive grid: refined until")


def test_an_interrupt_swallowed_in_a_c_callback_is_delivered_again(capsys):
    """SIGTERM/Ctrl-C landing in a C callback (numba's compiler calls back into Python) used to print an
    'Exception ignored' traceback and be lost, the run going on (found by benchmarks/fuzz_cli.py). The CLI's
    unraisable hook delivers it again, outside the callback, and prints nothing."""
    import ctypes
    import signal

    from pathmotion import cli

    def compare(a, b):
        raise KeyboardInterrupt("signal 15")

    cmp = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int))(compare)
    values = (ctypes.c_int * 3)(3, 1, 2)
    qsort = ctypes.CDLL(None).qsort
    before = sys.unraisablehook
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.unraisablehook = cli._unraisable
    try:
        with pytest.raises(KeyboardInterrupt):
            qsort(values, len(values), ctypes.sizeof(ctypes.c_int), cmp)  # the callback's exception is swallowed
            time.sleep(5.0)  # ... and raised again here, in the main thread, a moment later
    finally:
        sys.unraisablehook = before
        signal.signal(signal.SIGINT, previous)
    assert capsys.readouterr().err == ""
    # other unraisable exceptions go to the debug log only
    sys.unraisablehook = cli._unraisable
    try:
        qsort(values, len(values), ctypes.sizeof(ctypes.c_int), ctypes.CFUNCTYPE(
            ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int))(lambda a, b: 1 / 0))
    finally:
        sys.unraisablehook = before
    assert capsys.readouterr().err == ""


def test_an_interrupt_inside_numbas_compiler_is_delivered_after_it_returns():
    """Raised inside numba's compiler, a KeyboardInterrupt can leave a half-built compiled function that
    the caller still runs (a segmentation fault under benchmarks/fuzz_cli.py): the handler defers it."""
    import signal
    import time

    from pathmotion import cli

    namespace = {"__name__": "numba.core.fake_compiler", "cli": cli, "signal": signal, "sys": sys}
    exec("def compile_step():\n"
         "    cli._interrupt(signal.SIGINT, sys._getframe())\n"
         "    return 'compiled'\n", namespace)
    previous = signal.signal(signal.SIGINT, cli._interrupt)
    try:
        assert namespace["compile_step"]() == "compiled"  # not raised inside the "compiler"
        with pytest.raises(KeyboardInterrupt):
            time.sleep(5.0)  # ... but here, outside it, a moment later
        with pytest.raises(KeyboardInterrupt):  # outside the compiler it is raised at once
            cli._interrupt(signal.SIGTERM, sys._getframe())
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize("run_code", [0, 2])
def test_an_interrupt_after_the_run_ended_keeps_its_exit_code_and_prints_no_traceback(monkeypatch, run_code):
    """A signal landing after the command returned, before main() resets the handlers, raised KeyboardInterrupt
    in main's ``finally`` and printed a traceback through typer's exit (seen in CI under load, as a test's SIGINT
    arrived at the end of a plan). Simulated: the run exits with ``run_code`` and the first handler reset raises
    as the pending signal would; main() exits with the run's own code and no exception escapes."""
    import signal

    from pathmotion import cli

    def run(**_):
        raise SystemExit(run_code)

    real = signal.signal
    landed = []

    def reset(signum, handler):
        if handler is signal.SIG_IGN and not landed:
            landed.append(signum)
            raise KeyboardInterrupt("signal 2")
        return real(signum, handler)

    previous = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM), sys.unraisablehook)
    monkeypatch.setattr(cli, "app", run)
    monkeypatch.setattr(signal, "signal", reset)
    try:
        with pytest.raises(SystemExit) as exc:
            cli.main()
    finally:
        real(signal.SIGINT, previous[0])
        real(signal.SIGTERM, previous[1])
        sys.unraisablehook = previous[2]
    assert landed and exc.value.code == run_code
    assert exc.value.__suppress_context__


def test_a_warning_is_one_line_verbatim_never_wrapped(capsys):
    """At the default verbosity a log warning is one ``warning: ...`` line however long, its markup-like text
    verbatim, a further line of the message indented below it; INFO stays off (it needs -v)."""
    import logging

    from pathmotion import cli

    cli._configure_logging(0)
    try:
        log = logging.getLogger("pathmotion.test_cli")
        long = "joint 2 at its limit [rad] " + "x" * 300
        log.warning("%s\nthe second line", long)
        log.info("a stage")
        assert capsys.readouterr().err.splitlines() == [f"warning: {long}", "  the second line"]
    finally:  # the package's logger as a library user has it: no handler of the CLI's, no level
        logging.getLogger("pathmotion").removeHandler(cli._LOG_HANDLER)
        logging.getLogger("pathmotion").setLevel(logging.NOTSET)
        cli._LOG_HANDLER = None


def test_corners_without_casadi_is_a_clear_bad_input_before_any_work(tmp_path, monkeypatch):
    """Without the [optimal] extra the references cannot be solved: exit 1 naming the extra and --no-references,
    and no folder written (not exit 0 with every row an error)."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "casadi" else real(name, *a))
    code, out = run("corners", "--angles", "90", "--tolerances", "0.005", "--out", str(tmp_path / "c"))
    assert code == 1, out
    assert "pathmotion[optimal]" in out and "--no-references" in out
    assert not (tmp_path / "c").exists()


def test_help_shows_no_python_type_beside_flags_or_lists():
    for command in ("plan", "simulate", "sweep", "corners", "check"):
        code, out = run(command, "--help")
        assert code == 0
        assert "<bool>" not in out and "<list[" not in out, command
    assert "without planning" not in run("check", "--help")[1]

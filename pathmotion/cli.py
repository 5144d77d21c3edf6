"""The ``pathmotion`` command: one subcommand per job, each a few lines over :mod:`pathmotion.api`.

Errors are printed on one or two lines (never a traceback) and the exit code is non-zero:
1 for a PathmotionError (bad input, infeasible limits, ...), 2 for usage errors (Click's code), 3 for an
internal error (a bug), 4 for a failed result (``plan``/``simulate``: a path-speed jump, a limit exceeded,
tracking failed; every file is still written, the exports only with ``--force``), 130 when interrupted.
Set PATHMOTION_DEBUG=1 to see the traceback of an internal error.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import logging
import os
import re
import sys
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from . import defaults
from .errors import PathmotionError, ScenarioError, clipped, printable

app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode="rich",
                  help="Time-optimal path-constrained motion for robot arms, proven in closed-loop simulation.")
console = Console(stderr=False, soft_wrap=True)  # a message line (a command to copy) is never wrapped
err_console = Console(stderr=True, soft_wrap=True)
_option_type = typer.core.TyperOption.display_type_rich


def _shown_type(self, ctx):
    """Typer's type label beside an option in --help, but none beside a flag (Typer writes <bool>)."""
    return None if self.is_flag else _option_type(self, ctx)


typer.core.TyperOption.display_type_rich = _shown_type
logger = logging.getLogger(__name__)


#: The study's best score: the lowest score, not the fastest run within a deviation ("best within 10 mm").
BEST_SCORE_TITLE = "best score: least cycle time + weight x mean deviation from the sharp path"

#: Exit code of a failed result (Click uses 2 for usage errors; 1 bad input, 3 internal error, 130 interrupted).
EXIT_FAILED_RESULT = 4

_LOG_HANDLER = None


#: Longest line of an error or warning printed [characters]: a message quoting unbounded input is cut, the rest
#: counted (each quote is already cut to errors.MAX_QUOTED_CHARS where the message is made).
MAX_MESSAGE_LINE_CHARS = 1000


def _print_message(label: str, message: str, empty: str) -> None:
    """``label`` (Rich markup) and the first line of ``message`` (``empty`` if it has none) on stderr, its further lines
    indented below it: each one line, never wrapped, non-printable characters escaped, markup-like text verbatim."""
    lines = [printable(clipped(line, MAX_MESSAGE_LINE_CHARS)) for line in (message.strip() or empty).split("\n")]
    err_console.print(f"{label} {escape(lines[0])}", highlight=False, soft_wrap=True)
    for line in lines[1:]:
        err_console.print(f"  {escape(line)}", highlight=False, soft_wrap=True)


class _LineHandler(logging.Handler):
    """A record on stderr as ``warning: <message>`` (its level in lower case), as the errors of :func:`_fail`: what a
    script or a CI log reads."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            _print_message(f"[bold yellow]{record.levelname.lower()}:[/]", record.getMessage(), "-")
        except Exception:  # noqa: BLE001 - logging's own contract: a handler never raises
            self.handleError(record)


def _configure_logging(verbose: int) -> None:
    """The ``pathmotion`` logger to stderr: by default only its warnings (a corner left sharp, an adaptive grid stopped
    short: what the user should know without asking), one line each (_LineHandler); -v the stages at INFO, -vv DEBUG,
    through Rich with times (and -vv source lines) for a person reading along."""
    global _LOG_HANDLER
    package = logging.getLogger("pathmotion")
    if _LOG_HANDLER is not None:  # a second invocation in one process (tests) starts afresh
        package.removeHandler(_LOG_HANDLER)
        _LOG_HANDLER = None
    if verbose > 0:
        from rich.logging import RichHandler

        _LOG_HANDLER = RichHandler(console=err_console, show_path=verbose > 1, markup=False, rich_tracebacks=False,
                                   show_time=True)
    else:
        _LOG_HANDLER = _LineHandler()
    level = logging.DEBUG if verbose > 1 else logging.INFO if verbose > 0 else logging.WARNING
    _LOG_HANDLER.setLevel(level)  # also for a child logger set lower (records reach a parent's handler regardless)
    package.addHandler(_LOG_HANDLER)
    package.setLevel(level)


def _fail(message: str, code: int = 1):
    """Print ``message`` (its first line after 'error:', any further lines, e.g. more validation
    errors, indented below) and exit with ``code``."""
    _print_message("[bold red]error:[/]", message, "error")
    raise typer.Exit(code)


def guarded(fn):
    """Turn PathmotionError into a one-line message and exit 1; never show a traceback."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        import warnings

        from .io.files import os_reason

        try:
            with warnings.catch_warnings():  # NumPy RuntimeWarnings etc. go to the debug log, never the terminal
                warnings.showwarning = _log_warning
                return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except PathmotionError as exc:
            _fail(str(exc))
        except BrokenPipeError:
            _pipe_closed()
        except OSError as exc:  # a file or folder the run uses: name it and say why
            _fail(f"{exc.filename or 'a file'}: {os_reason(exc)}")
        except KeyboardInterrupt:
            _interrupted()
        except Exception as exc:  # a bug: say so plainly, keep the traceback for debugging
            if _SIGNALLED:  # the interrupt, swallowed by a C extension and turned into this exception
                logger.debug("after signal %s: %s: %s", _SIGNALLED[-1], type(exc).__name__, exc)
                _interrupted()
            if os.environ.get("PATHMOTION_DEBUG"):
                raise
            _fail(f"internal error ({type(exc).__name__}: {exc}); please report it with the scenario "
                  "(PATHMOTION_DEBUG=1 shows the traceback)", code=3)

    return wrapper


def _pipe_closed():
    """The reader of our output went away (``pathmotion schema | head``): a normal end, exit 0 without a word.
    stdout now points at /dev/null, so the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no real stdout (a test runner's): nothing to redirect
        pass
    raise typer.Exit(0)


def _interrupted():
    """The clean exit of an interrupted command: one line, code 130 (atomic writes left no half-written file)."""
    err_console.print("[yellow]interrupted[/]: finished files are complete, nothing half-written remains")
    raise typer.Exit(130)


def _log_warning(message, category, filename, lineno, file=None, line=None):
    logger.debug("%s: %s (%s:%s)", category.__name__, message, filename, lineno)


def _out(out: Path, *inputs: Optional[Path]) -> Path:
    """``--out`` checked before any work: a creatable, writable folder that holds none of ``inputs`` (the
    run's input files), nor the current or home folder, and is new, empty or an earlier result (else a
    one-line error, exit 1)."""
    from .io.files import check_output_dir

    return check_output_dir(out, keep=[k for k in inputs if k is not None])


def _out_file(out: Path, *inputs: Path) -> Path:
    """A file ``--out`` checked before any work: a file name, not a folder, none of ``inputs``."""
    from .io.files import check_output_file

    return check_output_file(out, inputs)


def _scheduler(address: Optional[str]) -> Optional[str]:
    """``--scheduler`` checked before any work (io.scheduler.check_scheduler_address): [PROTOCOL://]HOST:PORT."""
    if address is not None:
        from .io.scheduler import check_scheduler_address

        try:
            check_scheduler_address(address)
        except ScenarioError as exc:
            _fail(f"--scheduler: {exc}")
    return address


def _overrides(sets: Optional[List[str]]) -> dict:
    from .io.scenario import parse_value

    out = {}
    for item in sets or []:
        if "=" not in item:
            _fail(f"--set {item!r}: expected KEY=VALUE, e.g. --set plan.grid_points=2000", code=2)
        key, value = item.split("=", 1)
        try:
            out[key.strip()] = parse_value(value)
        except ScenarioError as exc:
            _fail(f"--set {clipped(key.strip())}: {exc}")
    return out


def _progress() -> Progress:
    """The stages' progress bar on stderr, on a terminal only (elsewhere, e.g. a CI log, a transient bar leaves only
    an empty line behind)."""
    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                    TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(), console=err_console,
                    transient=True, disable=not err_console.is_terminal)


def _on_result(progress: Progress, task, label: str):
    """A study's callback (done, total): moves the bar on a terminal, else prints one line per finished point (a
    log still shows that an hours-long run is alive)."""
    def on_result(done: int, total: int) -> None:
        progress.update(task, completed=done, total=total)
        if not err_console.is_terminal:
            err_console.print(f"{label}: {done}/{total} points done", highlight=False, soft_wrap=True)
    return on_result


#: The progress line of a stage (``_stage``), as tools reading stderr recognise it.
PROGRESS_LINE = re.compile(r"^(plan|simulate): [a-z -]+ \(stage \d+/\d+\)$")


def _stage(progress: Progress, task, description: str, advance: int = 1) -> None:
    """Move a command's bar on to the stage ``description`` ("plan: time-optimal profile"): logged, and off a
    terminal (without -v) one line on stderr per stage, as a study's line per point: a CI log shows where a long
    run is."""
    progress.update(task, advance=advance, description=description)
    state = next(t for t in progress.tasks if t.id == task)
    line = f"{description} (stage {int(state.completed) + 1}/{int(state.total)})"
    logger.info("%s", line)
    if not err_console.is_terminal and not logger.isEnabledFor(logging.INFO):  # -v: the log has the line
        err_console.print(line, highlight=False, soft_wrap=True, markup=False)


_NUMBER = re.compile(r"^[-+]?(\d[\d,_]*\.?\d*|\.\d+)([eE][-+]?\d+)?( \.\. [-+]?\d+\.?\d*)?$")


def _fit(table: Table) -> Table:
    """Never cut a number or a heading: each column is at least as wide as its heading's longest word
    and its longest number (yes/NO, '-' included); longer text folds onto more lines instead of '...'."""
    for col in table.columns:
        cells = [c for c in col.cells if isinstance(c, str)]
        words = [w.replace("\\[", "[") for w in re.findall(r"\\?\[[^\]]*\]|\S+", str(col.header)) if table.show_header]
        whole = [c for c in cells if _NUMBER.match(c) or c in ("yes", "NO", "-")]
        widths = [len(w) for w in words + whole]
        col.min_width = max([col.min_width or 0, *widths])
        col.overflow = "fold"
    return table


def _grid_note(setup, summary: dict) -> dict:
    """Why the reported grid_points differs from plan.grid_points (empty when it does not)."""
    asked = setup.scenario.plan.grid_points
    if asked is None:
        return {"grid_points": "adaptive grid: refined until the duration is within plan.duration_tolerance "
                               "(plan.grid_points fixes the grid)"}
    if summary.get("grid_points") == asked:
        return {}
    return {"grid_points": f"plan.grid_points = {asked} uniform points, plus the path's connections and spline "
                           "knots and finer points next to the ends and connections, and any the limit check added"}


def _print_table(table: Table, to: Console | None = None) -> None:
    """Print ``table`` (see :func:`_fit`) without cropping: a table wider than a narrow terminal or a
    pipe's 80 columns runs past the edge instead of losing its right-hand columns."""
    (to or console).print(_fit(table), crop=False)


def _shown(v) -> str:
    """A summary value as text: lists and tables written out (key: value; ...), floats to 6 digits."""
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, dict):
        return "; ".join(f"{k}: {_shown(x)}" for k, x in v.items()) or "-"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_shown(x) for x in v) + "]" if all(not isinstance(x, str) for x in v) else (
            "; ".join(_shown(x) for x in v) or "-")
    return str(v)


def _summary_table(title: str, summary: dict, notes: dict | None = None) -> Table:
    """Key / value rows of ``summary`` (every list and table written out), with an optional note per key."""
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("key", style="bold")
    table.add_column("value")
    for k, v in summary.items():
        text = _shown(v)
        if notes and k in notes:
            text += f" ({notes[k]})"
        table.add_row(k, escape(text))
    return _fit(table)


def _format_cell(v, scale: float = 1.0) -> str:
    """A table cell: '-' for None, yes/NO for booleans, 4 significant digits for numbers x scale."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    if isinstance(v, (int, float)):
        return f"{v * scale:.4g}"
    return str(v)


def _plan_figures(folder: Path) -> None:
    """phase_plane.png and joints.png, drawn from the plan folder's files."""
    from .report.figures import plan_figures

    plan_figures(folder)


def _simulation_figures(folder: Path) -> None:
    """tracking_joints.png and tracking_task.png, drawn from the simulation folder's files."""
    from .report.figures import simulation_figures

    simulation_figures(folder)


def _version(value: bool) -> None:
    if value:
        from . import __version__

        console.print(f"pathmotion {__version__}")
        raise typer.Exit()


@app.callback()
def _main(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="print the version and exit"),
          verbose: int = typer.Option(0, "--verbose", "-v", count=True,
                                      help="show the stages on stderr: -v the planner's and the loop's stages, "
                                           "-vv their details")):
    """Time-optimal path-constrained motion for robot arms, proven in closed-loop simulation."""
    _configure_logging(verbose)


def _default_out(out: Optional[Path], scenario: Path, overrides: dict) -> Path:
    """``out``, or out/<scenario name> when not given (the scenario validated for its name only)."""
    if out is not None:
        return out
    from .io.scenario import load_scenario

    return Path("out") / load_scenario(scenario, overrides)[0].name


OutOpt = typer.Option(None, "--out", help="output folder (default: out/<scenario name>)")
SetOpt = typer.Option(None, "--set", metavar="KEY=VALUE",
                      help="override a scenario key, e.g. --set plan.grid_points=2000")
WorkersOpt = typer.Option(None, "--workers", min=1, help="local processes that search the optimal blends' corners "
                          "in parallel (plan.workers; the same result as 1)")
SchedulerOpt = typer.Option(None, "--scheduler", help="Dask scheduler, tcp://HOST:PORT: a program's task runs (between "
                            "joint moves, dwells and stops) search their optimal blends on its workers "
                            "(plan.scheduler; the same result)")
VerifyOpt = typer.Option(None, "--verify", help="certified (default: a certified bound per grid interval) | dense "
                         "(the 0.1 ms resample) | off; sets plan.verify")
ForceOpt = typer.Option(False, "--force", help="write the exports (ROS 2, EGM, RAPID) even of a failed plan, "
                                               "with a warning header")


def _result_verdict(failures: list[str], notes: list[str], forced: bool) -> None:
    """Print the export notes and why the result failed; exit EXIT_FAILED_RESULT when it did."""
    for note in notes:
        if not note.startswith("WARNING"):
            err_console.print(f"[yellow]note[/]: exports: {escape(note)}", highlight=False, soft_wrap=True)
    if not failures:
        return
    for f in failures:
        err_console.print(f"[bold red]failed[/]: {escape(f)}", highlight=False, soft_wrap=True)
    err_console.print("exports (ROS 2, EGM, RAPID) " + ("written with a warning header (--force)" if forced else
                      "not written: rerun with --force to write them with a warning header"), highlight=False)
    raise typer.Exit(EXIT_FAILED_RESULT)


@app.command()
@guarded
def robots():
    """List the built-in robots and their limits.

    Example: [bold]pathmotion robots[/]
    """
    import numpy as np

    from .robot import builtin_robot_names, load_robot

    for name in builtin_robot_names():
        robot = load_robot(name)
        lim = robot.limits
        table = Table(title=f"{robot.name} ({name}): {robot.n} joints, flange frame {robot.flange_frame}",
                      title_justify="left")
        for col in ("joint", "range [deg]", "speed [deg/s]", "accel [rad/s^2]", "torque [N m]"):
            table.add_column(escape(col), justify="left" if col == "joint" else "right")
        for j, jn in enumerate(lim.names):
            table.add_row(jn, f"{np.degrees(lim.lower[j]):.0f} .. {np.degrees(lim.upper[j]):.0f}",
                          f"{np.degrees(lim.velocity[j]):.0f}",
                          "-" if lim.acceleration is None else f"{lim.acceleration[j]:g}", f"{lim.torque[j]:g}")
        _print_table(table)
        console.print(escape(_sources_line(lim)), highlight=False, soft_wrap=True)


def _sources_line(lim) -> str:
    """Where the figures come from, once: 'sources: range official, ...' when every joint agrees,
    else per quantity the joints of each status."""
    quantities = list(dict.fromkeys(q for jn in lim.names for q in lim.sources.get(jn, {})))
    parts = []
    for q in quantities:
        by_status: dict[str, list[str]] = {}
        for jn in lim.names:
            by_status.setdefault(lim.sources.get(jn, {}).get(q, "not given"), []).append(jn)
        if len(by_status) == 1:
            parts.append(f"{q} {next(iter(by_status))}")
        else:
            parts.append(f"{q} " + ", ".join(f"{st} ({' '.join(js)})" for st, js in by_status.items()))
    return "sources: " + ("; ".join(parts) if parts else "not given") + " (docs/robot.md)"


def _example_scenario(path: Path, template: str) -> str:
    """The example template for ``path``: its commands name the file, its ``name`` is the file's stem."""
    name = json.dumps(path.stem)[1:-1]  # a TOML basic string's content (quotes, backslashes escaped)
    return template.replace("{file}", str(path)).replace("{name}", name)


@app.command()
@guarded
def init(path: Path = typer.Argument(Path("scenario.toml"), help="file to write"),
         from_: Optional[str] = typer.Option(None, "--from", help="copy a shipped scenario instead of the example"),
         force: bool = typer.Option(False, "--force", help="overwrite an existing file")):
    """Write a commented example scenario (or a shipped one) to start from.

    Examples: [bold]pathmotion init my_corner.toml[/]
      [bold]pathmotion init c.toml --from corner_g2[/]
    """
    from importlib import resources

    from .io.atomic import write_text
    from .scenarios import scenario_path

    if path.exists() and not force:
        _fail(f"{path} exists; use --force to overwrite it or give another file name")
    if from_:
        text = scenario_path(from_).read_text()
    else:
        text = _example_scenario(path, (resources.files("pathmotion.io") / "templates" / "example.toml").read_text())
    write_text(path, text)
    shown = escape(str(path))
    console.print(f"wrote {shown}; next: [bold]pathmotion check {shown}[/]")


@app.command()
@guarded
def schema(out: Optional[Path] = typer.Option(None, "--out", help="write to this file instead of stdout")):
    """Print the JSON Schema of the scenario format (for editor completion and validation).

    Example: [bold]pathmotion schema --out pathmotion-scenario.schema.json[/]
    """
    from .io.atomic import write_json
    from .io.scenario import scenario_json_schema

    if out:
        write_json(_out_file(out), scenario_json_schema())
        console.print(f"wrote {escape(str(out))}")
    else:
        print(json.dumps(scenario_json_schema(), indent=2))


@app.command("import-rapid")
@guarded
def import_rapid(program: Path = typer.Argument(..., help="RAPID module (.mod)"),
                 out: Path = typer.Option(..., "--out", help="scenario TOML file to write"),
                 skip_unsupported: bool = typer.Option(False, "--skip-unsupported",
                                                       help="skip the instructions the import does not read"),
                 robot: str = typer.Option("irb140", "--robot", help="robot of the scenario"),
                 blend: str = typer.Option("g2", "--blend", help="the blend at each zone: g2 (symmetric, the "
                                           "zone's deviation) | optimal (the fastest G2 blend within that deviation; "
                                           "searched per zone with the scenario's default search = \"fast\", "
                                           "a few seconds of CPU each; set search = \"thorough\" in the written "
                                           "scenario for a longer search)")):
    """Turn an ABB RAPID program (MoveL/MoveJ/MoveC/MoveAbsJ, speeds, zones, tool, work object) into a scenario.

    Example: [bold]pathmotion import-rapid tests/data/abb_cycle.mod --out cycle.toml[/]
    """
    from .api import rapid_flange, rapid_zone_tolerances
    from .io.atomic import write_text
    from .io.rapid import check_blend_type, read_rapid, scenario_toml
    from .io.scenario import parse_scenario

    check_blend_type(blend, f"--blend {blend}")  # before reading the program
    out = _out_file(out, program)
    prog = read_rapid(program, rapid_flange(robot))
    if prog.unsupported and not skip_unsupported:
        listed = "; ".join(f"line {ln}: {text}" for ln, text in prog.unsupported)
        _fail(f"{program}: {len(prog.unsupported)} unsupported instruction(s), rerun with --skip-unsupported to skip "
              f"them: {listed}")
    text = scenario_toml(prog, rapid_zone_tolerances(prog), robot=robot, blend=blend)
    parse_scenario(text, str(out))  # the written scenario must load
    write_text(out, text)
    for ln, stmt in prog.unsupported:
        err_console.print(f"[yellow]skipped[/] {escape(str(program))}:{ln}: {escape(stmt)}", highlight=False)
    shown = escape(str(out))
    console.print(f"wrote {shown} ({len(prog.moves) - 1} segments); next: [bold]pathmotion check {shown}[/]")


@app.command()
@guarded
def check(scenario: Path = typer.Argument(..., help="scenario TOML file"), set_: Optional[List[str]] = SetOpt,
          workers: Optional[int] = WorkersOpt, scheduler: Optional[str] = SchedulerOpt):
    """Validate a scenario and run every check plan runs (reachability, singularity margin, the plan itself and its
    limits), writing nothing.

    Example: [bold]pathmotion check scenarios/corner_g2.toml[/]
    """
    from . import api

    report = api.check_scenario(api.search(api.load(scenario, _with_workers(_overrides(set_), workers, scheduler))))
    notes = {"closed": "it ends where it starts; " + ("planned as a periodic cycle" if report["periodic"] else
                                                      "run once; plan.periodic = true plans the cycle")}
    _print_table(_summary_table(f"check {scenario}: OK", report, notes if report["closed"] else None))
    _result_verdict([], report.get("export_notes", []), False)


def _with_workers(overrides: dict, workers: Optional[int], scheduler: Optional[str] = None) -> dict:
    """``overrides`` with plan.workers and plan.scheduler set from the --workers and --scheduler options."""
    if workers is not None:
        overrides["plan.workers"] = workers
    if _scheduler(scheduler) is not None:
        overrides["plan.scheduler"] = scheduler
    return overrides


def _with_verify(overrides: dict, verify: Optional[str]) -> dict:
    """``overrides`` with plan.verify set from the --verify option (validated with the scenario)."""
    if verify is not None:
        overrides["plan.verify"] = verify
    return overrides


@app.command()
@guarded
def plan(scenario: Path = typer.Argument(..., help="scenario TOML file"),
         out: Optional[Path] = OutOpt, set_: Optional[List[str]] = SetOpt,
         figures: bool = typer.Option(True, help="write PNG figures"), verify: Optional[str] = VerifyOpt,
         force: bool = ForceOpt, workers: Optional[int] = WorkersOpt, scheduler: Optional[str] = SchedulerOpt):
    """Plan the time-optimal motion: writes trajectory.csv/.parquet, summary.json, exports and figures.
    A failed plan (a path-speed jump, a limit exceeded) exits 4 after writing its files.

    Example: [bold]pathmotion plan scenarios/circle_max.toml --out out/circle[/]
    """
    from . import api
    from .io.atomic import output_lock, result_folder

    overrides = _with_workers(_with_verify(_overrides(set_), verify), workers, scheduler)
    out = _out(_default_out(out, scenario, overrides), scenario)
    with output_lock(out), _progress() as progress:
        task = progress.add_task("plan", total=3)
        _stage(progress, task, "plan: load and search", advance=0)
        setup = api.search(api.load(scenario, overrides))
        _stage(progress, task, "plan: time-optimal profile")
        result = api.plan_scenario(setup)
        _stage(progress, task, "plan: writing")
        with result_folder(out) as folder:  # the folder is replaced as one unit
            summary = api.write_plan(setup, result, folder, force_exports=force)
            if figures:
                _plan_figures(folder)
        progress.update(task, advance=1)
    failures = [f["message"] for f in summary["failures"]]
    _print_table(_summary_table(f"plan {setup.name} -> {out}", {**summary, "failures": failures},
                                _grid_note(setup, summary)))
    _result_verdict(failures, summary["export_notes"], force)


@app.command()
@guarded
def simulate(scenario: Path = typer.Argument(..., help="scenario TOML file"),
             out: Optional[Path] = OutOpt, set_: Optional[List[str]] = SetOpt,
             controller: Optional[str] = typer.Option(None, help="orbital | computed_torque | pd_gravity"),
             figures: bool = typer.Option(True, help="write PNG figures"), verify: Optional[str] = VerifyOpt,
             force: bool = ForceOpt, workers: Optional[int] = WorkersOpt, scheduler: Optional[str] = SchedulerOpt,
             full: bool = typer.Option(False, "--full", help="go on after the first failure to the end of the motion "
                                       "(by default the run stops there and its figures cover [0, t_fail])")):
    """Plan, then simulate the closed loop (controller at 4 ms, full arm dynamics); writes
    simulation.csv, summary.json and figures; plus the plan's files in OUT/plan. A failed result
    (a failed plan, or tracking failed) exits 4 after writing every file.

    Example: [bold]pathmotion simulate scenarios/corner_g2.toml --out out/g2[/]
    """
    from . import api
    from .io.atomic import output_lock, result_folder

    overrides = _with_workers(_with_verify(_overrides(set_), verify), workers, scheduler)
    if controller:
        overrides["simulate.controller"] = controller
    out = _out(_default_out(out, scenario, overrides), scenario)
    with output_lock(out), _progress() as progress:
        task = progress.add_task("simulate: load", total=4)
        _stage(progress, task, "simulate: load and search", advance=0)
        setup = api.search(api.load(scenario, overrides))
        _stage(progress, task, "simulate: plan")
        result = api.plan_scenario(setup)
        _stage(progress, task, "simulate: closed loop")
        sim = api.simulate_scenario(setup, result, full=full)
        _stage(progress, task, "simulate: writing")
        with result_folder(out) as folder:  # plan and simulation files replace the folder as one unit
            summary = api.write_simulation(setup, result, sim, folder)
            failures = api.plan_failures(result, setup) + [f for f in (api.tracking_failure(summary),) if f]
            plan_summary = api.write_plan(setup, result, folder / "plan", failures, force_exports=force)
            if figures:
                _plan_figures(folder / "plan")
                _simulation_figures(folder)
        progress.update(task, advance=1)
    summary.pop("plan", None)
    _print_table(_summary_table(f"simulate {setup.name} -> {out}", summary))
    _result_verdict([f.message for f in failures], plan_summary["export_notes"], force)


def _egm_setup(scenario: Path, set_, drives: Optional[Path]):
    """(setup, plan result, drive parameters) for the EGM commands: the scenario planned, or a directory read
    as the output folder of ``pathmotion plan`` (no planning)."""
    from . import api
    from .api.plan_folder import read_plan
    from .execution.drive_file import drive_file_for, load_drives

    if scenario.is_dir():
        if set_:
            _fail(f"--set changes a scenario before planning; {scenario} is a plan folder (planned already): "
                  "plan again with --set, or give the scenario file")
        setup, result = read_plan(scenario)
    else:
        setup = api.search(api.load(scenario, _overrides(set_)))
        result = api.plan_scenario(setup)
    name = setup.scenario.robot.name if drives is None else None
    params = load_drives(drives if drives is not None else drive_file_for(str(name)), setup.robot.n)
    return setup, result, params


def _egm_out(out: Optional[Path], scenario: Path, suffix: str) -> Path:
    """The EGM commands' output folder: ``out``, else out/<scenario name><suffix>, or for a plan folder the
    sibling <folder>_execute / <folder>_robot (never the plan folder itself)."""
    if out is not None:
        return out
    if scenario.is_dir():
        return scenario.parent / f"{scenario.name}{suffix or '_execute'}"
    return Path(f"{_default_out(None, scenario, {})}{suffix}")


def _egm_inputs(scenario: Path) -> tuple[Path, ...]:
    """The input files an EGM command's output folder must not replace (a plan folder: the folder itself)."""
    return (scenario / "scenario.toml",) if scenario.is_dir() else (scenario,)


def _stdin_commands():
    """A function returning the stdin lines read so far (a daemon thread reads them; none without a stdin)."""
    import queue
    import threading

    lines: queue.Queue = queue.Queue()
    if sys.stdin is None or sys.stdin.closed or not hasattr(sys.stdin, "readline"):
        return lambda: []

    def read():
        for line in sys.stdin:
            lines.put(line)

    threading.Thread(target=read, daemon=True).start()

    def pending():
        out = []
        while not lines.empty():
            out.append(lines.get_nowait())
        return out

    return pending


@app.command()
@guarded
def execute(scenario: Path = typer.Argument(..., help="scenario TOML file, or the output folder of pathmotion plan"),
            egm: int = typer.Option(defaults.EGM_PORT, "--egm", help="UDP port to listen on for the controller's EGM messages"),
            out: Optional[Path] = OutOpt, set_: Optional[List[str]] = SetOpt,
            correction: str = typer.Option("shaping", help="none | shaping (pre-compensate the drives and EGM) | orbital (shaping + transverse loop)"),
            drives: Optional[Path] = typer.Option(None, help="drive file (default: the robot's shipped one)"),
            start_tolerance: float = typer.Option(defaults.EGM_START_TOLERANCE, help="largest distance \\[rad] of "
                                                  "the robot's joints from the plan's start"),
            refine: int = typer.Option(defaults.EGM_REFINE_ITERATIONS, help="learning iterations refining the shaped "
                                       "references on the nominal drive model before streaming (0: analytic shaping)"),
            switch_lead: float = typer.Option(defaults.EGM_SWITCH_LEAD, help="a stop, override or resume switches this "
                                              "long \\[s] after it comes, re-timed meanwhile off the loop (0: on its "
                                              "cycle, whose answer waits for the re-timing)"),
            lockstep: bool = typer.Option(False, help="the robot waits for each answer (virtual-robot --lockstep): a "
                                          "switch waits for its re-timing, the run does not depend on compute time"),
            realtime_priority: int = typer.Option(defaults.EGM_REALTIME_PRIORITY, help="answer at this SCHED_FIFO "
                                                  "priority (Linux, 1-99, e.g. 50) with the memory locked; where the "
                                                  "system refuses, a warning and normal priority (0: off)")):
    """Plan (or read the plan folder pathmotion plan wrote), then stream the motion to an ABB controller over EGM
    (answer each EgmRobot with an EgmSensor); stdin takes 'override F', 'stop', 'resume'. Writes execution.csv and summary.json. A silent controller,
    Ctrl-C or SIGTERM end in a stop along the path (exit 4, 130), and so does an arm farther from the path than
    simulate.joint_tolerance (exit 4).

    Example: [bold]pathmotion execute scenarios/corner_g2.toml --egm 6510 --out out/run[/]
    or, planned before: [bold]pathmotion execute out/g2_plan --egm 6510[/]
    """
    from .execution.loops import open_listener, serve
    from .execution.realtime import priority_range, realtime
    from .execution.session import make_streamer, write_execution
    from .io.atomic import output_lock, result_folder

    low, high = priority_range()
    if realtime_priority != 0 and not low <= realtime_priority <= high:
        _fail(f"--realtime-priority {realtime_priority}: give a SCHED_FIFO priority {low}-{high} (0: normal "
              "scheduling)")
    out = _out(_egm_out(out, scenario, ""), *_egm_inputs(scenario))
    with output_lock(out):
        setup, result, params = _egm_setup(scenario, set_, drives)
        if not 0.0 <= start_tolerance < float("inf"):
            _fail(f"--start-tolerance {start_tolerance!r}: give a distance >= 0 in rad")
        if refine < 0:
            _fail(f"--refine {refine!r}: give a number of iterations >= 0")
        if not 0.0 <= switch_lead < float("inf"):
            _fail(f"--switch-lead {switch_lead!r}: give a time >= 0 in s")
        streamer = make_streamer(setup.robot, result, correction, params, tolerance=start_tolerance,
                                 path_tolerance=setup.scenario.simulate.joint_tolerance, refine=refine,
                                 lead=switch_lead, realtime=not lockstep)
        sock = open_listener(egm)
        commands, interrupted = _stdin_commands(), False
        try:
            # one real-time block for both serves: the stop after Ctrl-C answers on at once, its memory locked
            with realtime(realtime_priority) as scheduling:
                while True:
                    try:
                        ended = serve(sock, streamer, commands=commands)
                        break
                    except KeyboardInterrupt:
                        if interrupted or not streamer.started:
                            raise
                        interrupted = True
                        _SIGNALLED.clear()
                        streamer.stop("interrupted (Ctrl-C or SIGTERM)")
        finally:
            sock.close()
            streamer.close()
        streamer.scheduling = scheduling  # what was asked and granted (serve's own record: what it ran at)
        with result_folder(out) as folder:
            summary = write_execution(folder, setup.robot, streamer, ended)
    _print_table(_summary_table(f"execute {setup.name} -> {out}", summary))
    if interrupted:
        raise typer.Exit(130)
    if streamer.supervision.tripped is not None:
        _fail(f"{streamer.supervision.reason()}; stopped along the path. Lower the speed (stdin 'override 0.5', or "
              "the scenario's limits), put the payload into the scenario ([robot.payload]), or raise "
              "simulate.joint_tolerance", EXIT_FAILED_RESULT)
    if ended != "done":
        _fail(f"the motion did not complete: {ended}", EXIT_FAILED_RESULT)


@app.command("virtual-robot")
@guarded
def virtual_robot(scenario: Path = typer.Argument(..., help="scenario TOML file or plan folder (the arm starts at "
                                                 "its start)"),
                  egm: str = typer.Option(..., "--egm", help="HOST:PORT of the EGM sensor (pathmotion execute)"),
                  lockstep: bool = typer.Option(False, help="wait for each answer (deterministic) instead of 4 ms"),
                  rigid: bool = typer.Option(False, help="rigid gearboxes (the drive file's stiffness ignored)"),
                  plant: Optional[str] = typer.Option(None, help="builtin | mujoco: what moves the links (default: the "
                                                      "scenario's simulate.plant)"),
                  out: Optional[Path] = OutOpt, set_: Optional[List[str]] = SetOpt,
                  drives: Optional[Path] = typer.Option(None, help="drive file (default: the robot's shipped one)")):
    """A virtual IRC5: send EgmRobot every 4 ms (or in lockstep), move the arm (drives, elastic gears) by the
    answers; writes robot.csv and summary.json (ISO figures of the link side, the TCP that really moves).

    Example: [bold]pathmotion virtual-robot scenarios/corner_g2.toml --egm 127.0.0.1:6510 --lockstep[/]
    """
    import numpy as np

    from .execution.drives import VirtualArm
    from .execution.figures import execution_figures
    from .execution.loops import parse_address, run_virtual_robot
    from .io import exports
    from .io.atomic import output_lock, result_folder, write_json

    address = parse_address(egm)
    out = _out(_egm_out(out, scenario, "_robot"), *_egm_inputs(scenario))
    with output_lock(out):
        setup, result, params = _egm_setup(scenario, set_, drives)
        traj = result.trajectory
        start = traj.at_time([0.0])
        arm = VirtualArm(setup.robot, params.rigid() if rigid else params, start.q[0],
                         plant=plant or setup.scenario.simulate.plant)
        run = run_virtual_robot(arm, address, lockstep=lockstep, max_time=3.0 * traj.duration + 2.0)
        cols = run.arrays()
        if not len(cols["t"]):
            _fail(f"virtual robot: no EGM cycle ran ({run.ended})", EXIT_FAILED_RESULT)
        theta = traj.profile.state_at_time(cols["t"])[0]
        moving = np.flatnonzero(np.any(np.diff(cols["reference"], axis=0) != 0.0, axis=1))
        rest = float(cols["t"][moving[-1] + 1]) if moving.size else 0.0  # the references' last change
        summary = {"ended": run.ended, "resent": run.resent, "rigid": rigid, "lockstep": lockstep, "plant": arm.plant}
        summary.update(execution_figures(setup.robot, traj, cols["t"], cols["q"], theta, rest))
        with result_folder(out) as folder:
            table = {"t": cols["t"], "answered": cols["answered"].astype(float)}
            for name in ("q", "qm", "reference", "tau"):
                table.update({f"{name}{j + 1}": cols[name][:, j] for j in range(arm.n)})
            exports.write_table_csv(folder / "robot.csv", table)
            write_json(folder / "summary.json", summary)
    _print_table(_summary_table(f"virtual-robot {setup.name} -> {out}", summary))
    if run.ended != "done":
        _fail(f"virtual robot: {run.ended}", EXIT_FAILED_RESULT)


@app.command()
@guarded
def sweep(scenario: Path = typer.Argument(..., help="scenario TOML file"),
          set_: List[str] = typer.Option(..., "--set", metavar="KEY=V1,V2,...", help="the values of a scenario key "
                                         "(repeat for a grid)"),
          out: Path = typer.Option(..., "--out", help="output folder (a re-run resumes)"),
          scheduler: Optional[str] = typer.Option(None, help="Dask scheduler, tcp://HOST:PORT"),
          workers: int = typer.Option(2, min=1, help="local worker processes"),
          figures: bool = typer.Option(True, help="write the trade-off figures")):
    """Run plan + simulate for every combination of --set values, in parallel; writes sweep.csv,
    sweep.parquet, best.json and figures. Failed points are rows with an error.

    Example: [bold]pathmotion sweep scenarios/corner_transition.toml \\
      --set "path.blends\\[0].radius=0.02,0.03,0.04" --out out/rt[/]
    """
    from .io.atomic import output_lock
    from .study import run_study_sweep
    from .study.sweep import parse_sets

    out, scheduler = _out(out, scenario), _scheduler(scheduler)
    grid = parse_sets(set_)
    with output_lock(out), _progress() as progress:  # (a sweep's folder resumes in place: no swap)
        task = progress.add_task("sweep", total=None)
        outcome = run_study_sweep(scenario, grid, out, workers=workers, scheduler=scheduler,
                                  on_result=_on_result(progress, task, "sweep"), figures=figures)
    from .study.score import outcome_text

    console.print(f"{outcome_text(outcome.rows)} -> {escape(str(out / 'sweep.csv'))}")
    if outcome.best is not None:
        _print_table(_summary_table(f"{BEST_SCORE_TITLE} (best.json)", outcome.best))


@app.command()
@guarded
def corners(angles: str = typer.Option("30,60,90,120,150", help="turn angles \\[deg], comma-separated"),
            tolerances: str = typer.Option("0.0001,0.001,0.005,0.01,0.05", help="tolerances \\[m], comma-separated"),
            out: Path = typer.Option(..., "--out", help="output folder (a re-run resumes; optima are cached there)"),
            meshes: str = typer.Option(",".join(map(str, defaults.ATLAS_MESHES)),
                                       help="free-shape NLP meshes (intervals), each twice the last"),
            scheduler: Optional[str] = typer.Option(None, help="Dask scheduler, tcp://HOST:PORT"),
            workers: int = typer.Option(2, min=1, help="local worker processes"),
            figures: bool = typer.Option(True, help="write tdelta.png and gain_vs_angle.png"),
            torque: bool = typer.Option(False, help="plan every motion and solve both references within the joint "
                                                    "torque limits too (the torque column)"),
            torque_reserve: Optional[float] = typer.Option(
                None, "--torque-reserve", help="with --torque: fraction of each torque limit kept free for feedback, "
                f"in [0, {defaults.MAX_TORQUE_RESERVE:g}) (as \\[limits] torque_reserve; default "
                f"{defaults.TORQUE_RESERVE:g}): plans and references use (1 - R) tau_max, "
                "the closed-loop check's plant the whole"),
            robot: Optional[Path] = typer.Option(
                None, "--robot", help="robot file (TOML): a scenario's \\[robot] table (name or URDF, payload, tool, "
                "...) and \\[limits] velocity / acceleration / torque; default: the built-in IRB140"),
            bounds: bool = typer.Option(True, help="also bound the corner-confined optimum from above by a motion that "
                                                   "holds the tube on a dense resample (corner_bound_s; one to four "
                                                   "more NLPs per row, cached)"),
            references: bool = typer.Option(True, help="solve the free-shape references (CasADi NLPs, tens of "
                                                        "minutes per row uncached); --no-references: the planned motions and "
                                                        "their closed-loop check only, minutes per row, no CasADi")):
    """The corner atlas: every way to take a corner (stop, zone, circle, G2, optimal blend) against
    the free-shape optimum, per turn angle and tolerance; writes corners.csv. The references need CasADi
    (pip install "pathmotion\\[optimal]"). --torque adds the joint torque limits to every motion and
    reference (its optima are cached apart), --torque-reserve keeps a share of them free for the
    closed loop's feedback, --robot takes another arm, payload or drives.

    Examples (minutes, then hours uncached):
      [bold]pathmotion corners --angles 90 --tolerances 0.005 --no-references \\
        --out out/corners[/]
      [bold]pathmotion corners --angles 60,90,120 --tolerances 0.001,0.01 --out out/atlas[/]
    """
    from .study.atlas import check_torque_reserve, corner_atlas

    def numbers(text: str, what: str) -> list:
        try:
            return [float(v) for v in text.split(",") if v.strip()]
        except ValueError:
            _fail(f"--{what} {text!r}: give comma-separated numbers", code=2)

    reserve = check_torque_reserve(torque_reserve, torque, name="--torque-reserve", switch="--torque")
    if references and importlib.util.find_spec("casadi") is None:
        _fail('corners solves its free-shape references with CasADi, which is not installed: '
              'pip install "pathmotion[optimal]", or add --no-references (the planned motions only)')
    out = _out(out, robot)
    with _progress() as progress:
        task = progress.add_task("corners", total=None)
        on_result = _on_result(progress, task, "corners")
        atlas = corner_atlas(out, numbers(angles, "angles"), numbers(tolerances, "tolerances"),
                             meshes=numbers(meshes, "meshes"), workers=workers,
                             scheduler=scheduler, on_result=on_result, figures=figures, torque=torque,
                             torque_reserve=reserve if torque else None, robot_file=robot, bounds=bounds,
                             references=references)
    failed = sum(1 for r in atlas.rows if r.get("error") or any(
        part != "ok" and "(references off)" not in part for part in (r.get("status") or "ok").split("; ")))
    console.print(f"{len(atlas.rows)} rows, {failed} with an error, an unconverged optimum or a failed closed-loop "
                  f"check -> {escape(str(out / 'corners.csv'))}")


@app.command()
@guarded
def report(folder: Path = typer.Argument(..., help="a folder written by plan, simulate, sweep or demo"),
           out: Optional[Path] = typer.Option(None, "--out", help="HTML file to write (default: FOLDER/report.html)")):
    """Turn results into one self-contained interactive HTML page (works offline).

    Example: [bold]pathmotion report out/g2[/]   or   [bold]pathmotion report out/g2 --out g2.html[/]
    """
    from .report.html import build_report

    path = build_report(folder, None if out is None else _out_file(out))
    console.print(f"wrote {escape(str(path))}")


@app.command()
@guarded
def demo(out: Path = typer.Option(Path("out/demo"), "--out", help="output folder"),
         study: bool = typer.Option(True, help="also run the chapter-7 corner study (r_t, speed, G2 sweeps)"),
         workers: int = typer.Option(2, min=1, help="worker processes for the corner study")):
    """The main job: the thesis' experiments on the IRB140 (circle at boundary-level speed; the 90 degree
    corner stopped at, taken at boundary-level speed, with a transition circle and with a G2 blend),
    planned and simulated; then the corner study (sweeps over r_t, the blend speed and the G2
    tolerance, with the thesis-style figures and the best-scored trade-off); a comparison table and report.

    Example: [bold]pathmotion demo --out out/demo[/]
    """
    from . import api
    from .io import schema
    from .io.atomic import output_lock, result_folder

    from .io.files import mark_result

    out = _out(out)
    names = api.DEMO_SCENARIOS
    rows = []
    with output_lock(out), _progress() as progress:
        mark_result(out)
        task = progress.add_task("demo", total=len(names))
        for name in names:
            progress.update(task, description=f"demo: {name}")
            with result_folder(out / name) as folder:  # each scenario's folder replaced as one unit
                rows.append(api.run_shipped(name, folder))
                _plan_figures(folder / "plan")
                _simulation_figures(folder)
            progress.advance(task)
    table_path = api.write_demo_table(rows, out)
    table = Table(title=f"The thesis' experiments on the IRB140 ({table_path})", title_justify="left")
    for k, entry in enumerate(schema.DEMO):
        table.add_column(escape(entry.heading), no_wrap=k == 0, justify="left" if k == 0 else "right")
    for r in rows:
        table.add_row(*[_format_cell(r.get(e.key), e.scale) for e in schema.DEMO])
    _print_table(table)
    if study:
        from .study import corner_study

        with _progress() as progress:
            task = progress.add_task("corner study", total=None)
            result = corner_study(out / "corner_study", workers=workers,
                                  on_result=_on_result(progress, task, "corner study"))
        console.print(f"corner study: {len(result.rows)} runs, figures in {escape(str(result.out))}")
        if result.best is not None:
            _print_table(_summary_table(f"{BEST_SCORE_TITLE} (corner_study.json)", result.best))
    from .report.html import build_report

    console.print(f"report: {escape(str(build_report(out)))}")


#: Delay before an interrupt that could not be raised (inside numba's compiler, or swallowed in a C
#: callback) is delivered again [s].
INTERRUPT_REDELIVERY_DELAY = 0.05
#: The signals delivered as KeyboardInterrupt so far. A C extension may swallow that exception and raise another: a
#: SIGINT landing in pybind11's argument conversion (matplotlib's affine_transform while a figure renders) comes out
#: as "TypeError: incompatible function arguments" (seen in CI). Any exception after a signal is the interrupt.
_SIGNALLED: list = []


def _interrupt(signum, frame):
    """SIGINT or SIGTERM -> KeyboardInterrupt: the clean exit of Ctrl-C (temporary files removed, code 130).

    Not inside numba's or llvmlite's compiler: an exception there can leave a half-built compiled function
    that the caller may still run (a segmentation fault, found by benchmarks/fuzz_cli.py); the signal is
    delivered again INTERRUPT_REDELIVERY_DELAY later, until the compiler has returned. (Inside an IPOPT solve
    CasADi swallows the KeyboardInterrupt: study/free_shape.py raises it again after the solve.)"""
    if _in_compiler(frame):
        _redeliver(signum)
        return
    _SIGNALLED.append(signum)
    raise KeyboardInterrupt(f"signal {signum}")


def _in_compiler(frame) -> bool:
    while frame is not None:
        if frame.f_globals.get("__name__", "").startswith(("numba.", "llvmlite.")):
            return True
        frame = frame.f_back
    return False


def _redeliver(signum: int) -> None:
    """Deliver ``signum`` to the main thread again (through its Python handler) after a short delay."""
    import _thread
    import threading

    timer = threading.Timer(INTERRUPT_REDELIVERY_DELAY, _thread.interrupt_main, args=(signum,))
    timer.daemon = True
    timer.start()


def _unraisable(args) -> None:
    """sys.unraisablehook: an exception Python cannot raise where it occurred (in a C callback, a __del__)
    goes to the debug log, never the terminal. A KeyboardInterrupt among them (Ctrl-C or SIGTERM landing in
    numba's compiler callback: printed as a traceback and swallowed, the run went on; found by
    benchmarks/fuzz_cli.py) is delivered again to the main thread, a moment later (delivered at once, it
    would be raised inside this hook, still in the callback, and swallowed again), so the run stops as
    interrupted."""
    if args.exc_type is not None and issubclass(args.exc_type, KeyboardInterrupt):
        import signal

        _redeliver(signal.SIGINT)
        return
    logger.debug("ignored %s in %r: %s", getattr(args.exc_type, "__name__", "exception"), args.object,
                 args.exc_value)


def main():
    import signal

    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    sys.unraisablehook = _unraisable
    code = None
    try:
        try:
            app(prog_name="pathmotion")
        except SystemExit as exc:
            code = exc.code
            raise
        except KeyboardInterrupt:  # outside a command (argument parsing, start-up): nothing was written yet
            code = 130
            err_console.print("[yellow]interrupted[/]")
            raise SystemExit(130) from None
        finally:
            # the run is over (files complete, or the temporary ones removed): a late Ctrl-C or SIGTERM during
            # interpreter shutdown (numba's and llvmlite's exit handlers) must not print a traceback
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
    except KeyboardInterrupt:
        # a signal that landed after the run had ended and before the handlers above were reset (it raised in this
        # finally: a traceback through typer's exit, seen in CI under load): the run's own exit code stands
        raise SystemExit(130 if code is None else code) from None


if __name__ == "__main__":
    main()

"""The project's own command-line fuzzer (benchmarks/fuzz_cli.py): its escape rules catch what
they must, and CI's seeded 500-document slice finds no escape (about 5 minutes on 2 loaded cores)."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from benchmark_modules import load_benchmark

fuzz_cli = load_benchmark("fuzz_cli")


def _run(tmp_path, stderr="", stdout="", out=None, command="check", out_kind="fresh", signalled=False):
    folder = tmp_path / "d"
    folder.mkdir(exist_ok=True)
    (folder / "stderr.txt").write_text(stderr)
    (folder / "stdout.txt").write_text(stdout)
    doc = fuzz_cli.Doc(0, "wrong type", command=command, out_kind=out_kind)
    return fuzz_cli.Run(doc, folder, [], out, 0, 0.0, signalled=signalled)


def _exit(code):
    return code << 8  # a waitpid status


def test_the_escape_rules(tmp_path):
    v = fuzz_cli.verdict
    assert v(_run(tmp_path, "error: x.toml: plan.grid_points: bad\n"), _exit(1), 1.0) is None
    assert "internal error" in v(_run(tmp_path, "error: internal error (ValueError)\n"), _exit(3), 1.0)
    # the CLI's one-line warnings may come first (a corner left sharp before another corner's error), nothing else
    assert v(_run(tmp_path, "warning: y\n  more of y\n\nerror: x\n  another error of x\n"), _exit(1), 1.0) is None
    assert "not one line" in v(_run(tmp_path, "WARNING  y\nerror: x\n"), _exit(1), 1.0)
    assert "not one line" in v(_run(tmp_path, "error: x\nwarning: y\n"), _exit(1), 1.0)
    assert v(_run(tmp_path, "warning: y\nnote: exports: the first sample is not at rest\n"), _exit(0), 1.0) is None
    assert v(_run(tmp_path, "progress 3/5\n"), _exit(0), 1.0).startswith("stderr on success")
    # a stage's progress line (stderr not a terminal) may come anywhere, on success and before an error
    assert v(_run(tmp_path, "plan: load and search (stage 1/3)\nplan: writing (stage 3/3)\n"), _exit(0), 1.0) is None
    assert v(_run(tmp_path, "plan: load and search (stage 1/3)\nwarning: y\nerror: x\n"), _exit(1), 1.0) is None
    assert "not one line" in v(_run(tmp_path, "plan: load and search\nerror: x\n"), _exit(1), 1.0)
    assert v(_run(tmp_path, "Traceback (most recent call last):\n"), _exit(1), 1.0) == "traceback"
    assert v(_run(tmp_path), None, 120.0).startswith("hang")
    assert "signal 9" in v(_run(tmp_path), 9, 1.0)  # SIGKILL well inside the CPU budget: memory
    assert v(_run(tmp_path), signal.SIGXCPU, 30.0, cpu=120.5, cpu_limit=120.0).startswith("hang (over 120 s of CPU")
    assert v(_run(tmp_path), signal.SIGKILL, 30.0, cpu=125.0, cpu_limit=120.0).startswith("hang")
    out = tmp_path / "d" / "out"
    out.mkdir()
    (out / "summary.json").write_text('{"duration_s": NaN}')
    (out / "trajectory.csv").write_text("t,q1\n0,0\n")
    assert "not finite" in v(_run(tmp_path, out=out, command="plan"), _exit(0), 1.0)
    (out / "summary.json").write_text('{"duration_s": 1.0}')
    assert v(_run(tmp_path, out=out, command="plan"), _exit(0), 1.0) is None
    assert "left its --out" in v(_run(tmp_path, "error: no\n", out=out, command="plan"), _exit(1), 1.0)
    (tmp_path / "d" / ".out.pm-new-x.tmp").mkdir()
    assert "temporary" in v(_run(tmp_path, "error: no\n", command="check"), _exit(1), 1.0)


def test_the_half_a_result_rules(tmp_path):
    """An interrupted run (exit 130, one 'interrupted' line) leaves the previous result file for file, or a
    complete new one; a run into a folder another run holds is refused and changes nothing."""
    v = fuzz_cli.verdict
    out = tmp_path / "d" / "out"
    out.mkdir(parents=True)

    def previous():
        for p in out.iterdir():
            p.unlink()
        for name, text in fuzz_cli.PREVIOUS.items():
            (out / name).write_text(text)

    def run(stderr, kind="previous result", signalled=True):
        return _run(tmp_path, stderr, out=out, command="plan", out_kind=kind, signalled=signalled)

    said = "interrupted: finished files are complete, nothing half-written remains\n"
    previous()
    assert v(run(said), _exit(130), 1.0) is None
    assert "exit 130" in v(run(said, signalled=False), _exit(130), 1.0)  # nobody interrupted it
    assert "one line" in v(run("Aborted!\n" + said), _exit(130), 1.0)
    assert v(run(""), _exit(130), 1.0) is None  # Typer took the Ctrl-C before the command began
    (out / "trajectory.csv").write_text("t,q1\n0,0\n0.5,0\n")  # a new file beside the old summary
    assert "half a result" in v(run(said), _exit(130), 1.0)
    previous()
    assert "still in --out" in v(run(""), _exit(0), 1.0)
    (out / "previous.marker").unlink()
    (out / "summary.json").write_text('{"duration_s": 0.5}')
    assert v(run(""), _exit(0), 1.0) is None  # replaced as a whole by a complete result
    assert v(run(said), _exit(130), 1.0) is None  # interrupted after the swap: the new result is whole
    (out / "trajectory.csv").unlink()
    assert "contract" in v(run(said), _exit(130), 1.0)
    shutil.rmtree(out)
    assert "removed" in v(run("error: no\n"), _exit(1), 1.0)
    out.mkdir()
    previous()
    refused = "error: another pathmotion run (pid 7) is writing to out (lock .out.lock); wait\n"
    assert v(run(refused, "locked", False), _exit(1), 1.0) is None
    assert "not refused" in v(run("", "locked", False), _exit(0), 1.0)


def test_documents_cover_every_class_and_are_seeded():
    n = 3 * len(fuzz_cli.CLASSES)
    docs = [fuzz_cli.generate(i, fuzz_cli._doc_rng(1, i)) for i in range(n)]
    assert {d.klass for d in docs} == set(fuzz_cli.CLASSES)
    again = [fuzz_cli.generate(i, fuzz_cli._doc_rng(1, i)) for i in range(n)]
    assert [(d.data, d.special, d.files, d.out_kind) for d in docs] == [
        (d.data, d.special, d.files, d.out_kind) for d in again]


def test_a_blocked_child_is_a_hang_and_a_computing_one_is_not(tmp_path):
    """The hang watch goes by the child's CPU time and state, so a loaded machine (a runnable child that
    waits for a core) gives no false hang, while a child blocked without CPU progress (a FIFO) is one."""
    blocked = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.5)
        runs = {p: _run(tmp_path) for p in (blocked, busy)}
        for p, run in runs.items():
            run.pid, run.started = p.pid, time.monotonic()
            run.progressed = run.started
            assert fuzz_cli._watch(run, run.started, idle=0.3, wall_cap=1e9) is None
        time.sleep(1.0)
        later = time.monotonic()
        assert "blocked (state S)" in fuzz_cli._watch(runs[blocked], later, idle=0.3, wall_cap=1e9)
        assert fuzz_cli._watch(runs[busy], later, idle=0.3, wall_cap=1e9) is None
        assert "backstop" in fuzz_cli._watch(runs[busy], later, idle=0.3, wall_cap=0.5)
    finally:
        for p in (blocked, busy):
            p.kill()
            p.wait()


def test_a_run_resumes_where_it_stopped(tmp_path):
    first = fuzz_cli.fuzz(3, 7, tmp_path, workers=2, resume=True)
    assert first["ran"] == 3 and sum(first["per_class"].values()) == 3
    again = fuzz_cli.fuzz(3, 7, tmp_path, workers=2, resume=True)
    assert again["ran"] == 0 and again["per_class"] == first["per_class"] and again["found"] == first["found"]
    more = fuzz_cli.fuzz(5, 7, tmp_path, workers=2, resume=True)
    assert more["ran"] == 2 and sum(more["per_class"].values()) == 5
    lines = (tmp_path / f"results-seed7-g{fuzz_cli.GENERATOR}.jsonl").read_text().splitlines()
    assert sorted(json.loads(ln)["index"] for ln in lines) == [0, 1, 2, 3, 4]
    tail = fuzz_cli.fuzz(5, 7, tmp_path, workers=2, start=3, resume=True)
    assert tail["ran"] == 0 and sum(tail["per_class"].values()) == 2
    # a document that escaped runs again on resume (to confirm its fix); the table keeps that it escaped once
    escaped = dict(json.loads(lines[1]), escape="exit 3 (internal error): pretend")
    with open(tmp_path / f"results-seed7-g{fuzz_cli.GENERATOR}.jsonl", "a") as fh:
        fh.write(json.dumps(escaped) + "\n")
    again = fuzz_cli.fuzz(5, 7, tmp_path, workers=2, resume=True)
    assert again["ran"] == 1 and not again["found"]
    assert again["found_ever"] == {escaped["class"]: 1}


@pytest.mark.slow
def test_the_seeded_500_document_slice_has_no_escape(tmp_path):
    os.environ.setdefault("PYTHONHASHSEED", "0")
    result = fuzz_cli.fuzz(500, 1, tmp_path, workers=2, timeout=300.0)
    assert sum(result["per_class"].values()) == 500
    assert not result["found"], "\n".join(f"{i} ({k}): {w[:300]}" for i, k, w in result["found"])


def test_several_validation_errors_may_follow_the_error_line_indented(tmp_path):
    text = "error: s.toml: path.segments[0].x: unknown key\n  s.toml: path.segments[0].end: missing required key\n"
    assert fuzz_cli.verdict(_run(tmp_path, text), _exit(1), 1.0) is None
    assert "not one line" in fuzz_cli.verdict(_run(tmp_path, text + "Error: urdf\n"), _exit(1), 1.0)

"""Command-line output edges: a closed pipe ends the command quietly; an error quotes at most about 200
characters of the user's input and counts the rest."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def test_a_closed_pipe_is_a_normal_end():
    """``pathmotion schema | head -c 300``: the reader closes its end; no 'Broken pipe' line, exit 0."""
    proc = subprocess.Popen([sys.executable, "-m", "pathmotion.cli", "schema"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=_env())
    head = proc.stdout.read(300)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    assert head.startswith(b"{") and err == ""


def test_an_error_quotes_at_most_about_200_characters_of_the_input(tmp_path):
    """A 4,000-character key and 100,000 unknown gain names: the message quotes a bounded part and counts
    the rest."""
    from typer.testing import CliRunner

    from pathmotion.cli import app
    from reliability_cases import JOINT

    scenario = tmp_path / "s.toml"
    scenario.write_text(JOINT)
    key = "k" * 4000
    res = CliRunner().invoke(app, ["check", str(scenario), "--set", f"plan.{key}=1"])
    assert res.exit_code == 1 and "unknown key" in res.output
    assert len(res.output) < 1000 and "3,8" in res.output and "more characters" in res.output
    gains = tmp_path / "g.toml"
    gains.write_text(JOINT + "[simulate.gains]\n" + "".join(f"g{i} = 1.0\n" for i in range(100_000)))
    res = CliRunner().invoke(app, ["check", str(gains)])
    assert res.exit_code == 1 and "unknown gain" in res.output, res.output[:500]
    assert len(res.output) < 1000 and "more)" in res.output
    count = int(res.output.split("... (")[1].split(" more)")[0].replace(",", ""))
    assert count + res.output.split("unknown gain(s) ")[1].split(", ...")[0].count("'g") == 100_000


def test_clipped_and_listed_count_what_they_leave_out():
    from hypothesis import given, strategies as st

    from pathmotion.errors import clipped, listed

    @given(st.text(max_size=600), st.integers(1, 300))
    def clip(text, limit):
        out = clipped(text, limit)
        assert out == text if len(text) <= limit else (out.startswith(text[:limit])
                                                        and f"({len(text) - limit:,} more characters)" in out)

    @given(st.lists(st.text(max_size=30), max_size=200))
    def lists(items):
        out = listed(items)
        shown = out.rsplit(", ... (", 1)[0] if ", ... (" in out else out
        rest = int(out.rsplit("... (", 1)[1].split(" more)")[0].replace(",", "")) if out.endswith(" more)") else 0
        assert len(shown) <= 2 * 200 + 30 and rest <= len(items)

    clip()
    lists()

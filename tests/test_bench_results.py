"""make results: benchmarks/results.py renders the benchmarks' JSON tables (benchmarks/result_json.py) into
docs/results.md, each with its command, date and machine."""

import json
import subprocess
import sys

from benchmark_modules import BENCHMARKS, load_benchmark


def test_a_written_table_renders_with_its_command_date_and_machine(tmp_path, monkeypatch):
    result_json, results = load_benchmark("result_json"), load_benchmark("results")
    table = result_json.Table("Demo | table", [("name", "name"), ("t", "t [s]"), ("ok", "ok")], command="make demo")
    table.add(name="a|b", t=1.25, ok=True)
    table.add(name="c", t=None, ok=False)
    table.notes.append("a note")
    table.write(tmp_path / "x.json")
    doc = json.loads((tmp_path / "x.json").read_text())
    assert doc["machine"]["cores"] >= 1 and doc["machine"]["cpu"] and doc["date"].endswith("UTC")
    page = results.page(tmp_path)
    assert "## Demo | table" in page and "    make demo" in page
    assert f"{doc['machine']['cpu']}, {doc['machine']['cores']} cores" in page
    assert "| a\\|b | 1.25 | yes |" in page and "| c | — | no |" in page  # a pipe in a cell is escaped
    assert "- a note" in page


def test_make_results_writes_the_page_from_a_folder_and_refuses_an_empty_one(tmp_path):
    (tmp_path / "r").mkdir()
    run = [sys.executable, str(BENCHMARKS / "results.py"), "--results", str(tmp_path / "r"),
           "--out", str(tmp_path / "results.md")]
    empty = subprocess.run(run, capture_output=True, text=True)
    assert empty.returncode != 0 and "no JSON tables" in empty.stderr and not (tmp_path / "results.md").exists()
    for src in sorted((BENCHMARKS / "results").glob("*.json")):
        (tmp_path / "r" / src.name).write_text(src.read_text())
    assert subprocess.run(run, capture_output=True, text=True).returncode == 0
    shipped = (BENCHMARKS.parent / "docs" / "results.md").read_text()
    assert (tmp_path / "results.md").read_text() == shipped  # docs/results.md is exactly what make results writes

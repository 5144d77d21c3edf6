"""What a new clone meets on install and in the test run: no deprecation warning from the project."""

import tomllib
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted((ROOT / "pathmotion").rglob("*.py")) + sorted((ROOT / "tests").glob("*.py")) + sorted(
    (ROOT / "benchmarks").glob("*.py"))


def test_pyproject_license_is_an_spdx_string_with_a_setuptools_that_reads_it():
    doc = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert doc["project"]["license"] == "MIT"  # a table is deprecated since setuptools 77
    requires = doc["build-system"]["requires"]
    assert any(r.replace(" ", "").startswith("setuptools>=") and int(r.split(">=")[1].split(".")[0]) >= 77
               for r in requires), requires


@pytest.mark.parametrize("path", SOURCES, ids=[str(p.relative_to(ROOT)) for p in SOURCES])
def test_sources_compile_without_warnings(path):
    """Invalid escapes ('\\.' in a non-raw string) and the like warn at compile time."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compile(path.read_text(), str(path), "exec")


def test_documented_commands_use_the_readme_environment_not_a_machine_path():
    """Commands in the README, docs and benchmark headers run from a clone (.venv/bin/..., pathmotion ...), with
    relative paths: no folder of one machine, temporary ones included."""
    import re

    texts = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "benchmarks").glob("*.py"))]
    for path in texts:
        for n, line in enumerate(path.read_text().splitlines(), 1):
            assert not re.search(r"(^|[\s`\"'(=])/(work|home|root|Users|tmp)/", line), f"{path.name}:{n}: {line}"


def test_every_best_says_which_best():
    """Two rules pick a 'best' run: the study's score (time + weight x deviation) and the fastest run
    within 10 mm of the sharp path; the README, docs and the CLI's words name which one they mean."""
    import re

    named = re.compile(r"best[ -]scor|best within|best\.json|choose_best|outcome\.best|result\.best|best_|"
                       r"loc=\"best\"|best baseline|refined around the best|at best\b", re.I)
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "pathmotion" / "cli.py"]:
        for n, line in enumerate(path.read_text().splitlines(), 1):
            for m in re.finditer(r"\bbest\b", line, flags=re.I):
                around = line[max(0, m.start() - 25): m.end() + 30]
                assert named.search(around), f"{path.name}:{n}: which best? {line.strip()}"


def test_constraints_pin_every_requirement_within_its_range():
    """make install (and so CI) installs with -c constraints.txt: every requirement of every extra is pinned
    there, to a version its own specifier in pyproject.toml accepts."""
    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name
    from packaging.version import Version

    pins = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, version = line.split("==")
            pins[canonicalize_name(name)] = Version(version)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    requirements = [*project["dependencies"], *(r for extra in project["optional-dependencies"].values() for r in extra)]
    for text in requirements:
        req = Requirement(text)
        name = canonicalize_name(req.name)
        assert name in pins, f"{req.name} is not pinned in constraints.txt"
        assert req.specifier.contains(pins[name]), f"constraints.txt pins {req.name} {pins[name]}, pyproject wants {req}"
    install = [line for line in (ROOT / "Makefile").read_text().splitlines() if "pip install" in line and "-e" in line]
    assert install and all("-c constraints.txt" in line for line in install), install


def test_code_and_docs_carry_no_history():
    """Code and docs describe the code as it is: no issue or session numbers (the history is in git)."""
    import re

    marker = re.compile(r"\b(issue|session)s? #?\d+|\(issue\b|\bissue \d+'s\b", re.I)
    texts = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "pathmotion").rglob("*.py")),
             *sorted((ROOT / "pathmotion").rglob("*.toml")), *sorted((ROOT / "benchmarks").glob("*.py")),
             *sorted((ROOT / "tests").glob("*.py"))]
    for path in texts:
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if path.name == "test_packaging.py" and "marker = re.compile" in line:
                continue  # (the rule itself)
            assert not marker.search(line), f"{path.relative_to(ROOT)}:{n}: {line.strip()}"

"""Shipped scenarios (TOML): the thesis' experiments on the IRB140, a joint-space example, an imported RAPID cycle
and a pick-and-place cycle of joint moves, straight moves and waits.

``pathmotion init --from NAME`` copies one; ``scenario_path(NAME)`` gives its file.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def scenario_names() -> list[str]:
    return sorted(p.name[:-5] for p in resources.files(__name__).iterdir() if p.name.endswith(".toml"))


def scenario_path(name: str) -> Path:
    from ..errors import ScenarioError

    if name not in scenario_names():
        raise ScenarioError(f"no shipped scenario {name!r}; shipped: {', '.join(scenario_names())}")
    return Path(str(resources.files(__name__) / f"{name}.toml"))

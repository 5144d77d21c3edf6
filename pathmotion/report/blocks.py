"""The pieces every section of the HTML report is made of: the Section record, table cells, a figure's
div and a section's title. Shared by html.py (the page and most sections) and atlas.py."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from html import escape
from pathlib import Path

import numpy as np

from .discovery import ResultFolder

PLOTLY_CONFIG = {"displaylogo": False, "responsive": True,
                 "toImageButtonOptions": {"format": "png", "scale": 2}}


@dataclass(frozen=True)
class Section:
    """One section of the page: its anchor, title, HTML body, the number of Plotly figures in it and
    its row of the summary table ({column: HTML cell})."""

    anchor: str
    title: str
    body: str
    figures: int
    summary: dict = field(default_factory=dict)


def fmt(value, scale: float = 1.0) -> str:
    """A value as table text: numbers to 4 digits (times ``scale``), booleans yes/NO, lists joined, None '–'."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, (int, np.integer)) and scale == 1.0:
        return str(value)
    if isinstance(value, (int, float, np.floating)):
        v = float(value) * scale
        return "–" if not math.isfinite(v) else f"{v:.4g}"
    if isinstance(value, (list, tuple)):
        return escape(", ".join(str(v) for v in value)) if value else "none"
    return escape(str(value))


def cell(value, scale: float = 1.0) -> str:
    """A table cell; booleans coloured (ok green, NO red), errors red."""
    text = fmt(value, scale)
    if isinstance(value, bool):
        return f'<td class="{"ok" if value else "bad"}">{text}</td>'
    return f"<td>{text}</td>"


def figure_html(figure, div_id: str) -> str:
    """A Plotly figure as an HTML div (Plotly's script is included once per page, by the page)."""
    import plotly.io as pio

    return ('<div class="figure">' + pio.to_html(figure, include_plotlyjs=False, full_html=False, div_id=div_id,
                                                 config=PLOTLY_CONFIG, auto_play=False) + "</div>")


def section_title(kind: str, result: ResultFolder, root: Path, scenario) -> str:
    """'Plan: corner_g2 (out/g2)': the scenario's name and the folder (the root by its own name, not '.')."""
    label = result.label(root)
    folder = root.resolve().name if label == "." else label
    if scenario and str(scenario) != folder:
        return f"{kind}: {scenario} ({folder})"
    return f"{kind}: {folder}"

"""Conventions shared by the static figures (report/figures.py, study/figures.py): titles wrapped to a
width instead of widening the saved figure, legends right of the axes instead of over the curves."""

from __future__ import annotations

import textwrap

#: Characters per line of a figure title: longer titles wrap instead of widening the saved figure.
TITLE_WIDTH = 90


def wrapped(title: str, width: int = TITLE_WIDTH) -> str:
    """``title`` wrapped onto lines of at most ``width`` characters."""
    return "\n".join(textwrap.wrap(str(title), width)) or str(title)


def legend_outside(ax, fontsize: float = 8, **kwargs):
    """The legend of matplotlib axes ``ax`` right of them, never over the curves."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=fontsize, **kwargs)

"""What the EGM tests share: scenario texts of short IRB140 task paths from rest to rest, and their plans with
the IRB140's drive file."""

from __future__ import annotations

from pathmotion import api
from pathmotion.execution.drive_file import drive_file_for, load_drives


def irb140_task(name: str, tables: str) -> str:
    """A scenario text named ``name``: the IRB140, tool pointing down, the task path whose ``[[path.segments]]``
    (and ``[[path.blends]]``) tables are ``tables``, planned from rest to rest."""
    head = f'name = "{name}"\n[robot]\nname = "irb140"\n[path]\ntype = "task"\norientation = "down"\n'
    return head + tables.strip() + '\n[plan]\nstart = "zero"\nend = "zero"\n'


def line(start, end) -> str:
    """One ``[[path.segments]]`` straight line from ``start`` to ``end`` [m] (start None: from the previous end)."""
    first = "" if start is None else f"start = {list(start)}\n"
    return f'[[path.segments]]\ntype = "line"\n{first}end = {list(end)}\n'


def planned(text: str):
    """(robot, plan result, drives) of the scenario ``text`` with the IRB140's drive file."""
    setup = api.load_text(text)
    return setup.robot, api.plan_scenario(setup), load_drives(drive_file_for("irb140"), setup.robot.n)

"""What the EGM tests share: scenario texts of short IRB140 task paths from rest to rest, their plans with the
IRB140's drive file, a free UDP port, and the two commands run against each other as processes."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time

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


def free_port() -> int:
    """A UDP port on the loopback that was free a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_commands(source, robot_args=(), execute_args=()):
    """``pathmotion virtual-robot SOURCE --lockstep`` started first, then ``pathmotion execute SOURCE --lockstep``
    against it, as processes on a free loopback port, each with its extra arguments: (execute's CompletedProcess (text),
    the virtual robot's Popen after it ended, its combined output)."""
    port = free_port()
    env = dict(os.environ, PYTHONPATH=os.getcwd())
    cli = [sys.executable, "-m", "pathmotion.cli"]
    robot = subprocess.Popen(cli + ["virtual-robot", str(source), "--egm", f"127.0.0.1:{port}", "--lockstep",
                                    *robot_args], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    time.sleep(0.5)
    try:
        ex = subprocess.run(cli + ["execute", str(source), "--egm", str(port), "--lockstep", *execute_args], env=env,
                            stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
        out, _ = robot.communicate(timeout=60)
    finally:
        robot.kill()
    return ex, robot, out

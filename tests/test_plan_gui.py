"""scripts/plan.py's picking window, in a real Tk window on a virtual X server, clicked by xdotool.

Needs the Debian packages ``xvfb`` and ``xdotool`` (``apt-get install -y xvfb xdotool``) and Python's
tkinter; the test is skipped, saying which is missing, where they are not installed.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from conftest import REPO
from PIL import Image

SCRIPT = REPO / "scripts" / "plan.py"


def _missing() -> str:
    gone = [tool for tool in ("Xvfb", "xdotool") if shutil.which(tool) is None]
    if gone:
        return f"{' and '.join(gone)} not installed (Debian: apt-get install -y xvfb xdotool)"
    try:
        import tkinter  # noqa: F401
    except ImportError:
        return "Python has no tkinter (Debian: apt-get install -y python3-tk), so no TkAgg window"
    return ""


pytestmark = pytest.mark.skipif(bool(_missing()), reason=_missing() or "ok")


@pytest.fixture
def display():
    """A private virtual X server; yields its DISPLAY."""
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                              pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    try:
        with os.fdopen(read) as f:
            number = f.readline().strip()  # Xvfb writes its display number once it accepts clients
        if not number.isdigit():
            pytest.fail(f"Xvfb did not start (exit {server.poll()})")
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(timeout=10)


class Lines:
    """The lines a process prints, collected by a thread so that waiting for one never blocks."""

    def __init__(self, stream) -> None:
        self.lines: list[str] = []
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, prefix: str, timeout: float) -> str:
        end = time.monotonic() + timeout
        while True:
            found = [line for line in self.lines if line.startswith(prefix)]
            if found:
                return found[-1]
            if time.monotonic() >= end:
                break
            time.sleep(0.05)
        raise AssertionError(f"no line starting {prefix!r} within {timeout} s; got {self.lines}")

    def settled(self, prefix: str, quiet: float, timeout: float) -> str:
        """The last line starting ``prefix`` once none has come for ``quiet`` seconds (the window has
        settled: a first resize redraws the axes elsewhere)."""
        end = time.monotonic() + timeout
        seen, since = -1, time.monotonic()
        while time.monotonic() < end:
            n = sum(line.startswith(prefix) for line in self.lines)
            if n != seen:
                seen, since = n, time.monotonic()
            elif n and time.monotonic() - since >= quiet:
                return self.wait_for(prefix, 0)
            time.sleep(0.05)
        raise AssertionError(f"lines starting {prefix!r} kept coming for {timeout} s; got {self.lines}")


def xdotool(env, *args) -> str:
    return subprocess.run(["xdotool", *map(str, args)], env=env, capture_output=True, text=True, timeout=30,
                          check=True).stdout.strip()


ROS_MAP = REPO / "tests" / "data" / "ros" / "turtlebot3_world" / "map.yaml"


@pytest.mark.parametrize("kind", ["picture", "ros"])
def test_double_clicks_pick_start_and_goal(display, tmp_path, kind):
    if kind == "picture":  # pixels, y down
        img = np.full((64, 96), 255, dtype=np.uint8)
        img[:, 46:50] = 0
        img[28:34, 46:50] = 255  # a wall with a door
        map_path = tmp_path / "floor.png"
        Image.fromarray(img).save(map_path)
        start, goal, atol = (10.5, 12.5), (85.5, 50.5), 0.5  # a window pixel is under 0.2 map pixels
    else:  # metres from (-10, -10), y up
        map_path = ROS_MAP
        start, goal, atol = (-1.9, -0.5), (1.9, 0.5), 0.05  # a window pixel is about 0.03 m
    env = {**os.environ, "DISPLAY": display, "MPLBACKEND": "TkAgg", "SAMPLERGYM_PICK_DEBUG": "1"}
    env.pop("WAYLAND_DISPLAY", None)
    proc = subprocess.Popen([sys.executable, str(SCRIPT), str(map_path), "--planner", "rrt-connect", "--no-gif",
                             "--out", str(tmp_path / "out")], env=env, cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        out = Lines(proc.stdout)
        debug = json.loads(out.wait_for("pick-debug ", 120).split(" ", 1)[1])
        window = xdotool(env, "search", "--sync", "--onlyvisible", "--name", debug["title"]).split()[0]
        m = np.array(json.loads(out.settled("pick-debug ", quiet=1.5, timeout=30).split(" ", 1)[1])["world_to_window"])
        for x, y in (start, goal):
            px, py = m @ [x, y, 1.0]
            xdotool(env, "mousemove", "--window", window, round(px), round(py), "click", "--repeat", 2, "--delay",
                    100, 1)
            time.sleep(0.7)  # two double-clicks in a row would read as a triple click
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    text = "\n".join(out.lines)
    assert proc.returncode == 0, text
    query = re.search(r"query: +start \(([-\d.e]+), ([-\d.e]+)\) -> goal \(([-\d.e]+), ([-\d.e]+)\)", text)
    assert query, text
    picked = np.array([float(v) for v in query.groups()]).reshape(2, 2)
    np.testing.assert_allclose(picked, [start, goal], atol=atol)
    assert "solved:           True" in text and (tmp_path / "out" / "plan.png").is_file()

"""MAVProxy (PyPI ``MAVProxy``), driven through its stdin as a ground station, uploads a fence to the companion process
over loopback UDP and saves it back unchanged; a bad fence it uploads is NACKed and the companion keeps the old one.
Skipped when MAVProxy is not installed."""

from __future__ import annotations

import importlib.util
import json
import os
import queue
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from support import SQUARE_FENCE_WPL, free_udp_port

ROOT = Path(__file__).resolve().parents[1]
MAVPROXY = shutil.which("mavproxy.py")
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(MAVPROXY is None or importlib.util.find_spec("MAVProxy") is None, reason="MAVProxy not installed"),
]

START = SQUARE_FENCE_WPL
ROW = "{seq}\t0\t0\t{cmd}\t{p1:.6f}\t0.000000\t0.000000\t0.000000\t{lat:.6f}\t{lon:.6f}\t0.000000\t1"
UPLOAD = [(5001, 3, 47.3972, 8.5452), (5001, 3, 47.3972, 8.5465), (5001, 3, 47.3985, 8.5462), (5004, 20, 47.3977, 8.546), (5000, 0, 47.3976, 8.5458)]  # fmt: skip
BOWTIE = [(5001, 4, 47.3965, 8.5435), (5001, 4, 47.3975, 8.5465), (5001, 4, 47.3965, 8.5465), (5001, 4, 47.3975, 8.5435)]  # fmt: skip


def wpl(items) -> str:
    rows = [ROW.format(seq=i, cmd=c, p1=p1, lat=lat, lon=lon) for i, (c, p1, lat, lon) in enumerate(items)]
    return "QGC WPL 110\n" + "\n".join(rows) + "\n"


class Lines:
    """A process's stdout, line by line, read in a thread (``wait`` for a line containing a text)."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.q: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, args=(proc,), daemon=True).start()

    def _read(self, proc: subprocess.Popen) -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            self.q.put(line)

    def wait(self, text: str, timeout_s: float = 30.0) -> str:
        while True:
            try:
                line = self.q.get(timeout=timeout_s)
            except queue.Empty:
                raise AssertionError(f"no line with {text!r}; saw: {''.join(self.seen[-20:])}") from None
            self.seen.append(line)
            if text in line:
                return line


def test_mavproxy_uploads_a_fence_and_saves_it_back_unchanged(tmp_path):
    port = free_udp_port()
    (tmp_path / "start.txt").write_text(START)
    (tmp_path / "in.txt").write_text(wpl(UPLOAD))
    (tmp_path / "bad.txt").write_text(wpl(BOWTIE))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    companion = subprocess.Popen(
        [sys.executable, "-m", "scenarios.app.cli", "companion", "--connect", f"udpin:127.0.0.1:{port}",
         "--fence", str(tmp_path / "start.txt"), "--profile", "F450", "--ceiling-m", "60", "--max-duration-s", "120",
         "--report", str(tmp_path / "report.json")],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    mavproxy = None
    try:
        Lines(companion).wait("companion: listening")
        mavproxy = subprocess.Popen(
            [str(MAVPROXY), f"--master=udpout:127.0.0.1:{port}", "--source-system", "250", "--target-system", "255",
             "--target-component", "191", "--state-basedir", str(tmp_path / "mavproxy"), "--default-modules=fence"],
            cwd=tmp_path, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
        )  # fmt: skip
        out = Lines(mavproxy)
        assert mavproxy.stdin is not None
        say = mavproxy.stdin
        out.wait("Detected vehicle 255:191")
        say.write(f"fence load {tmp_path / 'in.txt'}\n")
        say.flush()
        assert "ACCEPTED" in out.wait("Got MISSION_ACK: TYPE_FENCE")
        say.write(f"fence save {tmp_path / 'out.txt'}\n")
        say.flush()
        out.wait("Saved 5 fence items")
        assert (tmp_path / "out.txt").read_text() == (tmp_path / "in.txt").read_text()

        say.write(f"fence load {tmp_path / 'bad.txt'}\n")  # self-intersecting: NACKed, nothing changes
        say.flush()
        assert "INVALID" in out.wait("Got MISSION_ACK: TYPE_FENCE")
        say.write(f"fence save {tmp_path / 'after.txt'}\n")
        say.flush()
        out.wait("Saved 5 fence items")
        assert (tmp_path / "after.txt").read_text() == (tmp_path / "in.txt").read_text()
        say.write("exit\n")
        say.close()  # (MAVProxy's console ends at the end of its input)
        mavproxy.wait(timeout=20)
        companion.send_signal(15)  # SIGTERM: the companion exits 0 and writes its report
        assert companion.wait(timeout=20) == 0
    finally:
        for p in (mavproxy, companion):
            if p is not None and p.poll() is None:
                p.kill()
    server = json.loads((tmp_path / "report.json").read_text())["fence_server"]
    assert server["accepted"] == 1 and server["refused"] == 1  # (MAVProxy sends no ACK after a download)

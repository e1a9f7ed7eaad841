"""The README's "make it move": tools/make_it_move.py against a fresh drive. It must enable the
drive, finish the pp move, the pv ramp and the homing run (it exits 1 naming the step that did
not), leave the drive switched off, and plot what the TPDOs carried."""

import re
import subprocess
import sys

import canopen
from conftest import NODE_ID, REPO_ROOT, DriveProcess


def test_make_it_move_runs_every_motion_and_plots_them(tmp_path):
    drive = DriveProcess(tmp_path, extra_args=("-v",))
    svg = tmp_path / "move.svg"
    try:
        result = subprocess.run(
            [sys.executable, str(REPO_ROOT / "tools" / "make_it_move.py"), "--port", str(drive.port),
             "--node-id", str(NODE_ID), "--out", str(svg)],
            capture_output=True, text=True, timeout=120,
        )
        assert result.returncode == 0, result.stdout + result.stderr
        for line in ("profile position: done", "profile velocity: done", "homing: done"):
            assert line in result.stdout
        network = canopen.Network()
        network.connect(interface="slcan", channel=drive.channel, bitrate=500000, sleep_after_open=0)
        try:
            node = network.add_node(NODE_ID)
            assert node.sdo.upload(0x6041, 0)[0] & 0x6F == 0x21, "left in Ready to switch on"
            assert abs(int.from_bytes(node.sdo.upload(0x6064, 0), "little", signed=True)) < 200, "at home"
        finally:
            network.disconnect()
    finally:
        assert drive.stop() == 0, drive.log()
    text = svg.read_text()
    assert text.startswith("<svg") and text.rstrip().endswith("</svg>")
    lines = re.findall(r'<polyline points="([^"]+)"', text)
    assert len(lines) == 4, "demand and actual of position and velocity"
    assert all(len(points.split()) > 200 for points in lines), "a sample every 10 ms for several seconds"
    # The axes: ticks at round values (1, 2 or 5 times a power of ten apart), at least three a
    # panel, and each panel's title above its frame, not over the data.
    values = [float(v.replace(",", "")) for v in re.findall(r'text-anchor="end">(-?[0-9,.]+)</text>', text)]
    assert len(values) >= 6, values
    steps = {abs(b - a) for a, b in zip(values, values[1:]) if b > a}
    for step in steps:
        mantissa = step / 10 ** len(str(int(step))[:-1]) if step >= 1 else step
        assert mantissa in (1, 2, 5) or step in (0.1, 0.2, 0.5), f"tick step {step}"
    for value in values:
        assert any(value % step == 0 for step in steps), f"tick {value} is not a multiple of its step"
    frames = [float(y) for y in re.findall(r'<rect x="[0-9.]+" y="([0-9.]+)" width="[0-9.]+" height="[0-9.]+" fill="none"', text)]
    titles = [float(y) for y in re.findall(r'<text x="[0-9.]+" y="([0-9.]+)" font-weight="bold"[^>]*>', text)]
    assert len(frames) == 2 and len(titles) == 2
    assert all(title < frame for title, frame in zip(titles, frames)), (titles, frames)
    log = drive.log()
    assert "mode of operation (6061h) 6" in log and "CiA 402 SwitchedOn -> OperationEnabled" in log

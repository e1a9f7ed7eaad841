"""`--trace FILE` and `-v`: a python-canopen session recorded by the drive, then replayed by
can-utils' `canplayer`.

What the test shows:

1. The trace holds every frame of the session in both directions: the frames python-canopen
   sent (in the order it sent them) and the frames it received (in the order it received
   them) are both in the file, in that order, and nothing else is (the drive is the only other
   node). Every line has the `candump -l` form `(seconds.microseconds) can0 ID#DATA`.
2. `canplayer` from can-utils accepts the file as it is: it parses every line (it exits with
   an error on a line it cannot parse), honours the timestamps and the interface assignment
   `vcan0=can0`, and writes each frame, in order and unchanged, to a CAN socket.
3. `-v` reported the session's state changes, the SDO abort and the EMCY on stderr.

How canplayer runs here: this machine's kernel has no SocketCAN (`socket(PF_CAN, ...)` fails,
so no vcan interface can be made, and canplayer stops before reading its file). The test
preloads `canplayer_shim.c` into canplayer: it replaces only the CAN socket (socket, bind,
setsockopt, the interface-index ioctl, sendto) and writes each `struct can_frame` canplayer
sends as a text line. Everything else is canplayer's own: reading, parsing, timing,
interface assignment. What this does not show is a kernel delivering the frames on a vcan
interface; on a host with SocketCAN that is `sudo ip link add vcan0 type vcan && sudo ip link
set vcan0 up && canplayer -I FILE vcan0=can0` (with `candump vcan0` watching).

Needs `canplayer` (apt-get install can-utils) and gcc; scripts/test.sh installs can-utils.
Without them the test is skipped, unless CANPLAYER_REQUIRED=1 (as scripts/test.sh sets it).
"""

import os
import re
import shutil
import subprocess
import threading
import time

import can
import canopen
import pytest

from conftest import NODE_ID, REPO_ROOT, DriveProcess

LINE = re.compile(r"^\((\d+)\.(\d{6})\) can0 ([0-9A-F]{3}|[0-9A-F]{8})#([0-9A-F]{0,16}|R\d)$")


def tools_or_skip():
    missing = [tool for tool in ("canplayer", "gcc") if shutil.which(tool) is None]
    if missing:
        if os.environ.get("CANPLAYER_REQUIRED") == "1":
            pytest.fail(f"missing {missing} (apt-get install can-utils gcc)", pytrace=False)
        pytest.skip(f"missing {missing} (apt-get install can-utils gcc)")


def candump(msg: can.Message) -> str:
    ident = f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"
    data = f"R{msg.dlc}" if msg.is_remote_frame else bytes(msg.data).hex().upper()
    return f"{ident}#{data}"


def is_subsequence(part, whole) -> bool:
    it = iter(whole)
    return all(any(x == y for y in it) for x in part)


class SessionRecorder(can.Listener):
    """Every frame the master sends and receives, in order."""

    def __init__(self, network: canopen.Network):
        self.sent, self.received = [], []
        self.lock = threading.Lock()
        send = network.bus.send

        def recording_send(msg, timeout=None):
            with self.lock:
                self.sent.append(candump(msg))
            return send(msg, timeout)

        network.bus.send = recording_send
        network.notifier.add_listener(self)

    def on_message_received(self, msg):
        with self.lock:
            self.received.append(candump(msg))


def run_session(drive: DriveProcess) -> SessionRecorder:
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05
    network.connect(interface="slcan", channel=drive.channel, bitrate=500000, sleep_after_open=0)
    try:
        recorder = SessionRecorder(network)
        node = network.add_node(NODE_ID)
        node.nmt.send_command(0x82)  # reset communication: a boot-up frame
        time.sleep(0.1)
        assert node.sdo.upload(0x1018, 2) != bytes(4)  # the generic identity is not blank
        assert node.sdo.upload(0x1008, 0) == b"canopen-drive-linux"  # segmented upload
        with pytest.raises(canopen.SdoAbortedError):
            node.sdo.upload(0x2FFF, 0)  # abort 06020000h
        node.sdo.download(0x6060, 0, bytes([3]))  # pv
        for controlword in (0x06, 0x07, 0x0F):
            node.sdo.download(0x6040, 0, controlword.to_bytes(2, "little"))
            time.sleep(0.02)
        node.sdo.download(0x2100, 0, (1).to_bytes(4, "little"))  # simulated over-current: EMCY
        time.sleep(0.05)
        node.nmt.state = "OPERATIONAL"  # TPDOs
        time.sleep(0.1)
        node.nmt.state = "PRE-OPERATIONAL"
        time.sleep(0.05)
    finally:
        network.disconnect()
    return recorder


def test_session_trace_replays_with_canplayer(tmp_path):
    tools_or_skip()
    trace = tmp_path / "session.log"
    drive = DriveProcess(tmp_path, extra_args=("--trace", str(trace), "-v"))
    started = time.time()
    try:
        session = run_session(drive)
    finally:
        assert drive.stop() == 0, drive.log()
    ended = time.time()

    # 1. The file: every frame of the session, both directions, candump -l lines.
    lines = trace.read_text().splitlines()
    assert lines, "empty trace"
    frames = []
    for line in lines:
        match = LINE.match(line)
        assert match, f"not a candump -l line: {line!r}"
        stamp = int(match[1]) + int(match[2]) / 1e6
        assert started - 1 <= stamp <= ended + 1, line
        frames.append(f"{match[3]}#{match[4]}")
    stamps = [float(line[1:].split(")")[0]) for line in lines]
    assert stamps == sorted(stamps)
    assert frames[0] == f"{0x700 + NODE_ID:03X}#00", "the boot-up frame comes first"
    assert is_subsequence(session.sent, frames), (session.sent, frames)
    # The boot-up frame went out before the master connected; everything after it was seen.
    assert is_subsequence(session.received, frames[1:]), (session.received, frames)
    assert len(frames) == 1 + len(session.sent) + len(session.received)
    assert f"{0x80 + NODE_ID:03X}#1023" in "\n".join(frames), "the over-current EMCY 2310h"
    assert any(f.startswith(f"{0x180 + NODE_ID:03X}#") for f in frames), "a TPDO in Operational"

    # 2. canplayer replays it (timestamps honoured, can0 assigned to vcan0).
    shim = tmp_path / "canplayer_shim.so"
    source = REPO_ROOT / "tests" / "python" / "canplayer_shim.c"
    subprocess.run(["gcc", "-O2", "-shared", "-fPIC", "-o", str(shim), str(source), "-ldl"], check=True)
    capture = tmp_path / "capture.txt"
    env = dict(os.environ, LD_PRELOAD=str(shim), CANPLAYER_CAPTURE=str(capture))
    begun = time.monotonic()
    replay = subprocess.run(
        ["canplayer", "-I", str(trace), "-v", "vcan0=can0"], env=env, capture_output=True, text=True, timeout=60
    )
    took = time.monotonic() - begun
    assert replay.returncode == 0, replay.stdout + replay.stderr
    assert capture.read_text().splitlines() == [f"vcan0 {frame}" for frame in frames]
    assert len(replay.stdout.splitlines()) == len(frames)
    assert took >= (stamps[-1] - stamps[0]) * 0.9, "the replay keeps the recorded timing"

    # 3. -v: the state changes, the abort and the EMCY on stderr.
    log = drive.log()
    for expected in (
        "NMT PreOperational -> Operational",
        "CiA 402 SwitchedOn -> OperationEnabled",
        "CiA 402 OperationEnabled { leaving: None } -> FaultReactionActive",
        "SDO abort 06020000h (ObjectDoesNotExist) of 2FFFh sub 0",
        f"EMCY from node {NODE_ID} (this drive): error code 2310h",
    ):
        assert expected in log, f"{expected!r} not in the log:\n{log}"


def test_very_verbose_shows_the_cores_own_log(tmp_path):
    """`-vv` adds the core's log (the `log` feature of canopen-drive): NMT transitions, PDO
    configuration, SDO aborts and EMCYs as the core saw them, during the same session."""
    drive = DriveProcess(tmp_path, extra_args=("-vv",))
    try:
        run_session(drive)
    finally:
        assert drive.stop() == 0, drive.log()
    log = drive.log()
    for expected in (
        f"core info: NMT: boot-up of node {NODE_ID}, Pre-operational",
        "core debug: PDO: Rpdo 1 valid: COB-ID 205, 1 entries",
        "core info: NMT: PreOperational -> Operational",
        "core debug: SDO: Mux { index: 12287, sub: 0 } aborted: ObjectDoesNotExist",
        "core info: EMCY: error 2310 raised",
    ):
        assert expected in log, f"{expected!r} not in the log:\n{log}"
    assert "core trace: deregistering" not in log, "only the core's records, not its libraries'"

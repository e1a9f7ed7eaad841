"""Fixtures for the python-canopen interop tests of `canopen-drive-linux`.

Nothing is built here: the binary is taken from the environment variable CANOPEN_DRIVE_LINUX
(a relative path is taken from the repository root), by default `debug/canopen-drive-linux` in
the directory cargo builds into (`cargo metadata`'s target directory: `target/`, or
CARGO_TARGET_DIR when set). Build it first, e.g. `cargo build -p canopen-drive-linux`.
"""

import json
import os
import pathlib
import queue
import select
import signal
import socket
import subprocess
import threading
import time

import can
import canopen
import pytest

REPO_ROOT = pathlib.Path(__file__).resolve().parents[2]
NODE_ID = 5
READY_TIMEOUT = 10.0


def cargo_target_dir() -> pathlib.Path:
    """Where cargo puts what it builds for this repository."""
    try:
        out = subprocess.run(
            ["cargo", "metadata", "--format-version", "1", "--no-deps"],
            cwd=REPO_ROOT, capture_output=True, text=True, check=True,
        ).stdout
        return pathlib.Path(json.loads(out)["target_directory"])
    except (OSError, subprocess.CalledProcessError, ValueError, KeyError):
        return REPO_ROOT / "target"


def binary_path() -> pathlib.Path:
    configured = os.environ.get("CANOPEN_DRIVE_LINUX")
    path = pathlib.Path(configured) if configured else cargo_target_dir() / "debug" / "canopen-drive-linux"
    if not path.is_absolute():
        path = REPO_ROOT / path
    if not path.is_file():
        pytest.fail(
            f"{path} does not exist: build it (cargo build -p canopen-drive-linux) "
            "or point CANOPEN_DRIVE_LINUX at it",
            pytrace=False,
        )
    return path


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class DriveProcess:
    """The drive binary serving SLCAN on a free local port."""

    def __init__(self, log_dir: pathlib.Path, extra_args=(), node_id=NODE_ID):
        self.node_id = node_id
        self.port = None
        self.proc = None
        self.log_path = log_dir / "canopen-drive-linux.log"
        for _ in range(5):  # another process may take the free port before the drive binds it
            self.port = free_port()
            if self._start(extra_args):
                return
        pytest.fail(f"the drive did not start; see {self.log_path}:\n{self.log()}", pytrace=False)

    def _start(self, extra_args) -> bool:
        args = [str(binary_path()), "--node-id", str(self.node_id), "--slcan-listen", f"127.0.0.1:{self.port}", *extra_args]
        log = open(self.log_path, "ab")
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=log, stdin=subprocess.DEVNULL)
        log.close()
        deadline = time.monotonic() + READY_TIMEOUT
        line = b""
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.proc.stdout], [], [], 0.05)
            if ready:
                line = self.proc.stdout.readline()
                break
            if self.proc.poll() is not None:
                break
        if line == b"ready\n":
            return True
        self.stop()
        return False

    @property
    def channel(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    def log(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""

    def stop(self, sig=signal.SIGTERM, timeout=5.0):
        """Signals the process and returns its exit status."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout:
            self.proc.stdout.close()
        return self.proc.returncode


def open_slcan(drive: DriveProcess) -> can.BusABC:
    return can.Bus(interface="slcan", channel=drive.channel, bitrate=500000, sleep_after_open=0)


class Recorder:
    """Records the frames of one CAN-ID seen by a canopen.Network, with arrival times."""

    def __init__(self, network: canopen.Network, can_id: int):
        self.frames = []  # (time.monotonic(), bytes)
        self._cond = threading.Condition()
        network.subscribe(can_id, self._on_frame)

    def _on_frame(self, can_id, data, timestamp):
        with self._cond:
            self.frames.append((time.monotonic(), bytes(data)))
            self._cond.notify_all()

    def clear(self):
        with self._cond:
            self.frames.clear()

    def wait_for(self, predicate, timeout=1.0, start=0):
        """The first frame from index `start` on whose data satisfies `predicate`, as (index, time, data)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                for i in range(start, len(self.frames)):
                    t, data = self.frames[i]
                    if predicate(data):
                        return i, t, data
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"no matching frame within {timeout} s; seen {self.frames[start:]!r}")
                self._cond.wait(left)

    def wait_count(self, n, timeout=1.0):
        deadline = time.monotonic() + timeout
        with self._cond:
            while len(self.frames) < n:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"{len(self.frames)} frames within {timeout} s, wanted {n}")
                self._cond.wait(left)
            return list(self.frames)


class RawSdo:
    """Single SDO request/response pairs with exact frames, for probing and timing."""

    def __init__(self, network: canopen.Network, node_id: int = NODE_ID):
        self.network = network
        self.request_id = 0x600 + node_id
        self.responses = queue.Queue()
        network.subscribe(0x580 + node_id, lambda _id, data, _ts: self.responses.put(bytes(data)))

    def request(self, data: bytes, timeout=1.0) -> bytes:
        while not self.responses.empty():
            self.responses.get_nowait()
        self.network.send_message(self.request_id, data)
        return self.responses.get(timeout=timeout)

    def initiate_upload(self, index: int, sub: int) -> bytes:
        """Sends an initiate upload; aborts a segmented transfer it starts. Returns the response."""
        request = bytes([0x40, index & 0xFF, index >> 8, sub, 0, 0, 0, 0])
        response = self.request(request)
        if response[0] & 0xE0 == 0x40 and not response[0] & 0x02:
            # Segmented: leave the server idle again (an abort is never answered).
            self.network.send_message(self.request_id, bytes([0x80, index & 0xFF, index >> 8, sub, 0, 0, 0, 0x08]))
        return response


def profile_args(request) -> tuple:
    """`--profile NAME` for a test module that sets `PROFILE = "NAME"` (default: generic), and
    `--axes N` for one that sets `AXIS_COUNT = N` (default: one axis)."""
    profile = getattr(request.module, "PROFILE", None)
    axes = getattr(request.module, "AXIS_COUNT", None)
    return (("--profile", profile) if profile else ()) + (("--axes", str(axes)) if axes else ())


@pytest.fixture(scope="module")
def eds_file(request, tmp_path_factory) -> pathlib.Path:
    path = tmp_path_factory.mktemp("eds") / "canopen-drive-linux.eds"
    result = subprocess.run(
        [str(binary_path()), *profile_args(request), "--node-id", str(NODE_ID), "--write-eds", str(path)],
        capture_output=True,
        timeout=10,
    )
    assert result.returncode == 0, result.stderr.decode(errors="replace")
    assert result.stdout == b""
    return path


@pytest.fixture(scope="module")
def drive(request, tmp_path_factory):
    process = DriveProcess(tmp_path_factory.mktemp("drive"), extra_args=profile_args(request))
    yield process
    status = process.stop()
    assert status == 0, f"exit status {status}; log:\n{process.log()}"


@pytest.fixture
def network(drive):
    net = canopen.Network()
    net.NOTIFIER_CYCLE = 0.05  # the receive thread's poll period: disconnect waits for one cycle
    net.connect(interface="slcan", channel=drive.channel, bitrate=500000, sleep_after_open=0)
    yield net
    net.disconnect()


@pytest.fixture
def heartbeats(network) -> Recorder:
    return Recorder(network, 0x700 + NODE_ID)


@pytest.fixture
def sdo_frames(network) -> Recorder:
    return Recorder(network, 0x580 + NODE_ID)


@pytest.fixture
def node(network, heartbeats, sdo_frames, eds_file) -> canopen.RemoteNode:
    """The drive as a python-canopen node, freshly reset (NMT reset communication).

    The recorders subscribe before the node's SDO client, so a frame is recorded before the
    client call that waits for it returns."""
    remote = canopen.RemoteNode(NODE_ID, str(eds_file))
    network.add_node(remote)
    heartbeats.clear()
    remote.nmt.send_command(0x82)
    heartbeats.wait_for(lambda d: d == b"\x00", timeout=2.0)
    heartbeats.clear()
    return remote

"""Fixtures for the python-canopen tests of the QEMU firmware (boards/qemu-mps2).

Nothing is built here. The firmware ELF comes from QEMU_MPS2_ELF (default: the thumbv7em
release build under target/firmware/qemu-mps2, where scripts/mcu.sh puts it; a relative path
is taken from the repository root). Without qemu-system-arm, or without the ELF, every test
is skipped with the reason.
"""

import os
import pathlib
import queue
import re
import shutil
import socket
import subprocess
import threading
import time

import canopen
import pytest

REPO_ROOT = pathlib.Path(__file__).resolve().parents[2]
RUN_SH = REPO_ROOT / "boards" / "qemu-mps2" / "run.sh"
DEFAULT_ELF = "target/firmware/qemu-mps2/thumbv7em-none-eabihf/release/qemu-mps2"
NODE_ID = 5


def firmware_path() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("QEMU_MPS2_ELF", DEFAULT_ELF))
    return path if path.is_absolute() else REPO_ROOT / path


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def listening_on(port: int) -> bool:
    """True when a local TCP socket listens on `port` (from /proc/net/tcp, state 0A)."""
    try:
        lines = pathlib.Path("/proc/net/tcp").read_text().splitlines()[1:]
    except OSError:
        return False
    for line in lines:
        fields = line.split()
        if len(fields) > 3 and fields[3] == "0A" and int(fields[1].split(":")[1], 16) == port:
            return True
    return False


class QemuFirmware:
    """qemu-system-arm running the firmware, its UART0 on a local TCP port (boards/qemu-mps2/run.sh)."""

    def __init__(self, elf: pathlib.Path, log_dir: pathlib.Path):
        self.elf = elf
        self.log_path = log_dir / "defmt.raw"
        self.stderr_path = log_dir / "qemu.stderr"
        for _ in range(5):  # another process may take the free port before QEMU binds it
            self.port = free_port()
            self.monitor_path = log_dir / "monitor.sock"
            env = dict(
                os.environ,
                SLCAN_PORT=str(self.port),
                DEFMT_RAW=str(self.log_path),
                # The user LEDs' writes, time-stamped, on stderr (the CiA 303-3 indicators).
                QEMU_EXTRA=f"-monitor unix:{self.monitor_path},server=on,wait=off "
                "-trace mps2_fpgaio_write -msg timestamp=on",
            )
            with open(self.stderr_path, "wb") as err:
                self.proc = subprocess.Popen(
                    [str(RUN_SH), str(elf)], env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err
                )
            if self._listening(timeout=10.0):
                return
            self.kill()
        pytest.fail(f"QEMU did not open its SLCAN port; {self.stderr_path}:\n{self.stderr()}", pytrace=False)

    def _listening(self, timeout: float) -> bool:
        """Waits until QEMU listens on the port, without connecting: QEMU's socket chardev
        serves one client at a time, and a probe would take the firmware's first bytes."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                return False
            if listening_on(self.port):
                return True
            time.sleep(0.05)
        return False

    @property
    def channel(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    def stderr(self) -> str:
        try:
            return self.stderr_path.read_text(errors="replace")
        except OSError:
            return ""

    def leds(self, since: float = 0.0) -> list:
        """The writes of the user LEDs (FPGA I/O LED0) since the host time `since`, as
        `(host time, bits)`, from QEMU's `mps2_fpgaio_write` trace event: bit 0 is the green
        RUN LED, bit 1 the red ERR LED."""
        pattern = re.compile(r"^\d+@(\d+\.\d+):mps2_fpgaio_write .*offset 0x0 data 0x([0-9a-f]+)", re.M)
        writes = [(float(t), int(bits, 16)) for t, bits in pattern.findall(self.stderr())]
        return [(t, bits) for t, bits in writes if t >= since]

    def log(self) -> str:
        """The firmware's defmt log, decoded when defmt-print is installed."""
        if not self.log_path.exists():
            return ""
        if shutil.which("defmt-print"):
            # QEMU's own notes share its stdout with the frames (run.sh).
            frames = re.sub(rb"Warning: The guest is now late by [0-9.]+ to [0-9.]+ seconds\.?\n", b"", self.log_path.read_bytes())
            result = subprocess.run(["defmt-print", "-e", str(self.elf)], input=frames, capture_output=True, timeout=30)
            return result.stdout.decode(errors="replace")
        return f"({self.log_path.stat().st_size} bytes of defmt frames in {self.log_path}; install defmt-print to decode)"

    def monitor(self, command: str) -> str:
        """A QEMU monitor command's output (for diagnosing a firmware that stopped answering)."""
        with socket.socket(socket.AF_UNIX) as s:
            s.connect(str(self.monitor_path))
            s.settimeout(0.3)
            s.sendall(command.encode() + b"\n")
            out = b""
            try:
                while chunk := s.recv(65536):
                    out += chunk
            except OSError:
                pass
        return out.decode(errors="replace")

    def wait(self, timeout: float):
        """QEMU's exit status (the firmware's own), or None when it is still running."""
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture(scope="module")
def firmware(tmp_path_factory):
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm is not installed (apt-get install -y qemu-system-arm; scripts/mcu.sh does)")
    elf = firmware_path()
    if not elf.is_file():
        pytest.skip(f"no firmware at {elf}: build boards/qemu-mps2 (scripts/mcu.sh) or set QEMU_MPS2_ELF")
    qemu = QemuFirmware(elf, tmp_path_factory.mktemp("qemu"))
    yield qemu
    status = qemu.wait(0)
    qemu.kill()
    print(f"\nfirmware log:\n{qemu.log()}")
    assert status is not None, "the firmware was still running at the end (the exit test did not run or failed)"


@pytest.fixture(scope="module")
def network(firmware):
    net = canopen.Network()
    net.NOTIFIER_CYCLE = 0.05
    net.connect(interface="slcan", channel=firmware.channel, bitrate=500000, sleep_after_open=0)
    yield net
    if net.bus is not None:
        net.disconnect()


@pytest.fixture(scope="module")
def node(network) -> canopen.RemoteNode:
    """The firmware as a python-canopen node; no EDS: objects are addressed by index."""
    remote = canopen.RemoteNode(NODE_ID, canopen.ObjectDictionary())
    remote.sdo.RESPONSE_TIMEOUT = 2.0
    network.add_node(remote)
    return remote


class Recorder:
    """Frames of one CAN-ID with their arrival times."""

    def __init__(self, network: canopen.Network, can_id: int):
        self.frames = []
        self._cond = threading.Condition()
        network.subscribe(can_id, self._on_frame)

    def _on_frame(self, can_id, data, timestamp):
        with self._cond:
            self.frames.append((time.monotonic(), bytes(data)))
            self._cond.notify_all()

    def clear(self):
        with self._cond:
            self.frames.clear()

    def wait_for(self, predicate, timeout=2.0):
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                for t, data in self.frames:
                    if predicate(data):
                        return t, data
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"no matching frame within {timeout} s; seen {self.frames!r}")
                self._cond.wait(left)


class RawSdo:
    """Single SDO request/response pairs with exact frames."""

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

"""Fixtures for the python-canopen tests of the QEMU firmware (boards/qemu-mps2).

Nothing is built here. The firmware ELF comes from QEMU_MPS2_ELF (default: the thumbv7em
release build under target/firmware/qemu-mps2, where scripts/mcu.sh puts it; a relative path
is taken from the repository root). Without qemu-system-arm, or without the ELF, every test
is skipped with the reason.

Program download (test_program_download.py): the bootloader's ELF from QEMU_BOOTLOADER_ELF
(default: the bootloader of that build) and two images of the application made by
boards/qemu-mps2/make_image.py from QEMU_APP_IMAGE_1 and QEMU_APP_IMAGE_2 (default:
target/firmware/qemu-mps2-image/app-1.img and app-2.img, where scripts/mcu.sh puts them,
each with its ELF beside it as app-N.elf for the log).
"""

import os
import pathlib
import queue
import re
import shutil
import socket
import subprocess
import sys
import threading
import time
import zlib

import canopen
import pytest

REPO_ROOT = pathlib.Path(__file__).resolve().parents[2]
BOARD = REPO_ROOT / "boards" / "qemu-mps2"
RUN_SH = BOARD / "run.sh"
DEFAULT_ELF = "target/firmware/qemu-mps2/thumbv7em-none-eabihf/release/qemu-mps2"
DEFAULT_BOOTLOADER_ELF = "target/firmware/qemu-mps2/thumbv7em-none-eabihf/release/bootloader"
DEFAULT_APP_IMAGES = ("target/firmware/qemu-mps2-image/app-1.img", "target/firmware/qemu-mps2-image/app-2.img")
NODE_ID = 5

sys.path.insert(0, str(BOARD))
import make_image  # noqa: E402  (boards/qemu-mps2/make_image.py: the image format)


def repo_path(variable: str, default: str) -> pathlib.Path:
    path = pathlib.Path(os.environ.get(variable, default))
    return path if path.is_absolute() else REPO_ROOT / path


def firmware_path() -> pathlib.Path:
    return repo_path("QEMU_MPS2_ELF", DEFAULT_ELF)


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

    def __init__(self, elf: pathlib.Path, log_dir: pathlib.Path, extra: str = "", log_elf: pathlib.Path = None):
        """`extra`: more QEMU arguments; `log_elf`: the ELF whose defmt table decodes the log
        (default `elf`)."""
        self.elf = elf
        self.log_elf = log_elf or elf
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
                f"-trace mps2_fpgaio_write -msg timestamp=on {extra}",
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
            result = subprocess.run(["defmt-print", "-e", str(self.log_elf)], input=frames, capture_output=True, timeout=30)
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
    skip_without_qemu()
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


def skip_without_qemu():
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm is not installed (apt-get install -y qemu-system-arm; scripts/mcu.sh does)")


class AppImage:
    """A program image of the application (make_image.py) and what the test needs of it."""

    def __init__(self, path: pathlib.Path):
        self.path = path
        self.image = path.read_bytes()
        self.payload = make_image.payload(self.image)
        self.crc = zlib.crc32(self.payload)
        # The ELF it was made from, beside it (app-N.img, app-N.elf): its defmt table.
        self.elf = path.with_suffix(".elf")


@pytest.fixture(scope="session")
def app_images():
    """The two builds of the application, as images (QEMU_APP_IMAGE_1, QEMU_APP_IMAGE_2)."""
    paths = [repo_path(f"QEMU_APP_IMAGE_{n}", default) for n, default in zip((1, 2), DEFAULT_APP_IMAGES)]
    for path in paths:
        if not path.is_file():
            pytest.skip(f"no application image at {path}: scripts/mcu.sh makes them (boards/qemu-mps2/make_image.py)")
    return [AppImage(path) for path in paths]


@pytest.fixture
def boot_firmware(tmp_path_factory, app_images):
    """QEMU with the bootloader and the first image in the program area, as a finished
    download leaves it: the bootloader starts the first build. The test ends the run through
    2F00h of the application it started."""
    skip_without_qemu()
    elf = repo_path("QEMU_BOOTLOADER_ELF", DEFAULT_BOOTLOADER_ELF)
    if not elf.is_file():
        pytest.skip(f"no bootloader at {elf}: build boards/qemu-mps2 (scripts/mcu.sh) or set QEMU_BOOTLOADER_ELF")
    # A short directory: QEMU's monitor socket is in it (a Unix socket path has 107 bytes).
    tmp_path = tmp_path_factory.mktemp("boot")
    area = tmp_path / "area.bin"
    area.write_bytes(make_image.area(app_images[0].image))
    log_elf = app_images[0].elf if app_images[0].elf.is_file() else elf
    qemu = QemuFirmware(
        elf, tmp_path, extra=f"-device loader,file={area},addr={make_image.PROGRAM_AREA:#x}", log_elf=log_elf
    )
    yield qemu
    status = qemu.wait(0)
    qemu.kill()
    print(f"\nfirmware log:\n{qemu.log()}")
    assert status == 0, f"the firmware ended with {status} (None: it was still running)"


@pytest.fixture
def boot_network(boot_firmware):
    net = canopen.Network()
    net.NOTIFIER_CYCLE = 0.05
    net.connect(interface="slcan", channel=boot_firmware.channel, bitrate=500000, sleep_after_open=0)
    yield net
    if net.bus is not None:
        net.disconnect()


@pytest.fixture
def boot_node(boot_network) -> canopen.RemoteNode:
    """Bootloader or application, whichever runs, at node-ID 5."""
    remote = canopen.RemoteNode(NODE_ID, canopen.ObjectDictionary())
    remote.sdo.RESPONSE_TIMEOUT = 2.0
    boot_network.add_node(remote)
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

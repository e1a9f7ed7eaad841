"""Program download (CiA 302-3) with python-canopen against the QEMU firmware and its
bootloader (boards/qemu-mps2: src/bin/bootloader.rs, src/boot.rs).

QEMU starts with the bootloader and the first build of the application in the program area;
the bootloader finds a valid image and starts it. The master then replaces it with the second
build in the boot-slave sequence of issue 35 (as Lely's nmt_boot.c and Zephyr's
canopen_program.py run it): read the identity, compare 1F56h:1, stop (the application jumps
to the bootloader, which stays), clear, download the image to 1F50h:1, poll 1F57h:1, compare
1F56h:1 with the CRC-32 it computed, start, poll 1F51h:1 until the program runs. Each test
runs its own QEMU and ends it through 2F00h of the application it started.

The two builds differ in 100Ah and 1018h:3 only; scripts/mcu.sh builds them with the values
of BUILDS (QEMU_MPS2_SOFTWARE_VERSION, QEMU_MPS2_REVISION).
"""

import time
import zlib

import pytest
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from conftest import Recorder, make_image

# (100Ah, 1018h:3) of the two builds, as scripts/mcu.sh makes them.
BUILDS = [("1.0.0", 0x0001_0000), ("2.0.0", 0x0002_0000)]
BOOTLOADER_VERSION = "bootloader 1.0.0"

DEVICE_TYPE = 0x1000
IDENTITY = 0x1018
SOFTWARE_VERSION = 0x100A
PROGRAM_DATA = 0x1F50
PROGRAM_CONTROL = 0x1F51
PROGRAM_IDENTIFICATION = 0x1F56
FLASH_STATUS = 0x1F57
TEST_EXIT = 0x2F00
# 0800 0022h: not in the present device state (a command while the bootloader is busy).
NOT_NOW = 0x0800_0022


def u32(node, index, sub=0) -> int:
    return int.from_bytes(node.sdo.upload(index, sub), "little")


def text(node, index) -> str:
    return node.sdo.upload(index, 0).decode()


def identity(node) -> list:
    """1000h and 1018h:1-4."""
    return [u32(node, DEVICE_TYPE)] + [u32(node, IDENTITY, sub) for sub in range(1, 5)]


def until(action, timeout=10.0, period=0.1):
    """`action()`'s result once it returns one that is not None, retried every `period` while
    the node does not answer (it is resetting) or is busy (0800 0022h)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            result = action()
            if result is not None:
                return result
        except SdoCommunicationError:
            pass  # no answer: the node is between two images
        except SdoAbortedError as e:
            if e.code != NOT_NOW:
                raise
        if time.monotonic() > deadline:
            raise AssertionError(f"no result within {timeout} s")
        time.sleep(period)


def flash_status(node) -> int:
    """Polls 1F57h:1 every 100 ms until its busy bit clears; its code (bits 1-7)."""
    return until(lambda: (lambda status: None if status & 1 else status >> 1)(u32(node, FLASH_STATUS, 1)))


class Update:
    """What the master saw in one run of the sequence."""

    def __init__(self, network, node, image: bytes, block: bool):
        boot_ups = Recorder(network, 0x700 + node.id)
        # 1-2: identity and program identification of the running application.
        self.app_identity = identity(node)
        self.old_identification = u32(node, PROGRAM_IDENTIFICATION, 1)
        # 3: stop; the application jumps to the bootloader, perhaps before the answer arrives.
        if u32(node, PROGRAM_CONTROL, 1) != 0:
            try:
                node.sdo.download(PROGRAM_CONTROL, 1, b"\x00")
            except SdoCommunicationError:
                pass
        # The bootloader's boot-up, then its identity; it verifies the program it found.
        boot_ups.wait_for(lambda data: data == b"\x00", timeout=5.0)
        self.boot_identity = until(lambda: identity(node))
        self.boot_version = text(node, SOFTWARE_VERSION)
        self.boot_code = flash_status(node)
        self.boot_control = u32(node, PROGRAM_CONTROL, 1)
        # 4: clear, retried while the bootloader starts or verifies; 1F57h busy while erasing.
        until(lambda: node.sdo.download(PROGRAM_CONTROL, 1, b"\x03") or True)
        self.cleared_code = flash_status(node)
        self.cleared_identification = u32(node, PROGRAM_IDENTIFICATION, 1)
        # 5: the image, by block or segmented transfer.
        started = time.monotonic()
        with node.sdo.open(PROGRAM_DATA, 1, "wb", size=len(image), block_transfer=block) as f:
            f.write(image)
        self.seconds = time.monotonic() - started
        # 6-7: flash status, identification.
        self.code = flash_status(node)
        self.boot_identification = u32(node, PROGRAM_IDENTIFICATION, 1)
        # 8: start, then 1F51h:1 until the program runs.
        node.sdo.download(PROGRAM_CONTROL, 1, b"\x01")
        until(lambda: u32(node, PROGRAM_CONTROL, 1) == 1 or None)
        self.new_identity = identity(node)
        self.new_identification = u32(node, PROGRAM_IDENTIFICATION, 1)
        self.new_version = text(node, SOFTWARE_VERSION)


def runs_build(node, image, build):
    """The running application is `build`, from `image`."""
    version, revision = build
    assert u32(node, PROGRAM_CONTROL, 1) == 1, "started"
    assert text(node, SOFTWARE_VERSION) == version
    assert u32(node, IDENTITY, 3) == revision
    assert u32(node, PROGRAM_IDENTIFICATION, 1) == image.crc


def end_run(firmware, network, node):
    """Ends QEMU through the application's 2F00h (exit status 0)."""
    node.sdo.download(TEST_EXIT, 0, (0).to_bytes(4, "little"))
    # The firmware waits 300 ms before it exits: leave the link first.
    network.disconnect()
    assert firmware.wait(10.0) == 0


def check_update(update: Update, crc: int, first):
    assert update.boot_version == BOOTLOADER_VERSION, "the bootloader answered after the stop"
    assert (update.boot_code, update.boot_control) == (0, 0), "stopped, with the first build's valid program"
    assert update.old_identification == first.crc
    assert (update.cleared_code, update.cleared_identification) == (1, 0), "cleared: no valid program"
    assert update.code == 0, "1F57h: the download is verified"
    assert update.boot_identification == crc, "1F56h in the bootloader = the master's CRC-32"
    assert update.new_identification == crc, "1F56h in the started application = the master's CRC-32"
    assert update.boot_identity[:3] == update.app_identity[:3], "1000h, 1018h:1-2: bootloader = application"
    assert update.new_identity[:3] == update.app_identity[:3], "1000h, 1018h:1-2: the new application"
    assert update.new_version == BUILDS[1][0]
    assert update.new_identity[3] == BUILDS[1][1], "1018h:3 of the second build"


@pytest.mark.parametrize("block", [True, False], ids=["block", "segmented"])
def test_a_master_replaces_the_application_with_the_second_build(boot_firmware, boot_network, boot_node, app_images, block):
    first, second = app_images
    node = boot_node
    runs_build(node, first, BUILDS[0])

    update = Update(boot_network, node, second.image, block)
    check_update(update, second.crc, first)
    runs_build(node, second, BUILDS[1])
    kind = "block" if block else "segmented"
    print(
        f"\n{kind} transfer of {len(second.image)} bytes: {update.seconds:.2f} s, "
        f"{len(second.image) / 1024 / update.seconds:.1f} KiB/s; bootloader identity {update.boot_identity}, "
        f"application {update.new_identity}"
    )
    end_run(boot_firmware, boot_network, node)


def test_a_256_kib_image_by_block_transfer_and_its_throughput(boot_firmware, boot_network, boot_node, app_images):
    first, second = app_images
    node = boot_node
    payload = second.payload + b"\xff" * (256 * 1024 - len(second.payload))
    image = make_image.image(payload)

    update = Update(boot_network, node, image, block=True)
    check_update(update, zlib.crc32(payload), first)
    print(
        f"\n256 KiB payload ({len(image)} bytes of image) by block transfer: {update.seconds:.2f} s, "
        f"{len(image) / 1024 / update.seconds:.1f} KiB/s"
    )
    end_run(boot_firmware, boot_network, node)


def test_reset_restarts_the_application_through_the_bootloader(boot_firmware, boot_network, boot_node, app_images):
    first, _ = app_images
    node = boot_node
    boot_ups = Recorder(boot_network, 0x700 + node.id)
    node.sdo.download(PROGRAM_CONTROL, 1, b"\x02")
    # The answer came first; then the restarted application's boot-up.
    boot_ups.wait_for(lambda data: data == b"\x00", timeout=5.0)
    until(lambda: u32(node, PROGRAM_CONTROL, 1) == 1 or None)
    runs_build(node, first, BUILDS[0])
    assert text(node, 0x1008) == "canopen-drive qemu-mps2", "the application, not the bootloader"
    end_run(boot_firmware, boot_network, node)

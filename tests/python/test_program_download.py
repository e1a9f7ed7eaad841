"""Program download (CiA 302-3) with python-canopen as the master: canopen-drive-linux with
--program-area runs as a device with a bootloader, and the master replaces its program in the
boot-slave sequence real masters use (Lely's boot-slave procedure, Zephyr's canopen_program
runner): read 1000h and 1018h, compare 1F56h, stop, clear, download to 1F50h:1 by block transfer
(segmented as the fallback), poll 1F57h every 100 ms, compare 1F56h with the CRC-32 it computed,
start, poll 1F51h until the program runs.

The Linux program cannot run a downloaded image as code: a payload whose first line is
`canopen-drive-linux build VERSION REVISION` runs as that build (100Ah, 1018h:3).
"""

import struct
import time
import zlib

import canopen
import pytest

from conftest import DriveProcess

NODE_ID = 5
PROGRAM_DATA, PROGRAM_CONTROL, IDENTIFICATION, FLASH_STATUS = 0x1F50, 0x1F51, 0x1F56, 0x1F57


def program(version: str, revision: int, size: int) -> bytes:
    """The payload of a build: its build line, then filler to `size` bytes."""
    line = f"canopen-drive-linux build {version} {revision:08x}\n".encode()
    return line + bytes((i * 13 + i // 7) & 0xFF for i in range(size - len(line)))


def image(payload: bytes) -> bytes:
    """The image of `payload`: 16-byte header (magic, format 1, length, CRC-32), then payload."""
    return b"CDPI" + struct.pack("<HHII", 1, 0, len(payload), zlib.crc32(payload)) + payload


def connect(process):
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05
    network.connect(interface="slcan", channel=process.channel, bitrate=500000, sleep_after_open=0)
    node = canopen.RemoteNode(NODE_ID, canopen.ObjectDictionary())
    network.add_node(node)
    node.sdo.RESPONSE_TIMEOUT = 1.0
    return network, node


def u32(node, index, sub=0) -> int:
    data = node.sdo.upload(index, sub)
    return int.from_bytes(data, "little")


def identity(node):
    return [u32(node, 0x1000)] + [u32(node, 0x1018, sub) for sub in range(1, 5)]


def abort_code(call) -> int:
    with pytest.raises(canopen.SdoAbortedError) as error:
        call()
    return error.value.code


def wait_flash_status(node, timeout=30.0) -> int:
    """Polls 1F57h:1 every 100 ms until its busy bit clears; returns the code (bits 1-7)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = u32(node, FLASH_STATUS, 1)
        if status & 1 == 0:
            return (status >> 1) & 0x7F
        time.sleep(0.1)
    pytest.fail("1F57h:1 stays busy")


def retry(call, timeout=5.0):
    """A command the device may not answer while it resets, or refuse while it is busy."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return call()
        except (canopen.SdoCommunicationError, canopen.SdoAbortedError):
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def update(node, payload: bytes, block: bool):
    """The master's boot-slave sequence; returns (1F56h in the bootloader, identity there)."""
    expected = zlib.crc32(payload)
    # 1-3: identity, the program's identification, program control.
    identity(node)
    if u32(node, IDENTIFICATION, 1) == expected:
        return None
    if u32(node, PROGRAM_CONTROL, 1) != 0:
        try:
            node.sdo.download(PROGRAM_CONTROL, 1, b"\x00")
        except canopen.SdoCommunicationError:
            pass  # a device may reset into its bootloader before it answers
    # 4: clear, retried while the device resets; its erase shows in 1F57h bit 0.
    retry(lambda: node.sdo.download(PROGRAM_CONTROL, 1, b"\x03"))
    assert wait_flash_status(node) == 1, "cleared: no valid program"
    boot_identity = identity(node)
    # 5: the image, by block transfer or segmented.
    data = image(payload)
    with node.sdo.open(PROGRAM_DATA, 1, "wb", size=len(data), block_transfer=block) as stream:
        stream.write(data)
    # 6-7: flash status, identification.
    assert wait_flash_status(node) == 0
    in_bootloader = u32(node, IDENTIFICATION, 1)
    # 8: start, then poll until the program runs.
    node.sdo.download(PROGRAM_CONTROL, 1, b"\x01")
    deadline = time.monotonic() + 5.0
    while True:
        try:
            if node.sdo.upload(PROGRAM_CONTROL, 1) == b"\x01":
                break
        except (canopen.SdoCommunicationError, canopen.SdoAbortedError):
            pass
        assert time.monotonic() < deadline, "1F51h:1 never reads 1 (started)"
        time.sleep(0.1)
    return in_bootloader, boot_identity


def test_a_master_installs_and_replaces_the_program_by_block_and_segmented_transfer(tmp_path):
    process = DriveProcess(tmp_path, ["--program-area", str(tmp_path / "area.bin")])
    network, node = connect(process)
    try:
        # An empty area: the bootloader waits for a program.
        assert node.sdo.upload(PROGRAM_CONTROL, 1) == b"\x03"
        assert u32(node, FLASH_STATUS, 1) == 1 << 1
        assert u32(node, IDENTIFICATION, 1) == 0
        assert node.sdo.upload(0x100A, 0) == b"bootloader"
        first = program("1.0.0", 0x0001_0000, 20_000)
        update(node, first, block=True)
        assert node.sdo.upload(0x100A, 0) == b"1.0.0"
        application = identity(node)
        assert application[3] == 0x0001_0000

        for version, revision, block in [("2.0.0", 0x0002_0000, True), ("3.1.0", 0x0003_0001, False)]:
            payload = program(version, revision, 30_000)
            in_bootloader, boot_identity = update(node, payload, block)
            assert in_bootloader == zlib.crc32(payload)
            assert u32(node, IDENTIFICATION, 1) == zlib.crc32(payload), "1F56h the same in the application"
            assert node.sdo.upload(0x100A, 0) == version.encode()
            now = identity(node)
            assert now[3] == revision
            assert boot_identity[:3] == now[:3] == application[:3], "1000h and 1018h:1-2"
    finally:
        network.disconnect()
        assert process.stop() == 0, process.log()


def test_the_device_side_rules_with_their_abort_codes(tmp_path):
    area = tmp_path / "area.bin"
    process = DriveProcess(tmp_path, ["--program-area", str(area)])
    network, node = connect(process)
    try:
        # The bootloader, no program.
        assert abort_code(lambda: node.sdo.upload(PROGRAM_DATA, 1)) == 0x0601_0001  # write only
        # (Expedited: a segmented download that python-canopen sees aborted at its initiation
        # leaves a stream whose collection later sends from inside another send.)
        assert abort_code(lambda: node.sdo.download(PROGRAM_DATA, 1, b"\x01\x02\x03\x04")) == 0x0800_0022
        assert u32(node, FLASH_STATUS, 1) == 4 << 1  # code 4: not cleared
        assert abort_code(lambda: node.sdo.download(PROGRAM_CONTROL, 1, b"\x05")) == 0x0609_0030
        assert abort_code(lambda: node.sdo.download(PROGRAM_CONTROL, 1, b"\x01")) == 0x0800_0022
        # A corrupt image: code 3, start refused.
        node.sdo.download(PROGRAM_CONTROL, 1, b"\x03")
        wait_flash_status(node)
        bad = bytearray(image(program("9.9.9", 9, 5000)))
        bad[1000] ^= 0x40
        with node.sdo.open(PROGRAM_DATA, 1, "wb", size=len(bad), block_transfer=True) as stream:
            stream.write(bytes(bad))
        assert wait_flash_status(node) == 3
        assert node.sdo.upload(PROGRAM_CONTROL, 1) == b"\x03"
        assert abort_code(lambda: node.sdo.download(PROGRAM_CONTROL, 1, b"\x01")) == 0x0800_0022
        # Not an image at all: code 2.
        node.sdo.download(PROGRAM_CONTROL, 1, b"\x03")
        wait_flash_status(node)
        with node.sdo.open(PROGRAM_DATA, 1, "wb", size=3000, block_transfer=False) as stream:
            stream.write(b"\x7fELF" + bytes(2996))
        assert wait_flash_status(node) == 2
        # The application refuses clear and a download: they are the bootloader's.
        update(node, program("1.0.0", 1, 4000), block=True)
        assert abort_code(lambda: node.sdo.download(PROGRAM_CONTROL, 1, b"\x03")) == 0x0800_0022
        assert abort_code(lambda: node.sdo.download(PROGRAM_DATA, 1, b"\x01\x02")) == 0x0800_0022
        assert abort_code(lambda: node.sdo.upload(PROGRAM_DATA, 1)) == 0x0601_0001
    finally:
        network.disconnect()
        assert process.stop() == 0, process.log()


def test_a_program_survives_a_restart_of_the_device(tmp_path):
    area = tmp_path / "area.bin"
    process = DriveProcess(tmp_path, ["--program-area", str(area)])
    network, node = connect(process)
    payload = program("4.0.0", 0x0004_0000, 10_000)
    try:
        update(node, payload, block=True)
    finally:
        network.disconnect()
        assert process.stop() == 0, process.log()
    # Power-on with the program in the area: the application runs at once.
    process = DriveProcess(tmp_path, ["--program-area", str(area)])
    network, node = connect(process)
    try:
        assert node.sdo.upload(PROGRAM_CONTROL, 1) == b"\x01"
        assert node.sdo.upload(0x100A, 0) == b"4.0.0"
        assert u32(node, IDENTIFICATION, 1) == zlib.crc32(payload)
    finally:
        network.disconnect()
        assert process.stop() == 0, process.log()


def test_throughput_of_a_256_kib_image_by_block_transfer(tmp_path, record_property):
    process = DriveProcess(tmp_path, ["--program-area", str(tmp_path / "area.bin")])
    network, node = connect(process)
    try:
        node.sdo.download(PROGRAM_CONTROL, 1, b"\x03")
        wait_flash_status(node)
        data = image(program("5.0.0", 5, 256 * 1024))
        start = time.monotonic()
        with node.sdo.open(PROGRAM_DATA, 1, "wb", size=len(data), block_transfer=True) as stream:
            stream.write(data)
        seconds = time.monotonic() - start
        assert wait_flash_status(node) == 0
        rate = len(data) / 1024 / seconds
        record_property("kib_per_s", round(rate, 1))
        print(f"\n256 KiB image by block transfer: {seconds:.2f} s, {rate:.1f} KiB/s")
    finally:
        network.disconnect()
        assert process.stop() == 0, process.log()

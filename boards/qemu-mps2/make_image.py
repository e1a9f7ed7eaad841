#!/usr/bin/env python3
"""Makes a program image for the bootloader (CiA 302-3 program download, src/boot.rs) from
the application's ELF: the ELF's loadable sections as a flat binary from the application's
first address on (`llvm-objcopy -O binary`), the payload, after a 16-byte header:

    offset  size  field (little-endian)
         0     4  magic "CDPI"
         4     2  format version 1
         6     2  reserved, 0
         8     4  payload length
        12     4  CRC-32 of the payload (zlib's; what 1F56h:1 reads)

The image goes to 1F50h:1 as it is; the bootloader puts the header at the start of the
program area and the payload PAYLOAD_OFFSET bytes further, where the application is linked
(memory/application.x).

    make_image.py APP_ELF IMAGE [--pad-to BYTES] [--area FILE [--payload-offset BYTES]]

--pad-to pads the payload with 0xFF to that length (an image of a given size, to measure a
download's throughput). --area FILE also writes the program area's contents as a finished
download leaves them (header, erased bytes up to PAYLOAD_OFFSET, payload), for QEMU to load
at the area's start: `-device loader,file=FILE,addr=0x10000`, or a flash tool to write there.
--payload-offset BYTES sets PAYLOAD_OFFSET for another board's area (0x800 on the
B-G431B-ESC1: boards/b-g431b-esc1/src/layout.rs); the image itself does not depend on it.

As a module: `header(payload)`, `image(payload)`, `payload(image)`, `area(image)`.
"""

import argparse
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

MAGIC = b"CDPI"
VERSION = 1
HEADER_LEN = 16
# Where the bootloader puts the payload in the program area (PAYLOAD_OFFSET in src/boot.rs).
PAYLOAD_OFFSET = 0x400
# The program area's start (PROGRAM_AREA in src/boot.rs).
PROGRAM_AREA = 0x0001_0000


def header(payload: bytes) -> bytes:
    """The 16-byte header of an image of `payload`."""
    return MAGIC + struct.pack("<HHII", VERSION, 0, len(payload), zlib.crc32(payload))


def image(payload: bytes) -> bytes:
    """Header and payload."""
    return header(payload) + payload


def payload(image_bytes: bytes) -> bytes:
    """The payload of an image, after checking its header."""
    magic, version, reserved, length, crc = struct.unpack("<4sHHII", image_bytes[:HEADER_LEN])
    body = image_bytes[HEADER_LEN:]
    if magic != MAGIC or version != VERSION or reserved != 0 or length != len(body) or crc != zlib.crc32(body):
        raise ValueError("not a valid CDPI image")
    return body


def area(image_bytes: bytes, payload_offset: int = PAYLOAD_OFFSET) -> bytes:
    """The program area's first bytes after a download of `image_bytes`: the header, erased
    bytes (0xFF) up to `payload_offset` (this board's PAYLOAD_OFFSET by default), the
    payload."""
    body = payload(image_bytes)
    return image_bytes[:HEADER_LEN] + b"\xff" * (payload_offset - HEADER_LEN) + body


def objcopy() -> str:
    """llvm-objcopy of the Rust toolchain (rustup component add llvm-tools), else one on PATH."""
    try:
        sysroot = subprocess.run(["rustc", "--print", "sysroot"], capture_output=True, text=True, check=True).stdout.strip()
        for candidate in pathlib.Path(sysroot).glob("lib/rustlib/*/bin/llvm-objcopy"):
            return str(candidate)
    except (OSError, subprocess.CalledProcessError):
        pass
    for name in ("llvm-objcopy", "rust-objcopy", "arm-none-eabi-objcopy"):
        if shutil.which(name):
            return name
    sys.exit("make_image: no objcopy (rustup component add llvm-tools)")


def binary(elf: pathlib.Path) -> bytes:
    """The loadable sections of `elf` as a flat binary, from its lowest load address on."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "app.bin"
        subprocess.run([objcopy(), "-O", "binary", str(elf), str(out)], check=True)
        return out.read_bytes()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("elf", type=pathlib.Path, help="the application's ELF (feature application-image)")
    parser.add_argument("image", type=pathlib.Path, help="the image to write")
    parser.add_argument("--pad-to", type=int, default=0, help="pad the payload with 0xFF to this many bytes")
    parser.add_argument("--area", type=pathlib.Path, help="also write the program area's contents to this file")
    parser.add_argument(
        "--payload-offset",
        type=lambda text: int(text, 0),
        default=PAYLOAD_OFFSET,
        help=f"where the payload lies in the program area, for --area (default {PAYLOAD_OFFSET:#x}, this board's)",
    )
    args = parser.parse_args()
    if args.payload_offset < HEADER_LEN or args.payload_offset % 8:
        sys.exit("make_image: --payload-offset must be at least 16 and a multiple of 8")
    body = binary(args.elf)
    if len(body) < args.pad_to:
        body += b"\xff" * (args.pad_to - len(body))
    args.image.write_bytes(image(body))
    if args.area:
        args.area.write_bytes(area(image(body), args.payload_offset))
    print(f"{args.image}: payload {len(body)} bytes, CRC-32 {zlib.crc32(body):08X}")


if __name__ == "__main__":
    main()

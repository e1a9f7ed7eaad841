"""The tick-delay bound under a long SDO block transfer, in instructions.

boards/qemu-mps2's `tick-bound` firmware runs the embassy runner, the drive and the 1 kHz
TIMER0 tick with an SDO client inside the firmware (no host in the loop) under
`-icount shift=3,sleep=off`, so its stopwatch counts instructions and every run gives the same
numbers. It measures, per phase, the longest critical section outside the tick — all that can
hold off the highest-priority tick interrupt — prints them, and exits 0 when the 16 KiB block
upload stayed within its bound (100 000 instructions on thumbv7em, 130 000 on thumbv6m: see
src/bin/tick_bound.rs) and every transfer was right.
"""

import os
import re
import shutil
import subprocess

import pytest

from conftest import REPO_ROOT, RUN_SH

TARGETS = ["thumbv7em-none-eabihf", "thumbv6m-none-eabi"]


def elf_path(target):
    default = f"target/firmware/qemu-mps2/{target}/release/tick-bound"
    variable = "QEMU_TICK_BOUND_ELF" if target.startswith("thumbv7em") else "QEMU_TICK_BOUND_ELF_V6M"
    path = REPO_ROOT / os.environ.get(variable, default)
    return path


@pytest.mark.parametrize("target", TARGETS)
def test_block_upload_holds_off_the_tick_within_the_bound(target, tmp_path):
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm is not installed (apt-get install -y qemu-system-arm; scripts/mcu.sh does)")
    elf = elf_path(target)
    if not elf.is_file():
        pytest.skip(f"no firmware at {elf}: build boards/qemu-mps2 (scripts/mcu.sh)")
    out = tmp_path / "console.txt"
    env = dict(os.environ, QEMU_ICOUNT="shift=3,sleep=off", DEFMT_RAW=str(out), SLCAN_PORT="0")
    result = subprocess.run([str(RUN_SH), str(elf)], env=env, capture_output=True, timeout=120)
    console = out.read_text(errors="replace") if out.exists() else ""
    print(f"\n{target}:\n{console}")
    assert result.returncode == 0, f"exit status {result.returncode}\n{console}\n{result.stderr.decode(errors='replace')}"
    upload = re.search(r"16 KiB block upload: longest critical section (\d+) instructions", console)
    assert upload and int(upload.group(1)) > 0, console

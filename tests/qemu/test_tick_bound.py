"""The tick-delay bound and the current loop's period under long SDO transfers and a profile
position set-point, in instructions.

boards/qemu-mps2's `tick-bound` firmware runs the embassy runner, the drive, the 1 kHz TIMER0
tick and a 20 kHz current loop (the dual timer's interrupt, above the drive's priority-ceiling
lock) with an SDO client inside the firmware (no host in the loop) under
`-icount shift=3,sleep=off`, so its stopwatch counts instructions and every run gives the same
numbers. Per phase it prints the longest hold of the drive's lock outside the tick (what can
hold off the tick), the longest stretch with every interrupt masked (what can hold off the
current loop), and the current loop's runs, longest gap and lateness; it exits 0 when the
16 KiB block upload stayed within its bound (100 000 instructions on thumbv7em, 130 000 on
thumbv6m: see src/bin/tick_bound.rs), the current loop never missed its period, and every
transfer and step was right. One run per target serves every test here (well under a second).
"""

import os
import re
import shutil
import subprocess

import pytest

from conftest import REPO_ROOT, RUN_SH

TARGETS = ["thumbv7em-none-eabihf", "thumbv6m-none-eabi"]
PHASES = [
    "16 KiB block upload",
    "200-byte block download",
    "200 expedited uploads",
    "profile position set-point",
    "NMT reset communication",
]
CURRENT_LOOP = re.compile(
    r"(?P<phase>[^\n:]+): current loop (?P<runs>\d+) runs of (?P<expected>\d+) expected; period (?P<period>\d+) instructions, "
    r"gap max (?P<gap>\d+) instructions, lateness max (?P<late>\d+) instructions"
)


def elf_path(target):
    default = f"target/firmware/qemu-mps2/{target}/release/tick-bound"
    variable = "QEMU_TICK_BOUND_ELF" if target.startswith("thumbv7em") else "QEMU_TICK_BOUND_ELF_V6M"
    path = REPO_ROOT / os.environ.get(variable, default)
    return path


@pytest.fixture(scope="module", params=TARGETS)
def run(request, tmp_path_factory):
    """The firmware's exit status and console for one target."""
    target = request.param
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm is not installed (apt-get install -y qemu-system-arm; scripts/mcu.sh does)")
    elf = elf_path(target)
    if not elf.is_file():
        pytest.skip(f"no firmware at {elf}: build boards/qemu-mps2 (scripts/mcu.sh)")
    out = tmp_path_factory.mktemp(target) / "console.txt"
    env = dict(os.environ, QEMU_ICOUNT="shift=3,sleep=off", DEFMT_RAW=str(out), SLCAN_PORT="0")
    result = subprocess.run([str(RUN_SH), str(elf)], env=env, capture_output=True, timeout=120)
    # Plain text, with the drive's few defmt frames in between (QEMU's stdout carries both).
    console = out.read_text(errors="replace") if out.exists() else ""
    print(f"\n{target}:\n{console}")
    return result.returncode, console, result.stderr.decode(errors="replace")


def test_the_firmware_ends_with_every_check_passed(run):
    status, console, stderr = run
    assert status == 0, f"exit status {status}\n{console}\n{stderr}"


def test_block_upload_holds_off_the_tick_within_the_bound(run):
    _, console, _ = run
    upload = re.search(r"16 KiB block upload: longest lock (\d+) instructions", console)
    assert upload and int(upload.group(1)) > 0, console
    assert re.search(r"bound: block upload longest lock \d+ <= \d+ instructions: true", console), console


def test_the_current_loop_above_the_lock_keeps_its_period(run):
    """In every phase — the block upload holds the drive's lock for some 85 000 instructions at
    a time, the set-point's tick runs for as long — the current loop (period 6 250
    instructions) starts within a few hundred instructions of each expiry and runs as often as
    the phase is long: it never waits for the drive."""
    _, console, _ = run
    phases = {m["phase"].strip(): m for m in CURRENT_LOOP.finditer(console)}
    for phase in PHASES:
        assert phase in phases, f"no current-loop line for {phase}:\n{console}"
        m = phases[phase]
        period, runs, expected = int(m["period"]), int(m["runs"]), int(m["expected"])
        gap, late = int(m["gap"]), int(m["late"])
        assert runs + 1 >= expected, f"{phase}: {runs} runs of {expected}"
        assert late < period // 4, f"{phase}: a run started {late} instructions late (period {period})"
        assert gap < period + period // 4, f"{phase}: {gap} instructions between two runs (period {period})"

"""`canopen-drive-linux --profile harmonic-drive` against the Harmonic Drive LLC CANopen firmware
manual: its object list, its step-by-step examples (pp §6.2, pv §7.2, hard-stop homing §8.3,
csp §9.2, csv §10.2, cst §11.2, PDO remapping §3.1.16/§3.1.18, node-ID and bit rate §4.1.22/23,
store/restore §3.1.7/8) and the behaviour it documents (NMT Stopped faults an enabled axis §2.2,
1029h values §3.1.14, statusword bits 14/15, hard-stop homing −1…−6 §8.1, limit switches on the
digital inputs §12.2, at most three mapped objects per PDO §1.1).

The simulated actuator is an RSF-5B-30: 16 384 encoder steps per motor revolution, limit switches
beyond ±150 000, elastic hard stops at ±200 000, rated current 1000 mA. Torques are mA,
velocities rpm and accelerations rpm/s, as in the manual; where an example's speed would run the
simulated axis into its limit switches within a second, the test uses a lower one.
"""

import subprocess
import time

import canopen
import pytest
from canopen.objectdictionary import datatypes as dt

from conftest import NODE_ID, DriveProcess, Recorder, binary_path
from profile_support import (abort_code, assert_matches_manual, assert_no_block_transfer, reset, statusword,
                             wait_until)

PROFILE = "harmonic-drive"

SIM_FAULTS, SIM_INPUTS, SIM_LOAD = 0x5E00, 0x5E01, 0x5E02
SIMULATION_OBJECTS = {SIM_FAULTS, SIM_INPUTS, SIM_LOAD}

# --- The manual's object list ------------------------------------------------------------------
# (index, sub, data type, access, PDO mapping, default). Data type None: the manual gives none
# (records list only ranges). PDO mapping None: not stated. ("node", x): x + node-ID.
U8, U16, U32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
I8, I16, I32, VS = dt.INTEGER8, dt.INTEGER16, dt.INTEGER32, dt.VISIBLE_STRING
RO, RW = "ro", "rw"


def _pdo_tables():
    rows = []
    rpdo = [(0x200, 0x60400010, 0), (0x300, 0x60400010, 0x60600008),
            (0x400, 0x60400010, 0x607A0020), (0x500, 0x60400010, 0x60FF0020)]
    tpdo = [(0x180, 0xFF, 0x60410010, 0), (0x280, 0xFF, 0x60410010, 0x60610008),
            (0x380, 0x01, 0x60410010, 0x60640020), (0x480, 0x01, 0x60410010, 0x606C0020)]
    for n, (cob, first, second) in enumerate(rpdo):
        rows += [(0x1400 + n, 0, U8, RO, None, 2), (0x1400 + n, 1, U32, RW, None, ("node", 0x40000000 + cob)),
                 (0x1400 + n, 2, U8, RW, None, 0xFF)]
        rows += [(0x1600 + n, 0, U8, RW, None, 2 if second else 1), (0x1600 + n, 1, U32, RW, None, first),
                 (0x1600 + n, 2, U32, RW, None, second), (0x1600 + n, 3, U32, RW, None, 0)]
    for n, (cob, kind, first, second) in enumerate(tpdo):
        rows += [(0x1800 + n, 0, U8, RO, None, 5), (0x1800 + n, 1, U32, RW, None, ("node", 0x40000000 + cob)),
                 (0x1800 + n, 2, U8, RW, None, kind), (0x1800 + n, 3, U16, RW, None, 0),
                 (0x1800 + n, 4, U8, RO, None, 0), (0x1800 + n, 5, U16, RW, None, 0)]
        rows += [(0x1A00 + n, 0, U8, RW, None, 2 if second else 1), (0x1A00 + n, 1, U32, RW, None, first),
                 (0x1A00 + n, 2, U32, RW, None, second), (0x1A00 + n, 3, U32, RW, None, 0)]
    return rows


COMMUNICATION = [
    (0x1000, 0, U32, RO, False, 0x00420192),
    (0x1001, 0, U8, RO, False, 0),
    (0x1005, 0, U32, RW, False, 0x80),
    (0x1008, 0, VS, RO, False, None),
    (0x1009, 0, VS, RO, False, None),
    (0x100A, 0, VS, RO, False, None),
    (0x1010, 0, U8, RO, False, 4),
    *[(0x1010, sub, U32, RW, False, value) for sub, value in ((1, 1), (2, 1), (3, 0), (4, 1))],
    (0x1011, 0, U8, RO, False, 4),
    *[(0x1011, sub, U32, RW, False, value) for sub, value in ((1, 1), (2, 1), (3, 0), (4, 1))],
    (0x1014, 0, U32, RW, False, ("node", 0x80)),
    (0x1015, 0, U16, RW, False, 0),
    (0x1016, 0, U8, RW, False, 1),
    (0x1016, 1, U32, RW, False, 0),
    (0x1017, 0, U16, RW, False, 0),
    (0x1018, 0, U8, RO, False, 3),
    (0x1018, 1, U32, RO, False, 0x443),
    (0x1018, 2, U32, RO, False, None),
    (0x1018, 3, U32, RO, False, None),
    (0x1029, 0, U8, RO, False, 2),
    (0x1029, 1, U8, RW, False, 0),
    (0x1029, 2, U8, RW, False, 1),
    *_pdo_tables(),
]

MANUFACTURER = [
    (0x2005, 0, U32, RW, False, 0),
    (0x200D, 0, U32, RO, False, 0),
    (0x200E, 0, U32, RO, False, 240),
    (0x200F, 0, I32, RO, False, 0),
    (0x2010, 1, None, RW, False, None),
    (0x2010, 2, None, RW, False, None),
    (0x2015, 1, None, RW, False, 0),
    *[(0x2020, sub, None, RW, False, None) for sub in (1, 2, 3)],
    (0x2020, 4, None, RW, False, 10000),
    (0x2025, 1, None, RO, False, 0),
    (0x2025, 2, None, RW, False, 40000),
    (0x2025, 3, None, RW, False, 40000),
    (0x2025, 4, None, RW, False, None),
    (0x2025, 5, None, RW, False, 0),
    *[(0x2030, sub, None, access, False, default) for sub, access, default in
      ((1, RO, 0), (2, RO, 0), (3, RO, 0), (4, RW, 500), (5, RW, 5000), (6, RO, 0), (7, RO, 0), (8, RO, 0), (9, RO, 0))],
    *[(0x2040, sub, None, access, False, default) for sub, access, default in
      ((1, RO, 0), (2, RO, 0), (3, RO, 0), (4, RW, 5), (5, RW, None), (6, RW, None), (7, RO, 0), (8, RO, 0))],
    *[(0x2050, sub, None, access, False, default) for sub, access, default in
      ((1, RW, 0), (2, RO, 0), (3, RO, 0), (4, RW, 100), (5, RO, 0), (6, RW, 500), (7, RW, 5), (8, RW, 32767),
       (9, RW, 0), (10, RO, 0), (11, RO, 0), (12, RO, 0), (13, RO, 0))],
    (0x2055, 0, None, RW, False, 2),
    (0x2056, 0, U8, RW, False, 1),
    (0x2060, 1, None, RO, False, 0),
    *[(0x2080, sub, None, access, False, default) for sub, access, default in
      ((1, RO, 0), (2, RW, None), (3, RW, 0), (4, RW, 1), (5, RW, 1), (6, RW, 1000), (7, RW, 200))],
    *[(0x2090, sub, None, access, False, default) for sub, access, default in
      ((1, RW, 3000), (2, RW, None), (3, RO, None), (4, RW, 6000), (5, RW, None), (6, RO, None), (7, RW, 0))],
    (0x2095, 1, None, RW, False, None),
    (0x2095, 2, None, RW, False, 0),
    (0x2096, 1, None, RW, False, None),
    (0x2096, 2, None, RW, False, 0),
    (0x2100, 0, I32, RO, False, 0),
    (0x2702, 0, U32, RO, True, 0),
    (0x2703, 1, None, RW, True, 0),
    (0x2703, 2, None, RW, False, 0),
    (0x2704, 0, U16, RW, False, 1000),
    (0x2705, 0, U8, RW, False, 1),
    (0x2706, 1, None, RW, False, 0),
    (0x2706, 2, None, RW, False, 0),
    (0x2706, 3, None, RW, False, 305419896),
    *[(0x270E, sub, None, RO, sub >= 5, 0) for sub in range(1, 7)],
    (0x5FFF, 0, U32, RW, False, 0),
]

PROFILE_AREA = [
    (0x605A, 0, I16, RW, False, 2),
    (0x605B, 0, U16, RW, False, 0),
    (0x605C, 0, U16, RW, False, 1),
    (0x605D, 0, U16, RW, False, 1),
    (0x605E, 0, U16, RW, False, 2),
    (0x6060, 0, I8, RW, True, 0),
    (0x6061, 0, I8, RW, True, 0),
    (0x608F, 1, None, RW, False, None),
    (0x608F, 2, None, RO, False, 1),
    (0x60FD, 0, U32, RO, True, 0),
    (0x6502, 0, U32, RO, False, 0x3A5),
    (0x6040, 0, U16, RW, True, None),
    (0x6041, 0, U16, RW, True, None),
    (0x6062, 0, I32, RO, True, 0),
    (0x6063, 0, I32, RO, True, 0),
    (0x6064, 0, I32, RO, True, 0),
    (0x6067, 0, U32, RW, False, 0xFFFFFFFF),
    (0x606B, 0, I32, RO, False, 0),
    (0x606C, 0, I32, RO, True, 0),
    (0x607A, 0, I32, RW, True, 0),
    (0x607D, 1, I32, RW, False, -2147483648),
    (0x607D, 2, I32, RW, False, 2147483647),
    (0x6081, 0, U32, RW, False, 6000),
    (0x6082, 0, I32, RW, False, 500),
    (0x6083, 0, U32, RW, False, None),
    (0x6084, 0, U32, RO, False, None),
    (0x6085, 0, U32, RW, False, None),
    (0x60FF, 0, I32, RW, True, 0),
    (0x607C, 0, I32, RW, False, 0),
    (0x6098, 0, I8, RW, False, 0),
    (0x6099, 1, U32, RW, False, 1000),
    (0x6099, 2, U32, RW, False, 500),
    (0x609A, 0, U32, RW, False, 2000),
    (0x60B0, 0, I32, RW, True, 0),
    (0x60C2, 0, U8, RO, False, 2),
    (0x60C2, 1, U8, RW, False, 1),
    (0x60C2, 2, I8, RW, False, -3),
    (0x60B1, 0, I32, RW, True, 0),
    (0x6071, 0, I32, RW, True, 0),
    (0x6077, 0, I32, RO, True, 0),
    (0x60B2, 0, I32, RW, False, 0),
]

MANUAL = COMMUNICATION + MANUFACTURER + PROFILE_AREA

DEVIATIONS = {
    ((0x1016, 0), "access"): "the core's number of consumer entries is constant",
    ((0x6061, 0), "access"): "read-only (CiA 402); the manual's table says rw",
    ((0x6041, 0), "access"): "read-only (CiA 402); the manual's table says rw",
    ((0x2705, 0), "default"): "reads the active node-ID ($NODEID), the manual's example module has 1",
}


def test_eds_imports_and_matches_the_manuals_object_list(tmp_path):
    # The manual's actuator keeps its parameters: the EDS of the program run with --storage (its
    # 1010h/1011h read 1 for the groups it stores; without storage they read 0).
    eds = tmp_path / "harmonic.eds"
    args = ["--profile", PROFILE, "--node-id", str(NODE_ID), "--storage", str(tmp_path / "p.bin"), "--write-eds"]
    subprocess.run([str(binary_path()), *args, str(eds)], check=True, timeout=10)
    od = canopen.import_od(str(eds), NODE_ID)
    assert_matches_manual(od, MANUAL, DEVIATIONS, NODE_ID, {index for index, *_ in MANUFACTURER}, SIMULATION_OBJECTS)


# Standard objects the manual's object descriptions (§3.1, §5.1–§11.1) do not have (§17: 100Ch and
# 100Dh removed, no node guarding).
ABSENT = (0x1003, 0x100C, 0x100D, 0x603F, 0x6065, 0x6066, 0x6068, 0x606D, 0x6072, 0x6080, 0x6086, 0x60F4)


def test_objects_the_actuator_does_not_have_do_not_exist(actuator, eds_file):
    """Issue 18: the manual describes none of these objects; a master probing for them gets
    0602 0000h (object does not exist), as from the real actuator, and the EDS does not list
    them (before the fix they answered and were listed)."""
    od = canopen.import_od(str(eds_file), NODE_ID)
    for index in ABSENT:
        assert abort_code(lambda: actuator.sdo.upload(index, 0)) == 0x06020000, hex(index)
        assert index not in od, hex(index)


# --- Helpers ----------------------------------------------------------------------------------

@pytest.fixture
def actuator(node, heartbeats):
    """The actuator after NMT reset node (every parameter at its default), simulation cleared."""
    return reset(node, heartbeats, (SIM_FAULTS, SIM_INPUTS, SIM_LOAD))


def to_state(node, *steps):
    for value, state in steps:
        node.sdo[0x6040].raw = value
        wait_until(lambda: statusword(node) & 0x6F == state, timeout=1.0)


READY, SWITCHED_ON, ENABLED = (6, 0x21), (7, 0x23), (15, 0x27)


class Interval:
    """Calls `each(k)` every `period` s, as the manual's examples write a set-point "in each
    interpolation time interval" (no SYNC: the actuator starts a cycle at each set-point)."""

    def __init__(self, period):
        self.period = period

    def run(self, seconds, each):
        start = time.monotonic()
        k = 0
        while time.monotonic() - start < seconds:
            each(k)
            k += 1
            time.sleep(max(0.0, start + k * self.period - time.monotonic()))


# --- Identity and configuration -----------------------------------------------------------------

def test_identity_modes_option_codes_and_homing_methods(actuator):
    assert actuator.sdo[0x1000].raw == 0x00420192
    assert actuator.sdo[0x1018][1].raw == 0x443
    # The manual's 1018h has no serial number, its 1016h one consumer entry.
    assert abort_code(lambda: actuator.sdo.upload(0x1018, 4)) == 0x06090011
    assert abort_code(lambda: actuator.sdo.upload(0x1016, 2)) == 0x06090011
    # 6084h is read-only and follows the profile acceleration 6083h.
    assert abort_code(lambda: actuator.sdo.download(0x6084, 0, (100).to_bytes(4, "little"))) == 0x06010002
    acceleration = actuator.sdo[0x6083].raw
    assert actuator.sdo[0x6084].raw == acceleration
    actuator.sdo[0x6083].raw = 1234
    assert wait_until(lambda: actuator.sdo[0x6084].raw == 1234)
    actuator.sdo[0x6083].raw = acceleration
    assert wait_until(lambda: actuator.sdo[0x6084].raw == acceleration)
    assert actuator.sdo[0x6502].raw == 0x3A5
    for index, refused in ((0x605A, (0, 3, 4, 7)), (0x605B, (1,)), (0x605C, (0,)), (0x605D, (2,)), (0x605E, (1,))):
        for value in refused:
            assert abort_code(lambda: setattr(actuator.sdo[index], "raw", value)) == 0x06090030, (hex(index), value)
    for method in (0, 17, 18, 35, -1, -2, -3, -4, -5, -6):
        actuator.sdo[0x6098].raw = method
    for method in (1, 2, 19, 33, 34, 37, -7):
        assert abort_code(lambda: setattr(actuator.sdo[0x6098], "raw", method)) == 0x06090030, method
    for mode in (2, 4, 5, 7):
        assert abort_code(lambda: setattr(actuator.sdo[0x6060], "raw", mode)) == 0x06090030, mode


def test_6084h_equals_6083h_at_the_next_read(actuator):
    """§6.1.14: the profile deceleration 6084h is the same as the profile acceleration 6083h, so
    the SDO read right after a write of 6083h already sees the new value (before the fix it
    lagged a tick behind in 178 of 300 tries)."""
    stale = []
    for n in range(300):
        value = 1000 + 37 * n
        actuator.sdo[0x6083].raw = value
        read = actuator.sdo[0x6084].raw
        if read != value:
            stale.append((value, read))
    assert not stale, f"6084h differed from the 6083h just written in {len(stale)} of 300 reads: {stale[:5]}"


def test_live_objects_of_the_actuator(actuator):
    assert actuator.sdo[0x200E].raw == 480  # 48 V in 100 mV
    assert actuator.sdo[0x200F].raw == 25
    flags = actuator.sdo[0x200D].raw
    assert flags & (1 << 15) and not flags & (1 << 5)  # initialised, driver off
    assert actuator.sdo[0x2050][10].raw == actuator.sdo[0x6063].raw
    actuator.sdo[SIM_FAULTS].raw = 0x08  # over-temperature
    time.sleep(0.05)
    assert actuator.sdo[0x200F].raw == 120
    assert actuator.sdo[0x200D].raw & (1 << 3)
    actuator.sdo[SIM_FAULTS].raw = 0
    actuator.sdo[0x6040].raw = 0x80
    # 2706h: user variables by address.
    actuator.sdo[0x2706][1].raw = 7
    actuator.sdo[0x2706][2].raw = -1234
    actuator.sdo[0x2706][1].raw = 8
    assert actuator.sdo[0x2706][2].raw == 0
    actuator.sdo[0x2706][1].raw = 7
    assert actuator.sdo[0x2706][2].raw == -1234
    actuator.sdo[0x5FFF].raw = 0x12345678
    assert actuator.sdo[0x5FFF].raw == 0
    assert abort_code(lambda: setattr(actuator.sdo[0x5FFF], "raw", 5)) == 0x06090030


# --- §6.2 pp, §7.2 pv --------------------------------------------------------------------------

def test_pp_example(actuator):
    actuator.sdo[0x2005].raw = 3  # no limit switches connected
    actuator.sdo[0x6081].raw = 360  # rpm (≈ 98 000 steps/s)
    start = actuator.sdo[0x6064].raw
    actuator.sdo[0x6060].raw = 1
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.sdo[0x607A].raw = start + 100_000
    actuator.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(actuator) & 0x4000)  # motion commencing
    assert actuator.sdo[0x200D].raw & ((1 << 5) | (1 << 10)) == (1 << 5) | (1 << 10)  # enabled, position mode
    actuator.sdo[0x6040].raw = 15
    wait_until(lambda: statusword(actuator) & 0x0400, timeout=8)
    wait_until(lambda: abs(actuator.sdo[0x6064].raw - (start + 100_000)) < 200, timeout=3)
    assert actuator.sdo[0x200D].raw & (1 << 14)  # position end
    actuator.sdo[0x6040].raw = 0


def test_pv_example(actuator):
    actuator.sdo[0x6060].raw = 3
    to_state(actuator, READY, SWITCHED_ON)
    actuator.sdo[0x60FF].raw = 75  # rpm (the example's 2000 would reach a limit switch at once)
    actuator.sdo[0x6040].raw = 15  # the motor accelerates to the target velocity
    wait_until(lambda: abs(actuator.sdo[0x606C].raw - 75) <= 2, timeout=3)
    assert statusword(actuator) & 0xC000 == 0x4000
    assert abs(actuator.sdo[0x2040][1].raw - 75) <= 2  # rpm
    assert actuator.sdo[0x606B].raw == 75 and actuator.sdo[0x2040][2].raw == 75
    actuator.sdo[0x60FF].raw = -75
    wait_until(lambda: statusword(actuator) & 0xC000 == 0xC000, timeout=3)
    actuator.sdo[0x60FF].raw = 0  # stop
    wait_until(lambda: statusword(actuator) & 0x4000 == 0, timeout=3)
    # 2020h sub 2 caps the speed (rpm, through 6080h).
    actuator.sdo[0x2020][2].raw = 30
    actuator.sdo[0x60FF].raw = 300
    time.sleep(1.5)
    assert abs(actuator.sdo[0x606C].raw - 30) <= 2
    assert abs(actuator.sdo[0x2040][1].raw - 30) <= 2
    actuator.sdo[0x60FF].raw = 0
    wait_until(lambda: statusword(actuator) & 0x4000 == 0, timeout=3)
    actuator.sdo[0x6040].raw = 0


# --- §8 hard-stop homing ------------------------------------------------------------------------

def home(actuator, method, timeout=30):
    actuator.sdo[0x6098].raw = method
    actuator.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(actuator) & 0x3400 == 0, timeout=1)  # started
    wait_until(lambda: statusword(actuator) & 0x3400 == 0x1400, timeout=timeout)
    actuator.sdo[0x6040].raw = 15  # when homing has finished
    time.sleep(0.3)


def test_hard_stop_homing_example_and_the_double_ended_methods(actuator):
    # (The limit switches at ±150 000 stay connected: the hard-stop methods pass them.)
    actuator.sdo[0x6060].raw = 6
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.sdo[0x6099][1].raw = 180  # rpm
    actuator.sdo[0x6099][2].raw = 150
    actuator.sdo[0x609A].raw = 1500  # rpm/s
    # −1: into the positive stop (200 000), back by 2025h sub 2, that is 0 and the max limit.
    actuator.sdo[0x6098].raw = -1
    actuator.sdo[0x6040].raw = 31
    wait_until(lambda: actuator.sdo[0x2025][1].raw == 5, timeout=1)  # checking the positive stop
    wait_until(lambda: statusword(actuator) & 0x3400 == 0x1400, timeout=20)
    actuator.sdo[0x6040].raw = 15
    time.sleep(0.3)
    assert abs(actuator.sdo[0x6064].raw) < 50
    assert abs(actuator.sdo[0x6063].raw - 160_000) < 1000  # (the stop is elastic)
    assert actuator.sdo[0x607D][2].raw == 0
    assert actuator.sdo[0x2025][1].raw == 1  # HOMED
    assert actuator.sdo[0x200D].raw & (1 << 20)
    # −2 with its own back-off (2025h sub 3).
    actuator.sdo[0x2025][3].raw = 20_000
    actuator.sdo[0x607D][2].raw = 2**31 - 1
    home(actuator, -2)
    assert abs(actuator.sdo[0x6063].raw + 180_000) < 1000
    assert actuator.sdo[0x607D][1].raw == 0
    # −3: positive stop first, then the negative one: 0 there, the range up to the first.
    actuator.sdo[0x607D][1].raw = -(2**31)
    home(actuator, -3, timeout=40)
    assert abs(actuator.sdo[0x6063].raw + 180_000) < 1000
    assert actuator.sdo[0x607D][1].raw == 0
    assert abs(actuator.sdo[0x607D][2].raw - 340_000) < 1000
    actuator.sdo[0x6040].raw = 0


def test_method_35_sets_6062h_6063h_and_6064h_to_zero(actuator):
    """§8.1 (Table 197) method 35: the actual position is home and all position values, 6062h,
    6063h and 6064h, are set to zero without motion; §8.1.2: Operation enabled is not needed.
    Read as soon as the statusword says homing completed (before the fix 6063h kept the encoder
    count of the pp move before, e.g. 4080)."""
    actuator.sdo[0x2005].raw = 3  # no limit switches connected
    actuator.sdo[0x6081].raw = 360  # rpm
    actuator.sdo[0x6060].raw = 1
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.sdo[0x607A].raw = actuator.sdo[0x6064].raw + 20_000
    actuator.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(actuator) & 0x1000, timeout=1)
    actuator.sdo[0x6040].raw = 15
    wait_until(lambda: statusword(actuator) & 0x0400, timeout=5)
    wait_until(lambda: actuator.sdo[0x606C].raw == 0, timeout=2)  # (the pp move is over)
    assert actuator.sdo[0x6063].raw != 0
    to_state(actuator, SWITCHED_ON)
    actuator.sdo[0x6060].raw = 6
    actuator.sdo[0x6098].raw = 35
    actuator.sdo[0x6040].raw = 0x17  # bit 4: start homing
    wait_until(lambda: statusword(actuator) & 0x3400 == 0x1400, timeout=2, period=0.001)
    values = {hex(index): actuator.sdo[index].raw for index in (0x6062, 0x6063, 0x6064)}
    assert values == {"0x6062": 0, "0x6063": 0, "0x6064": 0}
    actuator.sdo[0x6040].raw = 0


def test_teach_mode_procedure(actuator):
    # §8.1.9: jog to the min position, 2025h:05 = 1; to the max position, 2; the scaled range, 3.
    actuator.sdo[0x2005].raw = 3
    actuator.sdo[0x6060].raw = 1
    to_state(actuator, READY, SWITCHED_ON, ENABLED)

    def jog_to(target):
        actuator.sdo[0x607A].raw = target
        actuator.sdo[0x6040].raw = 0x1F
        wait_until(lambda: statusword(actuator) & 0x1000, timeout=1)  # set-point acknowledged
        actuator.sdo[0x6040].raw = 0x0F
        wait_until(lambda: statusword(actuator) & 0x0400, timeout=10)  # target reached
        time.sleep(0.5)  # settled within the position window

    jog_to(actuator.sdo[0x6064].raw - 3000)
    count = actuator.sdo[0x6063].raw
    actuator.sdo[0x2025][5].raw = 1
    time.sleep(0.05)
    assert abs(actuator.sdo[0x6064].raw) < 20, "the min position is 0 now"
    assert actuator.sdo[0x607D][1].raw == 0
    assert abs(actuator.sdo[0x6063].raw - count) < 20, "the encoder count did not move"
    jog_to(5000)
    actuator.sdo[0x2025][5].raw = 2
    time.sleep(0.05)
    assert abs(actuator.sdo[0x607D][2].raw - 5000) < 20, "the max limit is the present position"
    actuator.sdo[0x2025][5].raw = 3
    time.sleep(0.05)
    assert actuator.sdo[0x607D][2].raw == 65_535
    actuator.sdo[0x6040].raw = 0


# --- §9.2, §10.2, §11.2 cyclic modes: set-points by SDO each interval, no SYNC ---------------------

def test_csp_example(actuator, network):
    actuator.sdo[0x2005].raw = 3
    actuator.sdo[0x60C2][1].raw = 10  # the interpolation time period: 10 ms
    actuator.sdo[0x60C2][2].raw = -3
    start = actuator.sdo[0x6064].raw
    actuator.sdo[0x6060].raw = 8
    to_state(actuator, READY, SWITCHED_ON)
    actuator.sdo[0x607A].raw = start
    interval = Interval(0.01)
    interval.run(0.1, lambda k: None)
    actuator.sdo[0x6040].raw = 15
    # A new target position each interval: 200 steps per 10 ms, 100 times.
    interval.run(1.5, lambda k: setattr(actuator.sdo[0x607A], "raw", start + min(k, 100) * 200))
    assert abs(actuator.sdo[0x6064].raw - (start + 20_000)) < 300
    assert statusword(actuator) & 0x106F == 0x1027  # the target position is used
    actuator.sdo[0x6040].raw = 0


def test_csv_example(actuator, network):
    actuator.sdo[0x60C2][1].raw = 10
    actuator.sdo[0x6060].raw = 9
    to_state(actuator, READY, SWITCHED_ON)
    actuator.sdo[0x60FF].raw = 37  # rpm (≈ 10 000 steps/s)
    interval = Interval(0.01)
    actuator.sdo[0x6040].raw = 15  # accelerates to the target velocity
    interval.run(1.0, lambda k: setattr(actuator.sdo[0x60FF], "raw", 37))
    assert abs(actuator.sdo[0x606C].raw - 37) <= 2
    interval.run(0.5, lambda k: setattr(actuator.sdo[0x60FF], "raw", 0))  # stop
    assert abs(actuator.sdo[0x606C].raw) <= 2
    actuator.sdo[0x6040].raw = 0


def test_cyclic_set_point_written_before_operation_enabled_is_the_target(actuator):
    """§9.2/§10.2: the set-point written in Switched on (607Ah, 60FFh) is what "the motor now
    accelerates to" when controlword 15 enables the operation, with no further write. Before
    the fix it was dropped whenever a tick fell between the write and controlword 15: the
    statusword showed bit 12 but 6064h stayed until 607Ah was written again."""
    actuator.sdo[0x2005].raw = 3
    actuator.sdo[0x60C2][1].raw = 10  # ms
    actuator.sdo[0x60C2][2].raw = -3
    start = actuator.sdo[0x6064].raw
    actuator.sdo[0x6060].raw = 8  # csp
    to_state(actuator, READY, SWITCHED_ON)
    actuator.sdo[0x607A].raw = start + 512
    time.sleep(0.05)  # ticks fall between the set-point and the enable
    actuator.sdo[0x6040].raw = 15
    wait_until(lambda: abs(actuator.sdo[0x6064].raw - (start + 512)) <= 10, timeout=1)
    assert statusword(actuator) & 0x106F == 0x1027
    actuator.sdo[0x6040].raw = 0
    wait_until(lambda: statusword(actuator) & 0x4F == 0x40, timeout=1)
    actuator.sdo[0x6060].raw = 9  # csv
    to_state(actuator, READY, SWITCHED_ON)
    actuator.sdo[0x60FF].raw = 37  # rpm
    time.sleep(0.05)
    actuator.sdo[0x6040].raw = 15
    wait_until(lambda: abs(actuator.sdo[0x606C].raw - 37) <= 2, timeout=1)
    actuator.sdo[0x60FF].raw = 0  # stop
    wait_until(lambda: abs(actuator.sdo[0x606C].raw) <= 2, timeout=1)
    actuator.sdo[0x6040].raw = 0


def test_cst_example(actuator, network):
    actuator.sdo[0x2005].raw = 3
    actuator.sdo[0x60C2][1].raw = 10
    actuator.sdo[0x6060].raw = 10
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    interval = Interval(0.01)
    interval.run(0.5, lambda k: setattr(actuator.sdo[0x6071], "raw", 20))  # mA: starts the motor
    assert actuator.sdo[0x606C].raw > 3  # rpm
    assert actuator.sdo[0x2030][1].raw > 0  # actual current
    assert actuator.sdo[0x6077].raw > 0  # mA
    interval.run(0.1, lambda k: setattr(actuator.sdo[0x6071], "raw", 0))  # stops it
    actuator.sdo[0x6040].raw = 0


# --- §2.2, §3.1.14: NMT ---------------------------------------------------------------------------

def test_nmt_stopped_faults_an_enabled_axis_and_1029h_enters_stopped(actuator, network, heartbeats):
    actuator.sdo[0x6060].raw = 3
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.nmt.send_command(0x02)
    time.sleep(0.1)
    actuator.nmt.send_command(0x80)
    time.sleep(0.05)
    assert statusword(actuator) & 0x4F == 0x08
    assert actuator.sdo[0x200D].raw & (1 << 4)  # motor halted due to an error
    actuator.sdo[0x6040].raw = 0x80
    assert abort_code(lambda: setattr(actuator.sdo[0x1029][1], "raw", 2)) == 0x06090030
    actuator.sdo[0x1017].raw = 20
    actuator.sdo[0x1016][1].raw = (0x11 << 16) | 100
    actuator.nmt.send_command(0x01)
    network.send_message(0x711, b"\x05")
    heartbeats.clear()
    heartbeats.wait_for(lambda d: d == b"\x04", timeout=1.0)


EMCY_TABLE_BYTES = bytes([0, 255, 0, 0, 0])  # §13.2: the additional bytes of 8100h, 8130h, 8210h, 8220h


def test_a_fault_of_nmt_stopped_is_signalled_and_its_reset_sends_0000h(actuator, network):
    """§2.2: NMT Stopped switches an enabled axis into Fault. Stopped allows no EMCY, so the
    fault's EMCY 8100h (communication error, 00 FF 00 00 00 by §13.2) goes out once the node is
    Pre-operational again, and the fault reset sends 0000h (§13.2). Before the fix neither came."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    actuator.nmt.send_command(0x01)  # Operational
    actuator.sdo[0x6060].raw = 3
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.nmt.send_command(0x02)  # Stopped: the axis faults
    time.sleep(0.1)
    assert not any(d[:2] == b"\x00\x81" for _, d in emcy.frames), "an EMCY while Stopped"
    actuator.nmt.send_command(0x80)  # Pre-operational
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x00\x81", timeout=1.0)
    assert data[3:] == EMCY_TABLE_BYTES, data.hex()
    assert statusword(actuator) & 0x4F == 0x08
    emcy.clear()
    actuator.sdo[0x6040].raw = 0x80  # fault reset
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)
    assert data[3:] == bytes(5), data.hex()
    wait_until(lambda: statusword(actuator) & 0x4F == 0x40, timeout=1)


def test_the_heartbeat_timeout_emcy_goes_out_before_the_node_stops(actuator, network, heartbeats):
    """§3.1.11/§3.1.14/§13.2: a consumer heartbeat timeout in Operational is a communication
    error: EMCY 8130h (00 FF 00 00 00), then 1029h sub 1 = 0 (the default) enters Stopped,
    where the node sends no EMCY. So 8130h must come before the node is Stopped; before the fix
    it came only after NMT Pre-operational."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    assert actuator.sdo[0x1029][1].raw == 0  # communication error: enter Stopped
    actuator.sdo[0x1017].raw = 50  # ms
    actuator.sdo[0x1016][1].raw = 0x0010012C  # node 10h, 300 ms
    actuator.nmt.send_command(0x01)
    for _ in range(3):
        network.send_message(0x710, b"\x05")
        time.sleep(0.1)
    heartbeats.clear()
    _, stopped_at, _ = heartbeats.wait_for(lambda d: d == b"\x04", timeout=2.0)  # no more heartbeats from 10h
    _, sent_at, data = emcy.wait_for(lambda d: d[:2] == b"\x30\x81", timeout=0.5)
    assert data[3:] == EMCY_TABLE_BYTES, data.hex()
    assert sent_at <= stopped_at, "8130h came after the node reported Stopped"
    actuator.nmt.send_command(0x80)


# --- §4.1 limit switches, windows -----------------------------------------------------------------

def test_limit_switches_on_the_digital_inputs(actuator):
    time.sleep(0.02)
    physical = actuator.sdo[0x2702].raw  # where the axis stands now
    actuator.sdo[SIM_INPUTS].raw = 0x02  # the right limit switch
    time.sleep(0.02)
    assert actuator.sdo[0x2702].raw == physical | 0x02
    assert actuator.sdo[0x60FD].raw & 0x02
    actuator.sdo[0x2005].raw = 2  # not used
    time.sleep(0.02)
    assert actuator.sdo[0x2702].raw & 0x02 == 0 and actuator.sdo[0x60FD].raw & 0x02 == 0
    actuator.sdo[SIM_INPUTS].raw = 0
    actuator.sdo[0x2005].raw = 0x04  # left inverted
    time.sleep(0.02)
    assert actuator.sdo[0x60FD].raw & 0x01 == (physical & 0x01) ^ 0x01  # 2702h shows the pin
    actuator.sdo[0x6040].raw = 6
    wait_until(lambda: statusword(actuator) & 0x6F == 0x21)
    assert abort_code(lambda: setattr(actuator.sdo[0x2005], "raw", 0)) == 0x08000022
    actuator.sdo[0x6040].raw = 0
    wait_until(lambda: statusword(actuator) & 0x4F == 0x40)
    actuator.sdo[0x2005].raw = 0
    assert abort_code(lambda: setattr(actuator.sdo[0x2005], "raw", 16)) == 0x06090031


def test_position_window_stops_the_motor_with_an_emcy(actuator, network):
    emcy = Recorder(network, 0x80 + NODE_ID)
    actuator.sdo[0x2005].raw = 3
    actuator.sdo[0x2096][1].raw = 5  # steps
    actuator.sdo[0x6081].raw = 360  # rpm
    actuator.sdo[0x6060].raw = 1
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.sdo[0x607A].raw = actuator.sdo[0x6064].raw + 50_000
    actuator.sdo[0x6040].raw = 31
    emcy.wait_for(lambda d: d[:2] == b"\x11\x86", timeout=2.0)  # 8611h
    wait_until(lambda: statusword(actuator) & 0x4F == 0x08, timeout=3)
    actuator.sdo[0x6040].raw = 0x80


# --- §3.1.16/§3.1.18 PDO remapping ----------------------------------------------------------------

def test_pdo_remapping_procedure(actuator, network):
    tpdo4 = Recorder(network, 0x480 + NODE_ID)
    cob = actuator.sdo[0x1803][1].raw
    assert cob == 0x40000480 + NODE_ID
    actuator.sdo[0x1803][1].raw = cob | 0x80000000
    actuator.sdo[0x1A03][0].raw = 0
    actuator.sdo[0x1A03][1].raw = 0x60640020
    actuator.sdo[0x1A03][2].raw = 0x27020020
    assert abort_code(lambda: setattr(actuator.sdo[0x1A03][0], "raw", 4)) == 0x06090031
    actuator.sdo[0x1A03][0].raw = 2
    actuator.sdo[0x1803][1].raw = cob
    assert abort_code(lambda: setattr(actuator.sdo[0x1803][2], "raw", 0)) == 0x06090030  # 1..240, FEh, FFh
    assert abort_code(lambda: setattr(actuator.sdo[0x1400][2], "raw", 0)) == 0x06090030
    actuator.sdo[0x1803][2].raw = 2  # every second SYNC
    actuator.nmt.send_command(0x01)
    for _ in range(4):
        network.send_message(0x80, b"")
        time.sleep(0.02)
    frames = tpdo4.wait_count(2, timeout=1.0)
    data = frames[-1][1]
    assert len(data) == 8
    assert abs(int.from_bytes(data[:4], "little", signed=True) - actuator.sdo[0x6064].raw) < 50
    assert int.from_bytes(data[4:], "little") == actuator.sdo[0x2702].raw
    actuator.nmt.send_command(0x80)


def test_rpdos_of_the_wrong_length(actuator, network):
    """§13.2: 8210h "PDO not processed due to length error" (too few bytes) and 8220h "PDO
    length exceeded" (too many: the PDO could not be processed), both with the additional bytes
    00 FF 00 00 00. RPDO1 (§3.1.15/§3.1.16: 40000200h + node-ID, type FFh, 6040h 16 bits) in
    Operational. Before the fix 8210h carried zeros and the 3-byte PDO's controlword was applied."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    assert actuator.sdo[0x1400][1].raw == 0x40000200 + NODE_ID
    assert actuator.sdo[0x1600][0].raw == 1 and actuator.sdo[0x1600][1].raw == 0x60400010
    actuator.nmt.send_command(0x01)
    time.sleep(0.05)
    network.send_message(0x200 + NODE_ID, b"\x06")
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x10\x82", timeout=1.0)
    assert data[3:] == EMCY_TABLE_BYTES, data.hex()
    network.send_message(0x200 + NODE_ID, b"\x06\x00\x00")
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x20\x82", timeout=1.0)
    assert data[3:] == EMCY_TABLE_BYTES, data.hex()
    time.sleep(0.05)
    assert actuator.sdo[0x6040].raw == 0, "the long PDO's controlword was applied"
    assert statusword(actuator) & 0x6F == 0x40
    network.send_message(0x200 + NODE_ID, b"\x06\x00")  # the right length is applied at once
    wait_until(lambda: statusword(actuator) & 0x6F == 0x21, timeout=1)
    actuator.nmt.send_command(0x80)
    actuator.sdo[0x6040].raw = 0


# --- §3.1.7/8 store/restore, §4.1.22/23 bit rate and node-ID ---------------------------------------

@pytest.fixture
def stored_drive(tmp_path):
    storage = tmp_path / "params.bin"
    processes = []

    def start():
        process = DriveProcess(tmp_path, extra_args=("--profile", PROFILE, "--storage", str(storage)))
        processes.append(process)
        return process

    yield start
    for process in processes:
        assert process.stop() == 0, process.log()


def test_homing_parameters_are_saved_after_homing(stored_drive):
    # §8.1.10: the new homing parameters (and only they) go to flash after each homing run.
    process = stored_drive()
    network, node = connect(process)
    try:
        node.sdo[0x6060].raw = 6
        to_state(node, READY, SWITCHED_ON, ENABLED)
        node.sdo[0x6099][1].raw = 180
        node.sdo[0x6099][2].raw = 150
        node.sdo[0x609A].raw = 1500
        node.sdo[0x6098].raw = -1  # the positive stop: the max limit becomes 0
        node.sdo[0x6040].raw = 31
        wait_until(lambda: statusword(node) & 0x3400 == 0x1400, timeout=20)
        node.sdo[0x6040].raw = 0
        assert node.sdo[0x607D][2].raw == 0
        time.sleep(0.2)
    finally:
        network.disconnect()
    process.stop()
    process = stored_drive()  # power cycle: no store was written by the master
    network, node = connect(process)
    try:
        assert node.sdo[0x607D][2].raw == 0, "kept from the homing run"
        # What the master set for the run but did not store is back at the defaults.
        assert (node.sdo[0x6099][1].raw, node.sdo[0x6099][2].raw, node.sdo[0x609A].raw) == (1000, 500, 2000)
    finally:
        network.disconnect()


def connect(process, node_id=NODE_ID):
    eds = process.log_path.parent / "harmonic.eds"
    if not eds.exists():
        subprocess.run([str(binary_path()), "--profile", PROFILE, "--write-eds", str(eds)], check=True, timeout=10)
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05
    network.connect(interface="slcan", channel=process.channel, bitrate=500000, sleep_after_open=0)
    node = canopen.RemoteNode(node_id, canopen.import_od(str(eds), node_id))
    network.add_node(node)
    return network, node


def test_node_id_and_bit_rate_through_2704h_2705h_and_1010h_sub_2(stored_drive):
    process = stored_drive()
    network, node = connect(process)
    try:
        # §3.1.7/§3.1.8: the actuator profile group (sub 3) is not used: it reads 0.
        for index in (0x1010, 0x1011):
            assert [node.sdo[index][sub].raw for sub in (1, 2, 3, 4)] == [1, 1, 0, 1]
        assert abort_code(lambda: setattr(node.sdo[0x1010][3], "raw", 0x65766173)) == 0x08000020
        assert abort_code(lambda: setattr(node.sdo[0x2704], "raw", 800)) == 0x06090030
        node.sdo[0x2704].raw = 250
        node.sdo[0x2705].raw = 9
        node.sdo[0x2025][2].raw = 30_000  # an application parameter, kept by sub 1 only
        node.sdo[0x1010][2].raw = 0x65766173  # "save" the communication parameters
    finally:
        network.disconnect()
    process.stop()
    process = stored_drive()  # reset the module
    network, node = connect(process, node_id=9)
    try:
        assert node.sdo[0x2705].raw == 9
        assert node.sdo[0x2025][2].raw == 40_000
        node.sdo[0x2025][2].raw = 30_000
        node.sdo[0x1010][1].raw = 0x65766173  # everything
        node.sdo[0x1011][1].raw = 0x64616F6C  # and back to the defaults after the next reset
        node.nmt.send_command(0x81)
        time.sleep(0.2)
        assert node.sdo[0x2025][2].raw == 40_000
    finally:
        network.disconnect()


def test_node_id_and_bit_rate_take_effect_at_nmt_reset_node(stored_drive):
    """§4.1.22/§4.1.23: node-ID and bit rate written to 2705h/2704h and saved with 1010h sub 2
    become active when the module is reset, and NMT reset node resets it: the boot-up comes
    from the new node-ID, 2705h/2704h show the saved values and the COB-IDs whose defaults are
    node-relative follow (1014h 80h + node-ID §3.1.9, RPDO1 40000200h + node-ID §3.1.15, TPDO1
    40000180h + node-ID §3.1.17); a power cycle keeps them. Before the fix the boot-up came from
    the old node-ID, 2705h/2704h read back the old values and the COB-IDs kept the old node's."""
    process = stored_drive()
    network, node = connect(process)
    try:
        node.sdo[0x2705].raw = 7
        node.sdo[0x2704].raw = 500
        node.sdo[0x1010][2].raw = 0x65766173  # "save" the communication parameters
        old_boot, new_boot = Recorder(network, 0x700 + NODE_ID), Recorder(network, 0x707)
        node.nmt.send_command(0x81)  # reset node
        new_boot.wait_for(lambda d: d == b"\x00", timeout=2.0)
        assert old_boot.frames == [], "a boot-up from the old node-ID"
        new = canopen.RemoteNode(7, canopen.import_od(str(process.log_path.parent / "harmonic.eds"), 7))
        network.add_node(new)
        assert (new.sdo[0x2705].raw, new.sdo[0x2704].raw) == (7, 500)
        cob_ids = [new.sdo[0x1014].raw, new.sdo[0x1400][1].raw, new.sdo[0x1800][1].raw]
        assert cob_ids == [0x87, 0x40000207, 0x40000187], [hex(c) for c in cob_ids]
    finally:
        network.disconnect()
    process.stop()
    process = stored_drive()  # power cycle
    network, node = connect(process, node_id=7)
    try:
        assert (node.sdo[0x2705].raw, node.sdo[0x2704].raw) == (7, 500)
        cob_ids = [node.sdo[0x1014].raw, node.sdo[0x1400][1].raw, node.sdo[0x1800][1].raw]
        assert cob_ids == [0x87, 0x40000207, 0x40000187], [hex(c) for c in cob_ids]
    finally:
        network.disconnect()


# --- Units: rpm, rpm/s and mA (§4.1.7, §7.1, §11.1) -----------------------------------------------

def test_velocities_are_motor_rpm_and_accelerations_rpm_per_second(actuator):
    actuator.sdo[0x6083].raw = 600  # rpm/s: 60 rpm in 0.1 s
    actuator.sdo[0x6060].raw = 3
    to_state(actuator, READY, SWITCHED_ON, ENABLED)
    actuator.sdo[0x60FF].raw = 60  # one motor revolution per second
    wait_until(lambda: abs(actuator.sdo[0x606C].raw - 60) <= 1, timeout=2)
    before, start = actuator.sdo[0x6063].raw, time.monotonic()
    time.sleep(0.5)
    travelled, elapsed = actuator.sdo[0x6063].raw - before, time.monotonic() - start
    assert abs(travelled / elapsed - 16384) < 16384 * 0.15, (travelled, elapsed)  # encoder steps/s
    assert actuator.sdo[0x606B].raw == 60
    actuator.sdo[0x60FF].raw = 0
    wait_until(lambda: statusword(actuator) & 0x4000 == 0, timeout=3)
    actuator.sdo[0x6040].raw = 0


def test_sdo_block_transfer_is_not_offered(actuator):
    assert_no_block_transfer(actuator, "RSF-5B-30")

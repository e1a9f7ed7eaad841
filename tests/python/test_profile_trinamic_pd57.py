"""`canopen-drive-linux --profile trinamic-pd57` against the PD57/60-1378 CANopen firmware manual
(V3.23, document revision V1.00): its object list, its step-by-step procedures (pp §6.2, pv §7.2,
homing §8.3, closed loop §1.5, PDO remapping §3.1.18/§3.1.20, node-ID and bit rate §4.2.65/66,
store/restore §3.1.9/10) and the behaviour the manual documents where it departs from CiA 301/402
(NMT Stopped faults an enabled axis §2.2, 1029h values §3.1.16, statusword bits 14/15 §6.1.2,
option codes §5.1, homing methods table 311, at most three mapped objects per PDO §1.1).

Positions are microsteps: the simulated axis has 51 200 per revolution, limit switches beyond
±1 000 000 and a home switch from 100 000 to 150 000 (see boards/linux/src/profiles/trinamic.rs).
The manual leaves 6081h, 6083h, 6084h, 6099h and 609Ah at 0; its procedures assume a module
whose motion parameters were set, so the tests set them first.
"""

import subprocess
import time

import canopen
import pytest
from canopen.objectdictionary import datatypes as dt

from conftest import NODE_ID, DriveProcess, Recorder, binary_path
from profile_support import (abort_code, assert_matches_manual, assert_no_block_transfer, reset, statusword,
                             wait_until)

PROFILE = "trinamic-pd57"

SIM_FAULTS, SIM_INPUTS, SIM_LOAD = 0x5E00, 0x5E01, 0x5E02
SIMULATION_OBJECTS = {SIM_FAULTS, SIM_INPUTS, SIM_LOAD}

# --- The manual's object list ------------------------------------------------------------------
# (index, sub, data type, access, PDO mapping, default), transcribed from the manual's object and
# entry descriptions. PDO mapping None: the manual says "refer to CiA 402". Default None: the
# manual gives none, or "depends on device". ("node", x): x + node-ID.
U8, U16, U32, U64 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32, dt.UNSIGNED64
I8, I16, I32, VS = dt.INTEGER8, dt.INTEGER16, dt.INTEGER32, dt.VISIBLE_STRING
RO, RW = "ro", "rw"


def _pdo_tables():
    rows = []
    rpdo = [(0x200, 0xFF, 0x60400010, 0), (0x300, 0xFF, 0x60400010, 0x60600008),
            (0x400, 0xFF, 0x60400010, 0x607A0020), (0x500, 0xFE, 0x60400010, 0x60FF0020)]
    tpdo = [(0x180, 0xFF, 0x60410010, 0), (0x280, 0xFF, 0x60410010, 0x60610008),
            (0x380, 0x01, 0x60410010, 0x60640020), (0x480, 0x01, 0x60410010, 0x606C0020)]
    for n, (cob, kind, first, second) in enumerate(rpdo):
        rows += [(0x1400 + n, 0, U8, RO, False, 2), (0x1400 + n, 1, U32, RW, False, ("node", cob)),
                 (0x1400 + n, 2, U8, RW, False, kind)]
        rows += [(0x1600 + n, 0, U8, RW, False, 2 if second else 1), (0x1600 + n, 1, U32, RW, False, first),
                 (0x1600 + n, 2, U32, RW, False, second), (0x1600 + n, 3, U32, RW, False, 0)]
    for n, (cob, kind, first, second) in enumerate(tpdo):
        rows += [(0x1800 + n, 0, U8, RO, False, 5), (0x1800 + n, 1, U32, RW, False, ("node", cob)),
                 (0x1800 + n, 2, U8, RW, False, kind), (0x1800 + n, 3, U16, RW, False, 0),
                 (0x1800 + n, 4, U8, RO, False, 0), (0x1800 + n, 5, U16, RW, False, 0)]
        rows += [(0x1A00 + n, 0, U8, RW, False, 2 if second else 1), (0x1A00 + n, 1, U32, RW, False, first),
                 (0x1A00 + n, 2, U32, RW, False, second), (0x1A00 + n, 3, U32, RW, False, 0)]
    return rows


COMMUNICATION = [
    (0x1000, 0, U32, RO, False, 0xFFFC0192),
    (0x1001, 0, U8, RO, False, 0),
    (0x1005, 0, U32, RW, False, 0x80),
    (0x1008, 0, VS, RO, False, "PD57/60-1378"),
    (0x1009, 0, VS, RO, False, None),
    (0x100A, 0, VS, RO, False, None),
    (0x100C, 0, U16, RW, False, 0),
    (0x100D, 0, U8, RW, False, 0),
    *[(0x1010, sub, U32, RW, False, None) for sub in (1, 2, 3, 4)],
    *[(0x1011, sub, U32, RW, False, None) for sub in (1, 2, 3, 4)],
    (0x1014, 0, U32, RW, False, ("node", 0x80)),
    (0x1015, 0, U16, RW, False, 0),
    (0x1016, 0, U8, RO, False, 1),
    (0x1016, 1, U32, RW, False, 0),
    (0x1017, 0, U16, RW, False, 0),
    (0x1018, 0, U8, RO, False, 3),
    (0x1018, 1, U32, RO, False, 0x286),
    (0x1018, 2, U32, RO, False, 1378),
    (0x1018, 3, U32, RO, False, None),
    (0x1029, 0, U8, RO, False, 2),
    (0x1029, 1, U8, RW, False, 0),
    (0x1029, 2, U8, RW, False, 1),
    *_pdo_tables(),
]

MANUFACTURER = [
    (0x2000, 0, U8, RW, False, 8),
    (0x2001, 0, U16, RW, False, 200),
    (0x2002, 1, U16, RW, False, 0),
    (0x2002, 2, U16, RW, False, 0),
    (0x2003, 0, U8, RW, False, 128),
    (0x2004, 0, U8, RW, False, 8),
    (0x2005, 0, U32, RW, False, 0),
    (0x200A, 0, U16, RW, False, 0),
    (0x200B, 1, U8, RW, False, 0),
    (0x200B, 2, U8, RW, False, 0),
    (0x200B, 3, U8, RW, False, 1),
    (0x200C, 1, U8, RW, False, 0),
    (0x200C, 2, U8, RW, False, 0),
    (0x200F, 1, U8, RW, False, 0),
    (0x200F, 2, I32, RO, False, 0),
    (0x200F, 3, I32, RO, False, 0),
    (0x2010, 0, U32, RW, False, 0),
    (0x2011, 0, U32, RW, False, 0),
    (0x2012, 0, U32, RW, False, 0),
    (0x2013, 0, U32, RW, False, 0),
    (0x2014, 0, U32, RW, False, 0),
    (0x2015, 0, U8, RW, False, 1),
    (0x2020, 0, U8, RW, False, 0),
    (0x2021, 0, U32, RW, False, 0),
    (0x2022, 0, U8, RW, False, 0),
    (0x2027, 0, U16, RW, False, 255),
    (0x2028, 0, I32, RW, False, None),
    (0x2029, 0, U8, RW, False, None),
    (0x202A, 0, U8, RW, False, None),
    (0x202B, 0, U32, RW, False, None),
    (0x202C, 0, U32, RW, False, None),
    (0x202D, 0, U16, RW, False, None),
    (0x202E, 0, U16, RW, False, None),
    (0x202F, 0, U32, RW, False, 2147483647),
    (0x2030, 0, U32, RW, False, None),
    (0x2031, 0, U32, RW, False, None),
    (0x2033, 0, U8, RO, False, None),
    (0x2034, 0, U32, RW, False, None),
    (0x2035, 0, U32, RW, False, None),
    (0x2036, 0, U8, RW, False, None),
    (0x204E, 0, U8, RW, False, None),
    (0x2089, 0, U16, RW, False, 200),
    (0x208C, 0, U8, RW, False, 181),
    (0x208E, 0, U8, RO, False, 179),
    (0x2092, 0, U8, RW, False, 2),
    (0x2093, 0, U8, RW, False, 0),
    (0x2094, 0, U8, RW, False, 0),
    (0x2095, 0, I8, RW, False, 0),
    (0x2096, 0, U8, RW, False, 3),
    (0x2097, 0, U8, RW, False, 5),
    (0x2098, 0, U8, RW, False, 0),
    (0x2099, 0, U8, RW, False, 0),
    (0x209A, 0, U8, RW, False, 0),
    (0x209B, 0, U8, RW, False, 0),
    (0x209C, 0, U8, RW, False, 0),
    (0x209D, 0, U8, RW, False, 0),
    (0x209E, 0, I8, RW, False, 0),
    (0x20A1, 0, U8, RW, False, 0),
    (0x20A4, 0, U32, RW, False, 0),
    (0x20A5, 0, U32, RW, False, 0),
    (0x2100, 0, I32, RO, False, 0),
    (0x2101, 0, U16, RO, False, 0),
    (0x2102, 0, U8, RO, False, 0),
    (0x2107, 0, U8, RO, False, 8),
    (0x210B, 1, U32, RO, False, 0),
    (0x210B, 2, U32, RO, False, 0),
    (0x210B, 3, U64, RO, False, 0),
    (0x2120, 0, U8, RO, False, None),
    (0x2700, 0, U32, RW, False, 0),
    (0x2701, 0, U32, RW, False, 0),
    (0x2702, 0, U32, RO, True, 0),
    (0x2703, 1, U32, RW, True, 0),
    (0x2703, 2, U32, RW, True, 0),
    (0x2704, 0, U16, RW, False, 1000),
    (0x2705, 0, U8, RW, False, 1),
    (0x2706, 0, U32, RW, False, 1),
    (0x2707, 0, U8, RO, False, None),
    (0x2708, 0, U8, RO, False, None),
    (0x270E, 1, U32, RO, True, None),
    (0x5FFF, 0, U32, RW, False, 0),
]

PROFILE_AREA = [
    (0x605A, 0, I16, RW, False, 2),
    (0x605B, 0, U16, RW, False, 0),
    (0x605C, 0, U16, RW, False, 1),
    (0x605D, 0, U16, RW, False, 1),
    (0x605E, 0, U16, RW, False, 2),
    (0x6060, 0, I8, RW, None, 0),
    (0x6061, 0, I8, RW, None, 0),
    (0x606A, 0, I16, RW, False, -1),
    (0x608F, 1, U32, RW, False, 1),
    (0x608F, 2, U32, RO, False, 1),
    (0x60FD, 0, U32, RW, True, 0),
    (0x6502, 0, U32, RO, False, None),
    (0x6040, 0, U16, RW, None, None),
    (0x6041, 0, U16, RW, None, None),
    (0x6062, 0, I32, RO, None, None),
    (0x6063, 0, I32, RO, None, None),
    (0x6064, 0, I32, RO, None, None),
    (0x6065, 0, U32, RW, False, 0),
    (0x6067, 0, U32, RW, False, 0xFFFFFFFF),
    (0x6068, 0, U16, RW, False, 0),
    (0x606C, 0, I32, RO, None, None),
    (0x607A, 0, I32, RW, None, 0),
    (0x607D, 1, I32, RW, False, -2147483648),
    (0x607D, 2, I32, RW, False, 2147483647),
    (0x6081, 0, I32, RW, False, 0),
    (0x6082, 0, I32, RW, False, 0),
    (0x6083, 0, I32, RW, False, 0),
    (0x6084, 0, I32, RW, False, 0),
    (0x6085, 0, U32, RW, False, 51200),
    (0x6086, 0, U16, RW, False, 0),
    (0x60A4, 0, U8, RO, False, 4),
    *[(0x60A4, sub, U32, RW, False, 0) for sub in (1, 2, 3, 4)],
    (0x60F2, 0, U16, RW, False, 0),
    (0x60FF, 0, I32, RW, None, 0),
    (0x607C, 0, I32, RW, False, 0),
    (0x6098, 0, I8, RW, False, 0),
    (0x6099, 1, U32, RW, False, 0),
    (0x6099, 2, U32, RW, False, 0),
    (0x609A, 0, U32, RW, False, 0),
    (0x60B0, 0, I32, RW, True, 0),
    (0x60C2, 0, U8, RO, False, 2),
    (0x60C2, 1, U8, RW, False, 1),
    (0x60C2, 2, I8, RW, False, -3),
    (0x60B1, 0, I32, RW, True, 0),
    (0x6071, 0, I16, RW, True, 0),
    (0x6077, 0, I16, RO, True, 0),
    (0x60B2, 0, I16, RW, True, 0),
]

MANUAL = COMMUNICATION + MANUFACTURER + PROFILE_AREA

# Where this rebuild deliberately differs from the table, and why (key: (index, sub), field).
DEVIATIONS = {
    # The core's communication objects: 1029h has only the communication-error entry.
    # Types the manual prints against CiA 402 (same bytes on the wire for its values).
    ((0x2707, 0), "type"): "1000 kbit/s does not fit the manual's UNSIGNED8",
    # Access the manual prints for objects the drive itself writes.
    ((0x6061, 0), "access"): "read-only (CiA 402); the manual's table says rw",
    ((0x6041, 0), "access"): "read-only (CiA 402); the manual's table says rw",
    ((0x60FD, 0), "access"): "read-only (CiA 402); the manual's table says rw",
    ((0x2705, 0), "default"): "reads the active node-ID ($NODEID), the manual's example module has 1",
}


def test_eds_imports_and_matches_the_manuals_object_list(eds_file):
    od = canopen.import_od(str(eds_file), NODE_ID)
    assert_matches_manual(od, MANUAL, DEVIATIONS, NODE_ID, {index for index, *_ in MANUFACTURER}, SIMULATION_OBJECTS)


# --- Helpers ----------------------------------------------------------------------------------

@pytest.fixture
def pd57(node, heartbeats):
    """The drive after NMT reset node (every parameter at its default), simulation cleared."""
    return reset(node, heartbeats, (SIM_FAULTS, SIM_INPUTS, SIM_LOAD))


def enable(node, mode):
    """The manual's sequence: mode, then 6, 7, 15 to the controlword."""
    node.sdo[0x6060].raw = mode
    for value, state in ((6, 0x21), (7, 0x23), (15, 0x27)):
        node.sdo[0x6040].raw = value
        wait_until(lambda: statusword(node) & 0x6F == state, timeout=1.0)


def motion_parameters(node, velocity=400_000, acceleration=4_000_000):
    node.sdo[0x6081].raw = velocity
    node.sdo[0x6083].raw = acceleration
    node.sdo[0x6084].raw = acceleration


# --- Identity ---------------------------------------------------------------------------------

def test_identity_and_supported_modes(pd57):
    assert pd57.sdo[0x1000].raw == 0xFFFC0192
    assert pd57.sdo[0x1008].raw == "PD57/60-1378"
    assert pd57.sdo[0x1018][1].raw == 0x286
    assert pd57.sdo[0x1018][2].raw == 1378
    # The manual's 1018h has no serial number, its 1016h one consumer entry.
    assert pd57.sdo[0x1018][0].raw == 3
    assert abort_code(lambda: pd57.sdo.upload(0x1018, 4)) == 0x06090011
    assert pd57.sdo[0x1016][0].raw == 1
    assert abort_code(lambda: pd57.sdo.upload(0x1016, 2)) == 0x06090011
    # The manual's SIGNED32 velocities: the core takes magnitudes only.
    assert abort_code(lambda: pd57.sdo.download(0x6081, 0, (-1).to_bytes(4, "little", signed=True))) == 0x06090032
    assert pd57.sdo[0x6502].raw == 0x3A5  # pp, pv, hm, csp, csv, cst
    assert pd57.sdo[0x2708].raw == NODE_ID
    assert pd57.sdo[0x2707].raw == 1000


def test_option_codes_modes_and_homing_methods_the_manual_lists(pd57):
    for index, accepted, refused in ((0x605A, (1, 2, 5, 6), (0, 3, 4, 7, 8)), (0x605B, (0,), (1,)),
                                     (0x605C, (1,), (0,)), (0x605D, (1,), (2, 3, 4)), (0x605E, (2,), (0, 1, 3))):
        for value in accepted:
            pd57.sdo[index].raw = value
        for value in refused:
            assert abort_code(lambda: setattr(pd57.sdo[index], "raw", value)) == 0x06090030, (hex(index), value)
    for mode in (0, 1, 3, 6, 8, 9, 10):
        pd57.sdo[0x6060].raw = mode
    for mode in (2, 4, 5, 7, -1):
        assert abort_code(lambda: setattr(pd57.sdo[0x6060], "raw", mode)) == 0x06090030, mode
    for method in (0, 1, 2, 3, 5, 17, 18, 19, 21, 33, 34, 35):
        pd57.sdo[0x6098].raw = method
    for method in (4, 6, 7, 14, 20, 22, 23, 36, 37, -1):
        assert abort_code(lambda: setattr(pd57.sdo[0x6098], "raw", method)) == 0x06090030, method


# --- §6.2 pp, §7.2 pv ---------------------------------------------------------------------------

def test_pp_procedure_moves_to_the_target(pd57):
    pd57.sdo[0x2005].raw = 3  # no limit switches connected
    motion_parameters(pd57)
    start = pd57.sdo[0x6064].raw
    enable(pd57, 1)
    pd57.sdo[0x607A].raw = start + 500_000
    pd57.sdo[0x6040].raw = 31  # the new target is active: the motor starts
    wait_until(lambda: statusword(pd57) & 0x1000)  # set-point acknowledged
    pd57.sdo[0x6040].raw = 15  # may be reset while moving
    moving = wait_until(lambda: (sw := statusword(pd57)) & 0x4000 and sw)
    assert moving & 0x8000 == 0, "moving in the positive direction"
    wait_until(lambda: statusword(pd57) & 0x0400, timeout=10)  # target reached
    wait_until(lambda: abs(pd57.sdo[0x6064].raw - (start + 500_000)) < 200, timeout=3)
    assert statusword(pd57) & 0x4000 == 0, "standing still"
    pd57.sdo[0x6040].raw = 0


def test_pv_procedure_runs_at_the_target_speed_and_stops(pd57):
    pd57.sdo[0x2005].raw = 3
    motion_parameters(pd57)
    enable(pd57, 3)
    pd57.sdo[0x60FF].raw = 100_000
    wait_until(lambda: abs(pd57.sdo[0x606C].raw - 100_000) < 2_000, timeout=3)
    assert statusword(pd57) & 0xC000 == 0x4000, "bit 14 moving, bit 15 positive"
    pd57.sdo[0x60FF].raw = -100_000
    wait_until(lambda: abs(pd57.sdo[0x606C].raw + 100_000) < 2_000, timeout=3)
    assert statusword(pd57) & 0xC000 == 0xC000, "bit 15: the direction of rotation"
    pd57.sdo[0x60FF].raw = 0  # stops the motor
    wait_until(lambda: statusword(pd57) & 0x4000 == 0, timeout=3)
    wait_until(lambda: abs(pd57.sdo[0x606C].raw) < 500, timeout=3)
    pd57.sdo[0x6040].raw = 0


# --- §8.3 homing ------------------------------------------------------------------------------

def test_homing_procedure_with_method_19_and_a_pressed_home_switch(pd57):
    enable(pd57, 6)
    pd57.sdo[0x6098].raw = 19
    pd57.sdo[0x6099][1].raw = 50_000
    pd57.sdo[0x6099][2].raw = 10_000
    pd57.sdo[0x609A].raw = 1_000_000  # the manual's default 0 would not move
    pd57.sdo[0x6040].raw = 31  # starts the homing process: searching in the positive direction
    wait_until(lambda: pd57.sdo[0x606C].raw > 40_000, timeout=3)
    assert statusword(pd57) & 0x3400 == 0  # homing in progress
    pd57.sdo[SIM_INPUTS].raw = 0x04  # press the home switch ...
    wait_until(lambda: pd57.sdo[0x606C].raw < 0, timeout=3)  # ... the drive turns back slowly
    time.sleep(0.2)
    released_at = pd57.sdo[0x6063].raw
    pd57.sdo[SIM_INPUTS].raw = 0  # ... and release it: that is home
    wait_until(lambda: statusword(pd57) & 0x3400 == 0x1400, timeout=5)  # attained, at rest
    wait_until(lambda: abs(pd57.sdo[0x6064].raw) < 100, timeout=2)  # the shaft settles on home
    assert abs(pd57.sdo[0x6063].raw - released_at) < 2_000
    assert pd57.sdo[0x2100].raw == 0  # home offset display
    pd57.sdo[0x6040].raw = 15  # when homing has finished
    # Method 35: the actual position is home (no motion, not even Operation enabled needed).
    pd57.sdo[0x607C].raw = 0
    pd57.sdo[0x6098].raw = 35
    pd57.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(pd57) & 0x3400 == 0x1400, timeout=2)
    assert abs(pd57.sdo[0x6064].raw) < 100
    pd57.sdo[0x6040].raw = 0


# --- §2.2, §3.1.16, §12: NMT and faults ---------------------------------------------------------

def test_nmt_stopped_switches_an_enabled_axis_into_fault(pd57, heartbeats):
    enable(pd57, 3)
    pd57.nmt.send_command(0x02)
    time.sleep(0.1)
    pd57.nmt.send_command(0x80)
    time.sleep(0.05)
    assert statusword(pd57) & 0x4F == 0x08, hex(statusword(pd57))  # Fault
    pd57.sdo[0x6040].raw = 0x80  # fault reset
    wait_until(lambda: statusword(pd57) & 0x4F == 0x40)
    # An axis that is not enabled stays where it is.
    pd57.sdo[0x6040].raw = 6
    pd57.nmt.send_command(0x02)
    time.sleep(0.1)
    pd57.nmt.send_command(0x80)
    time.sleep(0.05)
    assert statusword(pd57) & 0x6F == 0x21


def test_error_behaviour_0_enters_stopped_on_a_heartbeat_timeout(pd57, network, heartbeats):
    assert pd57.sdo[0x1029][1].raw == 0
    assert abort_code(lambda: setattr(pd57.sdo[0x1029][1], "raw", 2)) == 0x06090030
    pd57.sdo[0x1017].raw = 20
    pd57.sdo[0x1016][1].raw = (0x10 << 16) | 100  # node 10h every 100 ms
    pd57.nmt.send_command(0x01)
    network.send_message(0x710, b"\x05")
    heartbeats.clear()
    heartbeats.wait_for(lambda d: d == b"\x04", timeout=1.0)  # Stopped (CiA 301 would be 7Fh)


def test_error_behaviour_of_an_application_error_the_drives_fault(pd57, network, heartbeats):
    pd57.sdo[0x1017].raw = 20
    assert pd57.sdo[0x1029][0].raw == 2
    assert pd57.sdo[0x1029][2].raw == 1  # default: remain in the current state
    pd57.nmt.send_command(0x01)
    enable(pd57, 3)
    pd57.sdo[SIM_FAULTS].raw = 0x01  # over-current: the drive enters Fault
    wait_until(lambda: statusword(pd57) & 0x4F == 0x08)
    heartbeats.clear()
    heartbeats.wait_for(lambda d: d == b"\x05", timeout=1.0)  # still Operational
    pd57.sdo[SIM_FAULTS].raw = 0
    pd57.sdo[0x6040].raw = 0x80
    wait_until(lambda: statusword(pd57) & 0x4F == 0x40)
    pd57.sdo[0x1029][2].raw = 0  # the manual's 0: enter Stopped
    enable(pd57, 3)
    pd57.sdo[SIM_FAULTS].raw = 0x01
    heartbeats.clear()
    heartbeats.wait_for(lambda d: d == b"\x04", timeout=1.0)  # Stopped
    pd57.nmt.send_command(0x80)  # (no SDO in Stopped)
    time.sleep(0.05)
    pd57.sdo[SIM_FAULTS].raw = 0


def test_emcy_of_an_over_current_and_of_the_fault_reset(pd57, network):
    emcy = Recorder(network, 0x80 + NODE_ID)
    enable(pd57, 3)
    pd57.sdo[SIM_FAULTS].raw = 0x01  # over-current in the power stage
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x10\x23", timeout=1.0)  # 2310h
    assert data[2] & 0x03 == 0x03  # error register: generic + current
    wait_until(lambda: statusword(pd57) & 0x4F == 0x08)
    assert pd57.sdo[0x2102].raw & 0x10  # driver error flag OCHS
    pd57.sdo[SIM_FAULTS].raw = 0
    emcy.clear()
    pd57.sdo[0x6040].raw = 0x80
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)  # 0000h: fault reset


def test_under_voltage_is_reported_with_the_manuals_code_ff00h(pd57, network):
    emcy = Recorder(network, 0x80 + NODE_ID)
    enable(pd57, 3)
    pd57.sdo[SIM_FAULTS].raw = 0x04  # under-voltage
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x00\xff", timeout=1.0)  # FF00h
    assert data[2] & 0x05 == 0x05  # error register: generic + voltage
    wait_until(lambda: statusword(pd57) & 0x4F == 0x08)
    # The manual's drive has neither 603Fh nor 1003h: the EMCY is where a master sees the code.
    assert abort_code(lambda: pd57.sdo.upload(0x603F, 0)) == 0x06020000
    assert abort_code(lambda: pd57.sdo.upload(0x1003, 0)) == 0x06020000
    pd57.sdo[SIM_FAULTS].raw = 0
    emcy.clear()
    pd57.sdo[0x6040].raw = 0x80
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)  # 0000h: fault reset
    wait_until(lambda: pd57.sdo[0x1001].raw & 0x04 == 0)


def test_travel_limits_are_reported_with_the_manuals_emcy_ff01h(pd57, network):
    emcy = Recorder(network, 0x80 + NODE_ID)
    pd57.sdo[SIM_INPUTS].raw = 0x02  # the right (positive) limit switch
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x01\xff", timeout=1.0)
    assert data[3] == 3, "byte 1: positive limit switch"
    assert data[2] & 0x81 == 0x81  # error register: generic + manufacturer-specific
    emcy.clear()
    pd57.sdo[SIM_INPUTS].raw = 0
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)
    emcy.clear()
    position = pd57.sdo[0x6064].raw
    pd57.sdo[0x607D][1].raw = position + 1000  # the axis is now below the negative limit
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x01\xff", timeout=1.0)
    assert data[3] == 2, "byte 1: negative software limit"
    emcy.clear()
    pd57.sdo[0x607D][1].raw = -2147483648
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)
    wait_until(lambda: pd57.sdo[0x1001].raw & 0x80 == 0)


def test_a_following_error_stops_the_motor_with_an_emcy_and_0_switches_it_off(pd57, network):
    emcy = Recorder(network, 0x80 + NODE_ID)
    motion_parameters(pd57)
    pd57.sdo[0x6085].raw = 4_000_000  # a short fault reaction (quick stop ramp)
    pd57.sdo[0x2005].raw = 3
    enable(pd57, 1)
    # 6065h = 0 (the default) is off: a fast move does not fault.
    pd57.sdo[0x607A].raw = pd57.sdo[0x6064].raw + 100_000
    pd57.sdo[0x6040].raw = 31
    pd57.sdo[0x6040].raw = 15
    wait_until(lambda: statusword(pd57) & 0x0400, timeout=5)
    assert statusword(pd57) & 0x4F == 0x07
    pd57.sdo[0x6065].raw = 10
    pd57.sdo[0x607A].raw = pd57.sdo[0x6064].raw + 100_000
    pd57.sdo[0x6040].raw = 31
    emcy.wait_for(lambda d: d[:2] == b"\x11\x86", timeout=2.0)  # 8611h
    wait_until(lambda: statusword(pd57) & 0x4F == 0x08, timeout=3)


# --- §4.2 manufacturer objects ------------------------------------------------------------------

def test_limit_switch_configuration_only_in_switch_on_disabled(pd57):
    pd57.sdo[SIM_INPUTS].raw = 0x01  # the left limit switch is active
    time.sleep(0.02)
    assert pd57.sdo[0x60FD].raw & 0x01
    assert pd57.sdo[0x2702].raw & 0x10000  # IN0
    pd57.sdo[0x2005].raw = 1  # left switch not used
    time.sleep(0.02)
    assert pd57.sdo[0x60FD].raw & 0x01 == 0
    assert pd57.sdo[0x2702].raw & 0x10000, "the input pin itself"
    pd57.sdo[SIM_INPUTS].raw = 0
    pd57.sdo[0x2005].raw = 4 | 0x20  # left switch and home switch inverted
    time.sleep(0.02)
    assert pd57.sdo[0x60FD].raw & 0x05 == 0x05
    pd57.sdo[0x6040].raw = 6
    wait_until(lambda: statusword(pd57) & 0x6F == 0x21)
    assert abort_code(lambda: setattr(pd57.sdo[0x2005], "raw", 0)) == 0x08000022
    assert abort_code(lambda: setattr(pd57.sdo[0x208C], "raw", 0)) == 0x08000022
    assert abort_code(lambda: setattr(pd57.sdo[0x200B][3], "raw", 0)) == 0x08000022
    assert pd57.sdo[0x2005].raw == 0x24  # always readable
    pd57.sdo[0x6040].raw = 0
    wait_until(lambda: statusword(pd57) & 0x4F == 0x40)
    pd57.sdo[0x2005].raw = 0


def test_closed_loop_procedure(pd57):
    # §1.5's example settings (1 A motor, 10 000 cpr encoder), all within range.
    settings = [(0x2003, 0, 85), (0x2004, 0, 10), (0x2034, 0, 300_000), (0x2035, 0, 1_600_000),
                (0x2036, 0, 255), (0x2027, 0, 255), (0x2029, 0, 50), (0x202A, 0, 255), (0x2022, 0, 255),
                (0x2030, 0, 1000), (0x2031, 0, 10_000), (0x202B, 0, 3000), (0x202C, 0, 20), (0x202D, 0, 2000),
                (0x202E, 0, 0), (0x202F, 0, 100_000), (0x2021, 0, 65_536)]
    for index, sub, value in settings:
        pd57.sdo[index].raw = value
        assert pd57.sdo[index].raw == value
    assert abort_code(lambda: setattr(pd57.sdo[0x2027], "raw", 512)) == 0x06090031
    enable(pd57, 1)
    pd57.sdo[0x2020].raw = 1  # closed loop on
    assert pd57.sdo[0x2120].raw in (0, 1)
    wait_until(lambda: pd57.sdo[0x2120].raw == 1, timeout=2)  # initialisation finished
    pd57.sdo[0x2020].raw = 0
    wait_until(lambda: pd57.sdo[0x2120].raw == 0, timeout=1)
    pd57.sdo[0x6040].raw = 0


def test_signature_objects_and_displays(pd57):
    pd57.sdo[0x2701].raw = 0x656B616D  # make: manufacturer specific mode on
    assert pd57.sdo[0x2701].raw == 1
    pd57.sdo[0x2701].raw = 0x6C6C696B  # kill
    assert pd57.sdo[0x2701].raw == 0
    assert abort_code(lambda: setattr(pd57.sdo[0x2701], "raw", 1)) == 0x06090030
    pd57.sdo[0x5FFF].raw = 0x12345678
    assert pd57.sdo[0x5FFF].raw == 0  # always reads zero
    assert abort_code(lambda: setattr(pd57.sdo[0x5FFF], "raw", 1)) == 0x06090030
    pd57.sdo[0x2000].raw = 4
    assert pd57.sdo[0x2107].raw == 4  # microstep resolution display
    assert abort_code(lambda: setattr(pd57.sdo[0x2000], "raw", 9)) == 0x06090031
    pd57.sdo[0x208C].raw = 0  # internal units ...
    assert pd57.sdo[0x208E].raw == 0
    pd57.sdo[0x208C].raw = 181  # ... PPS and PPS/s
    assert pd57.sdo[0x208E].raw == 179
    assert abort_code(lambda: setattr(pd57.sdo[0x208C], "raw", 180)) == 0x06090030
    assert abort_code(lambda: setattr(pd57.sdo[0x2097], "raw", 1)) == 0x06090030
    assert abort_code(lambda: setattr(pd57.sdo[0x2102], "raw", 0)) == 0x06010002  # read only
    assert pd57.sdo[0x2101].raw == 1023  # no load


def test_encoder_n_channel_latch_and_step_counter(pd57):
    pd57.sdo[0x2005].raw = 3
    motion_parameters(pd57)
    steps = pd57.sdo[0x210B][3].raw
    assert steps == (pd57.sdo[0x210B][2].raw << 32) | pd57.sdo[0x210B][1].raw
    pd57.sdo[0x200F][1].raw = 1  # arm the latch
    enable(pd57, 3)
    pd57.sdo[0x60FF].raw = 51_200  # one revolution per second: an index pulse within a second
    wait_until(lambda: pd57.sdo[0x200F][1].raw == 0, timeout=2)  # latched
    # Half a revolution more, wherever the index was: the step counter has something to count
    # (the axis may start just before an index mark, depending on the tests before).
    time.sleep(0.5)
    pd57.sdo[0x60FF].raw = 0
    internal, encoder = pd57.sdo[0x200F][2].raw, pd57.sdo[0x200F][3].raw
    assert internal == encoder
    assert min(internal % 51_200, -internal % 51_200) <= 60, internal  # at an index mark
    wait_until(lambda: statusword(pd57) & 0x4000 == 0, timeout=3)
    assert pd57.sdo[0x210B][3].raw - steps > 20_000
    pd57.sdo[0x6040].raw = 0


# --- §3.1.18/§3.1.20 PDO remapping ----------------------------------------------------------------

def test_motion_settings_and_the_error_register_are_not_pdo_mappable(pd57):
    # The manual lists 6081h-6085h and 6098h-609Ah (and 1001h) without PDO mapping: SDO only.
    pd57.sdo[0x1400][1].raw = pd57.sdo[0x1400][1].raw | 0x8000_0000
    pd57.sdo[0x1600][0].raw = 0
    for index, sub, bits in [(0x6081, 0, 32), (0x6083, 0, 32), (0x6085, 0, 32), (0x6098, 0, 8),
                             (0x6099, 1, 32), (0x6099, 2, 32), (0x609A, 0, 32)]:
        entry = index << 16 | sub << 8 | bits
        assert abort_code(lambda: setattr(pd57.sdo[0x1600][1], "raw", entry)) == 0x06040041, hex(index)
    pd57.sdo[0x1600][1].raw = 0x607A0020  # a target stays mappable
    pd57.sdo[0x1801][1].raw = pd57.sdo[0x1801][1].raw | 0x8000_0000
    pd57.sdo[0x1A01][0].raw = 0
    assert abort_code(lambda: setattr(pd57.sdo[0x1A01][1], "raw", 0x10010008)) == 0x06040041


def test_pdo_remapping_procedure_with_at_most_three_entries(pd57, network):
    tpdo2 = Recorder(network, 0x280 + NODE_ID)
    cob = pd57.sdo[0x1801][1].raw
    # Mapping a valid PDO is refused: first mark it invalid.
    assert abort_code(lambda: setattr(pd57.sdo[0x1A01][0], "raw", 0)) == 0x06010000
    pd57.sdo[0x1801][1].raw = cob | 0x8000_0000
    pd57.sdo[0x1A01][0].raw = 0
    pd57.sdo[0x1A01][1].raw = 0x60410010
    pd57.sdo[0x1A01][2].raw = 0x60640020
    pd57.sdo[0x1A01][3].raw = 0x60610008
    assert abort_code(lambda: setattr(pd57.sdo[0x1A01][0], "raw", 4)) == 0x06090031  # at most three
    assert abort_code(lambda: pd57.sdo.upload(0x1A01, 4)) == 0x06090011
    pd57.sdo[0x1A01][0].raw = 3
    pd57.sdo[0x1801][1].raw = cob
    # Transmission types: the manual's only.
    assert abort_code(lambda: setattr(pd57.sdo[0x1801][2], "raw", 5)) == 0x06090030
    assert abort_code(lambda: setattr(pd57.sdo[0x1400][2], "raw", 1)) == 0x06090030
    pd57.sdo[0x6060].raw = 3
    pd57.nmt.send_command(0x01)  # Operational: event-driven TPDOs are sent
    time.sleep(0.1)
    status, position = statusword(pd57), pd57.sdo[0x6064].raw
    _, _, data = tpdo2.wait_for(lambda d: len(d) == 7 and d[:2] == status.to_bytes(2, "little"), timeout=1.0)
    assert abs(int.from_bytes(data[2:6], "little", signed=True) - position) < 50
    assert data[6] == 3  # 6061h
    # RPDO 1 (6040h) drives the state machine.
    network.send_message(0x200 + NODE_ID, (6).to_bytes(2, "little"))
    wait_until(lambda: statusword(pd57) & 0x6F == 0x21, timeout=1)
    pd57.nmt.send_command(0x80)
    pd57.sdo[0x6040].raw = 0


def test_the_tpdo_inhibit_time_is_given_in_milliseconds(pd57, network):
    tpdo1 = Recorder(network, 0x180 + NODE_ID)  # statusword, on change
    cob = pd57.sdo[0x1800][1].raw
    pd57.sdo[0x1800][1].raw = cob | 0x8000_0000
    pd57.sdo[0x1800][3].raw = 200  # 200 ms (20 ms in CiA 301's 100 µs)
    pd57.sdo[0x1800][1].raw = cob
    pd57.nmt.send_command(0x01)
    time.sleep(0.4)  # the start's TPDO and its inhibit time
    tpdo1.clear()
    pd57.sdo[0x6040].raw = 6
    wait_until(lambda: statusword(pd57) & 0x6F == 0x21, timeout=1.0)
    pd57.sdo[0x6040].raw = 7  # two statusword changes a few ms apart
    i, first, _ = tpdo1.wait_for(lambda d: d[0] & 0x6F == 0x21, timeout=1.0)
    _, second, _ = tpdo1.wait_for(lambda d: d[0] & 0x6F == 0x23, timeout=1.0, start=i + 1)
    assert second - first > 0.18, f"{(second - first) * 1000:.0f} ms between the two TPDOs"
    pd57.nmt.send_command(0x80)
    pd57.sdo[0x6040].raw = 0


# --- §3.1.9/10 store and restore, §4.2.65–69 bit rate and node-ID ---------------------------------

@pytest.fixture
def stored_drive(tmp_path):
    """A drive of its own with a parameter file; restarted by the test (a power cycle)."""
    storage = tmp_path / "params.bin"
    args = ("--profile", PROFILE, "--storage", str(storage))
    processes = []

    def start():
        process = DriveProcess(tmp_path, extra_args=args)
        processes.append(process)
        return process

    yield start
    for process in processes:
        assert process.stop() == 0, process.log()


def connect(process, node_id=NODE_ID):
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05
    network.connect(interface="slcan", channel=process.channel, bitrate=500000, sleep_after_open=0)
    node = canopen.RemoteNode(node_id, canopen.import_od(str(write_eds(process)), node_id))
    network.add_node(node)
    return network, node


def write_eds(process):
    path = process.log_path.parent / "pd57.eds"
    if not path.exists():
        subprocess.run([str(binary_path()), "--profile", PROFILE, "--write-eds", str(path)], check=True, timeout=10)
    return path


def test_store_and_restore_parameters(stored_drive):
    process = stored_drive()
    network, node = connect(process)
    try:
        assert [node.sdo[0x1010][s].raw for s in (1, 2, 3, 4)] == [1, 1, 1, 1]
        node.sdo[0x2003].raw = 85
        node.sdo[0x6085].raw = 100_000
        assert abort_code(lambda: setattr(node.sdo[0x1010][1], "raw", 0x12345678)) == 0x08000020
        node.sdo[0x1010][1].raw = 0x65766173  # "save"
    finally:
        network.disconnect()
    process.stop()
    process = stored_drive()  # power cycle
    network, node = connect(process)
    try:
        assert node.sdo[0x2003].raw == 85
        assert node.sdo[0x6085].raw == 100_000
        node.sdo[0x1011][1].raw = 0x64616F6C  # "load": the defaults after the next reset
        assert node.sdo[0x2003].raw == 85
        node.nmt.send_command(0x81)
        time.sleep(0.2)
        assert node.sdo[0x2003].raw == 128
        assert node.sdo[0x6085].raw == 51_200
    finally:
        network.disconnect()


def test_node_id_and_bit_rate_are_changed_through_2704h_2705h_2706h(stored_drive):
    process = stored_drive()
    network, node = connect(process)
    try:
        assert node.sdo[0x2705].raw == NODE_ID
        assert abort_code(lambda: setattr(node.sdo[0x2704], "raw", 300)) == 0x06090030
        node.sdo[0x2704].raw = 500  # the new bit rate ...
        node.sdo[0x2705].raw = 7  # ... and node-ID
        assert abort_code(lambda: setattr(node.sdo[0x2706], "raw", 1)) == 0x08000020
        node.sdo[0x2706].raw = 0x65766173  # store them
        assert node.sdo[0x2708].raw == NODE_ID, "active after the reset"
    finally:
        network.disconnect()
    process.stop()
    process = stored_drive()  # reset the module
    network, node = connect(process, node_id=7)
    try:
        assert node.sdo[0x2708].raw == 7
        assert node.sdo[0x2707].raw == 500
        assert node.sdo[0x1014].raw == 0x87
    finally:
        network.disconnect()


def test_the_store_object_needs_parameter_storage(pd57):
    assert abort_code(lambda: setattr(pd57.sdo[0x2706], "raw", 0x65766173)) == 0x08000020


# --- §11 cst: torques in mA --------------------------------------------------------------------

def test_cst_target_torque_in_milliamps(pd57, network):
    """§11.1.6/11.1.7: 6071h and 6077h are mA. With the run current 2003h at 85 (1 A, §1.5's
    example) a target of 300 mA is 30 % of it: the torque demand reads 300 mA, the actual torque
    follows in mA, and the drive's rated current 6075h follows 2003h."""
    assert pd57.sdo[0x6075].raw == 1506  # the default run current 128 of 255 × 3 A
    pd57.sdo[0x2003].raw = 85
    wait_until(lambda: pd57.sdo[0x6075].raw == 1000, timeout=1)
    pd57.sdo[0x2005].raw = 0x3F  # no switches: the shaft may turn
    # RPDO 1: controlword and target torque, every SYNC cycle (the stream of cst).
    pd57.sdo[0x1400][1].raw = pd57.sdo[0x1400][1].raw | 0x8000_0000
    pd57.sdo[0x1600][0].raw = 0
    pd57.sdo[0x1600][2].raw = 0x60710010
    pd57.sdo[0x1600][0].raw = 2
    pd57.sdo[0x1400][1].raw = 0x200 + NODE_ID
    pd57.sdo[0x60C2][1].raw = 10  # 10 ms cycle
    enable(pd57, 10)
    pd57.nmt.send_command(0x01)

    def cycle(torque, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            network.send_message(0x200 + NODE_ID, (15).to_bytes(2, "little") + torque.to_bytes(2, "little", signed=True))
            network.send_message(0x80, b"")
            time.sleep(0.01)

    cycle(300, 0.3)
    assert pd57.sdo[0x6071].raw == 300
    assert abs(pd57.sdo[0x6074].raw - 300) <= 2  # mA
    assert statusword(pd57) & 0x1000  # the target torque is used
    actual = pd57.sdo[0x6077].raw
    assert 0 < actual <= 320, actual  # the motor's torque, in mA
    cycle(0, 0.2)
    assert abs(pd57.sdo[0x6074].raw) <= 2
    pd57.nmt.send_command(0x80)
    pd57.sdo[0x6040].raw = 0


def test_sdo_block_transfer_is_not_offered(pd57):
    assert_no_block_transfer(pd57, "PD57/60-1378")


# --- Issue 18: what the manual says a master sees (each of these failed before the fix) ------------

def test_homing_reports_complete_only_at_rest_on_home(pd57):
    """Table 106 / §8.3: "homing completed" (0x1400) means the axis rests on home. The first
    statusword that says so must already see the shaft still: 606Ch 0 and 6064h no longer
    changing (before the fix it came with the demand, 606Ch ≈ 1 258 microsteps/s)."""
    enable(pd57, 6)
    pd57.sdo[0x6098].raw = 19
    pd57.sdo[0x6099][1].raw = 50_000
    pd57.sdo[0x6099][2].raw = 10_000
    pd57.sdo[0x609A].raw = 1_000_000
    pd57.sdo[0x6040].raw = 31
    wait_until(lambda: pd57.sdo[0x606C].raw > 40_000, timeout=3)
    pd57.sdo[SIM_INPUTS].raw = 0x04
    wait_until(lambda: pd57.sdo[0x606C].raw < 0, timeout=3)
    time.sleep(0.2)
    pd57.sdo[SIM_INPUTS].raw = 0
    wait_until(lambda: statusword(pd57) & 0x3400 == 0x1400, timeout=5, period=0.001)
    velocity, position = pd57.sdo[0x606C].raw, pd57.sdo[0x6064].raw
    assert abs(velocity) < 20, f"606Ch = {velocity} when homing reported complete"
    time.sleep(0.3)
    assert abs(pd57.sdo[0x6064].raw - position) <= 20, "the axis moved on after 'complete'"
    pd57.sdo[0x6040].raw = 0


def test_method_35_sets_6062h_6063h_and_6064h_to_zero(pd57):
    """§8.2 method 35: all position values 6062h, 6063h and 6064h are set to zero (6064h always
    equals 6063h, §6.1.5); before the fix 6063h kept the count of the move before."""
    pd57.sdo[0x2005].raw = 3
    motion_parameters(pd57)
    enable(pd57, 1)
    pd57.sdo[0x607A].raw = pd57.sdo[0x6064].raw + 12_800
    pd57.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(pd57) & 0x1000)
    pd57.sdo[0x6040].raw = 15
    wait_until(lambda: statusword(pd57) & 0x0400, timeout=5)
    pd57.sdo[0x6040].raw = 6  # homing on the current position works without Operation enabled
    wait_until(lambda: statusword(pd57) & 0x6F == 0x21)
    pd57.sdo[0x6060].raw = 6
    pd57.sdo[0x6098].raw = 35
    pd57.sdo[0x6040].raw = 7
    pd57.sdo[0x6040].raw = 0x17
    wait_until(lambda: statusword(pd57) & 0x3400 == 0x1400, timeout=2)
    assert [pd57.sdo[index].raw for index in (0x6062, 0x6063, 0x6064)] == [0, 0, 0]
    pd57.sdo[0x6040].raw = 0


def test_2100h_shows_a_new_home_offset_at_the_next_read(pd57):
    """§4.2.55: 2100h is the home offset 607Ch; a read right after the write sees it (it lagged
    a tick behind in 65 of 100 tries)."""
    for n in range(100):
        pd57.sdo[0x607C].raw = 1000 + n
        assert pd57.sdo[0x2100].raw == 1000 + n


def test_node_id_and_bit_rate_take_effect_at_nmt_reset_node(stored_drive):
    """§4.2.65/66: a changed node-ID and bit rate, stored with 2706h, take effect when the module
    is reset, and NMT reset node is such a reset: the boot-up comes from the new node-ID and
    2705h/2704h show the stored values, also after a power cycle."""
    process = stored_drive()
    network, node = connect(process)
    try:
        node.sdo[0x2704].raw = 500
        node.sdo[0x2705].raw = 7
        node.sdo[0x2706].raw = 0x65766173
        boot = Recorder(network, 0x707)
        node.nmt.send_command(0x81)
        boot.wait_for(lambda d: d == b"\x00", timeout=2.0)
        new = canopen.RemoteNode(7, canopen.import_od(str(write_eds(process)), 7))
        network.add_node(new)
        assert new.sdo[0x2705].raw == 7
        assert new.sdo[0x2708].raw == 7
        assert new.sdo[0x2704].raw == 500
    finally:
        network.disconnect()
    process.stop()
    process = stored_drive()
    network, node = connect(process, node_id=7)
    try:
        assert node.sdo[0x2704].raw == 500
        assert node.sdo[0x2707].raw == 500
    finally:
        network.disconnect()


def test_make_lets_the_mapping_of_a_valid_pdo_change(pd57, network):
    """§4.2.62: after the make signature PDOs need not be disabled to change their mapping; the
    kill signature restores the CiA 301 rule."""
    pd57.sdo[0x2701].raw = 0x656B616D  # make
    assert pd57.sdo[0x2701].raw == 1
    pd57.sdo[0x1A00][0].raw = 0  # TPDO1 stays valid
    pd57.sdo[0x1A00][1].raw = 0x60410010
    pd57.sdo[0x1A00][2].raw = 0x60610008
    pd57.sdo[0x1A00][0].raw = 2
    tpdo1 = Recorder(network, 0x180 + NODE_ID)
    pd57.sdo[0x6060].raw = 3
    pd57.nmt.send_command(0x01)
    tpdo1.wait_for(lambda d: len(d) == 3 and d[2] == 3, timeout=1.0)
    pd57.nmt.send_command(0x80)
    pd57.sdo[0x2701].raw = 0x6C6C696B  # kill
    assert abort_code(lambda: setattr(pd57.sdo[0x1A00][0], "raw", 0)) == 0x06010000


def test_a_fault_of_nmt_stopped_is_signalled_and_its_reset_sends_0000h(pd57, network, heartbeats):
    """§2.2 and §12: NMT Stopped faults an enabled axis; its EMCY 8100h (00 FF 00 00 00) goes
    out once the node may send EMCYs again, and the fault reset sends 0000h, as for any fault."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    pd57.nmt.send_command(0x01)
    enable(pd57, 3)
    pd57.nmt.send_command(0x02)  # Stopped: no SDO, no EMCY
    time.sleep(0.1)
    assert not any(d[:2] == b"\x00\x81" for _, d in emcy.frames)
    pd57.nmt.send_command(0x80)
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x00\x81", timeout=1.0)
    assert data[3:] == bytes([0, 255, 0, 0, 0])
    assert statusword(pd57) & 0x4F == 0x08
    emcy.clear()
    pd57.sdo[0x6040].raw = 0x80
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)
    wait_until(lambda: statusword(pd57) & 0x4F == 0x40)


def test_the_heartbeat_timeout_emcy_goes_out_before_the_node_stops(pd57, network, heartbeats):
    """§3.1.16/§12: a consumer heartbeat timeout while Operational is reported with EMCY 8130h
    (00 FF 00 00 00) before the 1029h reaction (0: Stopped) silences the node; before the fix it
    came only after NMT Pre-operational."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    pd57.sdo[0x1017].raw = 50
    pd57.sdo[0x1016][1].raw = (0x10 << 16) | 300
    pd57.nmt.send_command(0x01)
    for _ in range(3):
        network.send_message(0x710, b"\x05")
        time.sleep(0.1)
    heartbeats.clear()
    heartbeats.wait_for(lambda d: d == b"\x04", timeout=2.0)  # Stopped
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x30\x81", timeout=0.5)
    assert data[3:] == bytes([0, 255, 0, 0, 0])
    pd57.nmt.send_command(0x80)


def test_rpdos_of_the_wrong_length(pd57, network):
    """§12: 8210h "PDO not processed due to length error" and 8220h "PDO length exceeded", both
    with 00 FF 00 00 00; a PDO with too many bytes "could not be processed": not applied."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    pd57.nmt.send_command(0x01)
    time.sleep(0.05)
    network.send_message(0x200 + NODE_ID, b"\x06")
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x10\x82", timeout=1.0)
    assert data[3:] == bytes([0, 255, 0, 0, 0])
    network.send_message(0x200 + NODE_ID, b"\x06\x00\x00")
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x20\x82", timeout=1.0)
    assert data[3:] == bytes([0, 255, 0, 0, 0])
    time.sleep(0.05)
    assert pd57.sdo[0x6040].raw == 0, "the long PDO's controlword was applied"
    assert statusword(pd57) & 0x6F == 0x40
    pd57.nmt.send_command(0x80)


ABSENT = (0x1003, 0x603F, 0x6007, 0x6072, 0x607F, 0x6091, 0x60B8, 0x60F4)


def test_objects_the_drive_does_not_have_do_not_exist(pd57, eds_file):
    """The manual's object list has none of these: a master probing for them gets 0602 0000h, as
    from the real drive, and the EDS does not list them."""
    od = canopen.import_od(str(eds_file), NODE_ID)
    for index in ABSENT:
        assert abort_code(lambda: pd57.sdo.upload(index, 0)) == 0x06020000, hex(index)
        assert index not in od, hex(index)


def test_a_move_further_into_an_active_limit_switch_is_not_made(pd57, network):
    """§4.2.6 and §12 FF01h/3: with the limit switches in use (2005h = 0) and the axis on the
    right one, a positive move does not run (before the fix it ran to its target); a move back
    off the switch does."""
    motion_parameters(pd57)
    pd57.sdo[SIM_INPUTS].raw = 0x02  # the right (positive) limit switch
    enable(pd57, 1)
    start = pd57.sdo[0x6064].raw
    pd57.sdo[0x607A].raw = start + 200_000
    pd57.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(pd57) & 0x1000)
    pd57.sdo[0x6040].raw = 15
    time.sleep(0.3)
    assert abs(pd57.sdo[0x6064].raw - start) < 50, "moved into the active limit switch"
    assert statusword(pd57) & 0x0800, "bit 11: internal limit active"
    pd57.sdo[0x607A].raw = start - 50_000
    pd57.sdo[0x6040].raw = 31
    wait_until(lambda: statusword(pd57) & 0x1000)
    pd57.sdo[0x6040].raw = 15
    wait_until(lambda: abs(pd57.sdo[0x6064].raw - (start - 50_000)) < 200, timeout=3)
    pd57.sdo[SIM_INPUTS].raw = 0
    pd57.sdo[0x6040].raw = 0


def test_each_move_into_an_active_limit_switch_sends_ff01h(pd57, network):
    """§12 FF01h/3 and /4: a limit switch touched outside homing. With the axis standing on an
    active switch, each move commanded into it is such a touch: one FF01h, byte 1 = 3 (positive)
    or 4 (negative), when the set-point is taken (before the fix only the switch becoming active
    sent it, so the master saw nothing at the move). A move off the switch sends none."""
    emcy = Recorder(network, 0x80 + NODE_ID)
    motion_parameters(pd57)
    pd57.sdo[SIM_INPUTS].raw = 0x02  # the right (positive) limit switch
    emcy.wait_for(lambda d: d[:2] == b"\x01\xff", timeout=1.0)  # the switch became active
    enable(pd57, 1)
    time.sleep(0.1)
    emcy.clear()

    def move(target):
        """A pp set-point; returns the EMCYs (time, data) from the bit-4 edge until 0.3 s later."""
        pd57.sdo[0x607A].raw = target
        emcy.clear()
        commanded = time.monotonic()
        pd57.sdo[0x6040].raw = 31
        wait_until(lambda: statusword(pd57) & 0x1000)
        pd57.sdo[0x6040].raw = 15
        time.sleep(0.3)
        frames = list(emcy.frames)
        assert all(t >= commanded for t, _ in frames)
        return frames

    def touch(frames, switch):
        assert len(frames) == 1, f"one EMCY per move into the switch: {frames!r}"
        t, data = frames[0]
        assert data[:2] == b"\x01\xff", data.hex()  # FF01h
        assert data[2] & 0x81 == 0x81  # error register: generic + manufacturer-specific
        assert data[3:] == bytes([switch, 0, 0, 0, 0]), data.hex()
        return t

    start = pd57.sdo[0x6064].raw
    touch(move(start + 200_000), 3)
    assert abs(pd57.sdo[0x6064].raw - start) < 50, "moved into the active limit switch"
    assert move(start - 50_000) == [], "a move off the switch"
    wait_until(lambda: abs(pd57.sdo[0x6064].raw - (start - 50_000)) < 200, timeout=3)
    touch(move(start + 200_000), 3)  # back into it: a new touch

    # The left (negative) switch: byte 1 = 4.
    pd57.sdo[SIM_INPUTS].raw = 0x01
    emcy.wait_for(lambda d: d[:2] == b"\x01\xff" and d[3] == 4, timeout=1.0)
    here = pd57.sdo[0x6064].raw
    touch(move(here - 200_000), 4)
    assert abs(pd57.sdo[0x6064].raw - here) < 50, "moved into the active limit switch"
    pd57.sdo[SIM_INPUTS].raw = 0
    pd57.sdo[0x6040].raw = 0

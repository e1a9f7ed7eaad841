"""`canopen-drive-linux --profile chieftek` against the Chieftek (cpc) DS402 manual (revision 1.0):
its object list (§2.3), its procedures (the set-point handshake §6.3.1, single set-points and
sets of set-points with one buffered §6.3.2/§6.3.3, homing with the standard methods §8.5 and the
cpc methods −1…−12 §8.6 with the hard-stop current 3293h and period 3294h) and the behaviour it
documents (modes change only outside Operation enabled §5.1, statusword bit 14 §4.3.2.1, option
code ranges §4.3, supported modes §3.2, pv zero speed §10.3, a following error is a fault §7.2).

The manual covers the drive profile only; the communication objects are the library's. The
simulated axis is the generic one: 10 000 counts per revolution, limit switches beyond ±100 000,
home switch 20 000..30 000, elastic hard stops at ±120 000.
"""

import time

import canopen
import pytest
from canopen.objectdictionary import datatypes as dt

from conftest import NODE_ID
from profile_support import abort_code, assert_matches_manual, reset, statusword
from profile_support import wait_until as support_wait_until

PROFILE = "chieftek"

SIM_FAULTS, SIM_INPUTS, SIM_LOAD, HARD_STOP_RECORD = 0x5E00, 0x5E01, 0x5E02, 0x5E10
BOARD_OBJECTS = {SIM_FAULTS, SIM_INPUTS, SIM_LOAD, HARD_STOP_RECORD}

U8, U16, U32 = dt.UNSIGNED8, dt.UNSIGNED16, dt.UNSIGNED32
I8, I16, I32, R32 = dt.INTEGER8, dt.INTEGER16, dt.INTEGER32, dt.REAL32
RO, RW, C = "ro", "rw", "ro"  # constants compare as read-only

SUPPORTED_HOMING_METHODS = [-12, -11, -10, -9, -8, -7, -6, -5, -4, -3, -2, -1, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 33, 34, 35, 37]

# (index, sub, data type, access, PDO mapping, default) of the table in §2.3 (PDO: "O" yes, "X"
# no) and the manufacturer objects of §8.3. Default None: "–" in the table.
MANUAL = [
    (0x6007, 0, I16, RW, False, 0),
    (0x603F, 0, U16, RO, True, 0),
    (0x6040, 0, U16, RW, True, 0),
    (0x6041, 0, U16, RO, True, None),
    (0x605A, 0, I16, RW, False, 2),
    (0x605B, 0, I16, RW, False, 0),
    (0x605C, 0, I16, RW, False, 0),
    (0x605D, 0, I16, RW, False, 1),
    (0x605E, 0, I16, RW, False, 0),
    (0x6060, 0, I8, RW, True, 0),
    (0x6061, 0, I8, RO, True, 0),
    (0x6062, 0, I32, RO, True, None),
    (0x6063, 0, I32, RO, True, 0),
    (0x6064, 0, I32, RO, True, 0),
    (0x6065, 0, U32, RW, True, 0),
    (0x6066, 0, U16, RW, True, 0),
    (0x6067, 0, U32, RW, True, 0),
    (0x6068, 0, U16, RW, True, 0),
    (0x606B, 0, I32, RO, True, None),
    (0x606C, 0, I32, RO, True, 0),
    (0x606D, 0, U16, RW, True, 0),
    (0x606E, 0, U16, RW, True, 0),
    (0x606F, 0, U16, RW, True, 0),
    (0x6070, 0, U16, RW, True, 0),
    (0x6071, 0, U16, RW, True, 0),
    (0x6073, 0, U16, RW, True, 0),
    (0x6074, 0, I16, RO, True, None),
    (0x6075, 0, U32, RW, False, 0),
    (0x6076, 0, U32, RW, False, 0),
    (0x6077, 0, I16, RO, True, 0),
    (0x6078, 0, I16, RO, True, 0),
    (0x6079, 0, U32, RO, False, 0),
    (0x6080, 0, U32, RW, True, 1_500_000),
    (0x607A, 0, I32, RW, True, 0),
    (0x607B, 0, U8, C, False, 2),
    (0x607B, 1, I32, RW, False, -2**31),
    (0x607B, 2, I32, RW, False, 2**31 - 1),
    (0x607C, 0, I32, RW, True, 0),
    (0x607D, 0, I32, C, False, 2),
    (0x607D, 1, I32, RW, False, -2**31),
    (0x607D, 2, I32, RW, False, 2**31 - 1),
    (0x607F, 0, U32, RW, True, 1_500_000),
    (0x6081, 0, U32, RW, True, 2_000_000),
    (0x6083, 0, U32, RW, False, 1_000_000),
    (0x6084, 0, U32, RW, True, 1_000_000),
    (0x6085, 0, U32, RW, True, 100_000_000),
    (0x6087, 0, U32, RW, True, 100_000),
    (0x6098, 0, I8, RW, True, 35),
    (0x6099, 0, U32, C, False, 2),
    (0x6099, 1, U32, RW, False, 20_000),
    (0x6099, 2, U32, RW, False, 20_000),
    (0x609A, 0, U32, RW, True, 20_000),
    (0x60B0, 0, I32, RW, True, 0),
    (0x60B1, 0, I32, RW, True, 0),
    (0x60B2, 0, I16, RW, True, 0),
    (0x60B8, 0, U16, RW, True, 1),
    (0x60B9, 0, U16, RO, True, None),
    (0x60BA, 0, I32, RO, True, None),
    (0x60BB, 0, I32, RO, True, None),
    (0x60BC, 0, I32, RO, True, None),
    (0x60BD, 0, I32, RO, True, None),
    (0x60C2, 0, U8, C, False, 2),
    (0x60C2, 1, U8, RW, False, 1),
    (0x60C2, 2, I8, RW, False, -3),
    (0x60D5, 0, U16, RO, True, None),
    (0x60D6, 0, U16, RO, True, None),
    (0x60D7, 0, U16, RO, True, None),
    (0x60D8, 0, U16, RO, True, None),
    (0x60E3, 0, I8, C, False, 44),
    # The chart of §8.3: sub-index 1..44 and the method it lists.
    *[(0x60E3, sub, I8, C, False, method) for sub, method in enumerate(SUPPORTED_HOMING_METHODS, start=1)],
    (0x60F4, 0, I32, RO, True, None),
    (0x60FC, 0, I32, RO, True, None),
    (0x60FD, 0, U32, RO, True, None),
    (0x60FE, 0, U32, C, False, 1),
    (0x60FE, 1, U32, RW, False, 0),
    (0x60FF, 0, I32, RW, True, 0),
    (0x6502, 0, U32, RO, True, 0x3AD),
    (0x67FE, 0, U32, C, False, 3),
    (0x3293, 0, R32, RW, False, 0.5),
    (0x3294, 0, U16, RW, False, 250),
]

DEVIATIONS = {
    # sub-index 0 is UNSIGNED8 by CiA 301; the table prints the entries' type.
    ((0x607D, 0), "type"): "CiA 301: UNSIGNED8",
    ((0x6099, 0), "type"): "CiA 301: UNSIGNED8",
    ((0x60FE, 0), "type"): "CiA 301: UNSIGNED8",
    # A constant: the core maps no constants.
    ((0x6502, 0), "pdo"): "a constant (the supported modes) is not mappable in the core",
}


def test_eds_imports_and_matches_the_manuals_object_list(eds_file):
    od = canopen.import_od(str(eds_file), NODE_ID)
    assert_matches_manual(od, MANUAL, DEVIATIONS, NODE_ID, {index for index, *_ in MANUAL if 0x2000 <= index <= 0x5FFF}, BOARD_OBJECTS)


# Standard objects of the core that the manual's object list (§2.3) does not have.
ABSENT = (0x6072, 0x6086, 0x608F, 0x6091, 0x60C1, 0x60C5)


def test_objects_the_drive_does_not_have_do_not_exist(factory, eds_file):
    """§2.3: the object list has none of these (max torque, motion profile type, encoder
    resolution, gear ratio, ip data record, max acceleration): a master probing for them gets
    0602 0000h (object does not exist), as from the real drive, and the EDS does not list them
    (before the fix they answered and were listed)."""
    od = canopen.import_od(str(eds_file), NODE_ID)
    for index in ABSENT:
        assert abort_code(lambda: factory.sdo.upload(index, 0)) == 0x06020000, hex(index)
        assert index not in od, hex(index)


# --- Helpers ----------------------------------------------------------------------------------

# What commissioning sets before the drive moves: the manual's defaults of these are 0
# (following error window and time-out, position window and time, peak current in 0.1 %).
COMMISSIONING = ((0x6065, 10_000), (0x6066, 100), (0x6067, 100), (0x6068, 10), (0x6073, 3000))


@pytest.fixture
def factory(node, heartbeats):
    """The drive after NMT reset node (every parameter at the manual's default), simulation
    cleared."""
    return reset(node, heartbeats, (SIM_FAULTS, SIM_INPUTS, SIM_LOAD))


@pytest.fixture
def cpc(factory):
    """The drive at its defaults, then commissioned (COMMISSIONING)."""
    for index, value in COMMISSIONING:
        factory.sdo[index].raw = value
    return factory


def wait_until(predicate, timeout=5.0):
    return support_wait_until(predicate, timeout, period=0.005)


def enable(node, mode):
    node.sdo[0x6060].raw = mode
    for value, state in ((6, 0x21), (7, 0x23), (15, 0x27)):
        node.sdo[0x6040].raw = value
        wait_until(lambda: statusword(node) & 0x6F == state, timeout=1.0)


def slow_motion(node):
    """Moves that take a while (the defaults move 2 000 000 counts/s)."""
    node.sdo[0x6081].raw = 100_000
    node.sdo[0x6083].raw = 400_000
    node.sdo[0x6084].raw = 400_000


# --- §2.3 defaults -------------------------------------------------------------------------------

def test_zero_defaults_until_commissioned(factory):
    for index, _ in COMMISSIONING:
        assert factory.sdo[index].raw == 0, hex(index)
    # Peak current 0: a torque command reaches nothing.
    enable(factory, 4)
    factory.sdo[0x6071].raw = 100
    time.sleep(0.1)
    assert factory.sdo[0x6074].raw == 0
    factory.sdo[0x6071].raw = 0
    # Following error window 0 (time-out 0): the first move is a following error, a fault.
    factory.sdo[0x6040].raw = 0
    # (the mode changes only outside Operation enabled: wait for the state first)
    wait_until(lambda: statusword(factory) & 0x4F == 0x40, timeout=1)
    enable(factory, 1)
    factory.sdo[0x607A].raw = 10_000
    factory.sdo[0x6040].raw = 0x1F
    wait_until(lambda: statusword(factory) & 0x4F == 0x08, timeout=1)
    assert factory.sdo[0x603F].raw == 0x8611
    factory.sdo[0x6040].raw = 0x80  # fault reset
    wait_until(lambda: statusword(factory) & 0x4F == 0x40, timeout=1)


# --- §3.2, §4.3, §5 -------------------------------------------------------------------------------

def test_modes_and_option_code_ranges(cpc):
    assert cpc.sdo[0x6502].raw == 0x3AD
    for mode in (0, 1, 3, 4, 6, 8, 9, 10, -2, -3, -4):  # with the direct modes
        cpc.sdo[0x6060].raw = mode
    for mode in (2, 5, 7, -1, -5, -6, -7):  # reserved, ip, direct voltage, cpc internal
        assert abort_code(lambda: setattr(cpc.sdo[0x6060], "raw", mode)) == 0x06090030, mode
    # §4.3: −1 is the dynamic brake; 605Dh 0 switches the drive function off.
    for index, accepted, refused in ((0x6007, range(0, 4), (4, -1)), (0x605A, range(-1, 5), (5, 6, 7, 8, -2)),
                                     (0x605B, (-1, 0, 1), (2, -2)), (0x605C, (-1, 0, 1), (2, -2)),
                                     (0x605D, range(-1, 5), (5, -2)), (0x605E, range(-1, 5), (5, -2))):
        for value in accepted:
            cpc.sdo[index].raw = value
        for value in refused:
            assert abort_code(lambda: setattr(cpc.sdo[index], "raw", value)) == 0x06090030, (hex(index), value)


def test_modes_change_only_outside_operation_enabled(cpc):
    enable(cpc, 3)
    assert abort_code(lambda: setattr(cpc.sdo[0x6060], "raw", 1)) == 0x08000022
    cpc.sdo[0x6060].raw = 3  # the same mode is no change
    cpc.sdo[0x6040].raw = 7  # Switched on: any FSA state but Operation enabled
    wait_until(lambda: statusword(cpc) & 0x6F == 0x23)
    cpc.sdo[0x6060].raw = 1
    wait_until(lambda: cpc.sdo[0x6061].raw == 1, timeout=1)
    cpc.sdo[0x6040].raw = 0


# --- §6.3 set-points -------------------------------------------------------------------------------

def test_set_point_handshake(cpc):
    slow_motion(cpc)
    enable(cpc, 1)
    start = cpc.sdo[0x6064].raw
    cpc.sdo[0x607A].raw = start + 20_000  # 1. the set-point
    cpc.sdo[0x6040].raw = 0x1F  # 2. rising edge of bit 4
    wait_until(lambda: statusword(cpc) & 0x1000)  # 3. acknowledged
    cpc.sdo[0x6040].raw = 0x0F  # 4. bit 4 back to 0
    wait_until(lambda: statusword(cpc) & 0x1000 == 0)  # 5. ready for the next set-point
    wait_until(lambda: statusword(cpc) & 0x0400, timeout=5)
    wait_until(lambda: abs(cpc.sdo[0x6064].raw - (start + 20_000)) < 100, timeout=2)
    cpc.sdo[0x6040].raw = 0


def test_single_set_point_and_a_set_of_set_points_with_one_buffered(cpc):
    slow_motion(cpc)
    enable(cpc, 1)
    start = cpc.sdo[0x6064].raw

    def new_set_point(target, immediately):
        cpc.sdo[0x607A].raw = target
        bits = 0x2F if immediately else 0x0F
        cpc.sdo[0x6040].raw = bits | 0x10
        time.sleep(0.01)
        cpc.sdo[0x6040].raw = bits

    # A set of set-points (bit 5 = 0): B waits in the buffer until A is reached.
    new_set_point(start + 30_000, False)  # A
    time.sleep(0.05)
    new_set_point(start + 50_000, False)  # B, buffered
    assert statusword(cpc) & 0x1000, "the buffer is busy"
    new_set_point(start + 90_000, False)  # D: ignored, the buffer is full
    wait_until(lambda: statusword(cpc) & 0x0400, timeout=6)
    wait_until(lambda: abs(cpc.sdo[0x6064].raw - (start + 50_000)) < 100, timeout=2)
    assert cpc.sdo[0x6064].raw < start + 60_000, "D was not taken"
    # A single set-point (bit 5 = 1) interrupts the one in progress.
    new_set_point(start + 150_000, False)
    time.sleep(0.2)
    new_set_point(start + 10_000, True)
    wait_until(lambda: statusword(cpc) & 0x0400, timeout=6)
    wait_until(lambda: abs(cpc.sdo[0x6064].raw - (start + 10_000)) < 100, timeout=3)
    cpc.sdo[0x6040].raw = 0


def toward_the_middle(node):
    """+1 or −1: the direction of travel away from the nearer limit switch (encoder ±100 000)."""
    return 1 if node.sdo[0x6063].raw <= 0 else -1


def switch_on(node):
    """Operation enabled → Switched on."""
    node.sdo[0x6040].raw = 7
    wait_until(lambda: statusword(node) & 0x6F == 0x23, timeout=1.0)


def move_until_reached(node, target, timeout=5.0):
    """A single set-point by the handshake of §6.3.1; returns the first statusword showing
    target reached (bit 10) and 6064h read right after it."""
    node.sdo[0x607A].raw = target
    node.sdo[0x6040].raw = 0x1F
    wait_until(lambda: statusword(node) & 0x1000)
    node.sdo[0x6040].raw = 0x0F
    status = wait_until(lambda: (sw := statusword(node)) & 0x0400 and sw, timeout=timeout)
    return status, node.sdo[0x6064].raw


def test_software_limits_act_only_once_the_axis_is_homed(cpc):
    """§6.4, 607Dh note: homing is required to validate the software position limits. Before
    any homing a move beyond 607Dh reaches its target; after homing (method 35, 607Ch = 0) the
    same limit clamps the target (statusword bit 11, internal limit active). 607Dh holds
    position values as 6064h reads them (§8.3). Before the fix the first move stopped at the
    limit too."""
    slow_motion(cpc)
    direction = toward_the_middle(cpc)
    limit_sub = 2 if direction > 0 else 1
    enable(cpc, 1)
    start = cpc.sdo[0x6064].raw
    cpc.sdo[0x607D][limit_sub].raw = start + direction * 5_000
    status, position = move_until_reached(cpc, start + direction * 10_000)
    assert abs(position - (start + direction * 10_000)) <= 100, f"stopped at {position - start:+} before homing"
    assert not status & 0x0800, "bit 11 before homing"
    # Homing on the current position: 6064h reads 0 here, the limit 5 000 counts ahead.
    cpc.sdo[0x607D][limit_sub].raw = direction * 5_000
    switch_on(cpc)  # (the mode changes only outside Operation enabled, §5.1)
    enable(cpc, 6)
    cpc.sdo[0x607C].raw = 0
    cpc.sdo[0x6098].raw = 35
    cpc.sdo[0x6040].raw = 0x1F
    wait_until(lambda: statusword(cpc) & 0x3400 == 0x1400, timeout=2)
    wait_until(lambda: abs(cpc.sdo[0x6064].raw) <= 2, timeout=1)
    switch_on(cpc)
    enable(cpc, 1)
    status, position = move_until_reached(cpc, direction * 10_000)
    assert abs(position - direction * 5_000) <= 100, f"not clamped at the limit after homing: {position}"
    assert status & 0x0800, "bit 11: the target was clamped"
    cpc.sdo[0x6040].raw = 0


def test_halt_reports_target_reached_only_once_the_shaft_rests(cpc):
    """§6.2.2: with halt (controlword bit 8) bit 10 means "the motor decelerated to 0 velocity".
    The first statusword with bit 10 must find the shaft at rest: 606Ch ~0 and 6064h no longer
    moving (before the fix bit 10 came with the demand, 606Ch ≈ −2 000 counts/s)."""
    direction = toward_the_middle(cpc)
    cpc.sdo[0x6081].raw = 50_000
    cpc.sdo[0x6083].raw = 400_000
    cpc.sdo[0x6084].raw = 400_000
    enable(cpc, 1)
    start = cpc.sdo[0x6064].raw
    cpc.sdo[0x607A].raw = start + direction * 80_000
    cpc.sdo[0x6040].raw = 0x1F
    wait_until(lambda: statusword(cpc) & 0x1000)
    cpc.sdo[0x6040].raw = 0x0F
    wait_until(lambda: abs(cpc.sdo[0x606C].raw) > 45_000, timeout=2)  # at speed
    cpc.sdo[0x6040].raw = 0x010F  # halt
    wait_until(lambda: statusword(cpc) & 0x0400, timeout=3)
    velocity, position = cpc.sdo[0x606C].raw, cpc.sdo[0x6064].raw
    assert abs(velocity) <= 5, f"606Ch = {velocity} when target reached was reported under halt"
    time.sleep(0.3)
    assert abs(cpc.sdo[0x6064].raw - position) <= 5, "the shaft moved on after target reached"
    cpc.sdo[0x6040].raw = 0


# --- §4.3.2, §10, §11 ------------------------------------------------------------------------------

def test_statusword_bit_14_while_a_quick_stop_runs_and_pv_zero_speed(cpc):
    cpc.sdo[0x6083].raw = 500_000
    cpc.sdo[0x6085].raw = 50_000  # a slow quick stop
    cpc.sdo[0x606F].raw = 100  # velocity threshold
    enable(cpc, 3)
    assert statusword(cpc) & 0x1000  # zero speed
    cpc.sdo[0x60FF].raw = 40_000
    wait_until(lambda: abs(cpc.sdo[0x606C].raw - 40_000) < 1000, timeout=3)
    assert statusword(cpc) & 0x5000 == 0  # moving, no transition
    cpc.sdo[0x605A].raw = 2
    cpc.sdo[0x6040].raw = 0x0B  # quick stop
    assert wait_until(lambda: statusword(cpc) & 0x4000, timeout=0.5)  # quick stop in process
    wait_until(lambda: statusword(cpc) & 0x4F == 0x40, timeout=3)  # then switch on disabled
    assert statusword(cpc) & 0x4000 == 0


def test_quick_stop_with_the_dynamic_brake(cpc):
    # §4.3.3: 605Ah −1: the drive function off at once, the windings shorted until rest.
    cpc.sdo[0x605A].raw = -1
    cpc.sdo[0x6083].raw = 500_000
    enable(cpc, 3)
    cpc.sdo[0x60FF].raw = 40_000
    wait_until(lambda: abs(cpc.sdo[0x606C].raw - 40_000) < 1000, timeout=3)
    cpc.sdo[0x6040].raw = 0x0B  # quick stop
    wait_until(lambda: statusword(cpc) & 0x4F == 0x40, timeout=1)  # at once: switch on disabled
    wait_until(lambda: cpc.sdo[0x606C].raw == 0, timeout=2)
    cpc.sdo[0x60FF].raw = 0
    cpc.sdo[0x6040].raw = 0


def test_profile_torque_ramps_with_the_torque_slope(cpc):
    cpc.sdo[0x6087].raw = 1000  # 0.1 %/s: 100 % per second
    enable(cpc, 4)
    cpc.sdo[0x6071].raw = 100  # 10 %
    time.sleep(0.05)
    assert 0 < cpc.sdo[0x6074].raw < 100, "ramping"
    wait_until(lambda: cpc.sdo[0x6074].raw == 100, timeout=1)
    wait_until(lambda: statusword(cpc) & 0x0400, timeout=1)  # target torque reached
    cpc.sdo[0x6071].raw = 0
    wait_until(lambda: cpc.sdo[0x6074].raw == 0, timeout=1)
    cpc.sdo[0x6040].raw = 0


# --- §8 homing -------------------------------------------------------------------------------------

def home(cpc, method, timeout=30):
    cpc.sdo[0x6098].raw = method
    cpc.sdo[0x6040].raw = 0x0F
    time.sleep(0.01)  # a tick sees bit 4 at 0: the next write is a rising edge
    cpc.sdo[0x6040].raw = 0x1F
    time.sleep(0.05)  # the run has started (or, for 35/37, completed)
    status = wait_until(lambda: (sw := statusword(cpc)) & 0x3400 in (0x1400, 0x2400) and sw, timeout=timeout)
    assert status & 0x3400 == 0x1400, hex(status)
    time.sleep(0.3)
    return cpc.sdo[0x6063].raw - cpc.sdo[0x6064].raw  # the count at home (607Ch = 0)


def test_homing_methods(cpc):
    cpc.sdo[0x6099][1].raw = 50_000
    cpc.sdo[0x6099][2].raw = 10_000
    cpc.sdo[0x609A].raw = 500_000
    assert cpc.sdo[0x6098].raw == 35  # the default: the current position
    for method in (-12, -1, 1, 14, 17, 30, 33, 34, 35, 37):
        cpc.sdo[0x6098].raw = method
    for method in (-13, 15, 16, 31, 32, 36):
        assert abort_code(lambda: setattr(cpc.sdo[0x6098], "raw", method)) == 0x06090030, method
    enable(cpc, 6)
    # −1: the positive hard stop (120 000) at 3293h × 6073h, detected after 3294h (from anywhere).
    cpc.sdo[0x3293].raw = 0.4
    cpc.sdo[0x3294].raw = 100
    time.sleep(0.02)
    assert cpc.sdo[HARD_STOP_RECORD][1].raw == 1200  # 0.4 × 3000 ‰
    assert cpc.sdo[HARD_STOP_RECORD][2].raw == 100
    assert abs(home(cpc, -1) - 120_000) < 100
    assert abort_code(lambda: setattr(cpc.sdo[0x3293], "raw", 0.95)) == 0x06090031
    # −5: the middle between the hard stops, positive first.
    cpc.sdo[0x6099][2].raw = 40_000
    assert abs(home(cpc, -5, timeout=40)) < 100
    # 19: the falling edge of the home switch (20 000), from the middle.
    cpc.sdo[0x6099][2].raw = 10_000
    assert abs(home(cpc, 19) - 20_000) < 20
    # −9: the middle of the home switch (25 000).
    cpc.sdo[0x6099][2].raw = 10_000
    assert abs(home(cpc, -9) - 25_000) < 50
    # −11: the same, first positive; from beyond the switch the hard stop turns it (§8.6).
    assert abs(home(cpc, -1) - 120_000) < 100  # the axis rests at the positive stop
    assert abs(home(cpc, -11, timeout=40) - 25_000) < 50
    # 37 = 35.
    here = cpc.sdo[0x6063].raw
    assert abs(home(cpc, 37) - here) < 50
    cpc.sdo[0x6040].raw = 0


def home_until_complete(cpc, method, timeout=30):
    """Starts homing with `method` (a rising edge of bit 4) and polls the statusword; returns
    606Ch and 6064h read right after the first one that says "homing is completed, velocity is
    0" (bits 13/12/10 = 0/1/1, §8.2.2)."""
    cpc.sdo[0x6098].raw = method
    cpc.sdo[0x6040].raw = 0x0F
    time.sleep(0.01)
    cpc.sdo[0x6040].raw = 0x1F
    if method not in (35, 37):
        wait_until(lambda: statusword(cpc) & 0x3400 == 0, timeout=1)  # in progress
    wait_until(lambda: statusword(cpc) & 0x3400 == 0x1400, timeout=timeout)
    return cpc.sdo[0x606C].raw, cpc.sdo[0x6064].raw


def test_homing_reports_complete_only_at_rest_on_home(cpc):
    """§8.2.2: bits 13/12/10 = 0/1/1 is "homing is completed, velocity is 0". The first
    statusword that says so must already find the shaft resting on home: 606Ch ~0 and 6064h
    no longer changing (before the fix method 17 reported it with 606Ch = −626)."""
    cpc.sdo[0x6099][1].raw = 50_000
    cpc.sdo[0x6099][2].raw = 10_000
    cpc.sdo[0x609A].raw = 500_000
    enable(cpc, 6)
    velocity, position = home_until_complete(cpc, 17)  # the negative limit switch
    assert abs(velocity) <= 5, f"606Ch = {velocity} when homing reported complete"
    time.sleep(0.3)
    assert abs(cpc.sdo[0x6064].raw - position) <= 5, "the axis moved on after 'complete'"
    cpc.sdo[0x6040].raw = 0


def test_home_offset_is_the_position_value_of_home(cpc):
    """§8.3 (607Ch): the home offset is set as the position value of the home position: with
    607Ch = 5, 6064h reads +5 at home when homing completes, on the current position (35) and
    on a limit switch (18). Before the fix it read −5."""
    cpc.sdo[0x6099][1].raw = 50_000
    cpc.sdo[0x6099][2].raw = 10_000
    cpc.sdo[0x609A].raw = 500_000
    cpc.sdo[0x607C].raw = 5
    enable(cpc, 6)
    assert statusword(cpc) & 0x3400 != 0x1400, "not homed yet"
    home_until_complete(cpc, 35)
    position = cpc.sdo[0x6064].raw
    assert position == 5, f"6064h = {position} at home (method 35)"
    _, position = home_until_complete(cpc, 18)  # the positive limit switch
    assert abs(position - 5) <= 3, f"6064h = {position} at home (method 18)"
    cpc.sdo[0x6040].raw = 0


def test_supported_homing_methods_60e3h(cpc):
    # §8.3: 44 methods, the cpc methods −12…−1 first, then the standard ones; each is accepted by 6098h.
    assert cpc.sdo[0x60E3][0].raw == 44
    listed = [cpc.sdo.upload(0x60E3, sub)[0] for sub in range(1, 45)]
    assert [b - 256 if b > 127 else b for b in listed] == SUPPORTED_HOMING_METHODS
    assert abort_code(lambda: cpc.sdo.upload(0x60E3, 45)) == 0x06090011
    assert abort_code(lambda: cpc.sdo.download(0x60E3, 1, b"\x05")) == 0x06010002
    for method in SUPPORTED_HOMING_METHODS:
        cpc.sdo[0x6098].raw = method


def test_version_number_and_the_manuals_types(cpc):
    # §16: 67FEh, a constant; §11.3: 6071h UNSIGNED16 (the same two bytes as CiA 402's INTEGER16).
    assert cpc.sdo[0x67FE].raw == 3
    assert abort_code(lambda: cpc.sdo.download(0x67FE, 0, (4).to_bytes(4, "little"))) == 0x06010002
    cpc.sdo.download(0x6071, 0, b"\xff\xff")
    assert cpc.sdo[0x6071].raw == 0xFFFF
    cpc.sdo[0x6071].raw = 0


def test_max_profile_velocity_and_max_motor_speed_are_one_value_in_counts_per_second(cpc):
    # §6.3: a change of 607Fh is applied to 6080h (and the other way); both count/s.
    assert cpc.sdo[0x607F].raw == cpc.sdo[0x6080].raw == 1_500_000
    cpc.sdo[0x607F].raw = 30_000
    wait_until(lambda: cpc.sdo[0x6080].raw == 30_000, timeout=1.0)
    cpc.sdo[0x6080].raw = 20_000
    wait_until(lambda: cpc.sdo[0x607F].raw == 20_000, timeout=1.0)
    # pv asks for 40 000 counts/s: held at 20 000 counts/s (not 20 000 rpm).
    cpc.sdo[0x6083].raw = 2_000_000
    enable(cpc, 3)
    cpc.sdo[0x60FF].raw = 40_000
    time.sleep(0.3)
    assert abs(cpc.sdo[0x606B].raw - 20_000) <= 100, cpc.sdo[0x606B].raw
    cpc.sdo[0x60FF].raw = 0
    cpc.sdo[0x6040].raw = 0


def test_direct_position_and_velocity_modes(cpc):
    # §5: 6060h −4 direct position, −3 direct velocity (set-points used at once, no profile).
    start = cpc.sdo[0x6064].raw
    cpc.sdo[0x607A].raw = start
    enable(cpc, -4)
    assert cpc.sdo[0x6061].raw == -4
    cpc.sdo[0x607A].raw = start + 2000
    wait_until(lambda: abs(cpc.sdo[0x6064].raw - (start + 2000)) < 50, timeout=2)
    cpc.sdo[0x6040].raw = 7  # modes change outside Operation enabled only (§5)
    wait_until(lambda: statusword(cpc) & 0x6F == 0x23, timeout=1)
    cpc.sdo[0x60FF].raw = 5000
    enable(cpc, -3)
    assert cpc.sdo[0x6061].raw == -3
    wait_until(lambda: abs(cpc.sdo[0x606C].raw - 5000) < 300, timeout=2)
    cpc.sdo[0x60FF].raw = 0
    cpc.sdo[0x6040].raw = 0


def test_touch_probe_edge_counters_timing_example(cpc):
    """§9.2.2: probe 1 enabled on both edges, continuous; each edge is stored and counted (60D5h,
    60D6h); sampling of the positive edge off and on again; the probe switched off."""
    probe_input = 1 << 6
    cpc.sdo[0x60B8].raw = 0x0033  # (1) enable, continuous, both edges
    time.sleep(0.02)
    assert cpc.sdo[0x60B9].raw & 0x07 == 0x01  # (2)
    assert (cpc.sdo[0x60D5].raw, cpc.sdo[0x60D6].raw) == (0, 0)
    for n in (1, 2, 3):
        cpc.sdo[SIM_INPUTS].raw = probe_input  # (3) positive edge
        time.sleep(0.02)
        assert cpc.sdo[0x60B9].raw & 0x02  # (4)
        assert cpc.sdo[0x60D5].raw == n
        cpc.sdo[SIM_INPUTS].raw = 0  # (5) negative edge
        time.sleep(0.02)
        assert cpc.sdo[0x60B9].raw & 0x04  # (6)
        assert cpc.sdo[0x60D6].raw == n
    stored = cpc.sdo[0x60BA].raw
    cpc.sdo[0x60B8].raw = 0x0023  # (7) positive edge sampling off
    cpc.sdo[SIM_INPUTS].raw = probe_input
    time.sleep(0.02)
    assert cpc.sdo[0x60D5].raw == 3 and cpc.sdo[0x60BA].raw == stored  # (8a) not sampled
    cpc.sdo[SIM_INPUTS].raw = 0
    cpc.sdo[0x60B8].raw = 0x0033  # (9) on again: continuous counting goes on
    time.sleep(0.02)
    cpc.sdo[SIM_INPUTS].raw = probe_input  # (11)
    time.sleep(0.02)
    assert cpc.sdo[0x60D5].raw == 4  # (12)
    cpc.sdo[SIM_INPUTS].raw = 0
    time.sleep(0.02)
    cpc.sdo[0x60B8].raw = 0x0032  # (13) probe 1 off
    time.sleep(0.02)
    assert cpc.sdo[0x60B9].raw & 0x07 == 0  # (14)
    assert cpc.sdo[0x60D5].raw == 4  # kept while off, restarted when switched on
    cpc.sdo[0x60B8].raw = 0x0033
    time.sleep(0.02)
    assert (cpc.sdo[0x60D5].raw, cpc.sdo[0x60D6].raw) == (0, 0)
    cpc.sdo[0x60B8].raw = 0

"""Two CiA 402 axes on one node (`canopen-drive-linux --axes 2`) with python-canopen as the master.

Axis n's objects are the first axis's shifted by n × 800h (CiA 402-2's logical devices): 6840h is
axis 1's controlword, 6841h its statusword. Each axis has its own state machine (§8.1, §8.2), its
own mode at the same time as the other's (profile position §10 on one, profile velocity §14 on the
other; cyclic synchronous position §17 on both, each from its own synchronous RPDO on one shared
SYNC), its own faults (603Fh/683Fh, an EMCY naming the axis in byte 7, fault reset §8.2) and its
own simulated motor (simulation objects 2100h–2102h for axis 0, 2110h–2112h for axis 1).

CiA 301 for the node: 1000h reads FFFFh in its additional information (several logical devices)
with the first device's profile 402, 67FFh and 6FFFh each axis's own device type, 77FFh does not
exist; PDOs 1–4 are axis 0's pre-defined set, PDOs 5–8 the same mapping shifted by 800h for
axis 1, without identifiers until the master gives them. CiA 306: the EDS that
`--axes 2 --write-eds` writes lists both axes and python-canopen imports it.
"""

import struct
import time

import canopen
import pytest
from canopen.objectdictionary import ODVariable, datatypes

from conftest import NODE_ID, Recorder
from profile_support import abort_code

# conftest starts the drive and writes its EDS with `--axes 2`.
AXIS_COUNT = 2

AXIS0, AXIS1 = 0x000, 0x800  # added to the first axis's index: axis n at + n × 800h
AXES = (AXIS0, AXIS1)

# The simulation objects of each axis: (index, bytes of a write).
SIMULATION = {
    AXIS0: ((0x2100, "<I"), (0x2101, "<I"), (0x2102, "<h")),  # faults, inputs, load torque
    AXIS1: ((0x2110, "<I"), (0x2111, "<I"), (0x2112, "<h")),
}
OVER_CURRENT = 0x01  # bit 0 of the simulated faults

EMCY = 0x80 + NODE_ID
DEVICE_TYPE_402 = 0x0002_0192  # CiA 402 servo drive
MULTI_DEVICE_402 = 0xFFFF_0192  # FFFFh: several logical devices, the first a CiA 402 drive

# Axis 1's PDOs take the pre-defined identifiers of node-ID + 40h (no such node on this bus).
AXIS1_NODE_ID = NODE_ID + 0x40

SWITCH_ON_DISABLED = (0x4F, 0x40)
READY_TO_SWITCH_ON = (0x6F, 0x21)
SWITCHED_ON = (0x6F, 0x23)
OPERATION_ENABLED = (0x6F, 0x27)
FAULT = (0x4F, 0x08)

VELOCITY_WINDOW = 100  # 606Dh/686Dh, increments/s


# --- Fixtures: conftest's drive and EDS, with AXIS_COUNT axes ------------------------------


def clear_simulation(node):
    for axis in AXES:
        for index, layout in SIMULATION[axis]:
            node.sdo.download(index, 0, struct.pack(layout, 0))


@pytest.fixture
def fresh(node, heartbeats):
    """The node after NMT reset node (every parameter of both axes at its default), with both
    axes' simulated faults, inputs and load cleared before the reset (so neither axis starts in
    Fault) and after it (so the board and the dictionary agree)."""
    clear_simulation(node)
    node.nmt.send_command(0x81)
    heartbeats.wait_for(lambda d: d == b"\x00", timeout=2.0)
    clear_simulation(node)
    return node


# --- Helpers ----------------------------------------------------------------------------------


def wait_until(predicate, timeout=3.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.005)
    return False


def number(axis):
    return axis // AXIS1


def statusword(node, axis):
    return node.sdo[0x6041 + axis].raw


def in_state(node, axis, state):
    mask, value = state
    return statusword(node, axis) & mask == value


def enable(node, axis):
    """Shutdown, switch on, enable operation through the axis's own controlword, each state
    awaited before the next command."""
    for controlword, state in ((0x06, READY_TO_SWITCH_ON), (0x07, SWITCHED_ON), (0x0F, OPERATION_ENABLED)):
        node.sdo[0x6040 + axis].raw = controlword
        assert wait_until(lambda: in_state(node, axis, state), timeout=1.0), (
            f"axis {number(axis)}: statusword {statusword(node, axis):#06x} after controlword {controlword:#04x}"
        )


def velocity_mode(node, axis, velocity):
    """Profile velocity on `axis`, enabled, turning at `velocity` (bit 10: velocity reached)."""
    node.sdo[0x6060 + axis].raw = 3
    node.sdo[0x6083 + axis].raw = 100_000
    node.sdo[0x6084 + axis].raw = 100_000
    node.sdo[0x606D + axis].raw = VELOCITY_WINDOW
    enable(node, axis)
    node.sdo[0x60FF + axis].raw = velocity
    # The statusword read right after the write may still be the one of the tick before it
    # (bit 10 set for the old target 0): wait for the velocity itself, then its bit 10.
    assert wait_until(lambda: abs(node.sdo[0x606C + axis].raw - velocity) <= VELOCITY_WINDOW), (
        f"axis {number(axis)} at {node.sdo[0x606C + axis].raw} increments/s"
    )
    assert wait_until(lambda: statusword(node, axis) & 0x0400), f"axis {number(axis)}: velocity not reached"


# --- The state machines -----------------------------------------------------------------------


def test_each_axis_runs_its_own_state_machine(fresh):
    node = fresh
    for axis in AXES:
        assert wait_until(lambda: in_state(node, axis, SWITCH_ON_DISABLED), timeout=1.0), (
            f"axis {number(axis)}: statusword {statusword(node, axis):#06x} after the reset"
        )

    enable(node, AXIS1)
    assert in_state(node, AXIS1, OPERATION_ENABLED)
    assert in_state(node, AXIS0, SWITCH_ON_DISABLED), f"axis 0 moved along: {statusword(node, AXIS0):#06x}"
    assert node.sdo[0x6040].raw == 0, "axis 0's controlword untouched"

    enable(node, AXIS0)
    assert in_state(node, AXIS0, OPERATION_ENABLED)
    assert in_state(node, AXIS1, OPERATION_ENABLED)

    # Apart again: a shutdown of axis 1 leaves axis 0 enabled.
    node.sdo[0x6840].raw = 0x06
    assert wait_until(lambda: in_state(node, AXIS1, READY_TO_SWITCH_ON)), f"axis 1: {statusword(node, AXIS1):#06x}"
    assert in_state(node, AXIS0, OPERATION_ENABLED), f"axis 0 followed axis 1: {statusword(node, AXIS0):#06x}"
    node.sdo[0x6040].raw = 0x06


# --- Two modes at once ------------------------------------------------------------------------

PP_TRAVEL = 30_000
PP_POSITION_WINDOW = 50  # 6067h
PV_VELOCITY = 5_000


def test_axis_0_positions_while_axis_1_turns_at_its_velocity(fresh):
    node = fresh
    node.sdo[0x6060].raw = 1  # axis 0: profile position
    node.sdo[0x6081].raw = 30_000
    node.sdo[0x6083].raw = 100_000
    node.sdo[0x6084].raw = 100_000
    node.sdo[0x6067].raw = PP_POSITION_WINDOW
    enable(node, AXIS0)
    velocity_mode(node, AXIS1, PV_VELOCITY)
    assert node.sdo[0x6061].raw == 1, "axis 0 in profile position"
    assert node.sdo[0x6861].raw == 3, "axis 1 in profile velocity"

    # One absolute move of axis 0 with the set-point handshake (§10).
    start = node.sdo[0x6064].raw
    target = start + PP_TRAVEL
    node.sdo[0x607A].raw = target
    node.sdo[0x6040].raw = 0x001F  # new set-point, absolute, single set-point off
    assert wait_until(lambda: statusword(node, AXIS0) & 0x1000), "axis 0: set-point acknowledged"
    node.sdo[0x6040].raw = 0x000F
    assert wait_until(lambda: not statusword(node, AXIS0) & 0x1000), "axis 0: acknowledge released"

    # Half-way: axis 0 on its way, axis 1 at its velocity.
    assert wait_until(lambda: node.sdo[0x6064].raw >= start + PP_TRAVEL // 2), f"axis 0 at {node.sdo[0x6064].raw}"
    assert not statusword(node, AXIS0) & 0x0400, "axis 0 reports target reached half-way"
    velocity = node.sdo[0x686C].raw
    assert abs(velocity - PV_VELOCITY) <= VELOCITY_WINDOW, f"axis 1 at {velocity} increments/s while axis 0 moves"

    assert wait_until(lambda: statusword(node, AXIS0) & 0x0400, timeout=5.0), "axis 0: target reached"
    position = node.sdo[0x6064].raw
    assert abs(position - target) <= PP_POSITION_WINDOW, f"axis 0 at {position}, target {target}"
    assert node.sdo[0x6062].raw == target, "axis 0's position demand"
    velocity = node.sdo[0x686C].raw
    assert abs(velocity - PV_VELOCITY) <= VELOCITY_WINDOW, f"axis 1 at {velocity} increments/s"
    assert statusword(node, AXIS1) & 0x0400, "axis 1: velocity still reached"
    assert in_state(node, AXIS1, OPERATION_ENABLED)
    # Neither axis took the other's set-point.
    assert node.sdo[0x687A].raw == 0, "axis 1's target position"
    assert node.sdo[0x60FF].raw == 0, "axis 0's target velocity"
    for axis in AXES:
        node.sdo[0x6040 + axis].raw = 0x06


# --- Cyclic synchronous position on both axes from one SYNC -----------------------------------

PERIOD = 0.01  # SYNC period and 60C2h/68C2h
STEPS = 100  # set-points streamed
HOLD = 10  # SYNCs more with the last set-point held
STEP = 50  # increments per SYNC period: 5 000 increments/s
TRAVEL = STEPS * STEP


def test_csp_streams_to_both_axes_from_one_rpdo_each_on_a_shared_sync(fresh, network):
    node = fresh
    node.rpdo.read()
    node.tpdo.read()
    # The pre-defined RPDO3 and TPDO3 are axis 0's controlword + target position and statusword +
    # position actual value (TPDO3 synchronous, RPDO3 event-driven until made synchronous here);
    # RPDO7 and TPDO7 are the same for axis 1.
    streams = {AXIS0: node.rpdo[3], AXIS1: node.rpdo[7]}
    reports = {AXIS0: node.tpdo[3], AXIS1: node.tpdo[7]}
    for axis in AXES:
        assert [(v.index, v.subindex) for v in streams[axis].map] == [(0x6040 + axis, 0), (0x607A + axis, 0)]
        assert [(v.index, v.subindex) for v in reports[axis].map] == [(0x6041 + axis, 0), (0x6064 + axis, 0)]
        assert streams[axis].trans_type == 255 and reports[axis].trans_type == 1
    assert streams[AXIS0].enabled and reports[AXIS0].enabled
    assert not streams[AXIS1].enabled and not reports[AXIS1].enabled, "axis 1's PDOs wait for identifiers"
    streams[AXIS1].cob_id = 0x400 + AXIS1_NODE_ID
    reports[AXIS1].cob_id = 0x380 + AXIS1_NODE_ID
    for axis in AXES:
        streams[axis].trans_type = 1
    for pdo in (streams[AXIS0], streams[AXIS1], reports[AXIS1]):
        pdo.enabled = True
        pdo.save()
    assert node.sdo[0x1402][2].raw == 1 and node.sdo[0x1406][2].raw == 1
    assert node.sdo[0x1406][1].raw == 0x400 + AXIS1_NODE_ID
    assert node.sdo[0x1806][1].raw & 0x8000_07FF == 0x380 + AXIS1_NODE_ID

    start = {}
    for axis in AXES:
        node.sdo[0x60C2 + axis][1].raw = 10  # 10 × 10⁻³ s: the SYNC period
        node.sdo[0x60C2 + axis][2].raw = -3
        # The stream starts at 5 000 increments/s from rest: no acceleration limit in the way.
        node.sdo[0x60C5 + axis].raw = 0xFFFF_FFFF
        node.sdo[0x60C6 + axis].raw = 0xFFFF_FFFF
        node.sdo[0x6060 + axis].raw = 8
        start[axis] = node.sdo[0x6064 + axis].raw
        node.sdo[0x607A + axis].raw = start[axis]  # hold where it stands until the stream begins
    node.nmt.state = "OPERATIONAL"
    for axis in AXES:
        enable(node, axis)
        assert node.sdo[0x6061 + axis].raw == 8, f"axis {number(axis)} in csp"

    # Opposite directions: axis 0 up, axis 1 down, so a mix-up shows.
    direction = {AXIS0: 1, AXIS1: -1}
    end = {axis: start[axis] + direction[axis] * TRAVEL for axis in AXES}
    recorders = {axis: Recorder(network, reports[axis].cob_id) for axis in AXES}
    deadline = time.monotonic()
    for k in range(1, STEPS + HOLD + 1):
        for axis in AXES:
            rpdo = streams[axis]
            rpdo[0].raw = 0x000F
            rpdo[1].raw = start[axis] + direction[axis] * STEP * min(k, STEPS)
            rpdo.transmit()
        network.sync.transmit()  # both RPDOs before the one SYNC
        deadline += PERIOD
        time.sleep(max(0.0, deadline - time.monotonic()))

    for axis in AXES:
        demand = node.sdo[0x6062 + axis].raw
        assert demand == end[axis], f"axis {number(axis)}: position demand {demand}, its last set-point {end[axis]}"
    for axis in AXES:
        frames = recorders[axis].wait_count(STEPS + HOLD - 5, timeout=1.0)
        reported = [struct.unpack_from("<Hi", data) for _, data in frames]
        assert all(sw & 0x6F == 0x27 for sw, _ in reported), f"axis {number(axis)} left Operation enabled"
        assert all(sw & 0x1000 for sw, _ in reported[5:]), f"axis {number(axis)}: statusword bit 12, following"
        # Half-way through the stream the axis is on its own way; at the end near its own end.
        _, middle = reported[STEPS // 2]
        assert TRAVEL // 4 < direction[axis] * (middle - start[axis]) < TRAVEL, (
            f"axis {number(axis)} at {middle} half-way from {start[axis]}"
        )
        _, last = reported[-1]
        assert abs(last - end[axis]) < TRAVEL // 10, f"axis {number(axis)} at {last}, stream's end {end[axis]}"
    for axis in AXES:
        node.sdo[0x6040 + axis].raw = 0x06


# --- A fault of one axis ----------------------------------------------------------------------


def test_a_fault_of_axis_1_leaves_axis_0_turning(fresh, network):
    node = fresh
    node.nmt.state = "OPERATIONAL"
    velocity_mode(node, AXIS0, 4_000)
    velocity_mode(node, AXIS1, -4_000)

    emcy = Recorder(network, EMCY)
    node.sdo.download(0x2110, 0, struct.pack("<I", OVER_CURRENT))  # axis 1's simulated hardware
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x10\x23", timeout=2.0)
    assert data[2] & 0x03 == 0x03, f"error register {data[2]:#04x}: generic and current"
    assert data[7] == 1, f"EMCY byte 7 {data[7]}: the axis"
    assert wait_until(lambda: in_state(node, AXIS1, FAULT)), f"axis 1: {statusword(node, AXIS1):#06x}"
    assert node.sdo[0x683F].raw == 0x2310, "axis 1's error code"
    assert node.sdo[0x603F].raw == 0, "axis 0 has no error"

    # Axis 0 is not touched: enabled, at its velocity, and travelling on.
    assert in_state(node, AXIS0, OPERATION_ENABLED), f"axis 0: {statusword(node, AXIS0):#06x}"
    velocity = node.sdo[0x606C].raw
    assert abs(velocity - 4_000) <= VELOCITY_WINDOW, f"axis 0 at {velocity} increments/s"
    position = node.sdo[0x6064].raw
    assert wait_until(lambda: node.sdo[0x6064].raw >= position + 2_000, timeout=1.0), "axis 0 stopped travelling"
    overcurrent = [d for _, d in emcy.frames if d[:2] == b"\x10\x23"]
    assert len(overcurrent) == 1, f"one over-current EMCY, axis 1's: {emcy.frames!r}"
    assert node.sdo.upload(0x2100, 0) == bytes(4), "axis 0's simulated faults untouched"

    # Cause gone, fault reset on axis 1's controlword: Switch on disabled, axis 0 still turning.
    node.sdo.download(0x2110, 0, struct.pack("<I", 0))
    node.sdo[0x6840].raw = 0x0080
    assert wait_until(lambda: in_state(node, AXIS1, SWITCH_ON_DISABLED)), f"axis 1: {statusword(node, AXIS1):#06x}"
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=2.0)  # error reset
    assert in_state(node, AXIS0, OPERATION_ENABLED), f"axis 0: {statusword(node, AXIS0):#06x}"
    velocity = node.sdo[0x606C].raw
    assert abs(velocity - 4_000) <= VELOCITY_WINDOW, f"axis 0 at {velocity} increments/s"
    node.sdo[0x6040].raw = 0x06


# --- Identity, PDO presets and the EDS --------------------------------------------------------

RPDO_MAPPING = ([0x6040_0010], [0x6040_0010, 0x6060_0008], [0x6040_0010, 0x607A_0020], [0x6040_0010, 0x60FF_0020])
TPDO_MAPPING = ([0x6041_0010], [0x6041_0010, 0x6061_0008], [0x6041_0010, 0x6064_0020], [0x6041_0010, 0x606C_0020])
# RPDOs event-driven (255); TPDOs 1–2 event-driven, 3–4 on every SYNC (1).
TRANSMISSION_TYPES = {0x1400: (255, 255, 255, 255), 0x1800: (255, 255, 1, 1)}


def test_the_eds_lists_both_axes_and_the_node_is_a_multi_device(fresh, eds_file):
    node = fresh
    od = canopen.import_od(str(eds_file), NODE_ID)
    missing = [f"{i:04X}" for i in (0x6040, 0x6840, 0x6841, 0x687A, 0x68C2, 0x67FF, 0x6FFF, 0x6502, 0x6D02) if i not in od]
    assert not missing, f"not in the EDS: {missing}"
    assert 0x77FF not in od and 0x7040 not in od, "no third axis"
    assert node.object_dictionary[0x6840].data_type == datatypes.UNSIGNED16
    statusword_1 = od[0x6841]
    assert isinstance(statusword_1, ODVariable) and statusword_1.data_type == datatypes.UNSIGNED16
    assert not statusword_1.writable, "6841h is read-only"
    # By name: the first axis's objects carry CiA 402's names, the second's are told apart.
    assert od["Statusword"].index == 0x6041 and od["Statusword (axis 1)"].index == 0x6841
    assert node.sdo["Controlword (axis 1)"].od.index == 0x6840

    assert od[0x1000].default == MULTI_DEVICE_402
    assert od[0x67FF].default == DEVICE_TYPE_402 and od[0x6FFF].default == DEVICE_TYPE_402
    assert node.sdo[0x1000].raw == MULTI_DEVICE_402, "1000h: several logical devices, the first a CiA 402 drive"
    assert node.sdo[0x67FF].raw == DEVICE_TYPE_402, "axis 0's device type"
    assert node.sdo[0x6FFF].raw == DEVICE_TYPE_402, "axis 1's device type"
    assert abort_code(lambda: node.sdo.upload(0x77FF, 0)) == 0x0602_0000, "no third axis"
    assert node.sdo[0x6D02].raw == node.sdo[0x6502].raw, "both axes support the same modes"
    assert node.sdo[0x6841].raw & 0x4F == 0x40, "axis 1 in Switch on disabled after the reset"


def test_pdos_5_to_8_are_axis_1s_predefined_set_without_identifiers(fresh, eds_file):
    node = fresh
    for n in range(8):
        axis, nth = divmod(n, 4)
        shift = (axis * AXIS1) << 16
        for communication, mapping, presets, base in (
            (0x1400, 0x1600, RPDO_MAPPING, 0x200),
            (0x1800, 0x1A00, TPDO_MAPPING, 0x180),
        ):
            where = f"{communication + n:04X}h"
            expected = [entry + shift for entry in presets[nth]]
            assert node.sdo[mapping + n][0].raw == len(expected), where
            assert [node.sdo[mapping + n][sub].raw for sub in range(1, len(expected) + 1)] == expected, where
            assert node.sdo[communication + n][2].raw == TRANSMISSION_TYPES[communication][nth], where
            cob_id = node.sdo[communication + n][1].raw
            if axis == 0:
                assert cob_id & 0x8000_07FF == base + 0x100 * nth + NODE_ID, f"{where}: {cob_id:#010x}"
            else:
                assert cob_id & 0x8000_0000, f"{where}: {cob_id:#010x} valid without an identifier"

    # The EDS describes the same presets.
    od = canopen.import_od(str(eds_file), NODE_ID)
    problems = []
    for index in (*range(0x1400, 0x1408), *range(0x1600, 0x1608), *range(0x1800, 0x1808), *range(0x1A00, 0x1A08)):
        for sub, var in od[index].subindices.items():
            if var.readable and var.default is not None and node.sdo[index][sub].raw != var.default:
                problems.append(f"{index:04X}sub{sub}: {node.sdo[index][sub].raw:#x}, EDS {var.default:#x}")
    assert not problems, "\n".join(problems)

"""The CiA 402 drive profile of canopen-drive-linux driven by python-canopen's BaseNode402:
state machine through PDOs, a profile position move with the set-point handshake, profile
velocity, a fault injected through the board's manufacturer
object 2100h, and the way back to Operation enabled by a fault reset (CiA 402-2 §8.1, §8.2: the state machine; docs/testing.md).
"""

import time

import canopen

from conftest import NODE_ID, Recorder

SIMULATED_FAULTS = 0x2100


def wait_until(predicate, timeout=3.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return False


def operational_402_node(network, node, eds_file):
    """The drive as python-canopen's CiA 402 node, NMT Operational, its state machine set up.
    Only RPDO1 (6040h) and TPDO1 (6041h) stay valid, so the controlword never travels with
    another object's stale value; the mode and targets go by SDO."""
    for index in (0x1401, 0x1402, 0x1403):
        node.sdo[index][1].raw = node.sdo[index][1].raw | 0x8000_0000
    for index in (0x1801, 0x1802, 0x1803):
        node.sdo[index][1].raw = node.sdo[index][1].raw | 0x8000_0000
    drive = canopen.BaseNode402(NODE_ID, str(eds_file))
    network.add_node(drive)
    drive.nmt.state = "PRE-OPERATIONAL"
    drive.setup_402_state_machine()
    drive.nmt.state = "OPERATIONAL"
    time.sleep(0.05)
    return drive


def test_state_machine_profile_position_velocity_fault_and_reset(network, node, eds_file):
    drive = operational_402_node(network, node, eds_file)

    drive.state = "OPERATION ENABLED"
    assert drive.state == "OPERATION ENABLED"

    # Profile position: one absolute move with the new-set-point handshake (digest §9.3).
    drive.op_mode = "PROFILED POSITION"
    assert drive.op_mode == "PROFILED POSITION"
    drive.sdo[0x6081].raw = 20_000
    drive.sdo[0x6083].raw = 100_000
    drive.sdo[0x6084].raw = 100_000
    drive.sdo[0x6067].raw = 50
    drive.sdo[0x607A].raw = 30_000
    drive.controlword = 0x001F  # new set-point, absolute, single set-point off
    assert wait_until(lambda: drive.statusword & 0x1000), "set-point acknowledged"
    drive.controlword = 0x000F
    assert wait_until(lambda: not drive.statusword & 0x1000), "acknowledge released"
    assert wait_until(lambda: drive.statusword & 0x0400), "target reached"
    assert abs(drive.sdo[0x6064].raw - 30_000) <= 50, drive.sdo[0x6064].raw
    assert drive.sdo[0x6062].raw == 30_000

    drive.op_mode = "PROFILED VELOCITY"
    assert drive.op_mode == "PROFILED VELOCITY"
    drive.sdo[0x6083].raw = 20_000
    drive.sdo[0x606D].raw = 50
    drive.sdo[0x60FF].raw = 2000
    assert wait_until(lambda: abs(drive.sdo[0x606C].raw - 2000) <= 50), drive.sdo[0x606C].raw
    assert wait_until(lambda: drive.sdo[0x6041].raw & 0x0400), "target reached"

    emcy = Recorder(network, 0x80 + NODE_ID)
    drive.sdo[SIMULATED_FAULTS].raw = 0x01  # over-current
    _, _, data = emcy.wait_for(lambda d: d[:2] == b"\x10\x23", timeout=2.0)
    assert data[2] & 0x23 == 0x23  # generic, current, device profile
    assert wait_until(lambda: drive.state == "FAULT")
    assert drive.sdo[0x603F].raw == 0x2310

    drive.sdo[SIMULATED_FAULTS].raw = 0
    drive.state = "OPERATION ENABLED"
    assert drive.state == "OPERATION ENABLED"
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=2.0)
    drive.state = "SWITCH ON DISABLED"


def test_profile_position_jerk_limited_move_and_quick_stop(network, node, eds_file):
    # The jerk-limited profile (6086h = 3, one jerk for every corner: 60A3h = 1, 60A4h:1),
    # commanded by a master: the set-point is acknowledged, the demand velocity (606Bh) never
    # exceeds the profile velocity, the target is reached, and a quick stop from a second move
    # brings the axis to standstill (CiA 402-2 §9.5, §6: the quick stop).
    drive = operational_402_node(network, node, eds_file)
    drive.state = "OPERATION ENABLED"
    assert drive.state == "OPERATION ENABLED"

    drive.op_mode = "PROFILED POSITION"
    drive.sdo[0x6086].raw = 3
    drive.sdo[0x60A3].raw = 1
    drive.sdo[0x60A4][1].raw = 2_000_000
    drive.sdo[0x6081].raw = 20_000
    drive.sdo[0x6083].raw = 100_000
    drive.sdo[0x6084].raw = 100_000
    drive.sdo[0x6067].raw = 50
    start = drive.sdo[0x6064].raw
    drive.sdo[0x607A].raw = start + 20_000
    drive.controlword = 0x001F  # new set-point, absolute
    assert wait_until(lambda: drive.statusword & 0x1000), "set-point acknowledged"
    drive.controlword = 0x000F
    fastest = 0
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and not drive.statusword & 0x0400:
        fastest = max(fastest, abs(drive.sdo[0x606B].raw))
        time.sleep(0.02)
    assert drive.statusword & 0x0400, "target reached"
    assert 0 < fastest <= 20_000, fastest
    assert abs(drive.sdo[0x6064].raw - (start + 20_000)) <= 50, drive.sdo[0x6064].raw

    # A second, longer move, stopped by a quick stop at 605Ah = 2 (the quick-stop ramp).
    drive.sdo[0x605A].raw = 2
    drive.sdo[0x6085].raw = 200_000
    drive.sdo[0x607A].raw = start + 200_000
    drive.controlword = 0x001F
    assert wait_until(lambda: drive.statusword & 0x1000), "set-point acknowledged"
    drive.controlword = 0x000F
    assert wait_until(lambda: abs(drive.sdo[0x606B].raw) > 5_000), "moving"
    drive.controlword = 0x000B  # quick stop
    assert wait_until(lambda: drive.sdo[0x606B].raw == 0, timeout=3.0), drive.sdo[0x606B].raw
    assert wait_until(lambda: drive.state == "SWITCH ON DISABLED"), drive.state
    assert drive.sdo[0x6064].raw < start + 200_000

"""Homing mode of canopen-drive-linux driven by python-canopen's BaseNode402.homing(): a
limit-switch method (17) on the board's simulated axis and the current-position method (35),
each followed by a check of 6064h (CiA 402-2 §11; home offset: 6064h reads −607Ch
at the home position)."""

import time

import canopen

from conftest import NODE_ID


def make_drive(network, node, eds_file):
    # RPDO1 (6040h) and TPDO1 (6041h) only; everything else by SDO.
    for index in (0x1401, 0x1402, 0x1403):
        node.sdo[index][1].raw = node.sdo[index][1].raw | 0x8000_0000
    for index in (0x1801, 0x1802, 0x1803):
        node.sdo[index][1].raw = node.sdo[index][1].raw | 0x8000_0000
    # TPDO1 also every 10 ms (event timer), so BaseNode402.check_statusword() waits for a fresh
    # statusword instead of reading one by SDO before the drive's next tick has run.
    node.sdo[0x1800][5].raw = 10
    drive = canopen.BaseNode402(NODE_ID, str(eds_file))
    network.add_node(drive)
    drive.nmt.state = "PRE-OPERATIONAL"
    drive.setup_402_state_machine()
    drive.tpdo[1].period = 0.01
    drive.nmt.state = "OPERATIONAL"
    time.sleep(0.05)
    return drive


def settle(drive, index, timeout=3.0):
    """The value of `index` once two reads 100 ms apart agree."""
    deadline = time.monotonic() + timeout
    last = drive.sdo[index].raw
    while time.monotonic() < deadline:
        time.sleep(0.1)
        value = drive.sdo[index].raw
        if value == last:
            return value
        last = value
    return last


def test_homing_on_the_negative_limit_switch_then_on_the_current_position(network, node, eds_file):
    drive = make_drive(network, node, eds_file)
    # Method 17: home where the negative limit switch (active below −100 000) releases.
    drive.sdo[0x6098].raw = 17
    drive.sdo[0x6099][1].raw = 100_000
    drive.sdo[0x6099][2].raw = 5_000
    drive.sdo[0x609A].raw = 500_000
    drive.sdo[0x607C].raw = 0
    # The simulated position loop (20/s, no feed-forward) lags 5000 increments at full speed.
    drive.sdo[0x6065].raw = 50_000
    assert drive.homing(timeout=20)
    assert drive.op_mode == "HOMING"
    # homing() returns at "attained"; the drive then settles on the home position.
    deadline = time.monotonic() + 5
    while drive.statusword & 0x3400 != 0x1400 and time.monotonic() < deadline:
        time.sleep(0.02)
    assert drive.statusword & 0x3400 == 0x1400, hex(drive.statusword)
    # At home the position reads −607Ch = 0; the encoder count is the switch's release point.
    assert abs(settle(drive, 0x6064)) <= 20
    assert abs(drive.sdo[0x6063].raw + 100_000) <= 20

    # Method 35: the current position is home, 6064h reads −607Ch.
    drive.sdo[0x6098].raw = 35
    drive.sdo[0x607C].raw = 1234
    drive.controlword = 0x000F  # bit 4 back to 0 for a new edge
    time.sleep(0.05)
    assert drive.homing(timeout=5)
    assert settle(drive, 0x6064) == -1234
    drive.state = "SWITCH ON DISABLED"

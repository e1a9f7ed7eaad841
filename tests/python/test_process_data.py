"""Process data and error handling of canopen-drive-linux with python-canopen as the master:
PDO remapping with python-canopen's own PDO API, SYNC-driven TPDOs, and the heartbeat consumer's
EMCY (CiA 301: heartbeat consumer, PDO, SYNC, EMCY).
"""

import struct
import time

import pytest

from conftest import NODE_ID, Recorder

EMCY = 0x80 + NODE_ID
MASTER_NODE_ID = 0x10


def test_tpdo1_remapped_through_python_canopen_arrives_at_sync(node, network):
    node.tpdo.read()
    tpdo = node.tpdo[1]
    tpdo.clear()
    tpdo.add_variable(0x6041)
    tpdo.add_variable(0x6064)
    tpdo.trans_type = 1
    tpdo.enabled = True
    node.tpdo.save()

    # The device now holds the new mapping.
    assert node.sdo[0x1A00][0].raw == 2
    assert node.sdo[0x1A00][1].raw == 0x6041_0010
    assert node.sdo[0x1A00][2].raw == 0x6064_0020
    assert node.sdo[0x1800][2].raw == 1

    node.nmt.state = "OPERATIONAL"
    time.sleep(0.05)
    statusword = node.sdo[0x6041].raw
    position = node.sdo[0x6064].raw
    # Record before sending: the drive answers a SYNC within a tick, possibly before
    # wait_for_reception would start waiting.
    frames = Recorder(network, 0x180 + NODE_ID)
    for n in range(1, 4):
        network.sync.transmit()
        frames.wait_count(n, timeout=1.0)
    time.sleep(0.05)
    assert len(frames.frames) == 3, "one TPDO per SYNC"
    assert tpdo["Statusword"].raw == statusword
    assert tpdo["Position actual value"].raw == position
    assert len(tpdo.data) == 6


def test_remap_while_valid_is_refused_with_the_documented_code(node):
    import canopen

    with pytest.raises(canopen.SdoAbortedError) as err:
        node.sdo[0x1A00][1].raw = 0x6064_0020
    assert err.value.code == 0x0601_0000


def test_heartbeat_consumer_timeout_sends_emcy_8130(node, network):
    emcy = Recorder(network, EMCY)
    node.sdo[0x1016][1].raw = (MASTER_NODE_ID << 16) | 200
    node.nmt.state = "OPERATIONAL"
    # Beat for a while: no EMCY.
    for _ in range(5):
        network.send_message(0x700 + MASTER_NODE_ID, b"\x05")
        time.sleep(0.05)
    assert emcy.frames == []
    # Stop: after 200 ms the drive reports the heartbeat error and, 1029h = 0, leaves Operational.
    stopped = time.monotonic()
    _, t, data = emcy.wait_for(lambda d: d[:2] == b"\x30\x81", timeout=2.0)
    assert 0.15 <= t - stopped <= 0.6
    assert data[2] & 0x11 == 0x11  # generic + communication bits of 1001h
    assert data[3] == MASTER_NODE_ID
    assert node.sdo[0x1001].raw & 0x10
    # The heartbeat comes back: error reset.
    network.send_message(0x700 + MASTER_NODE_ID, b"\x7F")
    emcy.wait_for(lambda d: d[:2] == b"\x00\x00", timeout=1.0)
    assert node.sdo[0x1001].raw == 0
    # python-canopen's EMCY consumer saw both.
    history = node.sdo[0x1003]
    assert history[0].raw >= 1
    assert history[1].raw & 0xFFFF == 0x8130


def test_duplicate_consumer_entries_are_refused(node):
    import canopen

    node.sdo[0x1016][1].raw = (0x20 << 16) | 500
    with pytest.raises(canopen.SdoAbortedError) as err:
        node.sdo[0x1016][2].raw = (0x20 << 16) | 300
    assert err.value.code == 0x0604_0043

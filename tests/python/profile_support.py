"""What the three vendor-profile test modules share: the comparison of a profile's EDS with the
object list transcribed from its manual, the per-test reset of the drive, and small SDO helpers.
"""

import time

import canopen
import pytest


def entry_of(od, index, sub):
    """The EDS entry `index`/`sub` of an imported dictionary, or None."""
    if index not in od:
        return None
    obj = od[index]
    if isinstance(obj, canopen.objectdictionary.ODVariable):
        return obj if sub == 0 else None
    return obj.subindices.get(sub)


def manual_mismatches(od, manual, deviations, node_id):
    """Where the EDS differs from the manual's rows (index, sub, type, access, pdo, default), other
    than the listed deviations ((index, sub), field). A type, PDO flag or default of None in a
    row is not compared; a default ("node", base) means base + node-ID."""
    problems = []
    for index, sub, data_type, access, pdo, default in manual:
        key = (index, sub)
        entry = entry_of(od, index, sub)
        if entry is None:
            if (key, "exists") not in deviations:
                problems.append(f"{index:04X}sub{sub}: missing")
            continue
        if data_type is not None and entry.data_type != data_type and (key, "type") not in deviations:
            problems.append(f"{index:04X}sub{sub}: type {entry.data_type:#x}, manual {data_type:#x}")
        eds_access = "ro" if entry.access_type in ("ro", "const") else "rw" if "w" in entry.access_type else "?"
        if eds_access != access and (key, "access") not in deviations:
            problems.append(f"{index:04X}sub{sub}: access {entry.access_type}, manual {access}")
        if pdo is not None and bool(entry.pdo_mappable) != pdo and (key, "pdo") not in deviations:
            problems.append(f"{index:04X}sub{sub}: PDO mapping {entry.pdo_mappable}, manual {pdo}")
        if default is not None and (key, "default") not in deviations:
            expected = default[1] + node_id if isinstance(default, tuple) else default
            if entry.default != expected:
                problems.append(f"{index:04X}sub{sub}: default {entry.default!r}, manual {expected!r}")
    return problems


def assert_matches_manual(od, manual, deviations, node_id, manual_area, board_objects):
    """The EDS has the manual's entries (up to the deviations), its manufacturer area is exactly
    the manual's plus this board's simulation objects, and every deviation is needed."""
    problems = manual_mismatches(od, manual, deviations, node_id)
    eds_area = {index for index in od.indices if 0x2000 <= index <= 0x5FFF} - board_objects
    assert eds_area == manual_area, (sorted(map(hex, eds_area - manual_area)), sorted(map(hex, manual_area - eds_area)))
    assert not problems, "\n".join(problems)
    for (key, field), reason in deviations.items():
        assert reason
        assert any((i, s) == key for i, s, *_ in manual), key


def reset(node, heartbeats, simulation_objects):
    """NMT reset node (every parameter at its default), then the simulation objects cleared."""
    node.nmt.send_command(0x81)
    heartbeats.wait_for(lambda d: d == b"\x00", timeout=2.0)
    for index in simulation_objects:
        node.sdo[index].raw = 0
    return node


def assert_no_block_transfer(node, device_name):
    """A manual that documents expedited and segmented SDO only: a block upload is refused with
    "command specifier not valid", a segmented upload of the same entry (1008h) works."""
    with pytest.raises(canopen.SdoAbortedError) as error:
        with node.sdo.open(0x1008, 0, "rb", block_transfer=True) as f:
            f.read()
    assert error.value.code == 0x05040001
    assert node.sdo[0x1008].raw == device_name


def abort_code(action):
    with pytest.raises(canopen.SdoAbortedError) as error:
        action()
    return error.value.code


def statusword(node):
    return node.sdo[0x6041].raw


def wait_until(predicate, timeout=5.0, period=0.01):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(period)
    raise AssertionError("condition not met in time")

"""canopen-drive-linux against a real CANopen master (python-canopen over SLCAN/TCP).

References are to CiA 301 (NMT, heartbeat, SDO abort codes) and CiA 306 (EDS); see docs/testing.md.
"""

import logging
import signal
import socket
import statistics
import struct
import subprocess
import time
import warnings

import can
import canopen
import pytest
from canopen.objectdictionary import ODVariable, datatypes

from conftest import NODE_ID, DriveProcess, RawSdo, binary_path, open_slcan

HEARTBEAT = 0x700 + NODE_ID
DEVICE_TYPE = 0x0002_0192  # CiA 402 servo drive


def set_heartbeat(node, ms):
    node.sdo[0x1017].raw = ms


# --- SDO upload: expedited, segmented, block ---------------------------------------------------


def test_expedited_uploads_of_device_type_and_identity(node, sdo_frames):
    assert node.sdo.upload(0x1000, 0) == struct.pack("<I", DEVICE_TYPE)
    assert sdo_frames.frames[-1][1][0] == 0x43  # expedited, size indicated, 4 bytes
    assert node.sdo[0x1000].raw == DEVICE_TYPE
    identity = node.object_dictionary[0x1018]
    assert node.sdo[0x1018][0].raw == 4
    for sub in range(1, 5):
        data = node.sdo.upload(0x1018, sub)
        assert len(data) == 4
        assert node.sdo[0x1018][sub].raw == identity[sub].default


def test_segmented_upload_of_device_name(node, sdo_frames):
    assert node.sdo[0x1008].raw == "canopen-drive-linux"
    # The initiate response announced a segmented transfer with its size (0x41, 19 bytes).
    initiate = sdo_frames.frames[0][1]
    assert initiate[0] == 0x41
    assert struct.unpack_from("<I", initiate, 4)[0] == len("canopen-drive-linux")
    assert node.sdo.upload(0x1008, 0) == b"canopen-drive-linux"


def test_block_upload_of_1021_equals_the_written_eds(node, sdo_frames, eds_file):
    with node.sdo.open(0x1021, 0, "rb", block_transfer=True) as stream:
        served = stream.read()
    assert served == eds_file.read_bytes()
    assert sdo_frames.frames[0][1][0] & 0xE0 == 0xC0  # block upload initiate response


# --- Heartbeat and boot-up -----------------------------------------------------------------------


def test_heartbeat_is_off_by_default(node, heartbeats):
    assert node.sdo[0x1017].raw == 0
    time.sleep(0.3)
    assert heartbeats.frames == []


def test_heartbeat_time_round_trips_and_sets_the_period(node, heartbeats):
    set_heartbeat(node, 100)
    assert node.sdo[0x1017].raw == 100
    assert node.sdo.upload(0x1017, 0) == struct.pack("<H", 100)
    frames = heartbeats.wait_count(9, timeout=2.0)
    assert all(data == b"\x7f" for _, data in frames)
    times = [t for t, _ in frames]
    intervals = [(b - a) * 1000 for a, b in zip(times, times[1:])]
    print(
        f"heartbeat 100 ms: {len(intervals)} intervals, min {min(intervals):.2f} ms, "
        f"max {max(intervals):.2f} ms, mean {statistics.mean(intervals):.2f} ms, "
        f"stdev {statistics.pstdev(intervals):.2f} ms"
    )
    assert all(80 <= i <= 120 for i in intervals), intervals


def test_heartbeat_period_change_takes_effect(node, heartbeats):
    set_heartbeat(node, 40)
    frames = heartbeats.wait_count(6, timeout=1.0)
    times = [t for t, _ in frames]
    intervals = [(b - a) * 1000 for a, b in zip(times, times[1:])]
    assert all(32 <= i <= 48 for i in intervals), intervals
    set_heartbeat(node, 0)
    time.sleep(0.05)  # a heartbeat may have been on its way
    heartbeats.clear()
    time.sleep(0.2)
    assert heartbeats.frames == []


def test_reset_communication_sends_boot_up_and_restores_1017(node, heartbeats):
    set_heartbeat(node, 50)
    heartbeats.wait_for(lambda d: d == b"\x7f")
    node.nmt.send_command(0x82)
    index, _, _ = heartbeats.wait_for(lambda d: d == b"\x00", timeout=1.0)
    # Back in Pre-operational with the default heartbeat time 0: silence after the boot-up.
    assert node.sdo[0x1017].raw == 0
    time.sleep(0.05)
    count = len(heartbeats.frames)
    time.sleep(0.2)
    assert len(heartbeats.frames) == count
    assert heartbeats.frames[index][1] == b"\x00"


def test_reset_node_sends_boot_up(node, heartbeats):
    node.nmt.send_command(0x81)
    heartbeats.wait_for(lambda d: d == b"\x00", timeout=1.0)
    assert node.sdo[0x1000].raw == DEVICE_TYPE


def test_nmt_commands_to_other_nodes_are_ignored(node, heartbeats, network):
    set_heartbeat(node, 30)
    network.send_message(0, bytes([0x02, NODE_ID + 1]))  # stop node 6
    time.sleep(0.1)
    heartbeats.clear()
    frames = heartbeats.wait_count(2, timeout=1.0)
    assert all(data == b"\x7f" for _, data in frames)


# --- NMT states --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "sequence",
    [
        [("OPERATIONAL", 0x05), ("STOPPED", 0x04), ("PRE-OPERATIONAL", 0x7F)],
        [("STOPPED", 0x04), ("OPERATIONAL", 0x05), ("PRE-OPERATIONAL", 0x7F), ("OPERATIONAL", 0x05)],
    ],
)
def test_nmt_commands_change_the_heartbeat_state(node, heartbeats, sequence):
    set_heartbeat(node, 50)
    heartbeats.wait_for(lambda d: d == b"\x7f")
    for command, state in sequence:
        start = len(heartbeats.frames)
        node.nmt.state = command
        index, _, _ = heartbeats.wait_for(lambda d: d == bytes([state]), timeout=0.5, start=start)
        # ...and the following heartbeats keep reporting it.
        heartbeats.wait_count(index + 3, timeout=0.5)
        assert [d for _, d in heartbeats.frames[index : index + 3]] == [bytes([state])] * 3


def test_broadcast_nmt_reaches_the_node(node, heartbeats, network):
    set_heartbeat(node, 50)
    network.send_message(0, bytes([0x01, 0]))
    heartbeats.wait_for(lambda d: d == b"\x05", timeout=0.5)


def test_stopped_node_does_not_answer_sdo(node, heartbeats, sdo_frames):
    set_heartbeat(node, 50)
    node.nmt.state = "STOPPED"
    heartbeats.wait_for(lambda d: d == b"\x04", timeout=0.5)
    sdo_frames.clear()
    node.sdo.RESPONSE_TIMEOUT = 0.2
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo.upload(0x1000, 0)
    assert sdo_frames.frames == []  # not even an abort
    node.nmt.state = "PRE-OPERATIONAL"
    heartbeats.wait_for(lambda d: d == b"\x7f", timeout=0.5)
    node.sdo.RESPONSE_TIMEOUT = 1.0
    assert node.sdo[0x1000].raw == DEVICE_TYPE


# --- SDO abort codes (§5.8) --------------------------------------------------------------------


@pytest.mark.parametrize(
    "action, index, sub, code",
    [
        ("upload", 0x1234, 0, 0x0602_0000),  # object does not exist
        ("upload", 0x1018, 5, 0x0609_0011),  # sub-index does not exist
        ("upload", 0x1017, 1, 0x0609_0011),
        ("download", 0x1000, 0, 0x0601_0002),  # write to a read-only object
        ("download", 0x1018, 1, 0x0601_0002),
        ("download", 0x1017, 0, 0x0607_0012),  # 4 bytes to an UNSIGNED16: too long
        ("download", 0x1234, 0, 0x0602_0000),
    ],
)
def test_abort_codes(node, sdo_frames, action, index, sub, code):
    with pytest.raises(canopen.SdoAbortedError) as error:
        if action == "upload":
            node.sdo.upload(index, sub)
        else:
            node.sdo.download(index, sub, b"\x01\x02\x03\x04")
    assert error.value.code == code
    abort = sdo_frames.frames[-1][1]
    assert abort[:4] == bytes([0x80, index & 0xFF, index >> 8, sub])
    assert struct.unpack_from("<I", abort, 4)[0] == code


def test_too_short_value_is_refused(node):
    with pytest.raises(canopen.SdoAbortedError) as error:
        node.sdo.download(0x1017, 0, b"\x01")
    assert error.value.code == 0x0607_0013


# --- EDS ---------------------------------------------------------------------------------------


def import_od_strictly(path):
    """Imports an EDS; any Python warning or python-canopen log warning fails the test."""
    records = []

    class Collect(logging.Handler):
        def emit(self, record):
            records.append(record)

    handler = Collect(level=logging.WARNING)
    logger = logging.getLogger("canopen")
    logger.addHandler(handler)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            od = canopen.import_od(str(path), NODE_ID)
    finally:
        logger.removeHandler(handler)
    assert not records, [r.getMessage() for r in records]
    return od


def variables(od):
    """Every variable of the dictionary's objects (not the DummyNNNN data-type entries that
    python-canopen adds from [DummyUsage])."""
    for obj in od.values():
        if obj.index < 0x1000:
            continue
        if isinstance(obj, ODVariable):
            yield obj
        else:
            yield from obj.values()


NO_DATA_AVAILABLE = 0x0800_0024
STRINGS = {datatypes.VISIBLE_STRING, datatypes.UNICODE_STRING, datatypes.OCTET_STRING, datatypes.DOMAIN}


TIMES = {0x000C, 0x000D}


def test_eds_imports_without_warnings_and_matches_the_device(node, eds_file):
    od = import_od_strictly(eds_file)
    assert {0x1000, 0x1001, 0x1017, 0x1018, 0x1021} <= set(od.keys())
    checked = 0
    for var in variables(od):
        assert var.data_type in ODVariable.STRUCT_TYPES or var.data_type in STRINGS | TIMES, var.name
        if not var.readable:
            continue
        where = f"{var.index:04X}sub{var.subindex} {var.name}"
        try:
            data = node.sdo.upload(var.index, var.subindex)
        except canopen.SdoAbortedError as e:
            # An entry that exists but holds nothing now, e.g. 1003h sub1 with an empty history.
            assert e.code == NO_DATA_AVAILABLE, where
            continue
        if var.data_type in TIMES:
            # TIME_OF_DAY / TIME_DIFFERENCE: python-canopen has no codec; 6 bytes on the wire.
            assert len(data) == 6, where
            checked += 1
            continue
        value = var.decode_raw(data)
        if var.data_type in ODVariable.STRUCT_TYPES:
            assert len(data) == ODVariable.STRUCT_TYPES[var.data_type].size, where
        elif var.data_type == datatypes.VISIBLE_STRING:
            data.decode("ascii")  # a visible string is ASCII
            assert isinstance(value, str), where
        if var.data_type == datatypes.DOMAIN:
            assert data == eds_file.read_bytes(), where
        elif var.default is not None and (var.access_type == "const" or var.index in (0x1000, 0x1018, 0x1200)):
            # Constants and identity values equal the EDS; other read-only entries are process
            # values (statusword, actual values) whose default is only their power-on value.
            assert value == var.default, where
        checked += 1
    assert checked >= 12


# Areas scanned for objects the EDS must list: the whole communication profile area, plus the
# first part of the manufacturer and device profile areas (a full 64 Ki scan would take a minute).
SCAN_INDICES = [*range(0x1000, 0x2000), *range(0x2000, 0x2100), *range(0x6000, 0x6100), *range(0x6400, 0x6600)]


def test_every_readable_entry_of_the_device_is_in_the_eds(network, node, eds_file):
    od = import_od_strictly(eds_file)
    sdo = RawSdo(network)
    found = []
    for index in SCAN_INDICES:
        response = sdo.initiate_upload(index, 0)
        if response[0] == 0x80 and struct.unpack_from("<I", response, 4)[0] == 0x0602_0000:
            continue
        found.append(index)
    subs_found = []
    for index in found:
        for sub in range(256):
            response = sdo.initiate_upload(index, sub)
            if response[0] == 0x80:
                code = struct.unpack_from("<I", response, 4)[0]
                if code == NO_DATA_AVAILABLE:  # readable, empty at the moment
                    subs_found.append((index, sub))
                    continue
                # No such sub-index, or write-only.
                assert code in (0x0609_0011, 0x0601_0001), f"{index:04X}sub{sub}: abort {code:08X}"
                continue
            assert response[0] & 0xE0 == 0x40, response
            subs_found.append((index, sub))
    print(f"scanned {len(SCAN_INDICES)} indices: {len(found)} objects, {len(subs_found)} readable entries")
    missing = []
    for index, sub in subs_found:
        if index not in od:
            missing.append(f"{index:04X}")
            continue
        obj = od[index]
        if isinstance(obj, ODVariable):
            if sub != 0:
                missing.append(f"{index:04X}sub{sub}")
        elif sub not in obj.subindices:
            missing.append(f"{index:04X}sub{sub}")
    assert not missing
    scanned = set(SCAN_INDICES)
    assert set(found) == {i for i in od.keys() if i in scanned}


# --- Bus behaviour -----------------------------------------------------------------------------


def recv_matching(bus, predicate, timeout):
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        msg = bus.recv(timeout=left)
        if msg is not None and predicate(msg):
            return msg
    return None


def test_two_slcan_clients_see_each_others_frames(drive):
    first = open_slcan(drive)
    second = open_slcan(drive)
    try:
        # The server attaches a new client asynchronously: repeat until the frame arrives.
        for attempt in range(20):
            first.send(can.Message(arbitration_id=0x123, data=[0xDE, 0xAD, attempt], is_extended_id=False))
            msg = recv_matching(second, lambda m: m.arbitration_id == 0x123, 0.1)
            if msg is not None:
                break
        assert msg is not None, "the second client never saw the first client's frame"
        assert msg.data[:2] == b"\xde\xad" and not msg.is_extended_id
        # The other direction, an extended frame, and a remote frame.
        second.send(can.Message(arbitration_id=0x1ABCDE, data=[1, 2, 3], is_extended_id=True))
        msg = recv_matching(first, lambda m: m.arbitration_id == 0x1ABCDE, 1.0)
        assert msg is not None and msg.is_extended_id and msg.data == b"\x01\x02\x03"
        second.send(can.Message(arbitration_id=0x234, dlc=2, is_remote_frame=True, is_extended_id=False))
        msg = recv_matching(first, lambda m: m.arbitration_id == 0x234, 1.0)
        assert msg is not None and msg.is_remote_frame and msg.dlc == 2
        # A request from one client: both see the drive's answer.
        first.send(can.Message(arbitration_id=0x600 + NODE_ID, data=[0x40, 0x00, 0x10, 0, 0, 0, 0, 0], is_extended_id=False))
        for bus in (first, second):
            msg = recv_matching(bus, lambda m: m.arbitration_id == 0x580 + NODE_ID, 1.0)
            assert msg is not None and bytes(msg.data) == bytes([0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])
    finally:
        first.shutdown()
        second.shutdown()


def test_garbage_and_vanishing_clients_do_not_stop_the_drive(drive, node):
    with socket.create_connection(("127.0.0.1", drive.port)) as raw:
        raw.settimeout(2.0)
        raw.sendall(b"garbage\rt12\rS9\rV\r")
        received = b""
        while not received.endswith(b"V1013\r"):
            received += raw.recv(64)
        assert received == b"\x07\x07\x07V1013\r"
        raw.sendall(b"t1234")  # and leave mid-line
    for _ in range(5):
        sock = socket.create_connection(("127.0.0.1", drive.port))
        sock.close()
    assert node.sdo[0x1000].raw == DEVICE_TYPE


def test_sdo_round_trip_rate(network, node):
    sdo = RawSdo(network)
    request = bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])
    n = 500
    start = time.monotonic()
    for _ in range(n):
        assert sdo.request(request)[0] == 0x43
    raw_rate = n / (time.monotonic() - start)
    start = time.monotonic()
    for _ in range(n):
        node.sdo.upload(0x1000, 0)
    client_rate = n / (time.monotonic() - start)
    print(f"SDO round trips: {raw_rate:.0f}/s raw, {client_rate:.0f}/s with python-canopen's SdoClient")
    # Loose bounds: a loaded CI machine must not fail this; the figures are printed.
    assert raw_rate > 200 and client_rate > 100


# --- Process behaviour -------------------------------------------------------------------------


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signals_end_the_process_cleanly(tmp_path, sig):
    process = DriveProcess(tmp_path, ["--storage", str(tmp_path / "params.bin")])
    bus = open_slcan(process)
    bus.shutdown()
    assert process.stop(sig, timeout=3.0) == 0
    # The storage file exists from the start (a blank journal); nothing was stored.
    assert (tmp_path / "params.bin").exists()


def run_binary(*args):
    return subprocess.run([str(binary_path()), *args], capture_output=True, text=True, timeout=10)


def test_help_exits_zero():
    result = run_binary("--help")
    assert result.returncode == 0
    assert "--slcan-listen" in result.stdout and "--storage" in result.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        ([], "--slcan-listen"),
        (["--node-id", "0", "--slcan-listen", "127.0.0.1:0"], "node-ID"),
        (["--node-id", "128", "--slcan-listen", "127.0.0.1:0"], "node-ID"),
        (["--node-id", "x", "--slcan-listen", "127.0.0.1:0"], "node-ID"),
        (["--slcan-listen", "nonsense"], "HOST:PORT"),
        (["--slcan-listen"], "needs a value"),
        (["--heartbeat", "100", "--slcan-listen", "127.0.0.1:0"], "unknown option"),
        (["--bogus"], "unknown option"),
    ],
)
def test_bad_arguments_fail_with_a_message(args, message):
    result = run_binary(*args)
    assert result.returncode == 2
    assert message in result.stderr
    assert result.stdout == ""


def test_missing_socketcan_interface_fails_cleanly():
    result = run_binary("--socketcan", "nosuchcan0")
    assert result.returncode == 1
    assert "nosuchcan0" in result.stderr
    assert "ready" not in result.stdout


def test_port_in_use_fails_cleanly(drive):
    result = run_binary("--slcan-listen", f"127.0.0.1:{drive.port}")
    assert result.returncode == 1
    assert "cannot listen" in result.stderr

"""The EDS `DefaultValue`s are what the node reads at start-up (CiA 306: the value after power-on),
for every profile of canopen-drive-linux: right after the program starts, every readable entry
of its EDS is read over SDO and compared with the EDS, byte for byte.

The entries whose start value is a live value (a measurement of the simulated axis or a status
the running drive sets up by itself) are listed in LIVE, each with the reason; every other entry
must match, and every readable entry but a DOMAIN must have a DefaultValue.
"""

import subprocess

import canopen
import pytest
from canopen.objectdictionary import ODVariable, datatypes

from conftest import NODE_ID, DriveProcess, binary_path

NO_DATA_AVAILABLE = 0x0800_0024

# (index, sub) -> why the start value is not the EDS default: live values. "*": every profile.
LIVE = {
    "*": {
        (0x6041, 0): "statusword: the state machine leaves Not ready to switch on (0000h, the "
        "power-on value) by itself for Switch on disabled, with the remote bit",
        (0x6079, 0): "DC link circuit voltage: measured (the simulated supply)",
    },
    "chieftek": {
        (0x60B9, 0): "touch probe status: probe 1, which 60B8h switches on by default, reports "
        "itself enabled once the drive runs",
    },
    "trinamic-pd57": {
        (0x2101, 0): "actual load value (StallGuard2): measured, 1023 without load (the manual's "
        "default is 0)",
    },
    "harmonic-drive": {
        (0x200D, 0): "status flags: the state of the running actuator (enable, motion, inputs)",
        (0x200E, 0): "supply voltage: measured (the simulated supply, 0.1 V units)",
        (0x200F, 0): "driver temperature: measured",
    },
}

# Entries that exist but hold nothing at start-up: the error history 1003h has no entry beyond
# its count (sub 0 = 0), so its sub-indices 1.. answer 0800 0024 "no data available" until an
# error is recorded.
EMPTY_AT_START = {0x1003}

TIMES = {datatypes.TIME_OF_DAY, datatypes.TIME_DIFFERENCE}


def variables(od):
    for obj in od.values():
        if obj.index < 0x1000:
            continue
        if isinstance(obj, ODVariable):
            yield obj
        else:
            yield from obj.values()


def expected_bytes(var):
    """The EDS default as the bytes an SDO upload returns."""
    if var.data_type in TIMES:
        # python-canopen has no codec for the 6-byte time types; the EDS gives a number.
        return int(var.default_raw, 0).to_bytes(6, "little")
    return var.encode_raw(var.default)


@pytest.mark.parametrize(
    "profile, storage",
    [("generic", False), ("chieftek", False), ("trinamic-pd57", False), ("harmonic-drive", False), ("generic", True)],
)
def test_every_readable_entry_starts_at_its_eds_default(tmp_path, profile, storage):
    storage_args = ["--storage", str(tmp_path / "parameters.bin")] if storage else []
    eds = tmp_path / f"{profile}.eds"
    subprocess.run(
        [str(binary_path()), "--profile", profile, "--node-id", str(NODE_ID), *storage_args, "--write-eds", str(eds)],
        check=True,
        timeout=10,
    )
    od = canopen.import_od(str(eds), NODE_ID)
    live = {**LIVE["*"], **LIVE.get(profile, {})}
    for index, sub in live:
        assert index in od and (isinstance(od[index], ODVariable) or sub in od[index]), f"{index:04X}sub{sub}"

    process = DriveProcess(tmp_path, extra_args=("--profile", profile, *storage_args))
    network = canopen.Network()
    try:
        network.connect(interface="slcan", channel=process.channel, bitrate=500000, sleep_after_open=0)
        node = canopen.RemoteNode(NODE_ID, od)
        network.add_node(node)
        # 1021h serves the EDS that was written.
        assert node.sdo.upload(0x1021, 0) == eds.read_bytes()
        problems, checked = [], 0
        for var in variables(od):
            if not var.readable or var.data_type == datatypes.DOMAIN or (var.index, var.subindex) in live:
                continue
            where = f"{var.index:04X}sub{var.subindex} {var.name!r}"
            if var.default is None:
                problems.append(f"{where}: no DefaultValue")
                continue
            expected = expected_bytes(var)
            try:
                data = node.sdo.upload(var.index, var.subindex)
            except canopen.SdoAbortedError as e:
                empty = expected == b"" or (var.index in EMPTY_AT_START and var.subindex > 0)
                if not (e.code == NO_DATA_AVAILABLE and empty):
                    problems.append(f"{where}: abort {e.code:08X}")
                continue
            checked += 1
            if data != expected:
                problems.append(f"{where}: reads {data.hex()}, EDS DefaultValue={var.default_raw}")
    finally:
        network.disconnect()
        status = process.stop()
    assert status == 0, process.log()
    assert not problems, "\n".join(problems)
    assert checked > 150

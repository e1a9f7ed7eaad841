"""Persistence and LSS of canopen-drive-linux with python-canopen as the master: store with
"save" and restore with "load" across restarts of the program on the same --storage file, and
an unconfigured node (--node-id 255) given a node-ID through python-canopen's LSS master
(CiA 301 1010h/1011h, CiA 305 LSS).
"""

import select
import struct

import canopen
import pytest

from conftest import DriveProcess

# 1018h of canopen-drive-linux (the generic profile: boards/linux/src/profiles/generic.rs)
VENDOR, PRODUCT, REVISION, SERIAL = 0, 0x0043_444C, 0x0000_0001, 1


def connect(process):
    network = canopen.Network()
    network.NOTIFIER_CYCLE = 0.05
    network.connect(interface="slcan", channel=process.channel, bitrate=500000, sleep_after_open=0)
    return network


def sdo_node(network, node_id, eds_file):
    node = canopen.RemoteNode(node_id, str(eds_file))
    network.add_node(node)
    return node


def test_save_survives_a_restart_and_load_restores_the_defaults(tmp_path, eds_file):
    storage = tmp_path / "params.bin"
    args = ["--storage", str(storage)]

    process = DriveProcess(tmp_path, args)
    network = connect(process)
    node = sdo_node(network, 5, eds_file)
    assert node.sdo[0x1010][1].raw == 1  # saves on command
    node.sdo[0x1017].raw = 321
    with pytest.raises(canopen.SdoAbortedError) as err:
        node.sdo.download(0x1010, 1, b"SAVE")
    assert err.value.code == 0x0800_0020
    node.sdo.download(0x1010, 1, b"save")
    node.sdo[0x1017].raw = 5  # not stored
    network.disconnect()
    assert process.stop() == 0

    process = DriveProcess(tmp_path, args)
    network = connect(process)
    node = sdo_node(network, 5, eds_file)
    assert node.sdo[0x1017].raw == 321
    node.sdo.download(0x1011, 1, b"load")
    assert node.sdo[0x1017].raw == 321, "restored defaults apply after the next reset"
    network.disconnect()
    assert process.stop() == 0

    process = DriveProcess(tmp_path, args)
    network = connect(process)
    node = sdo_node(network, 5, eds_file)
    assert node.sdo[0x1017].raw == 0
    network.disconnect()
    assert process.stop() == 0


def read_stdout_line(process, timeout=2.0):
    ready, _, _ = select.select([process.proc.stdout], [], [], timeout)
    assert ready, "no line on stdout"
    return process.proc.stdout.readline().decode()


def test_lss_gives_an_unconfigured_node_its_node_id_and_it_is_kept(tmp_path, eds_file):
    storage = tmp_path / "params.bin"
    args = ["--storage", str(storage)]

    process = DriveProcess(tmp_path, args, node_id=255)
    network = connect(process)
    # Not configured: it answers nothing but LSS.
    node = sdo_node(network, 42, eds_file)
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo[0x1000].raw
    # Fastscan finds it (and leaves it in configuration); back to waiting, then select it by
    # the identity fastscan reported.
    found, identity = network.lss.fast_scan()
    assert found and identity == [VENDOR, PRODUCT, REVISION, SERIAL]
    network.lss.send_switch_state_global(network.lss.WAITING_STATE)
    network.lss.send_switch_state_selective(*identity)
    assert network.lss.inquire_node_id() == 0xFF
    network.lss.configure_node_id(42)
    network.lss.configure_bit_timing(2)  # 500 kbit/s
    network.lss.store_configuration()
    network.lss.activate_bit_timing(10)
    assert read_stdout_line(process).startswith("bit-rate 500 kbit/s")
    boot = []
    network.subscribe(0x700 + 42, lambda _id, data, _ts: boot.append(bytes(data)))
    network.lss.send_switch_state_global(network.lss.WAITING_STATE)
    # The node continues its start-up with node-ID 42.
    assert node.sdo[0x1000].raw == 0x0002_0192
    assert boot[:1] == [b"\x00"]
    network.disconnect()
    assert process.stop() == 0
    assert (tmp_path / "params.bin.lss").read_text().startswith("node-id=42")

    # Started unconfigured again: the stored node-ID wins.
    process = DriveProcess(tmp_path, args, node_id=255)
    network = connect(process)
    node = sdo_node(network, 42, eds_file)
    assert node.sdo[0x1018][1].raw == VENDOR
    assert struct.unpack("<I", node.sdo.upload(0x1200, 1))[0] == 0x600 + 42
    network.disconnect()
    assert process.stop() == 0

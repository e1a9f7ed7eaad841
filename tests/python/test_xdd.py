"""The XDD (CiA 311) of canopen-drive-linux (`--write-xdd`) against its EDS (CiA 306,
`--write-eds`), for every profile: well-formed XML with the two ISO 15745 profiles of CiA 311
(device, communication network), parsed back with xml.etree, holds the same objects and
sub-objects with the same names, types, access, PDO mapping, defaults and limits, and states
the same device facts (identity, PDO counts, granularity, LSS, bit rates, dummy usage).
"""

import configparser
import subprocess
import xml.etree.ElementTree as ET

import canopen
import pytest

from conftest import NODE_ID, binary_path

PROFILES = ["generic", "chieftek", "trinamic-pd57", "harmonic-drive"]
CO = "{http://www.canopen.org/xml/1.1}"
XSI_TYPE = "{http://www.w3.org/2001/XMLSchema-instance}type"

# EDS AccessType -> XDD (accessType, the PDO directions it implies). CiA 311 has no rww/rwr: the
# direction is its PDOmapping attribute.
ACCESS = {"const": "const", "ro": "ro", "wo": "wo", "rw": "rw", "rww": "rw", "rwr": "rw"}


def describe(tmp_path, profile, storage=False):
    eds, xdd = tmp_path / f"{profile}.eds", tmp_path / f"{profile}.xdd"
    args = [str(binary_path()), "--profile", profile, "--node-id", str(NODE_ID)]
    if storage:
        args += ["--storage", str(tmp_path / "not-opened.bin")]
    result = subprocess.run(
        [*args, "--write-eds", str(eds), "--write-xdd", str(xdd)], capture_output=True, timeout=10
    )
    assert result.returncode == 0, result.stderr.decode(errors="replace")
    assert not (tmp_path / "not-opened.bin").exists()
    ini = configparser.ConfigParser(interpolation=None)
    ini.optionxform = str
    ini.read(eds)
    return ini, ET.parse(xdd).getroot(), eds


def profiles(root):
    """The (header, body) of each ISO15745Profile, in document order."""
    return [(p.find("ProfileHeader"), p.find("ProfileBody")) for p in root.findall(f"{CO}ISO15745Profile")]


def pdo_mapping(access, flag):
    """The XDD PDOmapping an EDS AccessType and PDOMapping flag stand for."""
    if flag == "0":
        return "no"
    return {"rww": "RPDO", "rwr": "TPDO", "ro": "TPDO", "const": "TPDO", "wo": "RPDO"}.get(access, "optional")


def compare_entry(where, section, element):
    """One VAR (an object or a sub-object) of the EDS against its XDD element."""
    problems = []
    checks = [
        ("ObjectType", "objectType", lambda eds, xdd: int(eds, 0) == int(xdd)),
        ("DataType", "dataType", lambda eds, xdd: int(eds, 0) == int(xdd, 16)),
        ("AccessType", "accessType", lambda eds, xdd: ACCESS[eds] == xdd),
        ("DefaultValue", "defaultValue", lambda eds, xdd: eds == xdd),
        ("LowLimit", "lowLimit", lambda eds, xdd: eds == xdd),
        ("HighLimit", "highLimit", lambda eds, xdd: eds == xdd),
    ]
    for key, attribute, same in checks:
        eds_value, xdd_value = section.get(key), element.get(attribute)
        if (eds_value is None) != (xdd_value is None) or (eds_value is not None and not same(eds_value, xdd_value)):
            problems.append(f"{where} {key}: EDS {eds_value!r}, XDD {attribute} {xdd_value!r}")
    expected = pdo_mapping(section["AccessType"], section["PDOMapping"])
    if element.get("PDOmapping") != expected:
        problems.append(f"{where} PDO mapping: EDS {expected}, XDD {element.get('PDOmapping')!r}")
    return problems


@pytest.mark.parametrize("profile", PROFILES)
def test_the_xdd_has_the_two_profiles_of_cia_311(tmp_path, profile):
    ini, root, _ = describe(tmp_path, profile)
    assert root.tag == f"{CO}ISO15745ProfileContainer"
    (device_header, device), (network_header, network) = profiles(root)
    assert device_header.findtext("ProfileClassID") == "Device"
    assert network_header.findtext("ProfileClassID") == "CommunicationNetwork"
    for header in (device_header, network_header):
        assert header.findtext("ISO15745Reference/ProfileTechnology") == "CANopen"
    assert device.get(XSI_TYPE) == "co:ProfileBody_Device_CANopen"
    assert network.get(XSI_TYPE) == "co:ProfileBody_CommunicationNetwork_CANopen"
    for body in (device, network):
        assert body.get("fileName") == ini["FileInfo"]["FileName"].removesuffix(".eds") + ".xdd"
    identity = device.find(f"{CO}DeviceIdentity")
    info = ini["DeviceInfo"]
    assert identity.findtext(f"{CO}vendorName") == info["VendorName"]
    assert int(identity.findtext(f"{CO}vendorID"), 0) == int(info["VendorNumber"], 0)
    assert identity.findtext(f"{CO}productName") == info["ProductName"]
    assert int(identity.findtext(f"{CO}productID"), 0) == int(info["ProductNumber"], 0)
    assert device.find(f"{CO}DeviceFunction/{CO}capabilities/{CO}characteristicsList/{CO}characteristic") is not None

    features = network.find("NetworkManagement/CANopenGeneralFeatures")
    assert features.get("granularity") == info["Granularity"]
    assert features.get("nrOfRxPDO") == info["NrOfRXPDO"]
    assert features.get("nrOfTxPDO") == info["NrOfTXPDO"]
    assert features.get("layerSettingServiceSlave") == {"0": "false", "1": "true"}[info["LSS_Supported"]]
    assert features.get("bootUpSlave") == {"0": "false", "1": "true"}[info["SimpleBootUpSlave"]]
    rates = {e.get("value") for e in network.findall("TransportLayers/PhysicalLayer/baudRate/supportedBaudRate")}
    eds_rates = {key.removeprefix("BaudRate_") for key, on in info.items() if key.startswith("BaudRate_") and on == "1"}
    assert rates == {f"{rate} Kbps" for rate in eds_rates}
    dummies = [e.get("entry") for e in network.findall("ApplicationLayers/dummyUsage/dummy")]
    assert dummies == [f"{key}={value}" for key, value in ini["DummyUsage"].items()]


@pytest.mark.parametrize("profile", PROFILES)
def test_the_xdd_has_the_objects_types_access_and_defaults_of_the_eds(tmp_path, profile):
    ini, root, eds_path = describe(tmp_path, profile)
    (_, _), (_, network) = profiles(root)
    object_list = network.find(f"ApplicationLayers/{CO}CANopenObjectList")
    objects = {int(o.get("index"), 16): o for o in object_list.findall("CANopenObject")}
    eds_objects = {int(s, 16) for s in ini.sections() if len(s) == 4 and all(c in "0123456789ABCDEF" for c in s)}
    assert set(objects) == eds_objects
    for key in ("mandatoryObjects", "optionalObjects", "manufacturerObjects"):
        assert object_list.get(key) == ini[key[0].upper() + key[1:]]["SupportedObjects"]

    problems = []
    for index, element in sorted(objects.items()):
        section = ini[f"{index:04X}"]
        if element.get("name") != section["ParameterName"]:
            problems.append(f"{index:04X} name {element.get('name')!r}, EDS {section['ParameterName']!r}")
        subs = {int(s.get("subIndex"), 16): s for s in element.findall("CANopenSubObject")}
        if not subs:
            problems += compare_entry(f"{index:04X}", section, element)
            continue
        assert int(element.get("objectType")) == int(section["ObjectType"], 0)
        assert int(element.get("subNumber")) == int(section["SubNumber"], 0) == len(subs)
        eds_subs = {int(s.split("sub")[1], 16) for s in ini.sections() if s.startswith(f"{index:04X}sub")}
        assert set(subs) == eds_subs, f"{index:04X}"
        for sub, sub_element in sorted(subs.items()):
            sub_section = ini[f"{index:04X}sub{sub:X}"]
            where = f"{index:04X}sub{sub}"
            if sub_element.get("name") != sub_section["ParameterName"]:
                problems.append(f"{where} name {sub_element.get('name')!r}, EDS {sub_section['ParameterName']!r}")
            problems += compare_entry(where, sub_section, sub_element)
    assert not problems, "\n".join(problems)

    # What a master makes of both: python-canopen's dictionary of the EDS has every entry the
    # XDD lists, with the XDD's default.
    od = canopen.import_od(str(eds_path), NODE_ID)
    for index, element in objects.items():
        for sub_element in element.findall("CANopenSubObject") or [element]:
            sub = int(sub_element.get("subIndex", "0"), 16)
            var = od[index] if sub_element is element else od[index][sub]
            assert var.name == sub_element.get("name")
            assert var.data_type == int(sub_element.get("dataType"), 16)
            if sub_element.get("defaultValue") is not None:
                assert var.default_raw == sub_element.get("defaultValue")


def test_the_xdd_of_a_drive_with_storage_states_its_store_commands(tmp_path):
    _, root, _ = describe(tmp_path, "harmonic-drive", storage=True)
    store = root.find(".//CANopenObject[@index='1010']")
    values = {s.get("subIndex"): s.get("defaultValue") for s in store.findall("CANopenSubObject")}
    # Harmonic Drive stores groups 1, 2 and 4 (sub 3, "actuator profile parameters", is not used).
    assert values == {"00": "0x4", "01": "0x1", "02": "0x1", "03": "0x0", "04": "0x1"}

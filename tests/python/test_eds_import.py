"""The dictionary from the integrator's EDS (canopen-drive-build).

The generic drive's manufacturer objects are not written in Rust: `examples/eds-import/build.rs`
generates their table from `examples/eds-import/generic-drive.eds` when the program is built.
What a master sees of them:

1. Every object of the source EDS answers over SDO with the source's default value, and the
   entries behave as the source describes them: writable ones take a value within their limits
   and refuse one beyond with the CiA 301 abort codes, a constant refuses every write, a string
   takes no more than its storage.
2. The EDS the drive writes (`--write-eds`, the file 1021h serves) describes each of those
   objects as the source does: names, object types, data types, access, PDO mappability,
   defaults and limits, compared after python-canopen has imported both files.
"""

import canopen
import pytest
from canopen.objectdictionary import ODArray, ODRecord, ODVariable

from conftest import REPO_ROOT
from profile_support import abort_code

SOURCE = REPO_ROOT / "examples" / "eds-import" / "generic-drive.eds"


def source_od():
    return canopen.import_od(str(SOURCE))


def variables(od):
    """Every entry of the manufacturer area: (index, sub) → ODVariable."""
    found = {}
    for index in od.keys():
        if not 0x2000 <= index <= 0x5FFF:
            continue
        obj = od[index]
        if isinstance(obj, ODVariable):
            found[(index, 0)] = obj
        else:
            for sub, var in obj.subindices.items():
                found[(index, sub)] = var
    return found


def test_every_source_object_answers_with_its_default(node):
    entries = variables(source_od())
    assert len(entries) == 15
    for (index, sub), var in entries.items():
        value = node.sdo.upload(index, sub)
        assert var.decode_raw(value) == pytest.approx(var.default), f"{index:04X}sub{sub}"


def test_the_entries_keep_the_rules_of_the_source(node):
    pole_pairs = node.sdo[0x2000]
    pole_pairs.raw = 32
    assert pole_pairs.raw == 32
    assert abort_code(lambda: setattr(pole_pairs, "raw", 33)) == 0x0609_0031  # above HighLimit
    assert abort_code(lambda: setattr(pole_pairs, "raw", 0)) == 0x0609_0032  # below LowLimit
    assert pole_pairs.raw == 32

    motor = node.sdo[0x2001]
    motor[3].raw = 1.25
    assert motor[3].raw == pytest.approx(1.25)
    assert abort_code(lambda: setattr(motor[3], "raw", 100.5)) == 0x0609_0031
    assert abort_code(lambda: setattr(motor[1], "raw", 50_001)) == 0x0609_0031
    assert abort_code(lambda: node.sdo.download(0x2001, 0, bytes([2]))) == 0x0601_0002  # const sub 0

    offsets = node.sdo[0x2002]
    offsets[2].raw = -100
    assert (offsets[1].raw, offsets[2].raw) == (-5, -100)
    assert abort_code(lambda: setattr(offsets[1], "raw", -101)) == 0x0609_0032
    assert abort_code(lambda: node.sdo.upload(0x2002, 3)) == 0x0609_0011  # two elements

    label = node.sdo[0x2003]
    label.raw = "left shoulder joint"  # segmented download
    assert label.raw == "left shoulder joint"
    assert abort_code(lambda: setattr(label, "raw", "x" * 33)) == 0x0607_0012  # 32 bytes of storage

    assert abort_code(lambda: node.sdo.download(0x2004, 0, bytes(4))) == 0x0601_0002  # const
    assert abort_code(lambda: node.sdo.download(0x2006, 0, bytes(2))) == 0x0601_0002  # ro
    assert abort_code(lambda: node.sdo.upload(0x2007, 0)) == 0x0602_0000

    # The RPDO-mappable entry maps into an RPDO and not into a TPDO; the read-only one the
    # other way round.
    for communication, mapping, accepted, refused in ((0x1400, 0x1600, 0x2005, 0x2006), (0x1800, 0x1A00, 0x2006, 0x2005)):
        cob_id = node.sdo[communication][1].raw
        node.sdo[communication][1].raw = cob_id | 0x8000_0000  # not valid: the mapping may change
        node.sdo.download(mapping, 0, bytes([0]))
        node.sdo.download(mapping, 1, (accepted << 16 | 0x10).to_bytes(4, "little"))
        code = abort_code(lambda: node.sdo.download(mapping, 2, (refused << 16 | 0x10).to_bytes(4, "little")))
        assert code == 0x0604_0041, f"{refused:04X}h in {mapping:04X}h"
    node.nmt.send_command(0x82)  # reset communication: the PDO records return to their defaults


def describe(var: ODVariable):
    return {
        "name": var.name,
        "data type": var.data_type,
        "access": var.access_type,
        "default": var.default,
        "low": var.min,
        "high": var.max,
        "pdo": var.pdo_mappable,
    }


def test_the_drives_eds_describes_the_objects_as_the_source_does(eds_file):
    source, written = source_od(), canopen.import_od(str(eds_file))
    manufacturer = sorted(index for index in source.keys() if 0x2000 <= index <= 0x5FFF)
    assert manufacturer == sorted(index for index in written.keys() if 0x2000 <= index <= 0x5FFF)
    for index in manufacturer:
        ours, theirs = written[index], source[index]
        assert (type(ours), ours.name) == (type(theirs), theirs.name), f"{index:04X}"
        if isinstance(theirs, (ODArray, ODRecord)):
            assert sorted(ours.subindices) == sorted(theirs.subindices), f"{index:04X}"
    for (index, sub), var in variables(source).items():
        ours = written[index] if isinstance(written[index], ODVariable) else written[index][sub]
        assert describe(ours) == describe(var), f"{index:04X}sub{sub}"

//! EDS generation (CiA 306, digest §13) from the dictionary's own description.
//!
//! The generated file is the only EDS of a device: masters import it, 1021h serves it, and it
//! cannot drift from the firmware because both come from the same tables. The writer streams
//! into any [`core::fmt::Write`], so it runs without allocation (on the host it usually writes
//! into a `String`).
//!
//! Rules followed for the two tools that matter (python-canopen, CANopenEditor): parent sections
//! before sub-sections, lower-case `sub`, hex always with `0x`, decimal without leading zeros,
//! no empty numeric keys, all seven `DummyNNNN` keys, `$NODEID+0x...` for node-relative values.

use core::fmt::{self, Write};

use super::{Access, Bound, DataType, DefaultValue, DeviceField, Dictionary, Kind, Object, PdoMapping, Var};

/// Facts about the device that the EDS states but the dictionary does not hold.
#[derive(Clone, Copy, Debug)]
pub struct EdsInfo {
    /// `[FileInfo] FileName`.
    pub file_name: &'static str,
    /// `[FileInfo] Description`.
    pub description: &'static str,
    /// `CreationDate`/`ModificationDate` as `mm-dd-yyyy`.
    pub date: &'static str,
    /// `CreationTime`/`ModificationTime` as `hh:mmAM`.
    pub time: &'static str,
    /// `CreatedBy`/`ModifiedBy`.
    pub created_by: &'static str,
    /// Supported bit rates in kbit/s among 10, 20, 50, 125, 250, 500, 800, 1000.
    pub baud_rates: &'static [u16],
    /// Number of RPDOs.
    pub rpdo_count: u16,
    /// Number of TPDOs.
    pub tpdo_count: u16,
    /// LSS slave supported.
    pub lss_supported: bool,
}

impl Default for EdsInfo {
    fn default() -> Self {
        EdsInfo {
            file_name: "canopen-drive.eds",
            description: "CiA 402 drive built on canopen-drive",
            date: "01-01-2026",
            time: "12:00PM",
            created_by: "canopen-drive",
            baud_rates: &[125, 250, 500, 1000],
            rpdo_count: 0,
            tpdo_count: 0,
            lss_supported: false,
        }
    }
}

const BAUD_RATES: [u16; 8] = [10, 20, 50, 125, 250, 500, 800, 1000];

/// Writes the EDS of `od` into `w`.
pub fn write<const B: usize>(od: &Dictionary<B>, info: &EdsInfo, w: &mut impl Write) -> fmt::Result {
    let device = od.device();
    writeln!(w, "[FileInfo]")?;
    writeln!(w, "FileName={}", Clean(info.file_name))?;
    writeln!(w, "FileVersion=1\nFileRevision=0\nEDSVersion=4.0")?;
    writeln!(w, "Description={}", Clean(info.description))?;
    for prefix in ["Creation", "Modification"] {
        writeln!(w, "{prefix}Time={}\n{prefix}Date={}", Clean(info.time), Clean(info.date))?;
    }
    writeln!(w, "CreatedBy={}\nModifiedBy={}", Clean(info.created_by), Clean(info.created_by))?;
    writeln!(w, "\n[DeviceInfo]")?;
    writeln!(w, "VendorName={}", Clean(device.vendor_name))?;
    writeln!(w, "VendorNumber=0x{:08X}", device.vendor_id)?;
    writeln!(w, "ProductName={}", Clean(device.device_name))?;
    writeln!(w, "ProductNumber=0x{:08X}", device.product_code)?;
    writeln!(w, "RevisionNumber=0x{:08X}", device.revision_number)?;
    writeln!(w, "OrderCode={}", Clean(device.device_name))?;
    for rate in BAUD_RATES {
        writeln!(w, "BaudRate_{rate}={}", u8::from(info.baud_rates.contains(&rate)))?;
    }
    writeln!(w, "SimpleBootUpMaster=0\nSimpleBootUpSlave=1\nGranularity=8")?;
    writeln!(w, "DynamicChannelsSupported=0\nGroupMessaging=0")?;
    writeln!(w, "NrOfRXPDO={}\nNrOfTXPDO={}", info.rpdo_count, info.tpdo_count)?;
    writeln!(w, "LSS_Supported={}", u8::from(info.lss_supported))?;
    writeln!(w, "\n[DummyUsage]")?;
    for ty in 1..=7 {
        // BOOLEAN (0001h) is not a dummy a byte-granular device accepts.
        writeln!(w, "Dummy{ty:04X}={}", u8::from(ty != 1))?;
    }
    writeln!(w, "\n[Comments]\nLines=1\nLine1=Generated from the firmware's object dictionary")?;

    for list in [List::Mandatory, List::Optional, List::Manufacturer] {
        writeln!(w, "\n[{}]", list.section())?;
        let listed = |o: &&Object| List::of(o) == list && !od.is_absent(o.index);
        writeln!(w, "SupportedObjects={}", od.objects().filter(listed).count())?;
        for (n, object) in od.objects().filter(listed).enumerate() {
            writeln!(w, "{}=0x{:04X}", n + 1, object.index)?;
        }
    }

    for object in od.objects().filter(|o| !od.is_absent(o.index)) {
        write_object(od, object, w)?;
    }
    Ok(())
}

/// The object lists of an EDS (CiA 306 §4.5).
#[derive(Clone, Copy, PartialEq, Eq)]
enum List {
    Mandatory,
    Optional,
    Manufacturer,
}

impl List {
    fn of(object: &Object) -> List {
        match object.index {
            0x1000 | 0x1001 | 0x1018 => List::Mandatory,
            0x2000..=0x5FFF => List::Manufacturer,
            _ => List::Optional,
        }
    }

    fn section(self) -> &'static str {
        match self {
            List::Mandatory => "MandatoryObjects",
            List::Optional => "OptionalObjects",
            List::Manufacturer => "ManufacturerObjects",
        }
    }
}

/// An object's name with its instance number.
struct ObjectName<'a>(&'a Object);

impl fmt::Display for ObjectName<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        Clean(self.0.name()).fmt(f)?;
        match self.0.number {
            0 => Ok(()),
            n => write!(f, " {n}"),
        }
    }
}

fn write_object<const B: usize>(
    od: &Dictionary<B>,
    object: &'static Object,
    w: &mut impl Write,
) -> fmt::Result {
    let index = object.index;
    match &object.kind {
        Kind::Var(var) => {
            let var = od.describe(index, 0, var);
            writeln!(w, "\n[{index:04X}]\nParameterName={}", ObjectName(object))?;
            write_var(od, var, od.default_of(index, 0, var), w)
        }
        Kind::Array { sub0, element, len } => {
            let len =
                &(1..=od.array_len(index, sub0, *len)).take_while(|sub| !od.hidden(object, *sub)).count();
            let len = &u8::try_from(*len).unwrap_or(u8::MAX);
            writeln!(w, "\n[{index:04X}]\nParameterName={}", ObjectName(object))?;
            writeln!(w, "ObjectType=0x8\nSubNumber=0x{:X}", u16::from(*len) + 1)?;
            let sub0 = od.describe(index, 0, sub0);
            writeln!(w, "\n[{index:04X}sub0]\nParameterName={}", Clean(sub0.name()))?;
            write_var(od, sub0, od.default_of(index, 0, sub0), w)?;
            for sub in 1..=*len {
                let element = od.describe(index, sub, element);
                writeln!(w, "\n[{index:04X}sub{sub:X}]\nParameterName={} {sub}", Clean(element.name()))?;
                write_var(od, element, od.default_of(index, sub, element), w)?;
            }
            Ok(())
        }
        Kind::Record(subs) => {
            writeln!(w, "\n[{index:04X}]\nParameterName={}", ObjectName(object))?;
            let visible = || subs.iter().filter(|(sub, _)| !od.hidden(object, *sub));
            writeln!(w, "ObjectType=0x9\nSubNumber=0x{:X}", visible().count())?;
            for (sub, var) in visible() {
                let var = od.describe(index, *sub, var);
                writeln!(w, "\n[{index:04X}sub{sub:X}]\nParameterName={}", Clean(var.name()))?;
                write_var(od, var, od.default_of(index, *sub, var), w)?;
            }
            Ok(())
        }
    }
}

fn write_var<const B: usize>(
    od: &Dictionary<B>,
    var: &Var,
    default: DefaultValue,
    w: &mut impl Write,
) -> fmt::Result {
    writeln!(w, "ObjectType=0x7\nDataType=0x{:04X}", var.data_type as u16)?;
    let access = match (var.access, var.pdo) {
        (Access::Const, _) => "const",
        (Access::ReadOnly, _) => "ro",
        (Access::WriteOnly, _) => "wo",
        (Access::ReadWrite, PdoMapping::Rpdo) => "rww",
        (Access::ReadWrite, PdoMapping::Tpdo) => "rwr",
        (Access::ReadWrite, _) => "rw",
    };
    writeln!(w, "AccessType={access}")?;
    write_default(od, var, default, w)?;
    writeln!(w, "PDOMapping={}", u8::from(var.pdo != PdoMapping::No))?;
    for (key, bound) in [("LowLimit", var.low()), ("HighLimit", var.high())] {
        match bound {
            Bound::None => {}
            Bound::Signed(v) => writeln!(w, "{key}={v}")?,
            Bound::Unsigned(v) => writeln!(w, "{key}=0x{v:X}")?,
            Bound::Real(v) => writeln!(w, "{key}={v}")?,
        }
    }
    Ok(())
}

fn write_default<const B: usize>(
    od: &Dictionary<B>,
    var: &Var,
    default: DefaultValue,
    w: &mut impl Write,
) -> fmt::Result {
    let device = od.device();
    let number = |value: u64| -> u64 {
        // Numbers are shown in the entry's own width (a signed default as two's complement
        // would otherwise print 16 hex digits).
        match var.data_type.fixed_size() {
            Some(n) if n < 8 => value & ((1u64 << (8 * n)) - 1),
            _ => value,
        }
    };
    match default {
        _ if var.data_type == DataType::Domain => Ok(()),
        DefaultValue::Zero => match var.data_type {
            DataType::VisibleString | DataType::OctetString | DataType::UnicodeString => Ok(()),
            DataType::Real32 | DataType::Real64 => writeln!(w, "DefaultValue=0"),
            _ => writeln!(w, "DefaultValue=0x0"),
        },
        DefaultValue::Unsigned(v) => writeln!(w, "DefaultValue=0x{:X}", number(v)),
        DefaultValue::Signed(v) => writeln!(w, "DefaultValue={v}"),
        DefaultValue::Real(v) => writeln!(w, "DefaultValue={v}"),
        DefaultValue::Text(s) => default_text(s, w),
        DefaultValue::Bytes(b) => {
            if b.is_empty() {
                return Ok(());
            }
            write!(w, "DefaultValue=")?;
            for byte in b {
                write!(w, "{byte:02X}")?;
            }
            writeln!(w)
        }
        DefaultValue::NodeIdPlus(base) => writeln!(w, "DefaultValue=$NODEID+0x{base:X}"),
        // Resolved by `default_of`.
        DefaultValue::PdoPreset => writeln!(w, "DefaultValue=0x0"),
        DefaultValue::Device(field) => {
            let value = match field {
                DeviceField::DeviceType => device.device_type,
                DeviceField::VendorId => device.vendor_id,
                DeviceField::ProductCode => device.product_code,
                DeviceField::RevisionNumber => device.revision_number,
                DeviceField::SerialNumber => device.serial_number,
                DeviceField::DriveModes => device.drive_modes,
                DeviceField::DeviceName => return default_text(device.device_name, w),
                DeviceField::HardwareVersion => return default_text(device.hardware_version, w),
                DeviceField::SoftwareVersion => return default_text(device.software_version, w),
                DeviceField::Eds => return Ok(()),
                // Resolved by `default_of`.
                DeviceField::HomingMethodCount | DeviceField::HomingMethods => 0,
            };
            writeln!(w, "DefaultValue=0x{value:08X}")
        }
    }
}

fn default_text(s: &str, w: &mut impl Write) -> fmt::Result {
    if s.is_empty() {
        Ok(())
    } else {
        writeln!(w, "DefaultValue={}", Clean(s))
    }
}

/// Text made safe for one INI value: control characters become spaces.
struct Clean<'a>(&'a str);

impl fmt::Display for Clean<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            f.write_char(if c.is_control() { ' ' } else { c })?;
        }
        Ok(())
    }
}

/// Counts the bytes [`write()`] produces (to size a buffer for 1021h).
pub fn size<const B: usize>(od: &Dictionary<B>, info: &EdsInfo) -> usize {
    struct Counter(usize);
    impl Write for Counter {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            self.0 += s.len();
            Ok(())
        }
    }
    let mut counter = Counter(0);
    // Writing into a counter cannot fail.
    let _ = write(od, info, &mut counter);
    counter.0
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::String;
    use std::vec::Vec;

    use super::*;
    use crate::od::{layout, standard, DefaultOverride, DeviceInfo, Object};

    static VENDOR: [Object; 2] = layout([
        Object::var(
            0x2000,
            "Limited",
            Var::new("Limited", DataType::Integer16)
                .access(Access::ReadWrite)
                .pdo(PdoMapping::Rpdo)
                .limits_signed(-5, 5),
        ),
        Object::array(0x2001, "Gains", 2, &Var::new("Gain", DataType::Real32).access(Access::ReadWrite)),
    ]);

    fn eds() -> String {
        let info = DeviceInfo { vendor_id: 0x1234, device_name: "Test drive", ..DeviceInfo::servo_drive() };
        let od = Dictionary::<1024>::new(&[&standard::COMMUNICATION, &VENDOR], info, 1).unwrap();
        let mut out = String::new();
        write(&od, &EdsInfo::default(), &mut out).unwrap();
        assert_eq!(size(&od, &EdsInfo::default()), out.len());
        out
    }

    fn section<'a>(eds: &'a str, name: &str) -> Vec<&'a str> {
        let header = std::format!("[{name}]");
        eds.split("\n\n")
            .find(|block| block.trim_start().starts_with(&header))
            .map(|block| block.lines().skip(1).collect())
            .unwrap_or_default()
    }

    #[test]
    fn sections_follow_cia_306() {
        let eds = eds();
        assert!(section(&eds, "DeviceInfo").contains(&"VendorNumber=0x00001234"));
        assert!(section(&eds, "DeviceInfo").contains(&"ProductName=Test drive"));
        assert_eq!(section(&eds, "DummyUsage").len(), 7);
        assert_eq!(
            section(&eds, "MandatoryObjects"),
            ["SupportedObjects=3", "1=0x1000", "2=0x1001", "3=0x1018"]
        );
        assert_eq!(section(&eds, "ManufacturerObjects"), ["SupportedObjects=2", "1=0x2000", "2=0x2001"]);
        assert_eq!(
            section(&eds, "1000"),
            [
                "ParameterName=Device type",
                "ObjectType=0x7",
                "DataType=0x0007",
                "AccessType=ro",
                "DefaultValue=0x00020192",
                "PDOMapping=0"
            ]
        );
        assert_eq!(
            section(&eds, "1018"),
            ["ParameterName=Identity object", "ObjectType=0x9", "SubNumber=0x5"]
        );
        assert!(section(&eds, "1200sub1").contains(&"DefaultValue=$NODEID+0x600"));
        assert!(section(&eds, "2000").contains(&"AccessType=rww"));
        assert!(section(&eds, "2000").contains(&"LowLimit=-5"));
        assert_eq!(section(&eds, "2001"), ["ParameterName=Gains", "ObjectType=0x8", "SubNumber=0x3"]);
        assert!(section(&eds, "2001sub2").contains(&"ParameterName=Gain 2"));
    }

    #[test]
    fn the_firmwares_defaults_are_the_eds_defaults() {
        static OVERRIDES: [DefaultOverride; 2] = [
            DefaultOverride { index: 0x2000, sub: 0, value: DefaultValue::Signed(-3) },
            DefaultOverride { index: 0x2001, sub: 2, value: DefaultValue::Real(0.5) },
        ];
        let mut od =
            Dictionary::<1024>::new(&[&standard::COMMUNICATION, &VENDOR], DeviceInfo::servo_drive(), 1)
                .unwrap();
        od.set_default_overrides(&OVERRIDES).unwrap();
        let mut eds = String::new();
        write(&od, &EdsInfo::default(), &mut eds).unwrap();
        assert!(section(&eds, "2000").contains(&"DefaultValue=-3"));
        assert!(section(&eds, "2001sub1").contains(&"DefaultValue=0"));
        assert!(section(&eds, "2001sub2").contains(&"DefaultValue=0.5"));
    }

    #[test]
    fn parents_come_before_their_sub_sections() {
        let eds = eds();
        let headers: Vec<&str> = eds.lines().filter(|l| l.starts_with('[')).collect();
        for (i, h) in headers.iter().enumerate() {
            if let Some(pos) = h.find("sub") {
                let parent = std::format!("{}]", &h[..pos]);
                assert!(headers[..i].contains(&parent.as_str()), "{h} before its parent");
            }
        }
        // Every numeric key is either hex with 0x or plain decimal.
        for line in eds.lines().filter(|l| l.starts_with("DataType=") || l.starts_with("SubNumber=")) {
            assert!(line.contains("=0x"), "{line}");
        }
    }
}

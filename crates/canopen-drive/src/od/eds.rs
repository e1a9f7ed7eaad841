//! EDS generation (CiA 306) from the dictionary's own description.
//!
//! The generated file is the only EDS of a device: masters import it, 1021h serves it, and it
//! cannot drift from the firmware because both come from the same tables. The writer streams
//! into any [`core::fmt::Write`], so it runs without allocation (on the host it usually writes
//! into a `String`).
//!
//! Rules followed for the two tools that matter (python-canopen, CANopenEditor): parent sections
//! before sub-sections, lower-case `sub`, hex always with `0x`, decimal without leading zeros,
//! no empty numeric keys, all seven `DummyNNNN` keys, `$NODEID+0x...` for node-relative values.
//!
//! Nothing in it is typed in by hand: `[DeviceInfo]` comes from the dictionary (PDO counts,
//! mapping granularity, dummy usage) and from the drive ([`Capabilities`]: bit rates, LSS), and
//! every `DefaultValue` is what the node reads at start-up (1010h/1011h: whether the drive
//! stores; an empty string: `DefaultValue=` with no text). The XDD ([`super::xdd`]) states the
//! same from the same computation.

use core::fmt::{self, Write};

use super::description::{
    self, access_text, for_each_sub, limit_text, value_text, Facts, Filtered, List, Name,
};
use super::{Access, Dictionary, Kind, Object, PdoMapping, Var};
use crate::wire::lss::BitRate::{self, Kbit1000, Kbit125, Kbit250, Kbit500};

/// Facts about the file that the EDS states but neither the dictionary nor the drive holds.
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
}

impl Default for EdsInfo {
    fn default() -> Self {
        EdsInfo {
            file_name: "canopen-drive.eds",
            description: "CiA 402 drive built on canopen-drive",
            date: "01-01-2026",
            time: "12:00PM",
            created_by: "canopen-drive",
        }
    }
}

/// What the drive around the dictionary can do, as a description states it (`[DeviceInfo]`, the
/// store commands' values). [`Drive::write_eds`](crate::Drive::write_eds) takes it from the
/// drive's configuration and its storage, so that the EDS says what the node does; the PDO
/// counts and the mapping granularity come from the dictionary itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// The bit rates the device runs at (`BaudRate_n`; CiA 306 has keys for 10, 20, 50, 125,
    /// 250, 500, 800 and 1000 kbit/s).
    pub bit_rates: &'static [BitRate],
    /// An LSS slave answers (CiA 305; `LSS_Supported`).
    pub lss: bool,
    /// The sub-indices 1–4 of 1010h/1011h that read 1 (bit n for sub-index n): the parameter
    /// groups the drive stores and restores on command. The others read 0.
    pub store_commands: u8,
}

impl Capabilities {
    /// A device at 125, 250, 500 and 1000 kbit/s, without LSS and without parameter storage.
    pub const PLAIN: Capabilities =
        Capabilities { bit_rates: &[Kbit1000, Kbit500, Kbit250, Kbit125], lss: false, store_commands: 0 };
}

/// Writes the EDS of `od`, in a drive that can do what `capabilities` say, into `w`.
pub fn write<const B: usize>(
    od: &Dictionary<B>,
    info: &EdsInfo,
    capabilities: &Capabilities,
    w: &mut impl Write,
) -> fmt::Result {
    let device = od.device();
    let facts = Facts::of(od, capabilities);
    writeln!(w, "[FileInfo]")?;
    writeln!(w, "FileName={}", clean(info.file_name))?;
    writeln!(w, "FileVersion=1\nFileRevision=0\nEDSVersion=4.0")?;
    writeln!(w, "Description={}", clean(info.description))?;
    for prefix in ["Creation", "Modification"] {
        writeln!(w, "{prefix}Time={}\n{prefix}Date={}", clean(info.time), clean(info.date))?;
    }
    writeln!(w, "CreatedBy={}\nModifiedBy={}", clean(info.created_by), clean(info.created_by))?;
    writeln!(w, "\n[DeviceInfo]")?;
    writeln!(w, "VendorName={}", clean(device.vendor_name))?;
    writeln!(w, "VendorNumber=0x{:08X}", device.vendor_id)?;
    writeln!(w, "ProductName={}", clean(device.device_name))?;
    writeln!(w, "ProductNumber=0x{:08X}", device.product_code)?;
    writeln!(w, "RevisionNumber=0x{:08X}", device.revision_number)?;
    writeln!(w, "OrderCode={}", clean(device.device_name))?;
    for rate in description::BIT_RATES {
        writeln!(w, "BaudRate_{rate}={}", u8::from(facts.runs_at(rate)))?;
    }
    writeln!(w, "SimpleBootUpMaster=0\nSimpleBootUpSlave=1\nGranularity={}", facts.granularity)?;
    writeln!(w, "DynamicChannelsSupported=0\nGroupMessaging=0")?;
    writeln!(w, "NrOfRXPDO={}\nNrOfTXPDO={}", facts.rpdos, facts.tpdos)?;
    writeln!(w, "LSS_Supported={}", u8::from(capabilities.lss))?;
    writeln!(w, "\n[DummyUsage]")?;
    for ty in 1..=7 {
        writeln!(w, "Dummy{ty:04X}={}", u8::from(facts.dummy(ty)))?;
    }
    writeln!(w, "\n[Comments]\nLines=1\nLine1=Generated from the firmware's object dictionary")?;

    for list in List::ALL {
        writeln!(w, "\n[{}]", section(list))?;
        writeln!(w, "SupportedObjects={}", list.objects(od).count())?;
        for (n, object) in list.objects(od).enumerate() {
            writeln!(w, "{}=0x{:04X}", n + 1, object.index)?;
        }
    }

    for object in description::listed(od) {
        write_object(od, capabilities, &object, w)?;
    }
    Ok(())
}

/// The EDS section of an object list.
fn section(list: List) -> &'static str {
    match list {
        List::Mandatory => "MandatoryObjects",
        List::Optional => "OptionalObjects",
        List::Manufacturer => "ManufacturerObjects",
    }
}

fn write_object<const B: usize>(
    od: &Dictionary<B>,
    capabilities: &Capabilities,
    object: &Object,
    w: &mut impl Write,
) -> fmt::Result {
    let index = object.index;
    if !matches!(object.kind, Kind::Var(_)) {
        writeln!(w, "\n[{index:04X}]\nParameterName={}", clean(Name::Object(object, od.copy_of(index))))?;
        let code = description::object_code(object);
        writeln!(w, "ObjectType=0x{code:X}\nSubNumber=0x{:X}", description::sub_count(od, object))?;
    }
    for_each_sub(od, capabilities, object, |entry| {
        match object.kind {
            Kind::Var(_) => writeln!(w, "\n[{index:04X}]")?,
            _ => writeln!(w, "\n[{index:04X}sub{:X}]", entry.sub)?,
        }
        writeln!(w, "ParameterName={}", clean(entry.name))?;
        write_var(od, entry.var, entry.default, w)
    })
}

fn write_var<const B: usize>(
    od: &Dictionary<B>,
    var: &Var,
    default: super::DefaultValue,
    w: &mut impl Write,
) -> fmt::Result {
    writeln!(w, "ObjectType=0x7\nDataType=0x{:04X}", var.data_type as u16)?;
    let access = match (var.access, var.pdo) {
        (Access::ReadWrite, PdoMapping::Rpdo) => "rww",
        (Access::ReadWrite, PdoMapping::Tpdo) => "rwr",
        (access, _) => access_text(access),
    };
    writeln!(w, "AccessType={access}")?;
    if let Some(text) = value_text(od, var, default) {
        writeln!(w, "DefaultValue={}", clean(text))?;
    }
    writeln!(w, "PDOMapping={}", u8::from(var.pdo != PdoMapping::No))?;
    for (key, bound) in [("LowLimit", var.low()), ("HighLimit", var.high())] {
        if let Some(text) = limit_text(bound) {
            writeln!(w, "{key}={text}")?;
        }
    }
    Ok(())
}

/// Text made safe for one INI value: control characters become spaces.
fn clean<T: fmt::Display>(text: T) -> Filtered<T> {
    Filtered(text, |c, f| f.write_char(if c.is_control() { ' ' } else { c }))
}

/// Counts the bytes [`write()`] produces (to size a buffer for 1021h).
pub fn size<const B: usize>(od: &Dictionary<B>, info: &EdsInfo, capabilities: &Capabilities) -> usize {
    description::count(|mut w| write(od, info, capabilities, &mut w))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::String;
    use std::vec::Vec;

    use super::*;
    use crate::od::{layout, standard, DataType, DefaultOverride, DefaultValue, DeviceInfo, Object};

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
        write(&od, &EdsInfo::default(), &Capabilities::PLAIN, &mut out).unwrap();
        assert_eq!(size(&od, &EdsInfo::default(), &Capabilities::PLAIN), out.len());
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
    fn device_info_comes_from_the_dictionary_and_the_drive() {
        // Without PDOs, LSS or storage: nothing to map, no dummies, the plain bit rates.
        let plain = eds();
        let device_info = section(&plain, "DeviceInfo");
        for key in ["Granularity=0", "NrOfRXPDO=0", "NrOfTXPDO=0", "LSS_Supported=0", "BaudRate_10=0"] {
            assert!(device_info.contains(&key), "{key}");
        }
        assert!(section(&plain, "DummyUsage").iter().all(|line| line.ends_with("=0")));
        assert!(section(&plain, "1010sub1").contains(&"DefaultValue=0x0"));

        // 3 RPDOs, 2 TPDOs (the crate's mapping takes single bits), LSS, groups 1 and 3 stored.
        static PDOS: [Object; 10] = layout(crate::comm::pdo::objects::<10>(3));
        let od = Dictionary::<4096>::new(
            &[&standard::COMMUNICATION, &PDOS, &VENDOR],
            DeviceInfo::servo_drive(),
            1,
        )
        .unwrap();
        let capabilities =
            Capabilities { bit_rates: &[BitRate::Kbit10, Kbit1000], lss: true, store_commands: 0b1010 };
        let mut text = String::new();
        write(&od, &EdsInfo::default(), &capabilities, &mut text).unwrap();
        let device_info = section(&text, "DeviceInfo");
        for key in ["Granularity=1", "NrOfRXPDO=3", "NrOfTXPDO=2", "LSS_Supported=1", "BaudRate_10=1"] {
            assert!(device_info.contains(&key), "{key}");
        }
        assert!(device_info.contains(&"BaudRate_125=0"));
        assert!(section(&text, "DummyUsage").iter().all(|line| line.ends_with("=1")));
        for (sub, value) in [(1, "0x1"), (2, "0x0"), (3, "0x1"), (4, "0x0")] {
            let default = std::format!("DefaultValue={value}");
            assert!(section(&text, &std::format!("1011sub{sub}")).contains(&default.as_str()), "{sub}");
        }
        assert!(section(&text, "1A01sub8").contains(&"ParameterName=Mapping entry 8"));
    }

    #[test]
    fn empty_strings_have_an_empty_default() {
        static TEXT: [Object; 1] = layout([Object::var(
            0x2000,
            "Catalogue number",
            Var::new("Catalogue number", DataType::VisibleString).access(Access::ReadWrite).capacity(8),
        )]);
        let od = Dictionary::<1024>::new(&[&standard::COMMUNICATION, &TEXT], DeviceInfo::servo_drive(), 1)
            .unwrap();
        let mut text = String::new();
        write(&od, &EdsInfo::default(), &Capabilities::PLAIN, &mut text).unwrap();
        assert!(section(&text, "2000").contains(&"DefaultValue="));
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
        write(&od, &EdsInfo::default(), &Capabilities::PLAIN, &mut eds).unwrap();
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

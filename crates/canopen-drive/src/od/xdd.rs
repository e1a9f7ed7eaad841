//! XDD generation (CiA 311, the XML device description of ISO 15745) from the dictionary's own
//! description: the same objects, types, access, limits and power-on values as the EDS
//! ([`super::eds`]), from the same tables, in the XML form tools that read CiA 311 take.
//!
//! ```text
//! ISO15745ProfileContainer
//! ├── ISO15745Profile  ProfileHeader (class Device)
//! │                    ProfileBody_Device_CANopen: DeviceIdentity, DeviceFunction
//! └── ISO15745Profile  ProfileHeader (class CommunicationNetwork)
//!                      ProfileBody_CommunicationNetwork_CANopen:
//!                        ApplicationLayers   CANopenObjectList (objects and sub-objects), dummyUsage
//!                        TransportLayers     PhysicalLayer: the supported bit rates
//!                        NetworkManagement   CANopenGeneralFeatures: granularity, PDO counts, LSS
//! ```
//!
//! Elements of the CANopen namespace (`http://www.canopen.org/xml/1.1`) carry the `co:` prefix;
//! the profile header and body, and the elements the schema leaves unqualified, carry none.
//! Each object and sub-object states its attributes itself (`dataType`, `accessType`,
//! `defaultValue`, `PDOmapping`, limits), as an EDS section does; there is no parameter list.
//! Access is `const`, `ro`, `wo` or `rw`; the PDO direction that an EDS writes as `rww`/`rwr`
//! is `PDOmapping` `RPDO`/`TPDO` (`optional`: either).
//!
//! Like the EDS writer, it streams into any [`core::fmt::Write`] without allocation.

use core::fmt::{self, Write};

use super::description::{
    self, access_text, for_each_sub, limit_text, value_text, Facts, Filtered, List, Name, Sub,
};
use super::eds::{Capabilities, EdsInfo};
use super::{Dictionary, Kind, Object, PdoMapping};

/// The CANopen namespace of CiA 311 v1.1.
const NAMESPACE: &str = "http://www.canopen.org/xml/1.1";

/// Writes the XDD of `od`, in a drive that can do what `capabilities` say, into `w`. The file
/// facts are the EDS's (`info`; the file name with `.xdd` for `.eds`).
pub fn write<const B: usize>(
    od: &Dictionary<B>,
    info: &EdsInfo,
    capabilities: &Capabilities,
    w: &mut impl Write,
) -> fmt::Result {
    let device = od.device();
    let facts = Facts::of(od, capabilities);
    writeln!(w, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(w, "<!-- Generated from the firmware's object dictionary -->")?;
    writeln!(
        w,
        r#"<co:ISO15745ProfileContainer xmlns:co="{NAMESPACE}" xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance">"#
    )?;

    // The device profile: identity and function.
    header(w, "CANopen device profile", "Device", device.device_name)?;
    body(w, "ProfileBody_Device_CANopen", info)?;
    writeln!(w, "      <co:DeviceIdentity>")?;
    writeln!(w, "        <co:vendorName>{}</co:vendorName>", escape(device.vendor_name))?;
    writeln!(w, "        <co:vendorID>0x{:08X}</co:vendorID>", device.vendor_id)?;
    writeln!(w, "        <co:productName>{}</co:productName>", escape(device.device_name))?;
    writeln!(w, "        <co:productID>0x{:08X}</co:productID>", device.product_code)?;
    for (kind, version) in [("SW", device.software_version), ("HW", device.hardware_version)] {
        writeln!(w, r#"        <co:version versionType="{kind}">{}</co:version>"#, escape(version))?;
    }
    writeln!(w, "      </co:DeviceIdentity>")?;
    writeln!(w, "      <co:DeviceFunction>\n        <co:capabilities>\n          <co:characteristicsList>")?;
    writeln!(w, "            <co:characteristic>")?;
    writeln!(
        w,
        r#"              <co:characteristicName><label lang="en">Device type</label></co:characteristicName>"#
    )?;
    writeln!(
        w,
        r#"              <co:characteristicContent><label lang="en">0x{:08X}</label></co:characteristicContent>"#,
        device.device_type
    )?;
    writeln!(w, "            </co:characteristic>")?;
    writeln!(
        w,
        "          </co:characteristicsList>\n        </co:capabilities>\n      </co:DeviceFunction>"
    )?;
    writeln!(w, "    </ProfileBody>\n  </co:ISO15745Profile>")?;

    // The communication network profile: the objects, the bus, the network management.
    header(w, "CANopen communication network profile", "CommunicationNetwork", device.device_name)?;
    body(w, "ProfileBody_CommunicationNetwork_CANopen", info)?;
    writeln!(w, "      <ApplicationLayers>")?;
    let [mandatory, optional, manufacturer] = List::ALL.map(|list| list.objects(od).count());
    writeln!(
        w,
        r#"        <co:CANopenObjectList mandatoryObjects="{mandatory}" optionalObjects="{optional}" manufacturerObjects="{manufacturer}">"#
    )?;
    for object in description::listed(od) {
        write_object(od, capabilities, &object, w)?;
    }
    writeln!(w, "        </co:CANopenObjectList>")?;
    writeln!(w, "        <dummyUsage>")?;
    for ty in 1..=7 {
        writeln!(w, r#"          <dummy entry="Dummy{ty:04X}={}"/>"#, u8::from(facts.dummy(ty)))?;
    }
    writeln!(w, "        </dummyUsage>\n      </ApplicationLayers>")?;
    writeln!(w, "      <TransportLayers>\n        <PhysicalLayer>\n          <baudRate>")?;
    for rate in description::BIT_RATES.into_iter().filter(|rate| facts.runs_at(*rate)) {
        writeln!(w, r#"            <supportedBaudRate value="{rate} Kbps"/>"#)?;
    }
    writeln!(w, "          </baudRate>\n        </PhysicalLayer>\n      </TransportLayers>")?;
    writeln!(w, "      <NetworkManagement>")?;
    writeln!(
        w,
        r#"        <CANopenGeneralFeatures groupMessaging="false" dynamicChannels="0" selfStartingDevice="false" SDORequestingDevice="false" granularity="{}" nrOfRxPDO="{}" nrOfTxPDO="{}" bootUpSlave="true" layerSettingServiceSlave="{}"/>"#,
        facts.granularity, facts.rpdos, facts.tpdos, capabilities.lss
    )?;
    writeln!(w, "      </NetworkManagement>")?;
    writeln!(w, "    </ProfileBody>\n  </co:ISO15745Profile>")?;
    writeln!(w, "</co:ISO15745ProfileContainer>")
}

/// Opens a profile with its header (ISO 15745-1).
fn header(w: &mut impl Write, identification: &str, class: &str, name: &str) -> fmt::Result {
    writeln!(w, "  <co:ISO15745Profile>\n    <ProfileHeader>")?;
    writeln!(w, "      <ProfileIdentification>{identification}</ProfileIdentification>")?;
    writeln!(w, "      <ProfileRevision>1.1</ProfileRevision>")?;
    writeln!(w, "      <ProfileName>{}</ProfileName>\n      <ProfileSource/>", escape(name))?;
    writeln!(w, "      <ProfileClassID>{class}</ProfileClassID>")?;
    writeln!(w, "      <ISO15745Reference>")?;
    writeln!(w, "        <ISO15745Part>1</ISO15745Part>\n        <ISO15745Edition>1</ISO15745Edition>")?;
    writeln!(w, "        <ProfileTechnology>CANopen</ProfileTechnology>")?;
    writeln!(w, "      </ISO15745Reference>\n    </ProfileHeader>")
}

/// Opens a profile body of schema type `kind` with the file's attributes.
fn body(w: &mut impl Write, kind: &str, info: &EdsInfo) -> fmt::Result {
    write!(w, r#"    <ProfileBody xsi:type="co:{kind}" fileName=""#)?;
    match info.file_name.strip_suffix(".eds") {
        Some(stem) => write!(w, "{}.xdd", escape(stem))?,
        None => write!(w, "{}", escape(info.file_name))?,
    }
    write!(w, r#"" fileCreator="{}" fileCreationDate=""#, escape(info.created_by))?;
    // `mm-dd-yyyy` becomes `yyyy-mm-dd`, `hh:mmAM` becomes `HH:MM:00`.
    match (info.date.get(0..2), info.date.get(3..5), info.date.get(6..10)) {
        (Some(month), Some(day), Some(year)) => {
            write!(w, "{}-{}-{}", escape(year), escape(month), escape(day))?
        }
        _ => write!(w, "{}", escape(info.date))?,
    }
    write!(w, r#"" fileCreationTime=""#)?;
    let hour = info.time.get(0..2).and_then(|h| h.parse::<u8>().ok());
    match (hour, info.time.get(3..5), info.time.get(5..)) {
        (Some(hour), Some(minute), Some(half)) => {
            let hour = hour % 12 + if half.eq_ignore_ascii_case("PM") { 12 } else { 0 };
            write!(w, "{hour:02}:{}:00", escape(minute))?;
        }
        _ => write!(w, "{}", escape(info.time))?,
    }
    writeln!(w, r#"" fileVersion="1">"#)
}

fn write_object<const B: usize>(
    od: &Dictionary<B>,
    capabilities: &Capabilities,
    object: &Object,
    w: &mut impl Write,
) -> fmt::Result {
    let index = object.index;
    let code = description::object_code(object);
    write!(
        w,
        r#"          <CANopenObject index="{index:04X}" name="{}" objectType="{code}""#,
        escape(Name::Object(object, od.copy_of(object.index)))
    )?;
    if let Kind::Var(_) = object.kind {
        return for_each_sub(od, capabilities, object, |entry| {
            write_attributes(od, &entry, w)?;
            writeln!(w, "/>")
        });
    }
    writeln!(w, r#" subNumber="{}">"#, description::sub_count(od, object))?;
    for_each_sub(od, capabilities, object, |entry| {
        write!(
            w,
            r#"            <CANopenSubObject subIndex="{:02X}" name="{}" objectType="7""#,
            entry.sub,
            escape(entry.name)
        )?;
        write_attributes(od, &entry, w)?;
        writeln!(w, "/>")
    })?;
    writeln!(w, "          </CANopenObject>")
}

/// The attributes of one entry: type, access, power-on value, PDO mapping, limits.
fn write_attributes<const B: usize>(od: &Dictionary<B>, entry: &Sub<'_>, w: &mut impl Write) -> fmt::Result {
    let var = entry.var;
    write!(w, r#" dataType="{:04X}" accessType="{}""#, var.data_type as u16, access_text(var.access))?;
    if let Some(text) = value_text(od, var, entry.default) {
        write!(w, r#" defaultValue="{}""#, escape(text))?;
    }
    let mapping = match var.pdo {
        PdoMapping::No => "no",
        PdoMapping::Rpdo => "RPDO",
        PdoMapping::Tpdo => "TPDO",
        PdoMapping::Both => "optional",
    };
    write!(w, r#" PDOmapping="{mapping}""#)?;
    for (key, bound) in [("lowLimit", var.low()), ("highLimit", var.high())] {
        if let Some(text) = limit_text(bound) {
            write!(w, r#" {key}="{text}""#)?;
        }
    }
    Ok(())
}

/// Text made safe for XML content and attribute values: the five markup characters as entity
/// references, control characters (which XML 1.0 does not allow) as spaces.
fn escape<T: fmt::Display>(text: T) -> Filtered<T> {
    Filtered(text, |c, f| match c {
        '&' => f.write_str("&amp;"),
        '<' => f.write_str("&lt;"),
        '>' => f.write_str("&gt;"),
        '"' => f.write_str("&quot;"),
        '\'' => f.write_str("&apos;"),
        c if c.is_control() => f.write_char(' '),
        c => f.write_char(c),
    })
}

/// Counts the bytes [`write()`] produces.
pub fn size<const B: usize>(od: &Dictionary<B>, info: &EdsInfo, capabilities: &Capabilities) -> usize {
    description::count(|mut w| write(od, info, capabilities, &mut w))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::String;

    use super::*;
    use crate::od::{layout, standard, Access, DataType, DefaultValue, DeviceInfo, Var};

    static VENDOR: [Object; 2] = layout([
        Object::var(
            0x2000,
            "Limited <&>",
            Var::new("Limited <&>", DataType::Integer16)
                .access(Access::ReadWrite)
                .pdo(PdoMapping::Rpdo)
                .limits_signed(-5, 5)
                .default(DefaultValue::Signed(-3)),
        ),
        Object::array(0x2001, "Gains", 2, &Var::new("Gain", DataType::Real32).access(Access::ReadWrite)),
    ]);

    fn xdd(capabilities: &Capabilities) -> String {
        let info =
            DeviceInfo { vendor_id: 0x1234, device_name: "Test \"drive\"", ..DeviceInfo::servo_drive() };
        let od = Dictionary::<1024>::new(&[&standard::COMMUNICATION, &VENDOR], info, 1).unwrap();
        let mut out = String::new();
        write(&od, &EdsInfo::default(), capabilities, &mut out).unwrap();
        assert_eq!(size(&od, &EdsInfo::default(), capabilities), out.len());
        out
    }

    #[test]
    fn objects_carry_the_eds_attributes() {
        let xdd = xdd(&Capabilities::PLAIN);
        assert!(xdd.contains(
            r#"<CANopenObject index="1000" name="Device type" objectType="7" dataType="0007" accessType="ro" defaultValue="0x00020192" PDOmapping="no"/>"#
        ));
        assert!(xdd.contains(
            r#"<CANopenObject index="2000" name="Limited &lt;&amp;&gt;" objectType="7" dataType="0003" accessType="rw" defaultValue="-3" PDOmapping="RPDO" lowLimit="-5" highLimit="5"/>"#
        ));
        assert!(xdd.contains(r#"<CANopenObject index="2001" name="Gains" objectType="8" subNumber="3">"#));
        assert!(xdd.contains(
            r#"<CANopenSubObject subIndex="02" name="Gain 2" objectType="7" dataType="0008" accessType="rw" defaultValue="0" PDOmapping="no"/>"#
        ));
        assert!(xdd.contains(r#"<CANopenSubObject subIndex="01" name="COB-ID client to server (rx)" objectType="7" dataType="0007" accessType="ro" defaultValue="$NODEID+0x600""#));
        assert!(xdd.contains(r#"<co:productName>Test &quot;drive&quot;</co:productName>"#));
        let optional = standard::COMMUNICATION.len() - 3;
        let lists =
            std::format!(r#"mandatoryObjects="3" optionalObjects="{optional}" manufacturerObjects="2""#);
        assert!(xdd.contains(&lists), "{xdd}");
        assert!(xdd.contains(r#"fileName="canopen-drive.xdd" fileCreator="canopen-drive" fileCreationDate="2026-01-01" fileCreationTime="12:00:00""#));
    }

    #[test]
    fn network_management_states_the_capabilities() {
        let plain = xdd(&Capabilities::PLAIN);
        assert!(plain.contains(r#"granularity="0" nrOfRxPDO="0" nrOfTxPDO="0" bootUpSlave="true" layerSettingServiceSlave="false"/>"#));
        assert!(plain.contains(
            "<supportedBaudRate value=\"125 Kbps\"/>\n            <supportedBaudRate value=\"250 Kbps\"/>"
        ));
        assert!(!plain.contains("\"10 Kbps\""));
        assert!(plain.contains(r#"<dummy entry="Dummy0002=0"/>"#));
        let lss = xdd(&Capabilities {
            bit_rates: &[crate::wire::lss::BitRate::Kbit10],
            lss: true,
            store_commands: 0b10,
        });
        assert!(lss.contains(r#"layerSettingServiceSlave="true""#));
        assert!(lss.contains(
            "<baudRate>\n            <supportedBaudRate value=\"10 Kbps\"/>\n          </baudRate>"
        ));
        // 1010h sub 1 reads 1, the others 0.
        assert!(lss.contains(r#"<CANopenSubObject subIndex="01" name="Store parameters 1" objectType="7" dataType="0007" accessType="rw" defaultValue="0x1""#));
        assert!(lss.contains(r#"<CANopenSubObject subIndex="02" name="Store parameters 2" objectType="7" dataType="0007" accessType="rw" defaultValue="0x0""#));
    }

    #[test]
    fn elements_open_and_close_in_order() {
        // A well-formedness check without a parser: every element that opens closes, in order.
        let xdd = xdd(&Capabilities::PLAIN);
        let mut open: std::vec::Vec<&str> = std::vec::Vec::new();
        for tag in xdd.split('<').skip(1).map(|t| &t[..t.find('>').unwrap()]) {
            if tag.starts_with('?') || tag.starts_with('!') || tag.ends_with('/') {
                continue;
            }
            let name = tag.split_whitespace().next().unwrap();
            match name.strip_prefix('/') {
                Some(closing) => assert_eq!(open.pop(), Some(closing)),
                None => open.push(name),
            }
        }
        assert!(open.is_empty(), "{open:?}");
    }
}

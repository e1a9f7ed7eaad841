//! Reading an EDS (CiA 306): the INI sections and the objects they describe.
//!
//! Only what a table needs is kept: per object its index, name and kind, per entry its name,
//! data type, access, PDO mappability, default and limits. The device sections
//! (`[FileInfo]`, `[DeviceInfo]`, the object lists) describe the device, not its objects, and
//! are not read: the objects are found by their section names (`[2000]`, `[2000sub1]`), as
//! python-canopen finds them.

use std::collections::BTreeMap;

use crate::Error;

/// One INI section: its keys in lower case, each with its last value.
type Section = BTreeMap<String, String>;

/// The sections of an object: the top one and its sub-sections by sub-index.
#[derive(Default)]
struct ObjectSections {
    top: Option<Section>,
    subs: BTreeMap<u8, Section>,
}

/// An object as the EDS describes it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct EdsObject {
    pub index: u16,
    pub name: String,
    pub kind: EdsKind,
}

/// How the sub-indices are organised (`ObjectType`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum EdsKind {
    /// 0x7.
    Var(EdsVar),
    /// 0x8: the entries by sub-index, sub 0 included.
    Array(Vec<(u8, EdsVar)>),
    /// 0x9: the entries by sub-index, sub 0 included.
    Record(Vec<(u8, EdsVar)>),
}

/// One entry: a VAR or a sub-index.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct EdsVar {
    pub name: String,
    pub data_type: u16,
    /// `AccessType` in lower case.
    pub access: String,
    pub pdo_mapping: bool,
    pub default: Option<String>,
    pub low: Option<String>,
    pub high: Option<String>,
}

/// The objects of an EDS text, ascending by index.
pub(crate) fn parse(text: &str) -> Result<Vec<EdsObject>, Error> {
    let mut objects: BTreeMap<u16, ObjectSections> = BTreeMap::new();
    // The section being read, when it belongs to an object.
    let mut current: Option<(u16, Option<u8>)> = None;
    for (number, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with(';') || line.starts_with('#') {
            continue;
        }
        if let Some(name) = line.strip_prefix('[') {
            let name = name
                .strip_suffix(']')
                .ok_or_else(|| Error::syntax(number + 1, format!("unterminated section name {line:?}")))?;
            current = object_section(name);
            if let Some((index, sub)) = current {
                let sections = objects.entry(index).or_default();
                let fresh = match sub {
                    None => sections.top.replace(Section::new()).is_none(),
                    Some(sub) => sections.subs.insert(sub, Section::new()).is_none(),
                };
                if !fresh {
                    return Err(Error::syntax(number + 1, format!("section [{name}] appears twice")));
                }
            }
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(Error::syntax(number + 1, format!("neither a section nor key=value: {line:?}")));
        };
        let Some((index, sub)) = current else { continue };
        let sections = objects.entry(index).or_default();
        let section = match sub {
            None => sections.top.get_or_insert_with(Section::new),
            Some(sub) => sections.subs.entry(sub).or_default(),
        };
        let value = value.trim();
        if !value.is_empty() {
            section.insert(key.trim().to_ascii_lowercase(), value.to_string());
        }
    }
    objects.into_iter().map(|(index, sections)| object(index, sections)).collect()
}

/// `2000` → (2000h, None); `2000sub1A` → (2000h, Some(1Ah)); anything else → None.
fn object_section(name: &str) -> Option<(u16, Option<u8>)> {
    let lower = name.to_ascii_lowercase();
    let (index, sub) = match lower.split_once("sub") {
        Some((index, sub)) => (index, Some(sub)),
        None => (lower.as_str(), None),
    };
    if index.len() != 4 {
        return None;
    }
    let index = u16::from_str_radix(index, 16).ok()?;
    match sub {
        None => Some((index, None)),
        Some(sub) => Some((index, Some(u8::from_str_radix(sub, 16).ok()?))),
    }
}

fn object(index: u16, sections: ObjectSections) -> Result<EdsObject, Error> {
    let Some(top) = sections.top else {
        return Err(Error::object(index, None, "sub-sections without the object's own section"));
    };
    if top.contains_key("compactsubobj") {
        return Err(Error::object(
            index,
            None,
            "CompactSubObj is not supported: write the sub-indices as [XXXXsubN] sections",
        ));
    }
    let name = required(&top, "parametername", index, None)?.to_string();
    let object_type = match top.get("objecttype") {
        Some(text) => number(text).ok_or_else(|| Error::object(index, None, "ObjectType is not a number"))?,
        None => 0x7,
    };
    let subs = || -> Result<Vec<(u8, EdsVar)>, Error> {
        if sections.subs.is_empty() {
            return Err(Error::object(index, None, "an ARRAY or RECORD without sub-sections"));
        }
        if let Some(count) = top.get("subnumber") {
            if number(count) != Some(sections.subs.len() as u64) {
                return Err(Error::object(
                    index,
                    None,
                    format!("SubNumber {count} but {} sub-sections", sections.subs.len()),
                ));
            }
        }
        sections.subs.iter().map(|(sub, section)| Ok((*sub, var(section, index, Some(*sub))?))).collect()
    };
    let kind = match object_type {
        0x7 => {
            if !sections.subs.is_empty() {
                return Err(Error::object(index, None, "a VAR with sub-sections"));
            }
            EdsKind::Var(var(&top, index, None)?)
        }
        0x8 => EdsKind::Array(subs()?),
        0x9 => EdsKind::Record(subs()?),
        other => {
            return Err(Error::object(
                index,
                None,
                format!("ObjectType 0x{other:X} is not supported (VAR 0x7, ARRAY 0x8, RECORD 0x9 are)"),
            ))
        }
    };
    Ok(EdsObject { index, name, kind })
}

fn var(section: &Section, index: u16, sub: Option<u8>) -> Result<EdsVar, Error> {
    let data_type = required(section, "datatype", index, sub)?;
    let data_type = number(data_type)
        .and_then(|n| u16::try_from(n).ok())
        .ok_or_else(|| Error::object(index, sub, format!("DataType {data_type} is not a number")))?;
    let pdo_mapping = match section.get("pdomapping").map(String::as_str) {
        None | Some("0") => false,
        Some("1") => true,
        Some(other) => return Err(Error::object(index, sub, format!("PDOMapping {other} (0 or 1)"))),
    };
    Ok(EdsVar {
        name: required(section, "parametername", index, sub)?.to_string(),
        data_type,
        access: required(section, "accesstype", index, sub)?.to_ascii_lowercase(),
        pdo_mapping,
        default: section.get("defaultvalue").cloned(),
        low: section.get("lowlimit").cloned(),
        high: section.get("highlimit").cloned(),
    })
}

fn required<'a>(section: &'a Section, key: &str, index: u16, sub: Option<u8>) -> Result<&'a str, Error> {
    section.get(key).map(String::as_str).ok_or_else(|| Error::object(index, sub, format!("no {key}")))
}

/// A number in one of CiA 306's notations: decimal, hexadecimal with `0x`, octal with a
/// leading `0`. Negative values are not numbers here (see [`signed`]).
pub(crate) fn number(text: &str) -> Option<u64> {
    let text = text.trim();
    if let Some(hex) = text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        u64::from_str_radix(hex, 16).ok()
    } else if text.len() > 1 && text.starts_with('0') {
        u64::from_str_radix(text.get(1..)?, 8).ok()
    } else {
        text.parse().ok()
    }
}

/// A number of a signed type `bits` wide: decimal with an optional `-`, or hexadecimal and
/// octal read as the type's two's complement (as python-canopen reads them).
pub(crate) fn signed(text: &str, bits: u32) -> Option<i64> {
    let text = text.trim();
    if let Some(magnitude) = text.strip_prefix('-') {
        let value = i64::try_from(number(magnitude)?).ok()?.checked_neg()?;
        return fits_signed(value, bits).then_some(value);
    }
    if text.starts_with('0') && text.len() > 1 {
        let raw = number(text)?;
        if bits < 64 && raw >> bits != 0 {
            return None;
        }
        let shift = 64 - bits;
        return Some(((raw << shift) as i64) >> shift);
    }
    let value: i64 = text.parse().ok()?;
    fits_signed(value, bits).then_some(value)
}

fn fits_signed(value: i64, bits: u32) -> bool {
    bits >= 64 || (-(1i64 << (bits - 1))..(1i64 << (bits - 1))).contains(&value)
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_every_notation() {
        assert_eq!(number("0x1F"), Some(31));
        assert_eq!(number("0X1f"), Some(31));
        assert_eq!(number("017"), Some(15));
        assert_eq!(number("0"), Some(0));
        assert_eq!(number("42"), Some(42));
        assert_eq!(number("-1"), None);
        assert_eq!(number("0x"), None);
        assert_eq!(signed("-3000", 16), Some(-3000));
        assert_eq!(signed("0xFFFF", 16), Some(-1));
        assert_eq!(signed("0x7FFF", 16), Some(0x7FFF));
        assert_eq!(signed("0x10000", 16), None);
        assert_eq!(signed("40000", 16), None);
        assert_eq!(signed("-32768", 16), Some(-32768));
        assert_eq!(signed("-32769", 16), None);
        assert_eq!(signed("0xFFFFFFFFFFFFFFFF", 64), Some(-1));
    }

    #[test]
    fn sections_of_objects_and_their_subs() {
        assert_eq!(object_section("2000"), Some((0x2000, None)));
        assert_eq!(object_section("2000sub1A"), Some((0x2000, Some(0x1A))));
        assert_eq!(object_section("1A00Sub3"), Some((0x1A00, Some(3))));
        assert_eq!(object_section("DeviceInfo"), None);
        assert_eq!(object_section("Comments"), None);
        assert_eq!(object_section("2000sub100"), None);
    }

    #[test]
    fn objects_by_index_with_their_entries() {
        let text = "[FileInfo]\nFileName=x.eds\n\n[2001]\nParameterName=Gains\nObjectType=0x8\n\
                    SubNumber=2\n\n[2001sub0]\nParameterName=Highest sub-index supported\n\
                    DataType=0x0005\nAccessType=const\nDefaultValue=1\n\n[2001sub1]\n\
                    ParameterName=Gain 1\nDataType=0x0008\nAccessType=rw\nDefaultValue=0.5\n\
                    ; a comment\n[2000]\nParameterName=Pole pairs\nDataType=5\nAccessType=rww\n\
                    PDOMapping=1\nLowLimit=1\nHighLimit=\n";
        let objects = parse(text).unwrap();
        assert_eq!(objects.len(), 2);
        assert_eq!(objects[0].index, 0x2000);
        let EdsKind::Var(var) = &objects[0].kind else { panic!("{:?}", objects[0]) };
        assert_eq!((var.data_type, var.access.as_str(), var.pdo_mapping), (5, "rww", true));
        assert_eq!((var.low.as_deref(), var.high.as_deref()), (Some("1"), None));
        let EdsKind::Array(subs) = &objects[1].kind else { panic!("{:?}", objects[1]) };
        assert_eq!(subs.iter().map(|(s, _)| *s).collect::<Vec<_>>(), [0, 1]);
        assert_eq!(subs[1].1.default.as_deref(), Some("0.5"));
    }

    #[test]
    fn what_cannot_be_read_is_named() {
        let cases = [
            ("[2000\n", "line 1"),
            ("[2000]\nParameterName=x\nDataType=7\nAccessType=rw\n[2000]\n", "appears twice"),
            ("[2000]\nDataType=7\nAccessType=rw\n", "no parametername"),
            ("[2000]\nParameterName=x\nObjectType=0x9\nSubNumber=2\n[2000sub0]\nParameterName=n\nDataType=5\nAccessType=ro\n", "SubNumber 2 but 1"),
            ("[2000]\nParameterName=x\nObjectType=0x2\n", "ObjectType 0x2"),
            ("[2000]\nParameterName=x\nObjectType=0x8\nCompactSubObj=4\n", "CompactSubObj"),
            ("[2000sub1]\nParameterName=x\n", "without the object's own section"),
            ("[2000]\nParameterName=x\nDataType=7\nAccessType=rw\nPDOMapping=2\n", "PDOMapping 2"),
            ("[2000]\nnot a key\n", "neither a section"),
        ];
        for (text, expected) in cases {
            let error = parse(text).unwrap_err().to_string();
            assert!(error.contains(expected), "{text:?}: {error}");
        }
    }
}

//! `ballpod.eds` (CiA 306): the committed file is the generated one, it is well-formed, and
//! every entry it declares behaves that way on the bus (a fresh node answers SDO uploads with
//! the declared type and default value, refuses writes beyond the declared limits, and has no
//! object the EDS does not declare).
use std::collections::BTreeMap;

use ballpod::config::FIELDS;
use ballpod::protocol::canopen::{CanFrame, CanOpenNode};
use ballpod::protocol::pod::PodModel;

const NODE: u8 = 5;

type Ini = BTreeMap<String, BTreeMap<String, String>>;

fn parse_ini(text: &str) -> Ini {
    let mut ini = Ini::new();
    let mut section = String::new();
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with(';') {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = name.to_ascii_uppercase();
            assert!(!ini.contains_key(&section), "duplicate section [{name}]");
            ini.insert(section.clone(), BTreeMap::new());
            continue;
        }
        let (k, v) = line.split_once('=').expect("key=value");
        let prev = ini
            .get_mut(&section)
            .expect("key before any section")
            .insert(k.to_string(), v.to_string());
        assert!(prev.is_none(), "duplicate key {k} in [{section}]");
    }
    ini
}

fn generated() -> String {
    let mut s = String::new();
    ballpod::protocol::canopen::eds::write_eds(&mut s).unwrap();
    s
}

#[test]
fn committed_eds_is_the_generated_one() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../ballpod.eds");
    let committed = std::fs::read_to_string(path).expect("ballpod.eds at the repository root");
    assert!(
        committed == generated(),
        "ballpod.eds is stale: run `cargo run --manifest-path host-tests/Cargo.toml --target host-tuple --bin gen-eds -- ballpod.eds`"
    );
}

fn int(s: &str) -> i64 {
    let s = s.replace("$NODEID+", "");
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => i64::from_str_radix(h, 16).unwrap(),
        None => s.parse().unwrap(),
    }
}

/// (index, sub) → key/values of every entry section, with sub = None for VAR objects.
fn entries(ini: &Ini) -> Vec<(u16, u8, &BTreeMap<String, String>)> {
    let mut out = Vec::new();
    for (name, keys) in ini {
        if name.len() == 4 && u16::from_str_radix(name, 16).is_ok() {
            if keys["ObjectType"] == "0x7" {
                out.push((u16::from_str_radix(name, 16).unwrap(), 0, keys));
            }
        } else if let Some((i, s)) = name.split_once("SUB") {
            out.push((
                u16::from_str_radix(i, 16).unwrap(),
                u8::from_str_radix(s, 16).unwrap(),
                keys,
            ));
        }
    }
    out
}

#[test]
fn eds_structure_is_consistent() {
    let ini = parse_ini(&generated());
    for key in [
        "FileInfo",
        "DeviceInfo",
        "MandatoryObjects",
        "OptionalObjects",
        "ManufacturerObjects",
    ] {
        assert!(ini.contains_key(&key.to_ascii_uppercase()), "[{key}]");
    }
    let mut listed = Vec::new();
    for list in ["MANDATORYOBJECTS", "OPTIONALOBJECTS", "MANUFACTUREROBJECTS"] {
        let l = &ini[list];
        let n: usize = l["SupportedObjects"].parse().unwrap();
        for k in 1..=n {
            listed.push(int(&l[&k.to_string()]) as u16);
        }
    }
    // CiA 301 §7.4: 0x1000, 0x1001 and 0x1018 are mandatory.
    assert_eq!(&listed[..3], &[0x1000, 0x1001, 0x1018]);
    let objects: Vec<u16> = ini
        .keys()
        .filter(|s| s.len() == 4)
        .filter_map(|s| u16::from_str_radix(s, 16).ok())
        .collect();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(sorted, objects, "every object section listed once");
    for &o in &objects {
        let keys = &ini[&format!("{o:04X}")];
        let kind = keys["ObjectType"].as_str();
        if kind == "0x8" || kind == "0x9" {
            let subs = ini
                .keys()
                .filter(|s| s.starts_with(&format!("{o:04X}SUB")))
                .count();
            assert_eq!(
                keys["SubNumber"].parse::<usize>().unwrap(),
                subs,
                "SubNumber of {o:04X}"
            );
        } else {
            assert_eq!(kind, "0x7");
        }
    }
    let dev = &ini["DEVICEINFO"];
    assert_eq!(dev["NrOfTXPDO"], "4");
    assert_eq!(
        int(&ini["1018SUB2"]["DefaultValue"]),
        int(&dev["ProductNumber"])
    );
}

#[test]
fn every_config_field_has_its_object_with_the_table_range() {
    let ini = parse_ini(&generated());
    for (i, f) in FIELDS.iter().enumerate() {
        let sec = format!("{:04X}", 0x2000 + i);
        let o = &ini[&sec];
        assert_eq!(o["ParameterName"], f.name);
        let var = if o["ObjectType"] == "0x7" {
            o
        } else {
            &ini[&format!("{sec}SUB1")]
        };
        assert_eq!(var["DataType"], "0x0008", "REAL32");
        assert_eq!(var["AccessType"], "rw");
        assert_eq!(var["LowLimit"].parse::<f64>().unwrap(), f.min, "{}", f.name);
        assert_eq!(
            var["HighLimit"].parse::<f64>().unwrap(),
            f.max,
            "{}",
            f.name
        );
    }
}

struct Node {
    node: CanOpenNode,
    pod: PodModel,
}

impl Node {
    fn new() -> Self {
        let mut n = Self {
            node: CanOpenNode::new(NODE, 0),
            pod: PodModel::default(),
        };
        n.node.poll(0, &n.pod, &mut |_| {});
        n
    }
    fn sdo(&mut self, req: [u8; 8]) -> [u8; 8] {
        let mut out = Vec::new();
        let f = CanFrame::new(0x600 + u16::from(NODE), &req).unwrap();
        self.node
            .on_frame(&f, &mut self.pod, 0, &mut |f| out.push(f));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].id, 0x580 + u16::from(NODE));
        out[0].data
    }
    /// Upload (expedited or segmented): data or abort code.
    fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, u32> {
        let i = index.to_le_bytes();
        let r = self.sdo([0x40, i[0], i[1], sub, 0, 0, 0, 0]);
        match r[0] {
            0x80 => Err(u32::from_le_bytes(r[4..8].try_into().unwrap())),
            0x41 => {
                let mut data = Vec::new();
                let mut t = 0;
                loop {
                    let s = self.sdo([0x60 | t << 4, 0, 0, 0, 0, 0, 0, 0]);
                    data.extend_from_slice(&s[1..8 - usize::from((s[0] >> 1) & 7)]);
                    t ^= 1;
                    if s[0] & 1 == 1 {
                        return Ok(data);
                    }
                }
            }
            b => Ok(r[4..8 - usize::from((b >> 2) & 3)].to_vec()),
        }
    }
    fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), u32> {
        let i = index.to_le_bytes();
        let mut d = [0u8; 4];
        d[..data.len()].copy_from_slice(data);
        let b0 = 0x23 | ((4 - data.len() as u8) << 2);
        let r = self.sdo([b0, i[0], i[1], sub, d[0], d[1], d[2], d[3]]);
        match r[0] {
            0x60 => Ok(()),
            _ => Err(u32::from_le_bytes(r[4..8].try_into().unwrap())),
        }
    }
}

fn size_of(data_type: &str) -> Option<usize> {
    match data_type {
        "0x0001" | "0x0005" => Some(1),
        "0x0006" => Some(2),
        "0x0007" | "0x0008" => Some(4),
        "0x0009" => None,
        t => panic!("unexpected DataType {t}"),
    }
}

#[test]
fn every_declared_entry_behaves_as_declared() {
    let ini = parse_ini(&generated());
    let mut n = Node::new();
    for (index, sub, keys) in entries(&ini) {
        let access = keys["AccessType"].as_str();
        let ty = keys["DataType"].as_str();
        let what = format!("{index:04X}sub{sub} {}", keys["ParameterName"]);
        match access {
            "wo" => assert_eq!(n.upload(index, sub), Err(0x0601_0001), "{what}"),
            _ => match (n.upload(index, sub), keys.get("DefaultValue")) {
                (Ok(data), Some(default)) => {
                    if let Some(size) = size_of(ty) {
                        assert_eq!(data.len(), size, "{what}");
                    }
                    match ty {
                        "0x0009" => {
                            assert_eq!(String::from_utf8(data).unwrap(), *default, "{what}")
                        }
                        "0x0008" => assert_eq!(
                            f32::from_le_bytes(data.try_into().unwrap()),
                            default.parse::<f32>().unwrap(),
                            "{what}"
                        ),
                        _ => {
                            let mut b = [0u8; 8];
                            b[..data.len()].copy_from_slice(&data);
                            let mut expect = int(default);
                            if default.contains("$NODEID") {
                                expect += i64::from(NODE);
                            }
                            assert_eq!(u64::from_le_bytes(b) as i64, expect, "{what}");
                        }
                    }
                }
                // Results without data: "no data available".
                (Err(code), None) => assert_eq!(code, 0x0800_0024, "{what}"),
                (r, d) => panic!("{what}: upload {r:?} but DefaultValue {d:?}"),
            },
        }
        if access == "ro" || access == "const" {
            let size = size_of(ty).unwrap_or(4).min(4);
            assert_eq!(
                n.download(index, sub, &vec![0; size]),
                Err(0x0601_0002),
                "{what}"
            );
        }
        // Integer entries: one above HighLimit is refused as too high (if the type can hold it).
        if access == "rw"
            && ty != "0x0008"
            && let Some(hi) = keys.get("HighLimit")
        {
            let above = int(hi) + 1;
            let size = size_of(ty).unwrap();
            if above < 1 << (8 * size) {
                let bytes = (above as u32).to_le_bytes();
                assert_eq!(
                    n.download(index, sub, &bytes[..size]),
                    Err(0x0609_0031),
                    "{what}"
                );
            }
        }
    }
    // Nothing answers that the EDS does not declare.
    let declared: std::collections::BTreeSet<u16> = entries(&ini).iter().map(|e| e.0).collect();
    for index in 0x1000u16..=0x6FFF {
        if !declared.contains(&index) {
            assert_eq!(n.upload(index, 0), Err(0x0602_0000), "{index:04X}");
        }
    }
}

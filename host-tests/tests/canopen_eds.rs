//! `ballpod.eds` (CiA 306): the committed file is the generated one, it is well-formed, and
//! every entry it declares behaves that way on the bus (a fresh node answers SDO uploads with
//! the declared type and default value, refuses writes beyond the declared limits, and has no
//! object the EDS does not declare).
use std::collections::BTreeMap;

use ballpod::acquisition::MAX_AXES;
use ballpod::app::App;
use ballpod::config::{Config, FIELDS, FieldType};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode};

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

/// The CiA 301 data type code (§7.1.6, table 44) a field of `ty` is sent as: REAL32 for the
/// floating-point fields (the f64 encoder scale too), UNSIGNED8/16/32 for the integers.
fn data_type_of(ty: FieldType) -> &'static str {
    match ty {
        FieldType::F32 | FieldType::F64 => "0x0008",
        FieldType::U8 => "0x0005",
        FieldType::U16 => "0x0006",
        FieldType::U32 => "0x0007",
    }
}

#[test]
fn every_config_field_has_its_object_with_the_table_type_and_range() {
    let ini = parse_ini(&generated());
    // rows 0…63 at 0x2000 + row, below the enumerated objects at 0x2040–0x2043; the rows
    // after them from 0x2044, below the live values at 0x2100
    let index = |row: usize| {
        if row < 0x40 {
            0x2000 + row
        } else {
            0x2044 + row - 0x40
        }
    };
    assert!(index(FIELDS.len() - 1) < 0x2100, "{} rows", FIELDS.len());
    assert_eq!(index(0x40), 0x2044, "probe_u_lobing is the first after");
    assert_eq!(FIELDS[0x40].name, "probe_u_lobing");
    assert_eq!(
        (index(FIELDS.len() - 1), FIELDS[FIELDS.len() - 1].name),
        (0x204B, "lvdt_serial"),
        "the last row"
    );
    for (i, f) in FIELDS.iter().enumerate() {
        let sec = format!("{:04X}", index(i));
        let o = &ini[&sec];
        assert_eq!(o["ParameterName"], f.name);
        let vars: Vec<&BTreeMap<String, String>> = if o["ObjectType"] == "0x7" {
            assert_eq!(f.elements, 0, "{}", f.name);
            vec![o]
        } else {
            assert_eq!(o["ObjectType"], "0x8", "ARRAY {}", f.name);
            assert_eq!(
                ini[&format!("{sec}SUB0")]["DefaultValue"],
                f.elements.to_string()
            );
            (1..=f.elements)
                .map(|k| &ini[&format!("{sec}SUB{k:X}")])
                .collect()
        };
        for var in vars {
            assert_eq!(var["DataType"], data_type_of(f.ty), "{}", f.name);
            assert_eq!(var["AccessType"], "rw");
            assert_eq!(var["LowLimit"].parse::<f64>().unwrap(), f.min, "{}", f.name);
            assert_eq!(
                var["HighLimit"].parse::<f64>().unwrap(),
                f.max,
                "{}",
                f.name
            );
            // a set-up field that is not set by default: NaN
            if f.optional {
                assert!(
                    var["DefaultValue"].parse::<f32>().unwrap().is_nan(),
                    "{}",
                    f.name
                );
            }
        }
    }
    // The examples of the object dictionary's doc: node-ID UNSIGNED8, samples per period
    // UNSIGNED16, the probe times UNSIGNED32, codes UNSIGNED8, lengths REAL32.
    let ty = |name: &str| {
        let i = FIELDS.iter().position(|f| f.name == name).unwrap();
        ini[&format!("{:04X}", index(i))]["DataType"].clone()
    };
    assert_eq!(ty("can_node_id"), "0x0005");
    assert_eq!(ty("samples_per_period"), "0x0006");
    assert_eq!(ty("probe_debounce"), "0x0007");
    assert_eq!(ty("ssm_min_dwell"), "0x0007");
    assert_eq!(ty("circle_plane"), "0x0005");
    assert_eq!(ty("ts_machine"), "0x0005");
    assert_eq!(ty("bar_length"), "0x0008");
    assert_eq!(ty("circle_radius"), "0x0008");
    // the enumerated configuration objects follow at 0x2040–0x2043
    for (index, name, ty) in [
        ("2040", "lvdt_input", "0x0005"),
        ("2041", "can_bitrate", "0x0005"),
    ] {
        assert_eq!(ini[index]["ParameterName"], name);
        assert_eq!(ini[index]["DataType"], ty);
    }
    assert_eq!(ini["2042"]["ParameterName"], "axis_name");
    assert_eq!(ini["2043"]["ParameterName"], "axis_reversed");
    assert_eq!(ini["2043SUB1"]["DataType"], "0x0001", "BOOLEAN");
}

#[test]
fn session_live_and_result_objects_are_declared_with_their_types() {
    let ini = parse_ini(&generated());
    // live values: ARRAY of 14 REAL32 (8 values, the live SSM E's u, the live fit's u), PDO
    // mappable; counter, status word, validity mask
    assert_eq!(ini["2100"]["ObjectType"], "0x8");
    assert_eq!(ini["2100"]["SubNumber"], "15");
    assert_eq!(ini["2100SUB9"]["ParameterName"], "u_ssm_ex");
    assert_eq!(ini["2100SUBC"]["ParameterName"], "u_ecc_u");
    assert_eq!(ini["2100SUBE"]["ParameterName"], "u_r0");
    for k in 1..=14 {
        let e = &ini[&format!("2100SUB{k:X}")];
        assert_eq!(e["DataType"], "0x0008");
        assert_eq!(e["PDOMapping"], "1");
        assert!(
            e["DefaultValue"].parse::<f32>().unwrap().is_nan(),
            "invalid: NaN"
        );
    }
    for (index, ty) in [("2101", "0x0007"), ("2102", "0x0006"), ("2103", "0x0006")] {
        assert_eq!(ini[index]["DataType"], ty, "{index}");
        assert_eq!(ini[index]["PDOMapping"], "1", "{index}");
    }
    assert_eq!(ini["2103"]["DefaultValue"], "0");
    // session: command write-only 1…8, refusal and note strings, touch points
    assert_eq!(ini["3002"]["AccessType"], "wo");
    assert_eq!(ini["3002"]["LowLimit"], "1");
    assert_eq!(ini["3002"]["HighLimit"], "8");
    for index in ["3006", "3007"] {
        assert_eq!(ini[index]["DataType"], "0x0009", "VISIBLE_STRING {index}");
        assert_eq!(ini[index]["DefaultValue"], "", "{index}");
    }
    assert_eq!(ini["3008"]["DataType"], "0x0005");
    for index in ["3009", "300A", "300B"] {
        assert_eq!(ini[index]["ObjectType"], "0x8");
        assert_eq!(ini[&format!("{index}SUB1")]["DataType"], "0x0008");
    }
    // results: three ARRAYs of RESULT_COUNT entries, named after the catalogue
    let results: Vec<_> = ballpod::app::ResultInfo::all().collect();
    assert_eq!(results.len(), ballpod::app::RESULT_COUNT);
    for (index, ty) in [("4000", "0x0008"), ("4001", "0x0008"), ("4002", "0x0001")] {
        assert_eq!(ini[index]["ObjectType"], "0x8");
        assert_eq!(
            ini[index]["SubNumber"],
            (results.len() + 1).to_string(),
            "{index}"
        );
        assert_eq!(
            ini[&format!("{index}SUB0")]["DefaultValue"],
            results.len().to_string()
        );
        for (k, r) in results.iter().enumerate() {
            let e = &ini[&format!("{index}SUB{:X}", k + 1)];
            assert_eq!(e["DataType"], ty, "{index}:{}", k + 1);
            assert_eq!(e["ParameterName"], r.name, "{index}:{}", k + 1);
        }
    }
}

struct Node {
    node: CanOpenNode,
    app: App,
}

impl Node {
    fn new() -> Self {
        let mut n = Self {
            node: CanOpenNode::new(NODE, 0),
            app: App::new(Config::default(), [16; MAX_AXES]),
        };
        n.node.poll(0, &n.app, &mut |_| {});
        n
    }
    fn sdo(&mut self, req: [u8; 8]) -> [u8; 8] {
        let mut out = Vec::new();
        let f = CanFrame::new(0x600 + u16::from(NODE), &req).unwrap();
        self.node
            .on_frame(&f, &mut self.app, 0, &mut |f| out.push(f));
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
                            let got = String::from_utf8(data).unwrap();
                            if index == 0x100A {
                                // the EDS names the release; the pod also the commit it was
                                // built from
                                assert!(got.starts_with(&format!("{default}+")), "{what}: {got}");
                            } else {
                                assert_eq!(got, *default, "{what}")
                            }
                        }
                        "0x0008" => {
                            // bit for bit: the value read, or NaN for "not set" / "invalid"
                            let got = f32::from_le_bytes(data.try_into().unwrap());
                            let want = default.parse::<f32>().unwrap();
                            assert!(
                                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                                "{what}: {got} vs DefaultValue {default}"
                            );
                        }
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
                // Results and touch points without data: "no data available".
                (Err(code), None) => {
                    assert_eq!(code, 0x0800_0024, "{what}");
                    assert!(
                        (0x4000..=0x4001).contains(&index) || (0x3009..=0x300B).contains(&index),
                        "{what}: only results and touch points have no data"
                    );
                }
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

/// The REAL32 configuration entries with their declared limits: (index, sub, name, low, high).
fn real32_limits(ini: &Ini) -> Vec<(u16, u8, String, f64, f64)> {
    entries(ini)
        .into_iter()
        // the configuration objects (0x2000 …); 0x300C's limits: tests/canopen_slave.rs
        .filter(|(i, _, k)| *i < 0x2100 && k["DataType"] == "0x0008" && k["AccessType"] == "rw")
        .map(|(i, s, k)| {
            (
                i,
                s,
                k["ParameterName"].clone(),
                k["LowLimit"].parse().unwrap(),
                k["HighLimit"].parse().unwrap(),
            )
        })
        .collect()
}

/// Excitation and sample rate are tied (a sample is 1 to 5 whole excitation periods): before
/// one of them is written at its limit, the pair is walked to where that limit is realisable
/// (20 kHz excitation: 5 kHz samples first; 200 Hz samples: a 1 kHz excitation; 10 kHz
/// samples: 5 kHz samples, then a 10 kHz excitation), every step itself valid. The counters'
/// reach ties counts, speed and rate: 200 Hz samples need the linear axes (16-bit counters) at
/// 600 mm/s first; a 16-bit input's count scale or speed at its high limit, the input unused
/// (0x2042, name NONE).
fn partner_for(n: &mut Node, name: &str, v: f64) {
    let sixteen_bit = ["axis_counts_0", "axis_counts_1", "axis_counts_2"]
        .iter()
        .chain(&["axis_max_speed_0", "axis_max_speed_1", "axis_max_speed_2"])
        .position(|x| *x == name);
    if let Some(k) = sixteen_bit.filter(|_| v > 5000.0) {
        n.download(0x2042, (k % 3) as u8 + 1, &[0]).unwrap();
        return;
    }
    let steps: &[(&str, f32)] = match (name, v) {
        ("excitation", v) if v > 5000.0 => &[("sample_rate", 5000.0)],
        ("sample_rate", v) if v < 1000.0 => &[
            ("axis_max_speed_0", 600.0),
            ("axis_max_speed_1", 600.0),
            ("axis_max_speed_2", 600.0),
            ("excitation", 1000.0),
        ],
        ("sample_rate", v) if v > 5000.0 => &[("sample_rate", 5000.0), ("excitation", 10_000.0)],
        _ => return,
    };
    let ini = parse_ini(&generated());
    let limits = real32_limits(&ini);
    for (partner, value) in steps {
        let (index, sub, ..) = limits.iter().find(|e| e.2 == *partner).unwrap();
        n.download(*index, *sub, &value.to_le_bytes()).unwrap();
    }
}

/// A declared limit is writable as the nearest REAL32, and a REAL32 beyond it is refused as too
/// high / too low (CiA 301 0x0609 0031 / 0032) on a fresh node (each write alone, so that no
/// cross-field rule trips).
#[test]
fn real32_config_entries_take_their_declared_limits_and_refuse_beyond() {
    let ini = parse_ini(&generated());
    let all = real32_limits(&ini);
    assert!(all.len() > 40, "{}", all.len());
    for (index, sub, name, lo, hi) in all {
        let span = (hi - lo).max(1.0);
        for (v, ok) in [
            (lo, Ok(())),
            (hi, Ok(())),
            (lo - span, Err(0x0609_0032)),
            (hi + span, Err(0x0609_0031)),
        ] {
            if f64::from(v as f32) != v && ok.is_ok() {
                // see real32_config_entries_take_declared_limits_without_an_exact_real32
                continue;
            }
            let mut n = Node::new();
            partner_for(&mut n, &name, v);
            assert_eq!(
                n.download(index, sub, &(v as f32).to_le_bytes()),
                ok,
                "{index:04X}sub{sub} {name} = {v}"
            );
            if ok.is_ok() {
                let back = f32::from_le_bytes(n.upload(index, sub).unwrap().try_into().unwrap());
                assert_eq!(back, v as f32, "{name}");
            }
        }
    }
}

/// lvdt_max_ratio, lvdt_dc_span and ssm_dwell_speed declare LowLimit=0.01, whose nearest REAL32
/// (0.00999999978) is below 0.01: the node takes it as the declared limit (the configuration
/// compares with the limits rounded to f32), and refuses the next REAL32 below it.
#[test]
fn real32_config_entries_take_declared_limits_without_an_exact_real32() {
    let ini = parse_ini(&generated());
    let mut inexact = 0;
    let mut seen = Vec::new();
    for (index, sub, name, lo, hi) in real32_limits(&ini) {
        for v in [lo, hi] {
            if f64::from(v as f32) == v {
                continue;
            }
            inexact += 1;
            seen.push((name.clone(), v));
            let mut n = Node::new();
            assert_eq!(
                n.download(index, sub, &(v as f32).to_le_bytes()),
                Ok(()),
                "{index:04X}sub{sub} {name} = {v} (REAL32 {})",
                v as f32
            );
            // the neighbouring REAL32 outside the range is refused (all limits here are > 0)
            let (outside, code) = if v == lo {
                (f32::from_bits((v as f32).to_bits() - 1), 0x0609_0032)
            } else {
                (f32::from_bits((v as f32).to_bits() + 1), 0x0609_0031)
            };
            assert_eq!(
                n.download(index, sub, &outside.to_le_bytes()),
                Err(code),
                "{index:04X}sub{sub} {name} = {outside}"
            );
        }
    }
    // lvdt_max_ratio, lvdt_min_signal, lvdt_dc_span, axis_counts_0…4, ssm_window_radius,
    // ssm_dwell_speed
    assert_eq!(inexact, 10, "{seen:?}");
}

// ---- The wire contract ----------------------------------------------------------------------
//
// Every object and sub-entry of a released EDS (`releases/ballpod-rev<major>.<minor>.eds`)
// keeps its index, sub-index, name, object type, data type, access and PDO mapping in every
// later firmware of the same major revision: new objects are appended, retired ones stay
// (a retired result reads "no data" for ever). Only a major revision (0x1018:3 upper 16 bits)
// may break it, and `CHANGELOG.md` must say so. Limits and defaults may change.

/// The keys of an entry that make its wire layout.
const LAYOUT_KEYS: [&str; 5] = [
    "ParameterName",
    "ObjectType",
    "DataType",
    "AccessType",
    "PDOMapping",
];

/// (section, key, value) of every object and sub-entry section's layout keys.
fn layout(ini: &Ini) -> BTreeMap<String, BTreeMap<&'static str, String>> {
    let mut out = BTreeMap::new();
    for (name, keys) in ini {
        let object = name.len() == 4 && u16::from_str_radix(name, 16).is_ok();
        let sub = name
            .split_once("SUB")
            .is_some_and(|(i, s)| i.len() == 4 && u8::from_str_radix(s, 16).is_ok());
        if !(object || sub) {
            continue;
        }
        let l = LAYOUT_KEYS
            .iter()
            .filter_map(|&k| keys.get(k).map(|v| (k, v.clone())))
            .collect();
        out.insert(name.clone(), l);
    }
    out
}

/// What `current` moved, renamed, retyped or removed of `released` (empty: the layout holds).
fn layout_breaks(released: &Ini, current: &Ini) -> Vec<String> {
    let now = layout(current);
    let mut breaks = Vec::new();
    for (section, keys) in layout(released) {
        let Some(cur) = now.get(&section) else {
            breaks.push(format!("[{section}] {} removed", keys["ParameterName"]));
            continue;
        };
        for (k, v) in &keys {
            match cur.get(k) {
                Some(c) if c == v => {}
                c => breaks.push(format!("[{section}] {k}: released {v}, now {c:?}")),
            }
        }
    }
    breaks
}

/// Sections of `current` that `released` does not have (appended objects or sub-entries).
fn appended(released: &Ini, current: &Ini) -> Vec<String> {
    let old = layout(released);
    layout(current)
        .into_keys()
        .filter(|s| !old.contains_key(s))
        .collect()
}

fn revision(ini: &Ini) -> (u16, u16) {
    let r = int(&ini["DEVICEINFO"]["RevisionNumber"]) as u32;
    ((r >> 16) as u16, r as u16)
}

/// Every released EDS in `releases/`, with its file name.
fn released_eds() -> Vec<(String, Ini)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../releases");
    let mut out: Vec<(String, Ini)> = std::fs::read_dir(dir)
        .expect("releases/ at the repository root")
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "eds"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, parse_ini(&std::fs::read_to_string(&p).unwrap()))
        })
        .collect();
    out.sort_by_key(|(_, ini)| revision(ini));
    out
}

fn changelog() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../CHANGELOG.md"))
        .expect("CHANGELOG.md at the repository root")
}

#[test]
fn the_wire_layout_keeps_every_released_one() {
    let current = parse_ini(&generated());
    let (major, minor) = revision(&current);
    let log = changelog();
    let released = released_eds();
    assert!(!released.is_empty(), "no released EDS in releases/");
    for (file, old) in &released {
        let (old_major, old_minor) = revision(old);
        assert_eq!(
            file,
            &format!("ballpod-rev{old_major}.{old_minor}.eds"),
            "a released EDS is named by its RevisionNumber"
        );
        assert!(
            (major, minor) >= (old_major, old_minor),
            "revision {major}.{minor} is older than the released {old_major}.{old_minor}"
        );
        let breaks = layout_breaks(old, &current);
        if major > old_major {
            // a deliberate break: the CHANGELOG names the new major revision
            assert!(
                log.contains(&format!("EDS revision {major}.0")),
                "revision {major}.{minor} breaks {file}: CHANGELOG.md must name \"EDS revision {major}.0\""
            );
            continue;
        }
        assert!(
            breaks.is_empty(),
            "the wire layout of {file} changed (append new objects instead, keep retired ones; a deliberate break needs a new major revision):\n{}",
            breaks.join("\n")
        );
        let added = appended(old, &current);
        if !added.is_empty() {
            assert!(
                minor > old_minor,
                "objects appended since {file} ({}…): raise the minor revision od::REVISION",
                added[0]
            );
        }
    }
    if !released
        .iter()
        .any(|(_, ini)| revision(ini) == (major, minor))
    {
        assert!(
            log.contains(&format!("EDS revision {major}.{minor}")),
            "the unreleased EDS revision {major}.{minor} is not named in CHANGELOG.md"
        );
    }
}

#[test]
fn the_released_layout_check_finds_a_moved_renamed_or_retyped_object() {
    // Independent of the check's own reading: edit the released text as a careless change
    // would (99dd7fe's insertion moved every later result by two sub-indices).
    let (_, released) = released_eds().pop().unwrap();
    let mut moved = released.clone();
    let a = moved["4000SUB20"].clone();
    let b = moved["4000SUB22"].clone();
    moved.insert("4000SUB20".into(), b);
    moved.insert("4000SUB22".into(), a);
    assert_eq!(
        layout_breaks(&released, &moved).len(),
        2,
        "two results swapped"
    );
    let mut retyped = released.clone();
    retyped
        .get_mut("2000")
        .unwrap()
        .insert("DataType".into(), "0x0007".into());
    assert_eq!(layout_breaks(&released, &retyped).len(), 1);
    let mut removed = released.clone();
    removed.remove("4002SUB1");
    assert_eq!(layout_breaks(&released, &removed).len(), 1);
    let mut added = released.clone();
    let mut extra = released["4000SUB1"].clone();
    extra.insert("ParameterName".into(), "new_result".into());
    added.insert("4000SUB7F".into(), extra);
    assert!(
        layout_breaks(&released, &added).is_empty(),
        "appending keeps the layout"
    );
    assert_eq!(appended(&released, &added), vec!["4000SUB7F".to_string()]);
}

#[test]
fn every_name_a_client_reads_by_is_unique() {
    // python canopen and most masters look objects up by ParameterName (`od["result_value"]
    // ["G_ccw"]`): an object's name is unique in the EDS, a sub-entry's within its object.
    let ini = parse_ini(&generated());
    let mut objects = BTreeMap::new();
    for (name, keys) in &ini {
        if name.len() == 4 && u16::from_str_radix(name, 16).is_ok() {
            let n = &keys["ParameterName"];
            assert!(
                objects.insert(n.clone(), name.clone()).is_none(),
                "object name {n} twice"
            );
            let mut subs = std::collections::BTreeSet::new();
            for (s, k) in ini.range(format!("{name}SUB")..format!("{name}SUC")) {
                let sn = &k["ParameterName"];
                assert!(subs.insert(sn.clone()), "{sn} twice in [{name}] ({s})");
            }
        }
    }
}

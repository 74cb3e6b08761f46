//! A configuration field is added by one row (issue 44): this test runs on a build of the core
//! with the `one-more-field` feature, whose only change is one more row at the end of
//! `src/config/fields.rs` (`test_extra`: µm, 0 … 10, default 2.5, encoding version 12, next
//! run). It checks that everything a field needs followed from that row: the storage and its
//! default, the name and range checks, the encoding (one version more, four bytes more, the
//! older version read with the new field at its default), the CANopen object in the EDS (every
//! object of the committed baseline unchanged) and the book's reference row.
//!
//! Run by `.ci/run` as `cargo host-test --release --features one-more-field --test config_one_row` (the
//! other tests run without the feature: with it the EDS is no longer the committed one).
use std::collections::BTreeMap;

use ballpod::config::{
    Config, ConfigError, ENCODED_LEN, ENCODING_VERSION, FIELDS, Field, FieldType, TakesEffect,
};
use ballpod::protocol::canopen::od;
use ballpod::units::Unit;
use ballpod_host::oracle::crc32_bitwise as crc32;

/// The EDS's sections: header → body.
fn sections(eds: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut name = String::new();
    for line in eds.lines() {
        if let Some(h) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            name = h.to_string();
            out.insert(name.clone(), String::new());
        } else if let Some(body) = out.get_mut(&name) {
            body.push_str(line);
            body.push('\n');
        }
    }
    out
}

#[test]
fn the_new_row_gives_storage_default_checks_and_lookup() {
    let last = FIELDS.last().unwrap();
    assert_eq!(last.field, Field::TestExtraUm);
    assert_eq!(
        (
            last.name,
            last.unit,
            last.ty,
            last.min,
            last.max,
            last.elements,
            last.optional
        ),
        ("test_extra", Unit::Um, FieldType::F32, 0.0, 10.0, 0, false)
    );
    assert_eq!(Field::TestExtraUm.takes_effect(), TakesEffect::NextRun);
    let mut c = Config::default();
    assert_eq!(c.setup.test_extra_um, 2.5);
    assert_eq!(c.field_value(Field::TestExtraUm), Some(2.5));
    assert_eq!(
        Config::field_by_name("test_extra"),
        Some(Field::TestExtraUm)
    );
    c.set(Field::TestExtraUm, 7.0).unwrap();
    assert_eq!(c.setup.test_extra_um, 7.0);
    let refused = c.set(Field::TestExtraUm, 10.5);
    assert!(
        matches!(refused, Err(ConfigError::OutOfRange { field: Field::TestExtraUm, min, max, .. }) if min == 0.0 && max == 10.0),
        "{refused:?}"
    );
    assert_eq!(
        c.setup.test_extra_um, 7.0,
        "a refused value changes nothing"
    );
}

#[test]
fn the_encoding_grows_by_one_version_and_reads_the_older_one() {
    assert_eq!(ENCODING_VERSION, 12);
    let mut c = Config::default();
    c.set(Field::TestExtraUm, 7.0).unwrap();
    c.set(Field::BarLengthMm, 123.0).unwrap();
    let mut buf = [0u8; 1024];
    let n = c.encode(&mut buf).unwrap();
    assert_eq!(n, ENCODED_LEN);
    let bytes = &buf[..n];
    // (NaN fields are not equal to themselves: compare the encodings)
    let mut again = [0u8; 1024];
    Config::decode(bytes).unwrap().encode(&mut again).unwrap();
    assert_eq!(&again[..n], bytes);
    // the new field is the payload's last row: its f32 stands before the enumerated bytes
    // (LVDT input, bit rate, per input name and reversed flag)
    let enums = 2 + 2 * ballpod::config::MAX_AXES;
    let at = n - 4 - enums - 4;
    assert_eq!(
        f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()),
        7.0
    );
    // the version-11 record a pod wrote before the row existed: without those four bytes
    let mut old = Vec::new();
    old.extend_from_slice(b"BPOD");
    old.extend_from_slice(&11u16.to_le_bytes());
    let payload = n - 12 - 4;
    old.extend_from_slice(&(payload as u16).to_le_bytes());
    old.extend_from_slice(&bytes[8..at]);
    old.extend_from_slice(&bytes[at + 4..n - 4]);
    let crc = crc32(&old);
    old.extend_from_slice(&crc.to_le_bytes());
    let read = Config::decode(&old).unwrap();
    assert_eq!(read.bar_length_mm, 123.0);
    assert_eq!(
        read.setup.test_extra_um, 2.5,
        "migrated: the new field at its default"
    );
}

#[test]
fn the_eds_gains_its_object_and_keeps_every_baseline_object() {
    let mut text = String::new();
    ballpod::protocol::canopen::eds::write_eds(&mut text).unwrap();
    let new = sections(&text);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../ballpod.eds");
    let baseline = sections(&std::fs::read_to_string(path).unwrap());
    let index = od::config_index(FIELDS.len() - 1);
    let name = format!("{index:X}");
    let object = new
        .get(&name)
        .unwrap_or_else(|| panic!("no object {name} in the EDS"));
    assert!(object.contains("ParameterName=test_extra"), "{object}");
    assert!(
        !baseline.contains_key(&name),
        "the new object takes a free index"
    );
    let mut changed = Vec::new();
    for (header, body) in &baseline {
        match new.get(header) {
            Some(b) if b == body => {}
            _ => changed.push(header.clone()),
        }
    }
    // only the lists of objects (and the file's own date/size lines) may change
    changed.retain(|h| !matches!(h.as_str(), "ManufacturerObjects" | "FileInfo"));
    assert!(changed.is_empty(), "baseline objects changed: {changed:?}");
    assert!(text.contains("Test build only: a field added by one row"));
}

#[test]
fn the_reference_page_has_its_row() {
    let page = ballpod_host::docs_ref::pages()
        .into_iter()
        .find(|p| p.file == "configuration-fields.md")
        .unwrap();
    let row = page
        .text
        .lines()
        .find(|l| l.starts_with("| `test_extra` |"))
        .expect("a reference row for test_extra");
    for cell in ["| um |", "| 2.5 |", "0 … 10", "next run", "Test build only"] {
        assert!(row.contains(cell), "{cell:?} not in {row}");
    }
}

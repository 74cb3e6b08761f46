//! The Electronic Data Sheet (CiA 306 v1.3 INI format) generated from the object dictionary
//! [`super::od`], so `ballpod.eds` can never disagree with what the firmware answers.
//!
//! Default values are read from the objects themselves on an application with the default
//! configuration and fresh communication parameters (a set-up field that is not set reads
//! `NaN`); COB-IDs derived from the node-ID are written `$NODEID+0x…`. Units and meanings are
//! given as `; unit:` and `; what:` comment lines, the codes of a code field as `; codes:` (CiA
//! 306 has no keys for them). The text is deterministic (fixed file dates) so a test can
//! compare it with the committed file.
//!
//! Float formatting (`core::fmt` for REAL32 defaults and limits) is used only here; the
//! firmware never calls this module, so the formatting code is not linked into the image.

use core::fmt::{self, Write};

use super::od::{self, Access, CommParams, DataType, Entry, MAX_VALUE_LEN, ObjectKind};
use super::pdo::TPDO_COUNT;
use crate::app::App;
use crate::app::results::RESULT_MEANINGS;
use crate::config::Config;

/// File name of the EDS.
pub const FILE_NAME: &str = "ballpod.eds";

fn write_value(w: &mut impl Write, e: &Entry, bytes: &[u8]) -> fmt::Result {
    let mut b = [0u8; 4];
    for (d, s) in b.iter_mut().zip(bytes) {
        *d = *s;
    }
    let raw = u32::from_le_bytes(b);
    match e.ty {
        DataType::VisibleString => {
            for c in bytes {
                w.write_char(char::from(*c))?;
            }
            Ok(())
        }
        DataType::Real32 => write!(w, "{}", f32::from_le_bytes(b)),
        DataType::Unsigned32 if e.node_id_relative => write!(w, "$NODEID+0x{raw:X}"),
        DataType::Unsigned32 => write!(w, "0x{raw:08X}"),
        DataType::Boolean | DataType::Unsigned8 | DataType::Unsigned16 => write!(w, "{raw}"),
    }
}

/// What object `index` is, for the EDS's `; what:` lines and the book's object reference (the
/// configuration objects ([`super::od::config_index`]) are described by [`crate::config::Field::meaning`], the
/// results by [`RESULT_MEANINGS`]). Empty for an index that is not an object.
pub const fn object_meaning(index: u16) -> &'static str {
    match index {
        0x1000 => {
            "Device type: 0, no standard device profile (the live values are CiA 404-style REAL32 process values, but the pod does not claim a profile whose objects it lacks)"
        }
        0x1001 => {
            "Error register: bit 0 generic, bit 4 communication (overrun, error state), bit 7 manufacturer-specific"
        }
        0x1003 => {
            "Error history: sub 0 the number of errors (write 0 to clear), sub k error k (1 = newest): the EMCY error code and its manufacturer byte"
        }
        0x1005 => {
            "COB-ID of the SYNC the pod consumes (default 0x080; a SYNC producer or a 29-bit ID is refused)"
        }
        0x1008 => "Manufacturer device name",
        0x1009 => "Manufacturer hardware version",
        0x100A => "Manufacturer software version",
        0x1010 => {
            "Store parameters: write \"save\" (0x65766173) to sub 1 to store the configuration in flash"
        }
        0x1011 => {
            "Restore default parameters: write \"load\" (0x64616F6C) to sub 1 to store the defaults, in force at the next reset"
        }
        0x1015 => "EMCY inhibit time, 100 µs",
        0x1017 => "Producer heartbeat time, ms (0: no heartbeat)",
        0x1018 => {
            "Identity: vendor 0, product 0xBA110001, revision, serial number (the CRC-32 of the MCU's unique ID, as SCPI *IDN? and the USB iSerialNumber)"
        }
        0x1200 => {
            "SDO server: COB-IDs 0x600 + node-ID (client to pod) and 0x580 + node-ID (pod to client); expedited and segmented transfers, 1 s segment timeout, no block transfer"
        }
        0x1800..=0x1803 => {
            "TPDO communication parameter: COB-ID (bit 31 disables), transmission type (1–240: every n-th SYNC; 254/255: event timer), inhibit time, event timer (ms)"
        }
        0x1A00..=0x1A03 => {
            "TPDO mapping: up to 64 bits of 0x1001, 0x2100–0x2103 and 0x3003, changed per the CiA 301 procedure (disable the TPDO, set sub 0 to 0, map, set sub 0)"
        }
        0x2040 => "LVDT input mode (written only in pre-operational)",
        0x2041 => "CAN bit rate, taken at reset (written only in pre-operational)",
        0x2042 => {
            "Axis name of encoder input k (written only in pre-operational; a name used twice is refused)"
        }
        0x2043 => {
            "Counting direction of encoder input k: true if the counter counts down in the axis' positive direction (written only in pre-operational)"
        }
        0x2100 => {
            "Live values, refreshed every sample: delta_l (µm), ssm_ex, ssm_ey, ssm_ez (µm), ecc_u, ecc_v, r0 (µm), temp (°C), u_ssm_ex, u_ssm_ey, u_ssm_ez (µm: the live E's standard uncertainty), u_ecc_u, u_ecc_v, u_r0 (µm: the live fit's standard uncertainty; each u refreshed every 32 samples, the live E's every 4 while its window grows, invalid where its value is; U = 2u); NaN while not valid (0x2103)"
        }
        0x2101 => "Sample counter: every sample the pod produced (a gap is a lost sample)",
        0x2102 => {
            "Status word: bits 0–5 the latest sample's flags (1 LVDT over-range, 2 LVDT open, 4 quadrature error, 8 probe, 16 overrun, 32 thermistor fault), 6 computing (a job of the last run or procedure runs: the results it publishes are invalid until it ends), 8 armed, 9 running, 10 results ready (the last run is done and every job it left has published), 11 aborted, 12 every live value of the pattern valid, 13 seed 002 identification pending, 14 a field that takes effect at reset changed, 15 error"
        }
        0x2103 => "Validity mask of the live values: bit k−1 set when 0x2100:k is valid",
        0x2110 => "Device counters (refreshed every 100 ms; 0xFFFFFFFF: not measured by this pod)",
        0x3000 => "Pattern of the next run (written while no run is armed or running)",
        0x3001 => "Direction of the next run",
        0x3002 => {
            "Session command: 1 arm (in IDLE, DONE or ABORTED), 2 start (ARMED), 3 stop (RUNNING: results, or ABORTED with reason 4 if the run has none), 4 abort (ARMED or RUNNING), 5 clear procedures and results (not while ARMED or RUNNING), 6 reset (any state: aborts a run, forgets procedures and results, keeps the configuration), 7 store the configuration, 8 restore the defaults at the next reset. A refused command aborts the SDO with 0x08000022 and 0x3006 says why"
        }
        0x3003 => "Session state",
        0x3004 => "Why the last run aborted",
        0x3005 => "Run counters of the present or last run, samples",
        0x3006 => "Why the last command or write was refused (text)",
        0x3007 => {
            "Procedure note: what the last procedure step could not do, or what an armed self-triggered run waits for (text)"
        }
        0x3008 => "Number of touch points of the last PROBE run",
        0x3009 => "X of touch point k of the last PROBE run, mm",
        0x300A => "Y of touch point k of the last PROBE run, mm",
        0x300B => "Z of touch point k of the last PROBE run, mm",
        0x300C => {
            "Axis positions, mm or degrees: reading sub k gives encoder input k's position at the last sample; writing references input k where the axis stands (it is at that machine position now; later counts extend from there). Not while a run is armed or running; the procedures' runs and the results are forgotten, as command 5"
        }
        0x4000 => {
            "Result values: sub-index k+1 = result k of the results catalogue; reading an invalid result aborts with 0x08000024 (no data available)"
        }
        0x4001 => {
            "Standard uncertainties of the results (NaN: not evaluated); an invalid result aborts with 0x08000024"
        }
        0x4002 => {
            "Validity of the results: true once a run (or the procedure) has computed the result"
        }
        _ => "",
    }
}

/// Writes the default of entry `e` as the EDS gives it (`DefaultValue=`), between `around.0`
/// and `around.1`: the value a pod with the default configuration and fresh communication
/// parameters reads, COB-IDs relative to the node-ID as `$NODEID+0x…`; nothing at all for an
/// entry that cannot be read.
pub fn write_default(
    w: &mut impl Write,
    e: &Entry,
    comm: &CommParams,
    app: &App,
    around: (&str, &str),
) -> fmt::Result {
    if e.index == 0x100A {
        // the release: what a pod answers also names its commit (od::SW_VERSION)
        w.write_str(around.0)?;
        w.write_str(od::SW_RELEASE)?;
        return w.write_str(around.1);
    }
    let mut buf = [0u8; MAX_VALUE_LEN];
    match od::read(comm, app, e.var, &mut buf) {
        Ok(n) => {
            w.write_str(around.0)?;
            write_value(w, e, buf.get(..n).unwrap_or(&[]))?;
            w.write_str(around.1)
        }
        Err(_) => Ok(()),
    }
}

/// The EDS ParameterName of an entry: its name, with the element number appended
/// (`name_k` for generated names, `Name k` for CiA names with spaces).
fn write_name(w: &mut impl Write, e: &Entry) -> fmt::Result {
    w.write_str(e.name.as_str())?;
    match e.element {
        Some(k) if e.name.as_str().contains(' ') => write!(w, " {k}"),
        Some(k) => write!(w, "_{k}"),
        None => Ok(()),
    }
}

fn write_entry(
    w: &mut impl Write,
    e: &Entry,
    section_sub: Option<u8>,
    comm: &CommParams,
    app: &App,
) -> fmt::Result {
    match section_sub {
        Some(s) => writeln!(w, "[{:04X}sub{:X}]", e.index, s)?,
        None => {
            writeln!(w, "[{:04X}]", e.index)?;
            let what = object_meaning(e.index);
            if !what.is_empty() {
                writeln!(w, "; what: {what}")?;
            }
        }
    }
    if !e.unit.as_str().is_empty() {
        writeln!(w, "; unit: {}", e.unit.as_str())?;
    }
    match e.var {
        od::Var::ResultValue(k) | od::Var::ResultUncertainty(k) | od::Var::ResultValid(k) => {
            if let Some(what) = RESULT_MEANINGS.get(usize::from(k)) {
                writeln!(w, "; what: {what}")?;
            }
        }
        od::Var::Config(f) => {
            writeln!(w, "; what: {}", f.meaning())?;
            if let Some(i) = Config::field_info(f) {
                if !i.choices().is_empty() {
                    w.write_str("; codes:")?;
                    for (code, name) in i.choices().iter().enumerate() {
                        write!(w, " {code}={name}")?;
                    }
                    writeln!(w)?;
                }
                if i.optional {
                    writeln!(
                        w,
                        "; not set (NaN) until written; a pattern that needs it is refused"
                    )?;
                }
            }
        }
        _ => {}
    }
    w.write_str("ParameterName=")?;
    write_name(w, e)?;
    writeln!(w)?;
    writeln!(w, "ObjectType=0x7")?;
    writeln!(w, "DataType=0x{:04X}", e.ty as u16)?;
    writeln!(w, "AccessType={}", e.access.eds())?;
    if let Some((lo, hi)) = e.limits {
        writeln!(w, "LowLimit={lo}")?;
        writeln!(w, "HighLimit={hi}")?;
    }
    if e.access != Access::Wo {
        write_default(w, e, comm, app, ("DefaultValue=", "\n"))?;
    }
    writeln!(w, "PDOMapping={}", u8::from(e.pdo_mappable))?;
    writeln!(w)
}

fn write_list(w: &mut impl Write, section: &str, pick: impl Fn(u16) -> bool) -> fmt::Result {
    writeln!(w, "[{section}]")?;
    let n = od::indices().filter(|&i| pick(i)).count();
    writeln!(w, "SupportedObjects={n}")?;
    for (k, i) in od::indices().filter(|&i| pick(i)).enumerate() {
        writeln!(w, "{}=0x{i:04X}", k + 1)?;
    }
    writeln!(w)
}

/// Writes the complete EDS of the pod.
pub fn write_eds(w: &mut impl Write) -> fmt::Result {
    let app = App::new(Config::default(), [16; crate::acquisition::MAX_AXES]);
    // Node-ID 0 so that node-relative defaults come out as the bare offset.
    let comm = CommParams::new(0, 0);
    let version = env!("CARGO_PKG_VERSION");
    writeln!(
        w,
        "; ballpod CANopen EDS (CiA 306). Generated by `cargo run --bin gen-eds` from"
    )?;
    writeln!(w, "; ballpod::protocol::canopen::od; do not edit by hand.")?;
    writeln!(w)?;
    writeln!(w, "[FileInfo]")?;
    writeln!(w, "FileName={FILE_NAME}")?;
    writeln!(w, "FileVersion=1")?;
    writeln!(w, "FileRevision=0")?;
    writeln!(w, "EDSVersion=4.0")?;
    writeln!(
        w,
        "Description=ballpod ball-bar / probe measurement pod, firmware {version}"
    )?;
    writeln!(w, "CreationTime=12:00PM")?;
    writeln!(w, "CreationDate=11-22-2026")?;
    writeln!(w, "CreatedBy=ballpod gen-eds")?;
    writeln!(w, "ModificationTime=12:00PM")?;
    writeln!(w, "ModificationDate=11-22-2026")?;
    writeln!(w, "ModifiedBy=ballpod gen-eds")?;
    writeln!(w)?;
    writeln!(w, "[DeviceInfo]")?;
    writeln!(w, "VendorName=ballpod")?;
    writeln!(w, "VendorNumber=0x{:08X}", od::VENDOR_ID)?;
    writeln!(w, "ProductName={}", od::DEVICE_NAME)?;
    writeln!(w, "ProductNumber=0x{:08X}", od::PRODUCT_CODE)?;
    writeln!(w, "RevisionNumber=0x{:08X}", od::REVISION)?;
    writeln!(w, "OrderCode=ballpod")?;
    for (rate, ok) in [
        (10, 0),
        (20, 0),
        (50, 0),
        (125, 1),
        (250, 1),
        (500, 1),
        (800, 0),
        (1000, 1),
    ] {
        writeln!(w, "BaudRate_{rate}={ok}")?;
    }
    writeln!(w, "SimpleBootUpMaster=0")?;
    writeln!(w, "SimpleBootUpSlave=1")?;
    writeln!(w, "Granularity=8")?;
    writeln!(w, "DynamicChannelsSupported=0")?;
    writeln!(w, "GroupMessaging=0")?;
    writeln!(w, "NrOfRXPDO=0")?;
    writeln!(w, "NrOfTXPDO={TPDO_COUNT}")?;
    writeln!(w, "LSS_Supported=1")?;
    writeln!(w)?;
    writeln!(w, "[DummyUsage]")?;
    for d in 1..=7 {
        writeln!(w, "Dummy000{d}=0")?;
    }
    writeln!(w)?;
    writeln!(w, "[Comments]")?;
    let comments = [
        "Configuration objects 0x2000-0x20FF are written only in pre-operational (abort 0x08000022 otherwise).",
        "Results 0x4000/0x4001 abort 0x08000024 until valid (0x4002); live values 0x2100 read NaN while invalid (0x2103).",
        "TPDO transmission types: 1-240 (SYNC) and 254/255 (event timer).",
    ];
    writeln!(w, "Lines={}", comments.len())?;
    for (k, c) in comments.iter().enumerate() {
        writeln!(w, "Line{}={c}", k + 1)?;
    }
    writeln!(w)?;
    let mandatory = |i: u16| matches!(i, 0x1000 | 0x1001 | 0x1018);
    let manufacturer = |i: u16| (0x2000..=0x5FFF).contains(&i);
    write_list(w, "MandatoryObjects", mandatory)?;
    write_list(w, "OptionalObjects", |i| !mandatory(i) && !manufacturer(i))?;
    write_list(w, "ManufacturerObjects", manufacturer)?;
    for index in od::indices() {
        let Some(obj) = od::object(index) else {
            continue;
        };
        if obj.kind == ObjectKind::Var {
            if let Ok(e) = od::entry(index, 0) {
                write_entry(w, &e, None, &comm, &app)?;
            }
            continue;
        }
        let subs = (0..=obj.max_sub).filter(|&s| od::entry(index, s).is_ok());
        writeln!(w, "[{index:04X}]")?;
        let what = object_meaning(index);
        if !what.is_empty() {
            writeln!(w, "; what: {what}")?;
        }
        writeln!(w, "ParameterName={}", obj.name.as_str())?;
        writeln!(w, "ObjectType=0x{:X}", obj.kind as u8)?;
        writeln!(w, "SubNumber={}", subs.clone().count())?;
        writeln!(w)?;
        for s in subs {
            if let Ok(e) = od::entry(index, s) {
                write_entry(w, &e, Some(s), &comm, &app)?;
            }
        }
    }
    Ok(())
}

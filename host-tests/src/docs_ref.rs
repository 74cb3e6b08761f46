//! The book's reference pages (`docs/src/reference/`), generated from the code's own tables:
//! the configuration fields (`config::FIELDS`, `Field::meaning`), the CANopen object dictionary
//! (`canopen::od`, `eds::object_meaning`), the SCPI commands and error numbers
//! (`scpi::reference`), the results catalogue (`app::results`) and the EMCY codes
//! (`canopen::emcy`). `gen-docs` writes them; `tests/docs.rs` fails when a committed page
//! differs from what this module generates.

use std::fmt::Write;

use ballpod::acquisition::{MAX_AXES, SampleFlags};
use ballpod::app::results::{RESULT_MEANINGS, ResultInfo};
use ballpod::app::run::AbortReason;
use ballpod::app::{App, Direction, Pattern, SessionState};
use ballpod::config::{AxisName, CanBitrate, Config, FIELDS, FieldInfo, FieldType, LvdtInput};
use ballpod::protocol::canopen::eds::{object_meaning, write_default};
use ballpod::protocol::canopen::emcy;
use ballpod::protocol::canopen::od::{self, CommParams, DataType, Entry};
use ballpod::protocol::scpi::reference::{ERRORS, commands};
use ballpod::protocol::scpi::status::message;

/// The folder of the reference pages, relative to the repository root.
pub const DIR: &str = "docs/src/reference";

/// One generated page: its file name in [`DIR`] and its text.
pub struct Page {
    /// File name, e.g. `results.md`.
    pub file: &'static str,
    /// The Markdown text.
    pub text: String,
}

/// Every reference page.
pub fn pages() -> Vec<Page> {
    vec![
        Page {
            file: "configuration-fields.md",
            text: configuration_fields(),
        },
        Page {
            file: "canopen-objects.md",
            text: canopen_objects(),
        },
        Page {
            file: "scpi-commands.md",
            text: scpi_commands(),
        },
        Page {
            file: "results.md",
            text: results(),
        },
        Page {
            file: "error-codes.md",
            text: error_codes(),
        },
        Page {
            file: "session-m-codes.md",
            text: session_m_codes(),
        },
        Page {
            file: "module-layers.md",
            text: module_layers(),
        },
    ]
}

/// The core's layers (`layers::LAYERS`) with who imports whom, read from the sources.
fn module_layers() -> String {
    use crate::layers::{LAYERS, core_imports, importers};
    let src = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../src"));
    let imports = core_imports(src).unwrap_or_default();
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# Module layers\n");
    let _ = writeln!(
        s,
        "The modules of the core (`src/`) from the bottom up. A module imports only from lower \
         levels, and exactly what its row says: `host-tests/tests/layers.rs` reads the sources \
         (`crate::` paths in code) and fails otherwise, so there is no import circle and no \
         arrow up. The table is `ballpod_host::layers::LAYERS`; the firmware (`src/main.rs`, \
         `src/board/`) and the host crate stand on top of every row. \
         [Architecture](../architecture.md) says what each module holds.\n"
    );
    let _ = writeln!(s, "| level | module | its job | imports | imported by |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    let list = |v: &[String]| {
        if v.is_empty() {
            "–".to_string()
        } else {
            v.iter()
                .map(|m| format!("`{m}`"))
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    for row in LAYERS {
        let own: Vec<String> = row.imports.iter().map(|m| m.to_string()).collect();
        let _ = writeln!(
            s,
            "| {} | `{}` | {} | {} | {} |",
            row.level,
            row.module,
            row.job,
            list(&own),
            list(&importers(&imports, row.module))
        );
    }
    s
}

/// The M-codes a program with its session carries (`ncgen circle --session`), from
/// `ncgen::SESSION_STEPS`: the LinuxCNC scripts' steps and a PLC's hand-shake.
fn session_m_codes() -> String {
    use crate::ncgen::{DEFAULT_M_BASE, SESSION_STEPS};
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# Session M-codes\n");
    let _ = writeln!(
        s,
        "The M-codes `ncgen circle --session` writes into a program (from M{DEFAULT_M_BASE}; \
         `--m-base` moves them), what LinuxCNC's scripts (`ncgen m-codes DIR`) do for each, and the \
         hand-shake a PLC implements on a control without LinuxCNC: the CANopen writes (objects by \
         their EDS names), then the state it waits for before it acknowledges the M-code. A write \
         the pod refuses (SDO abort) or a state not reached in time is a fault: stop the program \
         (`last_refusal` and `abort_reason` say why). [Running a test from the \
         CNC](../integrators.md) shows them in a program.\n"
    );
    let _ = writeln!(
        s,
        "| M-code | script step | does | CANopen writes | waits for |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|");
    for st in SESSION_STEPS {
        let p = if st.offset == 0 { " P<n>" } else { "" };
        let _ = writeln!(
            s,
            "| `M{}{p}` | `{}` | {} | {} | {} |",
            DEFAULT_M_BASE + st.offset,
            st.action,
            cell(st.what),
            cell(st.writes),
            cell(st.waits_for)
        );
    }
    s
}

const GENERATED: &str = "<!-- Generated by `cargo run --manifest-path host-tests/Cargo.toml --target host-tuple --bin gen-docs` from the code; do not edit by hand (tests/docs.rs fails when this page differs from what the code generates). -->";

/// A table cell: `|` escaped, line breaks flattened.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// A number as the docs print it: shortest round trip, no trailing `.0`.
fn num(v: f64) -> String {
    if v.is_nan() {
        return "not set".into();
    }
    let s = format!("{v}");
    s.strip_suffix(".0").map_or(s.clone(), str::to_string)
}

fn scpi_name(i: &FieldInfo) -> String {
    let upper = i.name.to_ascii_uppercase();
    match i.elements {
        0 => upper,
        _ if i.name.starts_with("axis") => format!("{upper}<n>"),
        _ => format!("{upper}<k>"),
    }
}

fn configuration_fields() -> String {
    let cfg = Config::default();
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# Configuration fields\n");
    let _ = writeln!(
        s,
        "Every field of the pod's configuration (`ballpod::config::FIELDS`): its name, unit, default and \
         allowed range, the CANopen object that holds it (written in pre-operational) and the SCPI header \
         (`CONFigure:<header>`, after `CONFigure:UNLock`). How a change takes effect, the encoding and the \
         flash slots: [Configuration](../configuration.md). A field marked *optional* is **not set** until \
         written (NaN over CANopen, `9.91E+37` over SCPI); a pattern that needs it is refused at arm, naming it. \
         *Takes effect* says when a written value is used (the rule: `ballpod::config`'s module doc): at the \
         *next sample* (the acquisition follows at once), at the *next run* armed (set-up and uncertainty budget, \
         frozen with the run), at the next *reset* (kept, read back and saved at once; status word bit 14 until \
         then) or at the next *reset communication* (NMT). No field changes while a run is armed or running.\n"
    );
    let _ = writeln!(
        s,
        "| field | CANopen | SCPI | unit | default | range | takes effect | what |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for (row, i) in FIELDS.iter().enumerate() {
        let index = od::config_index(row);
        let canopen = match i.elements {
            0 => format!("0x{index:04X}"),
            n => format!("0x{index:04X}:1–{n}"),
        };
        let show = |v: Option<f64>| match (v, i.choices().is_empty()) {
            (Some(v), false) => i
                .choices()
                .get(v as usize)
                .map_or_else(|| num(v), |c| (*c).to_string()),
            // an f32 field as the f32 it is (0.55, not 0.550000011920929)
            (Some(v), true) if matches!(i.ty, FieldType::F32) && !v.is_nan() => {
                format!("{}", v as f32)
            }
            (Some(v), true) => num(v),
            (None, _) => "–".into(),
        };
        let default = i
            .fields()
            .map(|f| show(cfg.field_value(f)))
            .collect::<Vec<_>>()
            .join(", ");
        let mut range = if i.choices().is_empty() {
            format!("{} … {}", num(i.min), num(i.max))
        } else {
            i.choices().join(", ")
        };
        if i.optional {
            range.push_str("; optional");
        }
        let elements = match i.elements {
            0 => String::new(),
            n if i.name.starts_with("axis") => format!(" (encoder input n = 1…{n})"),
            n => format!(" (k = 0…{})", n - 1),
        };
        let _ = writeln!(
            s,
            "| `{}` | {canopen} | `{}` | {} | {} | {} | {} | {}{} |",
            i.name,
            scpi_name(i),
            i.unit.as_str(),
            default,
            cell(&range),
            i.field.takes_effect().as_str(),
            cell(i.field.meaning()),
            elements
        );
    }
    let lvdt = [LvdtInput::AcRatiometric, LvdtInput::DcConditioner]
        .iter()
        .map(|m| format!("{} {m:?}", *m as u8))
        .collect::<Vec<_>>()
        .join(", ");
    let bitrate = (0..4)
        .filter_map(CanBitrate::from_u8)
        .enumerate()
        .map(|(k, b)| format!("{k} {} kbit/s", b.bits_per_s() / 1000))
        .collect::<Vec<_>>()
        .join(", ");
    let axes = (0..7)
        .filter_map(AxisName::from_u8)
        .enumerate()
        .map(|(k, a)| match a {
            AxisName::Unused => format!("{k} unused"),
            a => format!("{k} {a:?}"),
        })
        .collect::<Vec<_>>()
        .join(", ");
    let default_axes = cfg
        .axes
        .iter()
        .map(|a| format!("{:?}", a.name))
        .collect::<Vec<_>>()
        .join(", ");
    let _ = writeln!(
        s,
        "\nThe encoder inputs' axes and counting directions, the LVDT input mode and the CAN bit rate are \
         CANopen objects of their own (SCPI sets the axis names only, `CONFigure:AXIS<n>:NAME`):\n"
    );
    let _ = writeln!(s, "| field | CANopen | SCPI | default | codes | what |");
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    let rows: [(&str, String, &str, String, String, &str); 4] = [
        (
            "`lvdt_input`",
            "0x2040".to_string(),
            "–",
            format!("{:?}", cfg.lvdt_input),
            lvdt,
            object_meaning(0x2040),
        ),
        (
            "`can_bitrate`",
            "0x2041".to_string(),
            "–",
            format!("{} kbit/s", cfg.can_bitrate.bits_per_s() / 1000),
            bitrate,
            object_meaning(0x2041),
        ),
        (
            "`axis_name`",
            format!("0x2042:1–{MAX_AXES}"),
            "`AXIS<n>:NAME`",
            default_axes,
            axes,
            object_meaning(0x2042),
        ),
        (
            "`axis_reversed`",
            format!("0x2043:1–{MAX_AXES}"),
            "–",
            "false".into(),
            "false, true".into(),
            object_meaning(0x2043),
        ),
    ];
    for (name, canopen, scpi, default, codes, what) in rows {
        let _ = writeln!(
            s,
            "| {name} | {canopen} | {scpi} | {default} | {} | {} |",
            cell(&codes),
            cell(what)
        );
    }
    s
}

fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::Boolean => "BOOLEAN",
        DataType::Unsigned8 => "UNSIGNED8",
        DataType::Unsigned16 => "UNSIGNED16",
        DataType::Unsigned32 => "UNSIGNED32",
        DataType::Real32 => "REAL32",
        DataType::VisibleString => "VISIBLE_STRING",
    }
}

fn default_value(e: &Entry, comm: &CommParams, app: &App) -> String {
    let mut text = String::new();
    if e.access.readable() {
        // the EDS's own formatter: `$NODEID+0x…` for node-relative COB-IDs
        let _ = write_default(&mut text, e, comm, app, ("", ""));
    }
    if text.is_empty() { "–".into() } else { text }
}

/// Codes of the session objects, from the application's own enums.
fn codes(index: u16) -> String {
    let list = |v: Vec<String>| format!(" Codes: {}.", v.join(", "));
    match index {
        0x3000 => list(
            Pattern::ALL
                .iter()
                .map(|p| format!("{} {}", *p as u8, p.name()))
                .collect(),
        ),
        0x3001 => list(
            Direction::ALL
                .iter()
                .map(|d| format!("{} {}", *d as u8, d.name()))
                .collect(),
        ),
        0x3003 => list(
            [
                SessionState::Idle,
                SessionState::Armed,
                SessionState::Running,
                SessionState::Done,
                SessionState::Aborted,
            ]
            .iter()
            .map(|s| format!("{} {}", *s as u8, s.name()))
            .collect(),
        ),
        0x3004 => list(
            std::iter::once("0 NONE".to_string())
                .chain(
                    (1..=4)
                        .filter_map(AbortReason::from_u8)
                        .map(|r| format!("{} {}", r as u8, r.name())),
                )
                .collect(),
        ),
        _ => String::new(),
    }
}

fn canopen_objects() -> String {
    let app = App::new(Config::default(), [16; MAX_AXES]);
    let comm = CommParams::new(0, 0);
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# CANopen objects\n");
    let _ = writeln!(
        s,
        "Every entry of the pod's object dictionary (`ballpod::protocol::canopen::od`), as the SDO server \
         answers it and as `ballpod.eds` (CiA 306, generated from the same table) lists it. Defaults are \
         those of a pod with the default configuration; COB-IDs relative to the node-ID are written as in the EDS, `$NODEID+0x…`. The \
         configuration objects 0x2000–0x203F and 0x2044 on are listed with their unit, default and range under \
         [Configuration fields](configuration-fields.md), the result arrays' sub-entries under \
         [Results](results.md). How the CNC uses them: [The CNC's side](../cnc.md).\n"
    );
    let _ = writeln!(
        s,
        "| index:sub | name | type | access | PDO | unit | limits | default | what |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for index in od::indices() {
        let Some(obj) = od::object(index) else {
            continue;
        };
        let config = od::config_row(index).is_some();
        let result = (od::RESULT_VALUES..=od::RESULT_VALUES + 2).contains(&index);
        if config || result {
            let n = if obj.max_sub == 0 {
                String::new()
            } else {
                format!(":0–{}", obj.max_sub)
            };
            let what = if config {
                "configuration field, see [Configuration fields](configuration-fields.md)"
                    .to_string()
            } else {
                cell(object_meaning(index))
            };
            let _ = writeln!(
                s,
                "| 0x{index:04X}{n} | {} | | | | | | | {what} |",
                obj.name.as_str()
            );
            continue;
        }
        let mut what = format!("{}{}", object_meaning(index), codes(index));
        // one row per entry; a run of array elements alike but for their number is one row
        let rows: Vec<(u8, Option<u8>, &str, String)> = (0..=obj.max_sub)
            .filter_map(|sub| od::entry(index, sub).ok())
            .map(|e| {
                let limits = e.limits.map_or(String::new(), |(lo, hi)| {
                    format!("{} … {}", num(lo), num(hi))
                });
                let rest = format!(
                    "{} | {} | {} | {} | {} | {}",
                    type_name(e.ty),
                    e.access.eds(),
                    if e.pdo_mappable { "yes" } else { "" },
                    e.unit.as_str(),
                    limits,
                    cell(&default_value(&e, &comm, &app)),
                );
                (e.sub, e.element, e.name.as_str(), rest)
            })
            .collect();
        // the EDS's ParameterName: `name_k`, or `Name k` for CiA names with spaces
        let named = |base: &str, k: &str| {
            let sep = if base.contains(' ') { " " } else { "_" };
            format!("{base}{sep}{k}")
        };
        let mut k = 0;
        while let Some((sub, element, name, rest)) = rows.get(k) {
            let mut last = k;
            while element.is_some()
                && rows
                    .get(last + 1)
                    .is_some_and(|(_, el, n, r)| el.is_some() && n == name && r == rest)
            {
                last += 1;
            }
            let (subs, shown) = match element {
                Some(_) if last > k => {
                    let to = rows.get(last).map_or(*sub, |r| r.0);
                    (format!("{sub}–{to}"), named(name, "k"))
                }
                Some(el) => (format!("{sub}"), named(name, &el.to_string())),
                None => (format!("{sub}"), name.to_string()),
            };
            let _ = writeln!(
                s,
                "| 0x{index:04X}:{subs} | {} | {rest} | {} |",
                cell(&shown),
                cell(&what)
            );
            what.clear();
            k = last + 1;
        }
    }
    let _ = writeln!(
        s,
        "\nRun counters (0x3005) are described under [Reliability](../reliability.md), device counters \
         (0x2110) under [Hardware](../hardware.md)."
    );
    s
}

fn scpi_commands() -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# SCPI commands\n");
    let _ = writeln!(
        s,
        "Every command of the pod's USB command port (`ballpod::protocol::scpi`); keywords in short \
         (upper-case letters) or long form, any letter case; `;` separates units of one line. The rules, \
         the port's lock and examples: [The technician's side](../technician.md); the error numbers: \
         [Error codes](error-codes.md).\n"
    );
    let _ = writeln!(s, "| command | what | e.g. |");
    let _ = writeln!(s, "|---|---|---|");
    for c in commands() {
        let _ = writeln!(
            s,
            "| `{}` | {} | `{}` |",
            cell(c.syntax),
            cell(c.what),
            c.example
        );
    }
    s
}

fn results() -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# Results\n");
    let _ = writeln!(
        s,
        "The pod's results catalogue (`ballpod::app::results`): every figure it computes from its runs. \
         Result k is CANopen 0x4000:k+1 (value), 0x4001:k+1 (standard uncertainty u; NaN: not evaluated) \
         and 0x4002:k+1 (valid), and SCPI `FETCh:RESult? <name>` or `<k>` (`value,u,UNIT`). A result is \
         invalid until a run (or the procedure) computes it: CANopen answers 0x08000024, SCPI queues -230 \
         — never 0.0. What each u covers: \
         [What each stated uncertainty covers](../methods/index.md#what-each-stated-uncertainty-covers).\n"
    );
    let _ = writeln!(s, "| k | name | unit | what |");
    let _ = writeln!(s, "|---|---|---|---|");
    for (k, (r, what)) in ResultInfo::all().zip(RESULT_MEANINGS).enumerate() {
        let _ = writeln!(
            s,
            "| {k} | `{}` | {} | {} |",
            r.name,
            r.unit.as_str(),
            cell(what)
        );
    }
    s
}

fn error_codes() -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{GENERATED}\n");
    let _ = writeln!(s, "# Error codes\n");
    let _ = writeln!(s, "## EMCY (CANopen)\n");
    let _ = writeln!(
        s,
        "Emergency messages on 0x080 + node-ID (CiA 301 §7.2.7): error code, error register (0x1001), then \
         byte 3 the manufacturer's reason and bytes 4–5 the fault bits still active. One EMCY per newly \
         raised fault, 0x0000 once every fault has cleared, at most one per inhibit time (0x1015); the \
         history is 0x1003.\n"
    );
    let _ = writeln!(s, "| code | when | byte 3 |");
    let _ = writeln!(s, "|---|---|---|");
    for (flag, code) in emcy::FAULTS {
        let name = flag_name(flag);
        let _ = writeln!(
            s,
            "| 0x{code:04X} | a sample flagged {name} (newly raised) | {} (the flag's bit number) |",
            flag.0.trailing_zeros()
        );
    }
    let fixed = [
        (
            emcy::SOFTWARE_ERROR,
            "after the boot-up: the previous run ended in a panic, a watchdog reset or a HardFault \
             (`SYSTem:ERRor?` has the panic's place or the fault's PC)"
                .to_string(),
            format!(
                "{} panic, {} watchdog, {} HardFault",
                emcy::REASON_PANIC,
                emcy::REASON_WATCHDOG,
                emcy::REASON_HARD_FAULT
            ),
        ),
        (
            emcy::DEVICE_HARDWARE,
            "after the boot-up: the previous run ended in a low-power reset, or the option bytes \
             are wrong for the firmware (`SYSTem:ERRor?` says which bit and how to set it)"
                .to_string(),
            format!(
                "{} low-power reset, {} option bytes",
                emcy::REASON_LOW_POWER_RESET,
                emcy::REASON_OPTION_BYTES
            ),
        ),
        (
            emcy::DATA_SET,
            "after the boot-up: a stored configuration was rejected, or a settings slot could not be \
             read (a double ECC error: a save cut by a power loss); the other slot's settings or \
             the defaults are in use"
                .to_string(),
            format!(
                "{} rejected, {} unreadable",
                emcy::REASON_SETTINGS_REJECTED,
                emcy::REASON_SETTINGS_UNREADABLE
            ),
        ),
        (
            emcy::CAN_OVERRUN,
            "the CAN controller lost received frames (its receive FIFO full; at most one per \
             inhibit time; device counter `can_rx_lost`)"
                .to_string(),
            "–".to_string(),
        ),
        (
            emcy::ERROR_PASSIVE,
            "the CAN controller went error passive".to_string(),
            "–".to_string(),
        ),
        (
            emcy::BUS_OFF_RECOVERED,
            "the CAN controller recovered from bus-off (sent at once, before the held-back EMCYs)"
                .to_string(),
            "–".to_string(),
        ),
        (
            emcy::ERROR_RESET,
            "every fault has cleared".to_string(),
            "–".to_string(),
        ),
    ];
    for (code, when, byte3) in fixed {
        let _ = writeln!(s, "| 0x{code:04X} | {} | {byte3} |", cell(&when));
    }
    let _ = writeln!(s, "\n## SCPI (`SYSTem:ERRor?`)\n");
    let _ = writeln!(
        s,
        "`<code>,\"<message>;<detail>\"`: the standard message (SCPI-99 Vol 2 §21.8) and what the pod \
         adds. A rejected command changes nothing. A command error (-1xx) also discards the rest of its \
         line; execution errors (-2xx) do not. The queue holds 16.\n"
    );
    let _ = writeln!(s, "| code | message | when |");
    let _ = writeln!(s, "|---|---|---|");
    for (code, when) in ERRORS {
        let _ = writeln!(s, "| {code} | {} | {} |", message(*code), cell(when));
    }
    let _ = writeln!(
        s,
        "\n## SDO abort codes (CANopen)\n\nThe abort codes and when the pod sends each: \
         [The CNC's side](../cnc.md#refusals)."
    );
    s
}

fn flag_name(f: SampleFlags) -> &'static str {
    match f {
        SampleFlags::LVDT_OPEN => "LVDT open",
        SampleFlags::LVDT_OVER_RANGE => "LVDT over-range",
        SampleFlags::QUADRATURE_ERROR => "quadrature error",
        SampleFlags::TEMPERATURE_FAULT => "thermistor fault",
        SampleFlags::OVERRUN => "overrun (samples lost before it)",
        _ => "?",
    }
}

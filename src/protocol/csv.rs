//! The text of a recorded run: the format of the log download (`DATA:LOG?`) and of the USB
//! sample stream, which replay reads back into the same application.
//!
//! # Format (version 2)
//!
//! ```text
//! # ballpod run v2
//! # run=3
//! # pattern=CIRCLE
//! # direction=CCW
//! # bar_length=150
//! # bar_cte=11.5
//! # lvdt_poly0=0
//! …                          every configuration field (config::FIELDS, indexed ones with their
//! # circle_radius=150         element number from 0), then lvdt_input, can_bitrate and per
//! # circle_centre_x=nan       encoder input axis_name<k>, axis_reversed<k>
//! …
//! # source=log               log: source, decimation, records, overwritten; stream: source,
//!                             and partial=1 when the reader joined after the run's first samples
//! # decimation=1
//! # records=3
//! # overwritten=0
//! # flags=bit0 lvdt_over_range|bit1 lvdt_open|bit2 quadrature_error|bit3 probe_event|bit4 overrun|bit5 temperature_fault|bit15 touch
//! # firmware=0.2.0+1a2b3c4d5e6f  the firmware that made the text (crate version + commit)
//! seq,t_s,dl_um,x_mm,y_mm,z_mm,b_deg,c_deg,temp_c,flags
//! 12344,12.345678,0.123456791,150,0,-20,0,90,20.12,0
//! 12345,12.346678,nan,150.000015,0.0100000007,-20,0,90,20.12,32768
//! # end=DONE
//! # reason=NONE
//! # seen=3
//! …                          every run counter (RunCounters::NAMES)
//! ```
//!
//! `#` lines are `key=value` metadata; then the column header; then one row per sample the run
//! saw (used or skipped: the flags say), oldest first, and one row per touch point (flags bit
//! 15; the axes are the positions latched at the probe edge, `dl_um` is `nan`); then, once the
//! run has ended, how it ended and its counters. Columns: `seq` (sample number, counting lost
//! samples: a gap is a loss), `t_s` (s since boot, 6 decimals = 1 µs), `dl_um`, one column per
//! configured axis in the order X, Y, Z, A, B, C (`x_mm` … `c_deg`), `temp_c` (2 decimals),
//! `flags` (decimal). ΔL, positions and the configuration's f32 fields are written with 9
//! significant digits, which read back to the same `f32`; a value that is not valid (or a
//! set-up field that is not set, or a non-finite number) is `nan`. Lines end with `\n`.

use crate::acquisition::MAX_AXES;
use crate::app::log::{LogRecord, LoggedRecord};
use crate::app::{RunCounters, RunEnd, RunMeta};
use crate::config::{AxisName, FIELDS, FieldType, LvdtInput};
use crate::protocol::scpi::number::{Text, push_bytes, push_exact, push_fixed, push_u64};

/// Format version in the first line.
pub const VERSION: u32 = 2;

/// Longest line, bytes (a data row with five axes is at most ~140).
pub const CSV_LINE_MAX: usize = 192;

/// One line under construction.
pub type Line = Text<CSV_LINE_MAX>;

/// Significant digits of an `f32` value (reads back exactly).
const F32_DIGITS: u32 = 9;
/// Significant digits of an `f64` configuration value (the encoder scales).
const F64_DIGITS: u32 = 15;

/// Lines of the run header before the configuration.
const HEAD_LINES: usize = 4;

/// Configuration lines of [`FIELDS`]' rows: one per element.
const FIELD_LINES: usize = field_lines();

// Evaluated at compile time: an index out of bounds is a build error.
#[allow(clippy::indexing_slicing)]
const fn field_lines() -> usize {
    let (mut n, mut i) = (0, 0);
    while i < FIELDS.len() {
        n += if FIELDS[i].elements == 0 {
            1
        } else {
            FIELDS[i].elements as usize
        };
        i += 1;
    }
    n
}

/// The [`FIELDS`] row and element of each of the configuration's field lines: a line is
/// formatted without searching the table (a header's hundred lines each searched it: ≈ 30 000
/// Cortex-M4F instructions of a run's start).
// Evaluated at compile time: an index out of bounds is a build error.
#[allow(clippy::indexing_slicing)]
const LINE_FIELDS: [(u8, u8); FIELD_LINES] = {
    assert!(FIELDS.len() <= 256);
    let mut t = [(0u8, 0u8); FIELD_LINES];
    let (mut line, mut i) = (0, 0);
    while i < FIELDS.len() {
        let n = if FIELDS[i].elements == 0 {
            1
        } else {
            FIELDS[i].elements
        };
        let mut k = 0;
        while k < n {
            t[line] = (i as u8, k);
            line += 1;
            k += 1;
        }
        i += 1;
    }
    t
};

/// Configuration lines: every element of [`FIELDS`], the two enums, two per encoder input.
const fn config_lines() -> usize {
    FIELD_LINES + 2 + 2 * MAX_AXES
}

/// Lines of the run header ([`meta_line`]): head and configuration.
pub fn meta_lines() -> usize {
    HEAD_LINES + config_lines()
}

fn kv(line: &mut Line, key: &str) -> bool {
    push_bytes(line, b"# ") && push_bytes(line, key.as_bytes()) && push_bytes(line, b"=")
}

/// Line `index` (< [`meta_lines`]) of the run header, into `line` (cleared first, with `\n`).
pub fn meta_line(index: usize, meta: &RunMeta, line: &mut Line) -> bool {
    line.clear();
    let c = &meta.config;
    match index {
        0 => {
            push_bytes(line, b"# ballpod run v");
            push_u64(line, u64::from(VERSION));
        }
        1 => {
            kv(line, "run");
            push_u64(line, u64::from(meta.run));
        }
        2 => {
            kv(line, "pattern");
            push_bytes(line, meta.pattern.name().as_bytes());
        }
        3 => {
            kv(line, "direction");
            push_bytes(line, meta.direction.name().as_bytes());
        }
        k => {
            let k = k - HEAD_LINES;
            let found = if let Some(&(r, k)) = LINE_FIELDS.get(k)
                && let Some(row) = FIELDS.get(usize::from(r))
            {
                push_bytes(line, b"# ");
                push_bytes(line, row.name.as_bytes());
                if row.elements > 0 {
                    push_u64(line, u64::from(k));
                }
                push_bytes(line, b"=");
                let v = c.field_value(row.element(k)).unwrap_or(f64::NAN);
                match row.ty {
                    FieldType::F32 => push_exact(line, v, F32_DIGITS, b"nan"),
                    FieldType::F64 => push_exact(line, v, F64_DIGITS, b"nan"),
                    _ => match row.choices().get(v as usize) {
                        Some(name) => push_bytes(line, name.as_bytes()),
                        None => push_u64(line, v as u64),
                    },
                };
                true
            } else {
                false
            };
            if !found {
                // (past the field lines; an index in them always has its row)
                match k.wrapping_sub(FIELD_LINES) {
                    0 => {
                        kv(line, "lvdt_input");
                        push_bytes(
                            line,
                            match c.lvdt_input {
                                LvdtInput::AcRatiometric => b"AC",
                                LvdtInput::DcConditioner => b"DC",
                            },
                        );
                    }
                    1 => {
                        kv(line, "can_bitrate");
                        push_u64(line, u64::from(c.can_bitrate.bits_per_s()));
                    }
                    k if k < 2 + 2 * MAX_AXES => {
                        let i = (k - 2) / 2;
                        let a = c.axes.get(i);
                        push_bytes(
                            line,
                            if (k - 2) % 2 == 0 {
                                b"# axis_name"
                            } else {
                                b"# axis_reversed"
                            },
                        );
                        push_u64(line, i as u64);
                        push_bytes(line, b"=");
                        if (k - 2) % 2 == 0 {
                            let l = a.map_or('-', |a| a.name.letter());
                            push_bytes(line, &[l as u8]);
                        } else {
                            push_u64(line, u64::from(a.is_some_and(|a| a.reversed)));
                        }
                    }
                    _ => return false,
                }
            }
        }
    }
    push_bytes(line, b"\n")
}

/// The line naming the firmware that made the text (`# firmware=0.2.0+1a2b3c4d5e6f`:
/// [`crate::FIRMWARE_VERSION`] on the pod), after the flags legend.
pub fn firmware_line(version: &str, line: &mut Line) -> bool {
    line.clear();
    kv(line, "firmware") && push_bytes(line, version.as_bytes()) && push_bytes(line, b"\n")
}

/// The flags legend line.
pub fn flags_line(line: &mut Line) -> bool {
    line.clear();
    push_bytes(
        line,
        b"# flags=bit0 lvdt_over_range|bit1 lvdt_open|bit2 quadrature_error|bit3 probe_event|bit4 overrun|bit5 temperature_fault|bit15 touch\n",
    )
}

/// The CSV columns of the configured axes: (input index, column name), in the order
/// X, Y, Z, A, B, C.
pub fn axis_columns(meta: &RunMeta) -> impl Iterator<Item = (usize, &'static str)> + '_ {
    const ORDER: [(AxisName, &str); 6] = [
        (AxisName::X, "x_mm"),
        (AxisName::Y, "y_mm"),
        (AxisName::Z, "z_mm"),
        (AxisName::A, "a_deg"),
        (AxisName::B, "b_deg"),
        (AxisName::C, "c_deg"),
    ];
    ORDER.into_iter().filter_map(move |(name, col)| {
        meta.config
            .axes
            .iter()
            .position(|a| a.name == name)
            .map(|input| (input, col))
    })
}

/// The column header line.
pub fn columns_line(meta: &RunMeta, line: &mut Line) -> bool {
    line.clear();
    push_bytes(line, b"seq,t_s,dl_um");
    for (_, col) in axis_columns(meta) {
        push_bytes(line, b",");
        push_bytes(line, col.as_bytes());
    }
    push_bytes(line, b",temp_c,flags\n")
}

/// The data row of a sample or touch point.
pub fn record_line(r: &LoggedRecord, meta: &RunMeta, line: &mut Line) -> bool {
    let rec: &LogRecord = &r.record;
    let mut axes = [f32::NAN; MAX_AXES];
    let mut n = 0;
    for ((input, _), slot) in axis_columns(meta).zip(axes.iter_mut()) {
        *slot = rec.axes.get(input).copied().unwrap_or(f32::NAN);
        n += 1;
    }
    row_line(
        &Row {
            seq: rec.seq,
            t_us: r.t_us,
            delta_l_um: rec.delta_l_um,
            axes: axes.get(..n).unwrap_or(&[]),
            temp_c: rec.temp_c(),
            flags: rec.flags,
        },
        line,
    )
}

/// One data row's values, the axes already in column order ([`axis_columns`]).
#[derive(Clone, Copy, Debug)]
pub struct Row<'a> {
    /// Sample number.
    pub seq: u32,
    /// Time stamp, µs since boot.
    pub t_us: u64,
    /// ΔL, µm.
    pub delta_l_um: f32,
    /// Positions of the axis columns, mm or degrees.
    pub axes: &'a [f32],
    /// Bar temperature, °C, as logged (0.01 °C steps, [`LogRecord::temp_c`]).
    pub temp_c: f32,
    /// Flags ([`LogRecord::flags`]).
    pub flags: u16,
}

/// The data row `r` (the log's and the stream decoder's one formatter).
pub fn row_line(r: &Row, line: &mut Line) -> bool {
    line.clear();
    push_u64(line, u64::from(r.seq));
    push_bytes(line, b",");
    push_u64(line, r.t_us / 1_000_000);
    push_bytes(line, b".");
    let mut digits = [b'0'; 6];
    let mut f = r.t_us % 1_000_000;
    for d in digits.iter_mut().rev() {
        *d = b'0' + (f % 10) as u8;
        f /= 10;
    }
    push_bytes(line, &digits);
    push_bytes(line, b",");
    push_exact(line, f64::from(r.delta_l_um), F32_DIGITS, b"nan");
    for &v in r.axes {
        push_bytes(line, b",");
        push_exact(line, f64::from(v), F32_DIGITS, b"nan");
    }
    push_bytes(line, b",");
    push_fixed(line, f64::from(r.temp_c), 2, false, b"nan");
    push_bytes(line, b",");
    push_u64(line, u64::from(r.flags));
    push_bytes(line, b"\n")
}

/// Lines of a run's end ([`end_line`]).
pub const END_LINES: usize = 2 + RunCounters::LEN;

/// Line `index` (< [`END_LINES`]) of how a run ended.
pub fn end_line(index: usize, end: &RunEnd, line: &mut Line) -> bool {
    line.clear();
    match index {
        0 => {
            kv(line, "end");
            push_bytes(
                line,
                if end.abort.is_some() {
                    b"ABORTED"
                } else {
                    b"DONE"
                },
            );
        }
        1 => {
            kv(line, "reason");
            push_bytes(line, end.abort.map_or("NONE", |a| a.name()).as_bytes());
        }
        k => {
            let k = k - 2;
            let (Some(name), Some(v)) = (
                RunCounters::NAMES.get(k),
                end.counters.as_array().get(k).copied(),
            ) else {
                return false;
            };
            kv(line, name);
            push_u64(line, u64::from(v));
        }
    }
    push_bytes(line, b"\n")
}

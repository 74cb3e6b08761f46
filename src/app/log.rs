//! The pod's own log of the last run, for a download over USB (`DATA:LOG?`) when no PC
//! recorded the stream: the run's header, its samples and touch points in fixed RAM.
//!
//! # Whole runs at the best rate that fits
//!
//! The log holds one run (a new run clears it). While the run fits, every sample is kept; when
//! the log is full it keeps every other sample and from then on logs one in two, then one in
//! four, … (`decimation`, a power of two, counted from the run's first sample number), so it
//! always spans the whole run: a 57 s circle at 1 kHz in 416 records is logged at 1 kHz / 256.
//! Touch points are never dropped by the decimation. What could not be kept is counted
//! ([`SampleLog::overwritten`]). The USB sample stream has every sample; replaying a decimated
//! log gives the results of the logged samples, not the pod's own.
//!
//! # Record layout and RAM
//!
//! One [`LogRecord`] is 36 bytes: sample number (u32), time stamp low word (u32, µs), ΔL (f32,
//! µm), five axis positions (f32, mm or degrees, input order, exactly the sample's values),
//! temperature (i16, 0.01 °C) and flags (u16: the [`SampleFlags`] bits, and
//! [`LogRecord::TOUCH`] for a touch point). The firmware's log holds [`LOG_CAPACITY`] records
//! plus the run's header (its configuration, ~0.5 KiB).

use super::record::{Recorder, RunEnd, RunMeta, Touch};
use super::run::{AbortReason, RunCounters};
use crate::acquisition::{MAX_AXES, Sample, SampleFlags};
use crate::in_place::{self, init_in_place};
use core::mem::MaybeUninit;

/// Records the firmware's log holds (36 bytes each: 14.6 KiB, in the 32 KiB CCM SRAM of the
/// pod, `memory.x`, beside the 17.4 KiB job slot, `app::job`).
pub const LOG_CAPACITY: usize = 416;

/// Temperature stored when the sample's temperature is not finite or beyond ±327 °C.
const TEMP_INVALID: i16 = i16::MIN;

/// One logged sample or touch point (36 bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LogRecord {
    /// Sample number ([`Sample::seq`]); for a touch point, the number of the next sample.
    pub seq: u32,
    /// Low 32 bits of the time stamp, µs since boot.
    pub t_lo_us: u32,
    /// ΔL, µm (NaN for a touch point).
    pub delta_l_um: f32,
    /// Axis positions in input order, mm or degrees (a touch point: the latched positions).
    pub axes: [f32; MAX_AXES],
    /// Bar temperature, 0.01 °C (`i16::MIN` if not valid).
    pub temp_centi_c: i16,
    /// [`SampleFlags`] bits, and [`LogRecord::TOUCH`] for a touch point.
    pub flags: u16,
}

const _: () = assert!(core::mem::size_of::<LogRecord>() == 36);

impl LogRecord {
    /// Flags bit of a touch point (the axes are the positions latched at the probe edge).
    pub const TOUCH: u16 = 1 << 15;

    const ZERO: Self = Self {
        seq: 0,
        t_lo_us: 0,
        delta_l_um: 0.0,
        axes: [0.0; MAX_AXES],
        temp_centi_c: 0,
        flags: 0,
    };

    /// The record of a sample (temperature rounded to 0.01 °C).
    pub fn from_sample(s: &Sample) -> Self {
        let temp_centi_c = Self::centi_c(s.temp_c);
        Self {
            seq: s.seq,
            t_lo_us: s.t_us as u32,
            delta_l_um: s.delta_l_um,
            axes: s.axes,
            temp_centi_c,
            flags: s.flags.0,
        }
    }

    /// A temperature in °C as stored: the f32 product `temp_c · 100` rounded half away from
    /// zero (`i16::MIN`: not finite or beyond ±327 °C). In f32 on purpose: one multiply on the
    /// sample path, where the f64 product took ~300 soft-float instructions a sample.
    pub fn centi_c(temp_c: f32) -> i16 {
        let centi = temp_c * 100.0;
        if centi.is_finite() && centi.abs() < 32_767.0 {
            (if centi < 0.0 {
                centi - 0.5
            } else {
                centi + 0.5
            }) as i16
        } else {
            TEMP_INVALID
        }
    }

    /// The record of a touch point before sample `next_seq`.
    pub fn from_touch(t: &Touch, next_seq: u32) -> Self {
        Self {
            seq: next_seq,
            t_lo_us: t.t_us as u32,
            delta_l_um: f32::NAN,
            axes: t.axes,
            temp_centi_c: TEMP_INVALID,
            flags: Self::TOUCH,
        }
    }

    /// True for a touch point.
    pub const fn is_touch(&self) -> bool {
        self.flags & Self::TOUCH != 0
    }

    /// The temperature, °C (NaN if it was not valid).
    pub fn temp_c(&self) -> f32 {
        Self::c_of_centi(self.temp_centi_c)
    }

    /// A stored temperature ([`LogRecord::centi_c`]) in °C (NaN if it was not valid).
    pub fn c_of_centi(centi: i16) -> f32 {
        if centi == TEMP_INVALID {
            f32::NAN
        } else {
            f32::from(centi) / 100.0
        }
    }
}

/// A logged record as read back (full time stamp).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoggedRecord {
    /// Time stamp, µs since boot.
    pub t_us: u64,
    /// The stored record.
    pub record: LogRecord,
}

impl LoggedRecord {
    /// The sample this record holds (a touch point gives its latched positions and NaN ΔL).
    pub fn sample(&self) -> Sample {
        let r = &self.record;
        Sample {
            seq: r.seq,
            t_us: self.t_us,
            delta_l_um: r.delta_l_um,
            axes: r.axes,
            temp_c: r.temp_c(),
            flags: SampleFlags(r.flags & !LogRecord::TOUCH),
        }
    }
}

/// The log of the last run: up to `N` records (module doc).
#[derive(Clone, Debug)]
pub struct SampleLog<const N: usize> {
    records: [LogRecord; N],
    len: usize,
    /// Full time stamp of the first record, µs.
    first_t_us: u64,
    /// Sample number the decimation counts from (the run's first sample).
    first_seq: Option<u32>,
    /// Log one sample in 2^`decimation_log2`.
    decimation_log2: u8,
    /// Samples or touch points that could not be kept.
    overwritten: u32,
    /// Sample number of the last sample seen (a touch point is filed before the next one).
    last_seq: u32,
    /// The run's header; valid when `has_meta`.
    meta: RunMeta,
    has_meta: bool,
    /// How the run ended ([`AbortReason`] code, 0 = normal stop); valid when `has_end`.
    end_abort: u8,
    end_counters: RunCounters,
    has_end: bool,
    /// Samples not logged because a download was in progress, since boot
    /// ([`SampleLog::count_paused`]).
    paused: u32,
}

impl<const N: usize> Default for SampleLog<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleLog<N> {
    /// An empty log.
    pub fn new() -> Self {
        in_place::build(Self::init)
    }

    /// An empty log built in place in `slot` (the pod's log is larger than its stack).
    pub fn init(slot: &mut MaybeUninit<Self>) -> &mut Self {
        init_in_place!(slot, Self {
            len: 0,
            first_t_us: 0,
            first_seq: None,
            decimation_log2: 0,
            overwritten: 0,
            last_seq: 0,
            meta: RunMeta::ZERO,
            has_meta: false,
            end_abort: 0,
            end_counters: RunCounters::ZERO,
            has_end: false,
            paused: 0,
        } in place {
            records: |s| in_place::fill(s, LogRecord::ZERO),
        })
    }

    /// Capacity, records.
    pub const fn capacity(&self) -> usize {
        N
    }

    /// Records held.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True if no record is held.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Counts a sample not logged because the log is being downloaded (it must not change
    /// meanwhile; the stream still has the sample).
    pub fn count_paused(&mut self) {
        self.paused = self.paused.saturating_add(1);
    }

    /// Samples not logged because a download was in progress, since boot.
    pub const fn paused_samples(&self) -> u32 {
        self.paused
    }

    /// Samples or touch points the log could not keep in this run.
    pub const fn overwritten(&self) -> u32 {
        self.overwritten
    }

    /// One sample in this many is logged (a power of two).
    pub const fn decimation(&self) -> u32 {
        1 << self.decimation_log2
    }

    /// The run's header, if a run was recorded.
    pub const fn meta(&self) -> Option<&RunMeta> {
        if self.has_meta {
            Some(&self.meta)
        } else {
            None
        }
    }

    /// How the run ended, once it has.
    pub fn end(&self) -> Option<RunEnd> {
        self.has_end.then(|| RunEnd {
            run: self.meta.run,
            abort: AbortReason::from_u8(self.end_abort),
            counters: self.end_counters,
        })
    }

    /// Empties the log.
    pub fn clear(&mut self) {
        self.len = 0;
        self.first_seq = None;
        self.decimation_log2 = 0;
        self.overwritten = 0;
        self.has_meta = false;
        self.has_end = false;
    }

    fn keeps(&self, seq: u32, log2: u8) -> bool {
        let rel = seq.wrapping_sub(self.first_seq.unwrap_or(seq));
        rel.trailing_zeros() >= u32::from(log2)
    }

    /// Keeps the touch points and every other logged sample; doubles the decimation.
    fn thin(&mut self) {
        let log2 = self.decimation_log2.saturating_add(1).min(31);
        let mut kept = 0;
        for i in 0..self.len {
            let Some(r) = self.records.get(i).copied() else {
                break;
            };
            if r.is_touch() || self.keeps(r.seq, log2) {
                if let Some(dst) = self.records.get_mut(kept) {
                    copy_record(dst, &r);
                }
                kept += 1;
            }
        }
        self.len = kept;
        self.decimation_log2 = log2;
    }

    fn push(&mut self, r: LogRecord, t_us: u64) {
        if self.len == N && N > 0 && self.decimation_log2 < 31 {
            self.thin();
        }
        if r.is_touch() || self.keeps(r.seq, self.decimation_log2) {
            match self.records.get_mut(self.len) {
                Some(slot) => {
                    if self.len == 0 {
                        self.first_t_us = t_us;
                    }
                    *slot = r;
                    self.len += 1;
                }
                None => self.overwritten = self.overwritten.saturating_add(1),
            }
        }
    }

    /// The `k`-th record, oldest first, with its full time stamp, µs since boot: of the times
    /// whose low 32 bits are the record's, the one nearest to the time its sample number gives
    /// (the first record's time plus the sample periods between them; lost periods advance
    /// the sample number too). So a run of any length comes back exact, where the low word
    /// alone wraps every 71.6 min. Without a header (no sample rate) the time runs forward from
    /// the first record's, exact for 71.6 min.
    pub fn get(&self, k: usize) -> Option<LoggedRecord> {
        let records = self.records.get(..self.len)?;
        let r = *records.get(k)?;
        let first_seq = records.first().map_or(r.seq, |f| f.seq);
        let t_us = match self.period_us() {
            Some(period_us) => {
                let periods = u64::from(r.seq.wrapping_sub(first_seq));
                let expected = self
                    .first_t_us
                    .saturating_add(periods.saturating_mul(period_us));
                // (the low words' difference read as signed: ±35.8 min around the expected)
                let off = i64::from(r.t_lo_us.wrapping_sub(expected as u32) as i32);
                expected.saturating_add_signed(off)
            }
            None => self
                .first_t_us
                .wrapping_add(u64::from(r.t_lo_us.wrapping_sub(self.first_t_us as u32))),
        };
        Some(LoggedRecord { t_us, record: r })
    }

    /// The run's sample period, whole µs, from its header's sample rate (`None`: no header).
    fn period_us(&self) -> Option<u64> {
        let rate = self.meta.config.sample_rate_hz;
        (self.has_meta && rate >= 1.0).then(|| (1e6 / f64::from(rate)) as u64)
    }

    /// The records, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = LoggedRecord> + '_ {
        (0..self.len).filter_map(|k| self.get(k))
    }
}

impl<const N: usize> Recorder for SampleLog<N> {
    fn begin_run(&mut self, meta: &RunMeta) {
        self.clear();
        self.meta = *meta;
        self.has_meta = true;
    }

    fn sample(&mut self, s: &Sample) {
        let first = *self.first_seq.get_or_insert(s.seq);
        self.last_seq = s.seq;
        // a sample the decimation drops (also after the thinning `push` may do) is not built
        if s.seq.wrapping_sub(first).trailing_zeros() >= u32::from(self.decimation_log2) {
            self.push(LogRecord::from_sample(s), s.t_us);
        }
    }

    fn touch(&mut self, t: &Touch) {
        let next = self.last_seq.wrapping_add(1);
        self.push(LogRecord::from_touch(t, next), t.t_us);
    }

    fn end_run(&mut self, end: &RunEnd) {
        self.end_abort = end.abort.map_or(0, |a| a as u8);
        self.end_counters = end.counters;
        self.has_end = true;
    }
}

/// `*dst = *src` for two records that cannot overlap (distinct references: the compiler copies
/// without the 1.5 KiB memmove it would otherwise link into the firmware for the log's
/// in-place thinning).
#[inline(never)]
fn copy_record(dst: &mut LogRecord, src: &LogRecord) {
    *dst = *src;
}

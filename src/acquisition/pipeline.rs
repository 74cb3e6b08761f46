//! The acquisition pipeline: one LVDT reading + the encoder counters + the last temperature →
//! one calibrated, flagged [`Sample`]. The firmware and the simulator both call this; neither
//! has maths of its own.

use super::encoder::{AxisScale, CountExtender};
use super::lvdt::{DemodError, LvdtCalibration, LvdtReading, LvdtStatus, dc_reading};
use super::probe::{ProbeDebouncer, ProbeLatch, TriggerOutcome};
use super::sample::{MAX_AXES, Sample, SampleFlags};
use super::thermal::{REFERENCE_TEMP_C, Thermistor, ThermistorFault, bar_expansion_um};
use crate::config::{Config, GLITCH_MARGIN};

/// Counters of everything acquisition flagged or lost (nothing is dropped silently).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AcquisitionCounters {
    /// Samples produced.
    pub samples: u32,
    /// Samples with an LVDT over-range.
    pub lvdt_over_range: u32,
    /// Samples with an open / weak LVDT.
    pub lvdt_open: u32,
    /// Samples with a quadrature error on any axis.
    pub quadrature_errors: u32,
    /// Samples that used a faulty (or no) temperature.
    pub temperature_faults: u32,
    /// Items lost upstream (ADC blocks or samples), as reported by the queues' overrun counters.
    pub lost_upstream: u32,
}

/// Acquisition state of the pod (calibrations derived from the [`Config`], counter extension,
/// probe bookkeeping, temperature, counters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acquisition {
    lvdt: LvdtCalibration,
    dc: (f32, f32),
    thermistor: Thermistor,
    bar_length_mm: f32,
    cte_ppm_per_k: f32,
    scales: [AxisScale; MAX_AXES],
    counters_hw: [CountExtender; MAX_AXES],
    /// The last (count, position) of each axis: an axis that did not move is not scaled again
    /// (most axes stand still in most tests). (0, 0.0) holds for any scale.
    last_position: [(i64, f32); MAX_AXES],
    /// Touch-probe debounce and lock-out.
    pub probe: ProbeDebouncer,
    temp_c: Option<f32>,
    temp_fault: bool,
    last_lost: u32,
    seq: u32,
    /// What was flagged or lost so far.
    pub counters: AcquisitionCounters,
}

impl Acquisition {
    /// Builds the pipeline from a (validated) configuration; `counter_bits[i]` is the width of
    /// the hardware counter of encoder input i (16 or 32).
    pub fn new(cfg: &Config, counter_bits: [u32; MAX_AXES]) -> Self {
        let mut scales = [AxisScale::new(1.0, false); MAX_AXES];
        let mut counters_hw = [CountExtender::new(16, 0); MAX_AXES];
        let rate = f64::from(cfg.sample_rate_hz).max(1.0);
        for (((s, c), a), bits) in scales
            .iter_mut()
            .zip(counters_hw.iter_mut())
            .zip(cfg.axes.iter())
            .zip(counter_bits)
        {
            *s = AxisScale::new(a.counts_per_unit, a.reversed);
            let step = f64::from(a.max_speed_per_s) * a.counts_per_unit / rate * GLITCH_MARGIN;
            let max_step = if step >= f64::from(u32::MAX) {
                0
            } else {
                (step as u32).max(1)
            };
            *c = CountExtender::new(bits, max_step);
        }
        Self {
            lvdt: LvdtCalibration {
                poly_um: cfg.lvdt_poly_um,
                max_abs_ratio: cfg.lvdt_max_abs_ratio,
                min_signal_level: cfg.lvdt_min_signal,
            },
            dc: (cfg.lvdt_dc_zero_v, cfg.lvdt_dc_span_v),
            thermistor: Thermistor {
                r0_ohm: cfg.thermistor_r25_ohm,
                t0_c: 25.0,
                beta_k: cfg.thermistor_beta_k,
                r_fixed_ohm: cfg.thermistor_r_fixed_ohm,
                min_c: -10.0,
                max_c: 60.0,
            },
            bar_length_mm: cfg.bar_length_mm,
            cte_ppm_per_k: cfg.bar_cte_ppm_per_k,
            scales,
            counters_hw,
            last_position: [(0, 0.0); MAX_AXES],
            probe: ProbeDebouncer::new(
                u64::from(cfg.probe_debounce_us),
                u64::from(cfg.probe_reseat_us),
            ),
            temp_c: None,
            temp_fault: true,
            last_lost: 0,
            seq: 0,
            counters: AcquisitionCounters::default(),
        }
    }

    /// Takes a new configuration without losing what did not change: the extended axis counts
    /// (the axes stay referenced; a new counts-per-unit or direction scales the same counts),
    /// the sample counter, the temperature and the counters. Calibration, scales, glitch limits
    /// and probe times follow the configuration. `counter_bits` is as for [`Acquisition::new`].
    pub fn reconfigure(&mut self, cfg: &Config, counter_bits: [u32; MAX_AXES]) {
        let fresh = Self::new(cfg, counter_bits);
        for (ext, new) in self.counters_hw.iter_mut().zip(fresh.counters_hw.iter()) {
            *ext = ext.with_max_step(new.max_step());
        }
        self.scales = fresh.scales;
        self.last_position = fresh.last_position;
        self.lvdt = fresh.lvdt;
        self.dc = fresh.dc;
        self.thermistor = fresh.thermistor;
        self.bar_length_mm = fresh.bar_length_mm;
        self.cte_ppm_per_k = fresh.cte_ppm_per_k;
        self.probe = self.probe.with_times(
            u64::from(cfg.probe_debounce_us),
            u64::from(cfg.probe_reseat_us),
        );
    }

    /// The LVDT calibration in use (from the configuration), e.g. for the R-test head's
    /// three channels (the host's `ballpod_host::methods::rtest_head`).
    pub fn lvdt_calibration(&self) -> LvdtCalibration {
        self.lvdt
    }

    /// The LVDT reading of a DC conditioner voltage under the configured zero and span
    /// (saturation limits ±10.5 V, the conditioner class's rails).
    pub fn dc_reading(&self, volts: f32) -> LvdtReading {
        dc_reading(volts, self.dc.0, self.dc.1, -10.5, 10.5)
    }

    /// Feeds a thermistor ADC code (12-bit). A fault keeps the last good temperature (or 20 °C
    /// if none yet) and flags the following samples until a good reading arrives.
    pub fn update_temperature(&mut self, code: u16) -> Result<f32, ThermistorFault> {
        match self
            .thermistor
            .temperature_c(code, super::lvdt::ADC12_FULL_SCALE)
        {
            Ok(t) => {
                self.temp_c = Some(t);
                self.temp_fault = false;
                Ok(t)
            }
            Err(e) => {
                self.temp_fault = true;
                Err(e)
            }
        }
    }

    /// The temperature the expansion correction uses, °C.
    pub fn temperature_c(&self) -> f32 {
        self.temp_c.unwrap_or(REFERENCE_TEMP_C)
    }

    /// Extends and scales the raw encoder counters without producing a sample (for the probe
    /// latch and for reading faster than the sample rate). Returns the extended counts and
    /// whether any axis glitched.
    pub fn update_counts(&mut self, raw: [u32; MAX_AXES]) -> ([i64; MAX_AXES], bool) {
        // the five axes written out: a loop over a zeroed array costs a memset call per sample
        let [e0, e1, e2, e3, e4] = &mut self.counters_hw;
        let [r0, r1, r2, r3, r4] = raw;
        let u = [
            e0.update(r0),
            e1.update(r1),
            e2.update(r2),
            e3.update(r3),
            e4.update(r4),
        ];
        let [u0, u1, u2, u3, u4] = u;
        let glitch = u0.glitch | u1.glitch | u2.glitch | u3.glitch | u4.glitch;
        ([u0.count, u1.count, u2.count, u3.count, u4.count], glitch)
    }

    /// References the axes (homing): the hardware counters reading `raw` are at `positions`
    /// (mm / degrees). Later counts extend from there.
    pub fn reference_axes(&mut self, raw: [u32; MAX_AXES], positions: [f64; MAX_AXES]) {
        for (((ext, s), r), p) in self
            .counters_hw
            .iter_mut()
            .zip(self.scales.iter())
            .zip(raw)
            .zip(positions)
        {
            ext.set(r, s.count_at(p).unwrap_or(0));
        }
    }

    /// References axis `k` (0-based) where it stands: its counter's last reading is at
    /// `position` (mm / degrees), and later counts extend from there. False, and nothing
    /// changes, if the axis has not been read yet or `position` is not a count.
    pub fn reference_axis(&mut self, k: usize, position: f64) -> bool {
        let (Some(ext), Some(s), Some(last)) = (
            self.counters_hw.get_mut(k),
            self.scales.get(k),
            self.last_position.get_mut(k),
        ) else {
            return false;
        };
        let Some(c) = s.count_at(position) else {
            return false;
        };
        if !ext.rebase(c) {
            return false;
        }
        *last = (c, s.position(c));
        true
    }

    /// The position of axis `k` (0-based) at the last sample or reference, mm / degrees.
    pub fn axis_position(&self, k: usize) -> Option<f32> {
        self.last_position.get(k).map(|l| l.1)
    }

    /// Axis positions (mm / degrees) of extended counts.
    pub fn positions(&self, counts: &[i64; MAX_AXES]) -> [f32; MAX_AXES] {
        let mut p = [0.0f32; MAX_AXES];
        for ((p, s), &c) in p.iter_mut().zip(self.scales.iter()).zip(counts.iter()) {
            *p = s.position(c);
        }
        p
    }

    /// [`Self::positions`], scaling only the axes whose count changed since the last call.
    fn positions_moved(&mut self, counts: &[i64; MAX_AXES]) -> [f32; MAX_AXES] {
        #[inline(always)]
        fn moved(last: &mut (i64, f32), scale: &AxisScale, count: i64) -> f32 {
            if count != last.0 {
                *last = (count, scale.position(count));
            }
            last.1
        }
        // the five axes written out, as in `update_counts`
        let [l0, l1, l2, l3, l4] = &mut self.last_position;
        let [s0, s1, s2, s3, s4] = &self.scales;
        let [c0, c1, c2, c3, c4] = *counts;
        [
            moved(l0, s0, c0),
            moved(l1, s1, c1),
            moved(l2, s2, c2),
            moved(l3, s3, c3),
            moved(l4, s4, c4),
        ]
    }

    /// Handles a probe trigger edge whose raw counters were latched in the interrupt.
    pub fn probe_trigger(&mut self, t_us: u64, raw: [u32; MAX_AXES]) -> TriggerOutcome {
        let (counts, _) = self.update_counts(raw);
        self.probe.trigger(ProbeLatch { counts, t_us })
    }

    /// Produces the next sample.
    ///
    /// - `lvdt`: the block's demodulation (or a DC reading); an error flags the sample open.
    /// - `raw`: the hardware encoder counters now.
    /// - `lost_total`: the cumulative count of samples lost upstream (ADC blocks the queues
    ///   dropped); if it grew since the previous sample, this one carries
    ///   [`SampleFlags::OVERRUN`] and its `seq` skips the lost ones.
    /// - `probe_event`: a probe trigger was accepted since the previous sample.
    pub fn calibrate(
        &mut self,
        t_us: u64,
        lvdt: Result<LvdtReading, DemodError>,
        raw: [u32; MAX_AXES],
        lost_total: u32,
        probe_event: bool,
    ) -> Sample {
        let mut flags = SampleFlags::NONE;
        let (x_um, status) = match lvdt {
            Ok(r) => self.lvdt.displacement_um(&r),
            Err(_) => (0.0, LvdtStatus::Open),
        };
        match status {
            LvdtStatus::Ok => {}
            LvdtStatus::OverRange => {
                flags.insert(SampleFlags::LVDT_OVER_RANGE);
                self.counters.lvdt_over_range = self.counters.lvdt_over_range.saturating_add(1);
            }
            LvdtStatus::Open => {
                flags.insert(SampleFlags::LVDT_OPEN);
                self.counters.lvdt_open = self.counters.lvdt_open.saturating_add(1);
            }
        }
        let (counts, glitch) = self.update_counts(raw);
        if glitch {
            flags.insert(SampleFlags::QUADRATURE_ERROR);
            self.counters.quadrature_errors = self.counters.quadrature_errors.saturating_add(1);
        }
        if self.temp_fault {
            flags.insert(SampleFlags::TEMPERATURE_FAULT);
            self.counters.temperature_faults = self.counters.temperature_faults.saturating_add(1);
        }
        let lost = lost_total.wrapping_sub(self.last_lost);
        if lost != 0 {
            flags.insert(SampleFlags::OVERRUN);
            self.counters.lost_upstream = self.counters.lost_upstream.saturating_add(lost);
            self.last_lost = lost_total;
            // the lost samples keep their numbers: the gap in `seq` is the loss
            self.seq = self.seq.wrapping_add(lost);
        }
        if probe_event {
            flags.insert(SampleFlags::PROBE_EVENT);
        }
        let temp_c = self.temperature_c();
        let delta_l_um = x_um + bar_expansion_um(self.bar_length_mm, self.cte_ppm_per_k, temp_c);
        let s = Sample {
            seq: self.seq,
            t_us,
            delta_l_um,
            axes: self.positions_moved(&counts),
            temp_c,
            flags,
        };
        self.seq = self.seq.wrapping_add(1);
        self.counters.samples = self.counters.samples.saturating_add(1);
        s
    }
}

/// Sample periods lost between two blocks that reached the shell with reference instants
/// `prev_us` and `t_us` (µs, timestamped by the hardware's block interrupt, so a gap is whole
/// periods up to the interrupt latency) at the nominal period `period_us`: the gap rounded to
/// whole periods, less the one expected. A gap under 1.5 periods, a clock that did not advance
/// or a zero period count nothing; a gap beyond `u32` periods saturates.
pub fn periods_lost(prev_us: u64, t_us: u64, period_us: u32) -> u32 {
    if period_us == 0 {
        return 0;
    }
    let gap = t_us.saturating_sub(prev_us);
    let periods = (gap + u64::from(period_us) / 2) / u64::from(period_us);
    u32::try_from(periods.saturating_sub(1)).unwrap_or(u32::MAX)
}

//! LVDT: ratiometric synchronous demodulation of the two secondaries (AC mode) and the DC-input
//! mode for an external conditioner, then the calibration polynomial to µm.
//!
//! # AC mode
//! The DAC drives the primary with a sine of `P` samples per period; both secondaries are
//! sampled by the ADCs in sync with it (sample `k` of a block is at excitation phase
//! `2πk/P`). Over a block of whole periods, each secondary `s` is projected on the in-phase and
//! quadrature references:
//!
//! ```text
//! I_s = Σ v_s[k]·sin(2πk/P),  Q_s = Σ v_s[k]·cos(2πk/P),  A_s = (2/n)·√(I_s² + Q_s²)
//! ```
//!
//! A DC offset sums to zero over whole periods, and taking the magnitude makes `A_s`
//! independent of the phase between excitation and secondaries (cable, coil inductance). The
//! position is the **ratiometric** figure
//!
//! ```text
//! r = (A_a − A_b) / (A_a + A_b)          (−1 … 1, 0 at the electrical null)
//! ```
//!
//! which does not change when the excitation amplitude drifts: both secondaries scale alike.
//! `A_a + A_b` is nearly constant over the stroke of a standard LVDT, so it serves as the
//! signal-level (open coil / unplugged bar) check. Noise: with white noise σ_v per ADC sample,
//! each amplitude has σ_A = σ_v·√(2/n), and `r` has σ_r = 2·σ_A·√(A_a² + A_b²)/(A_a + A_b)²
//! (the averaging gain the host tests check).
//!
//! # DC mode
//! An external LVDT conditioner delivers a voltage proportional to position; the ratio is
//! `r = (v − v_zero)/v_span` and the same calibration polynomial applies.

use super::projection::RailTest;

/// Why a block could not be demodulated (the caller flags the sample; nothing is guessed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DemodError {
    /// The block is empty or not a whole number of excitation periods.
    NotWholePeriods {
        /// Samples in the block.
        len: usize,
        /// Samples per excitation period.
        period: usize,
    },
    /// The two secondaries' blocks differ in length.
    LengthMismatch,
    /// The block was acquired in the other input mode (the mode was just changed).
    ModeChanged,
}

/// What the shell read from one block, in the input mode it was acquired in: the AC
/// demodulation, or the DC conditioner's mean voltage (converted with the configured zero and
/// span by the application, so a change of either takes effect at the next sample).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BlockReading {
    /// AC ratiometric: the demodulation of the two secondaries.
    Ac(Result<LvdtReading, DemodError>),
    /// DC conditioner: the block's mean input, V.
    DcVolts(f32),
}

/// One ADC sample of a secondary: how a block of them is projected on the excitation.
pub trait AdcSample: Copy {
    /// The projections of two blocks `a`, `b` of one length, a whole number of periods, on
    /// `table` (see [`Projection`]), with the rail test `rails` says (converter codes only).
    fn project<const P: usize>(
        a: &[Self],
        b: &[Self],
        table: &ExcitationTable<P>,
        rails: RailTest,
    ) -> Projection;
}

/// Full-scale code of the STM32G4's 12-bit ADCs.
pub const ADC12_FULL_SCALE: u16 = 4095;

/// What a block's per-sample work yields: I = Σ v·sin and Q = Σ v·cos of each secondary (input
/// units × samples) and whether an input sat on a converter rail (clipping makes the amplitude
/// wrong, so the block is flagged over-range).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Projection {
    /// (I, Q) of secondary a.
    pub a: [f32; 2],
    /// (I, Q) of secondary b.
    pub b: [f32; 2],
    /// A code sat on a rail.
    pub clipped: bool,
}

/// 12-bit converter codes: the Q14 integer projection ([`super::projection`], the M4's DSP
/// kernel on the pod), in chunks of at most [`MAX_CHUNK_SAMPLES`](super::projection::MAX_CHUNK_SAMPLES)
/// samples; a code of 0 or ≥ 4095 is a rail.
impl AdcSample for u16 {
    fn project<const P: usize>(
        a: &[u16],
        b: &[u16],
        table: &ExcitationTable<P>,
        rails: RailTest,
    ) -> Projection {
        use super::projection::{MAX_CHUNK_SAMPLES, Q14_ONE, Q14Sums};
        let per_chunk = (MAX_CHUNK_SAMPLES / P).max(1) * P;
        let mut out = Projection::default();
        for (ca, cb) in a.chunks(per_chunk).zip(b.chunks(per_chunk)) {
            let acc = Q14Sums::of(ca, cb, &table.q14, rails);
            let f = |v: i32| v as f32 * (1.0 / Q14_ONE);
            out.a[0] += f(acc.ia);
            out.a[1] += f(acc.qa);
            out.b[0] += f(acc.ib);
            out.b[1] += f(acc.qb);
            out.clipped |= acc.clipped();
        }
        out
    }
}

/// Volts or model values (host tests, the DC path): the f32 projection; never at a rail.
impl AdcSample for f32 {
    fn project<const P: usize>(
        a: &[f32],
        b: &[f32],
        table: &ExcitationTable<P>,
        _rails: RailTest,
    ) -> Projection {
        let mut out = Projection::default();
        for (ca, cb) in a.chunks_exact(P).zip(b.chunks_exact(P)) {
            // Per-period partial sums keep f32 rounding small on long blocks.
            let mut p = [0.0f32; 4];
            for (((&va, &vb), &s), &c) in ca
                .iter()
                .zip(cb.iter())
                .zip(table.sin.iter())
                .zip(table.cos.iter())
            {
                p[0] += va * s;
                p[1] += va * c;
                p[2] += vb * s;
                p[3] += vb * c;
            }
            out.a[0] += p[0];
            out.a[1] += p[1];
            out.b[0] += p[2];
            out.b[1] += p[3];
        }
        out
    }
}

/// Sine/cosine reference of the excitation, `P` samples per period (the same table the DAC
/// plays, so demodulation is phase-locked by construction). `P` is a multiple of 4 (the
/// integer projection takes two sample pairs at a time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExcitationTable<const P: usize> {
    /// sin(2πk/P).
    pub sin: [f32; P],
    /// cos(2πk/P).
    pub cos: [f32; P],
    /// The Q14 reference words of the integer projection
    /// ([`reference_words`](super::projection::reference_words)).
    pub q14: [u32; P],
}

impl<const P: usize> ExcitationTable<P> {
    const CHECK: () = assert!(P >= 4 && P.is_multiple_of(4), "P must be a multiple of 4");

    /// Builds the table (at start-up; never on the hot path).
    pub fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        let mut t = Self {
            sin: [0.0; P],
            cos: [0.0; P],
            q14: [0; P],
        };
        let step = 2.0 * core::f64::consts::PI / P as f64;
        for (k, s) in t.sin.iter_mut().enumerate() {
            *s = crate::num::sin(step * k as f64) as f32;
        }
        // cos(2πk/P) = sin(2π(k + P/4)/P): the same values, a quarter period on
        for (k, c) in t.cos.iter_mut().enumerate() {
            *c = t.sin.get((k + P / 4) % P).copied().unwrap_or(0.0);
        }
        t.q14 = super::projection::reference_words(&t.sin, &t.cos);
        t
    }

    /// The DAC codes of one excitation period for a 12-bit DAC: mid-scale ± `amplitude_counts`.
    pub fn dac_codes(&self, amplitude_counts: u16) -> [u16; P] {
        let mut out = [0u16; P];
        let mid = f32::from(ADC12_FULL_SCALE / 2 + 1);
        let amp = f32::from(amplitude_counts.min(ADC12_FULL_SCALE / 2));
        for (o, s) in out.iter_mut().zip(self.sin.iter()) {
            // round to nearest; clamped to the DAC's range
            let v = mid + amp * s + 0.5;
            *o = if v <= 0.0 {
                0
            } else if v >= f32::from(ADC12_FULL_SCALE) {
                ADC12_FULL_SCALE
            } else {
                v as u16
            };
        }
        out
    }
}

impl<const P: usize> Default for ExcitationTable<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// Result of demodulating one block (AC mode) or reading one DC value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LvdtReading {
    /// Ratiometric position figure `r` (dimensionless, −1 … 1); 0 when the signal is too weak.
    pub ratio: f32,
    /// Signal level `A_a + A_b` in input units (ADC counts or volts), for the open check.
    pub signal_level: f32,
    /// Secondary A's projections (I, Q) on the excitation's sine and cosine, input units
    /// (`[0, 0]` in DC mode): its phase, [`phase_deg`](Self::phase_deg).
    pub iq_a: [f32; 2],
    /// An input sample sat on a converter rail (clipping).
    pub clipped: bool,
}

impl LvdtReading {
    /// Phase of secondary A relative to the excitation sine, degrees (−180 … 180; 0 without a
    /// signal): a quality figure (a jump means a wiring fault or a core outside the coil),
    /// computed when asked, not per block.
    pub fn phase_deg(&self) -> f32 {
        let [i, q] = self.iq_a;
        if i == 0.0 && q == 0.0 {
            0.0
        } else {
            libm::atan2f(q, i).to_degrees()
        }
    }
}

/// Demodulates one block of both secondaries (see the module doc for the equations).
///
/// `a` and `b` hold the same whole number of excitation periods, sample `k` taken at phase
/// `2πk/P`. The per-sample work is two multiply-accumulates per channel
/// ([`AdcSample::project`]) and, for converter codes, the rail test of each code.
pub fn demodulate<S: AdcSample, const P: usize>(
    a: &[S],
    b: &[S],
    table: &ExcitationTable<P>,
) -> Result<LvdtReading, DemodError> {
    demodulate_with(a, b, table, RailTest::PerCode)
}

/// [`demodulate`] of a block of converter codes whose conversions the ADCs' analog watchdogs
/// watched (window 1…4094 codes; see the board's LVDT acquisition): the per-code rail test
/// runs only if a watchdog `tripped` during the block, otherwise no code can be at a rail and
/// the leaner projection does the block (about half the instructions per code). The same
/// reading as [`demodulate`] whenever the watchdog's report is true.
pub fn demodulate_watched<const P: usize>(
    a: &[u16],
    b: &[u16],
    table: &ExcitationTable<P>,
    tripped: bool,
) -> Result<LvdtReading, DemodError> {
    let rails = if tripped {
        RailTest::PerCode
    } else {
        RailTest::WatchdogQuiet
    };
    demodulate_with(a, b, table, rails)
}

fn demodulate_with<S: AdcSample, const P: usize>(
    a: &[S],
    b: &[S],
    table: &ExcitationTable<P>,
    rails: RailTest,
) -> Result<LvdtReading, DemodError> {
    if a.len() != b.len() {
        return Err(DemodError::LengthMismatch);
    }
    if P == 0 || a.is_empty() || !a.len().is_multiple_of(P) {
        return Err(DemodError::NotWholePeriods {
            len: a.len(),
            period: P,
        });
    }
    let p = S::project(a, b, table, rails);
    let scale = 2.0 / a.len() as f32;
    let amplitude = |[i, q]: [f32; 2]| scale * crate::num::sqrtf(i * i + q * q);
    let (amp_a, amp_b) = (amplitude(p.a), amplitude(p.b));
    let level = amp_a + amp_b;
    let ratio = if level > 0.0 {
        (amp_a - amp_b) / level
    } else {
        0.0
    };
    Ok(LvdtReading {
        ratio,
        signal_level: level,
        iq_a: p.a,
        clipped: p.clipped,
    })
}

/// DC-input mode: the ratio of an external conditioner's output voltage.
///
/// `r = (v − zero_v)/span_v`; `clipped` when `v` is outside `[min_v, max_v]` (the conditioner
/// saturates there). The signal level is reported as `|span_v|` (a DC conditioner gives no
/// open-coil information).
pub fn dc_reading(v: f32, zero_v: f32, span_v: f32, min_v: f32, max_v: f32) -> LvdtReading {
    let ok = v.is_finite() && span_v.is_finite() && span_v != 0.0;
    let ratio = if ok { (v - zero_v) / span_v } else { 0.0 };
    LvdtReading {
        ratio: if ratio.is_finite() { ratio } else { 0.0 },
        signal_level: if ok { libm::fabsf(span_v) } else { 0.0 },
        iq_a: [0.0; 2],
        clipped: !ok || !(min_v..=max_v).contains(&v),
    }
}

/// Mean of a block of ADC codes (DC mode: the conditioner's output averaged over one sample
/// period), counts; 0 for an empty block. The sum is exact (integer) for blocks of up to
/// 65 537 codes.
pub fn block_mean(block: &[u16]) -> f32 {
    if block.is_empty() {
        return 0.0;
    }
    let sum = block
        .iter()
        .fold(0u32, |s, &v| s.wrapping_add(u32::from(v)));
    sum as f32 / block.len() as f32
}

/// The analogue front end of the DC input: conditioner volts from ADC counts,
/// `v = counts · volts_per_count + offset_v` (a property of the board's input divider).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DcFrontEnd {
    /// Conditioner volts per ADC count, V.
    pub volts_per_count: f32,
    /// Conditioner volts at ADC count 0, V.
    pub offset_v: f32,
}

impl DcFrontEnd {
    /// Conditioner voltage, V, of a (mean) ADC count.
    pub fn volts(&self, counts: f32) -> f32 {
        counts * self.volts_per_count + self.offset_v
    }
}

/// Calibration of the LVDT: polynomial ratio → displacement in µm, the usable stroke and the
/// open-coil threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LvdtCalibration {
    /// Polynomial coefficients `c_k` in µm: `x_um = Σ c_k · r^k` (k = 0…3).
    pub poly_um: [f32; 4],
    /// Largest |r| inside the calibrated stroke; beyond it the reading is over-range.
    pub max_abs_ratio: f32,
    /// Smallest signal level `A_a + A_b` (input units) of a connected, excited LVDT.
    pub min_signal_level: f32,
}

/// Validity of an LVDT displacement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LvdtStatus {
    /// Inside the calibrated stroke with a healthy signal.
    Ok,
    /// Outside the calibrated stroke or clipped: the value is the stroke-limit value.
    OverRange,
    /// Signal too weak (open coil, bar unplugged): the value is 0.
    Open,
}

impl LvdtCalibration {
    /// Displacement in µm of a reading, with its status. Never NaN: a weak signal gives 0 µm
    /// and [`LvdtStatus::Open`]; an out-of-stroke or clipped reading gives the value at the
    /// stroke limit and [`LvdtStatus::OverRange`].
    pub fn displacement_um(&self, reading: &LvdtReading) -> (f32, LvdtStatus) {
        // A NaN signal level fails the comparison and counts as open.
        if !(reading.signal_level >= self.min_signal_level) || !reading.ratio.is_finite() {
            return (0.0, LvdtStatus::Open);
        }
        let over = reading.clipped || libm::fabsf(reading.ratio) > self.max_abs_ratio;
        // Comparisons, not `f32::clamp` (it asserts min <= max with a formatted panic message,
        // which put the panic path and core's float formatting into the firmware) nor
        // `f32::max`/`min` (`fmaxf`/`fminf` library calls on the M4F, every sample).
        let m = self.max_abs_ratio;
        let r = if reading.ratio > m {
            m
        } else if reading.ratio < -m {
            -m
        } else {
            reading.ratio
        };
        // Horner, in f32: coefficients in µm, r dimensionless (written out: an iterator fold
        // is a loop at opt-level "z")
        let [c0, c1, c2, c3] = self.poly_um;
        let x = ((c3 * r + c2) * r + c1) * r + c0;
        if !x.is_finite() {
            return (0.0, LvdtStatus::OverRange);
        }
        (
            x,
            if over {
                LvdtStatus::OverRange
            } else {
                LvdtStatus::Ok
            },
        )
    }
}

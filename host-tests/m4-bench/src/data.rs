//! Realistic data for the benchmark, from the same models the virtual machine tool uses
//! (host-tests `lvdt_model` and the ball-bar forward model, re-stated here because this crate
//! is no_std): a CCW circle about the socket with a location error E, a radius change, a
//! 2nd-harmonic (scale mismatch) term and white noise from SplitMix64.

use ballpod::acquisition::lvdt::ExcitationTable;
use ballpod::acquisition::{Sample, SampleFlags};

/// Samples of the circle (0.5° apart).
pub const N: usize = 720;
/// Bar length, mm.
pub const BAR_MM: f32 = 150.0;
/// Socket (= circle centre) in machine coordinates, mm.
pub const SOCKET_MM: [f32; 3] = [100.0, 50.0, 0.0];
/// Location error of the circle centre (the eccentricity the fit must find), µm.
pub const E_UM: [f32; 2] = [3.0, -2.0];
/// Radius change, µm.
const R0_UM: f64 = 0.5;
/// 2nd-harmonic (0°/90° ovality) amplitude, µm.
const OVAL_UM: f64 = 0.3;
/// White noise of ΔL, µm rms.
pub const NOISE_UM: f32 = 0.1;
/// Neighbourhood radius of the streaming SSM, mm (≈ 4 samples at 1.3 mm per sample).
pub const SSM_RADIUS_MM: f32 = 5.0;

/// SplitMix64 (Steele, Lea, Flood 2014), as host-tests `rng`.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Approximately standard normal: the sum of 12 uniforms minus 6 (no libm log needed).
    fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
}

/// Feed of a measuring run (the simulator's), mm/min, and the sample rate, Hz.
pub const MEASURING_FEED_MM_PER_MIN: f64 = 1000.0;
const SAMPLE_RATE_HZ: f64 = 1000.0;

/// The CCW circle's samples, 0.5° apart (a whole turn in 720 samples: 78 m/min at 1 kHz, far
/// faster than a measuring feed; every path sees the whole circle).
pub fn circle_samples() -> [Sample; N] {
    circle_arc(2.0 * core::f64::consts::PI / N as f64, 0)
}

/// Samples `first .. first + N` of the same circle at the measuring feed (F1000 at 1 kHz:
/// 0.0064° per sample), for the steady state of the paths whose cost depends on how far the
/// machine moves per sample.
pub fn circle_samples_at_feed(first: usize) -> [Sample; N] {
    let step = MEASURING_FEED_MM_PER_MIN / 60.0 / SAMPLE_RATE_HZ / f64::from(BAR_MM);
    circle_arc(step, first)
}

/// Samples `first ..` of the circle, `step_rad` apart.
fn circle_arc(step_rad: f64, first: usize) -> [Sample; N] {
    let mut rng = Rng(0x00BA_11B0_D000_0006 ^ first as u64);
    let mut out = [Sample::default(); N];
    for (k, s) in out.iter_mut().enumerate() {
        let i = first + k;
        let th = step_rad * i as f64;
        let (sn, cs) = libm::sincos(th);
        let dl = R0_UM
            + f64::from(E_UM[0]) * cs
            + f64::from(E_UM[1]) * sn
            + OVAL_UM * libm::cos(2.0 * th)
            + f64::from(NOISE_UM) * rng.normal();
        let l = f64::from(BAR_MM);
        *s = Sample {
            seq: i as u32,
            t_us: i as u64 * 1000,
            delta_l_um: dl as f32,
            axes: [
                (f64::from(SOCKET_MM[0]) + l * cs) as f32,
                (f64::from(SOCKET_MM[1]) + l * sn) as f32,
                SOCKET_MM[2],
                0.0,
                0.0,
            ],
            temp_c: 20.0,
            flags: SampleFlags::NONE,
        };
    }
    out
}

/// One ADC block of both secondaries as host-tests `lvdt_model` produces it: 12-bit codes
/// about mid-scale, secondary amplitudes 1.125 and 0.875 × 1500 counts (ratio 0.125), a
/// 10° phase lag and ±1 LSB of noise.
pub fn lvdt_block<const P: usize, const B: usize>(_t: &ExcitationTable<P>) -> ([u16; B], [u16; B]) {
    let mut rng = Rng(0x1BD7_0006);
    let mut a = [0u16; B];
    let mut b = [0u16; B];
    let lag = 10f64.to_radians();
    for (k, (va, vb)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
        let s = libm::sin(2.0 * core::f64::consts::PI * (k % P) as f64 / P as f64 - lag);
        let na = rng.uniform() - 0.5;
        let nb = rng.uniform() - 0.5;
        *va = (2048.0 + 1500.0 * 1.125 * s + na + 0.5) as u16;
        *vb = (2048.0 + 1500.0 * 0.875 * s + nb + 0.5) as u16;
    }
    (a, b)
}

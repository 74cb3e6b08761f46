//! The naive baseline: the same maths written the straightforward way (nalgebra, a dynamic LU
//! solve per sample, libm trigonometry per sample). Not used by the core; measured beside it on
//! the same data so that the ratio shows what the core's formulation buys.

use ballpod::acquisition::Sample;
use nalgebra::{Matrix3, Vector3};

/// LVDT demodulation with `libm::sinf`/`cosf` per ADC sample instead of the reference table.
/// Returns the ratiometric figure (A_a − A_b)/(A_a + A_b).
#[inline(never)]
pub fn lvdt_demodulate(a: &[u16], b: &[u16], period: usize) -> f32 {
    let (mut ia, mut qa, mut ib, mut qb) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let step = 2.0 * core::f32::consts::PI / period as f32;
    for (k, (&va, &vb)) in a.iter().zip(b.iter()).enumerate() {
        let ph = step * (k % period) as f32;
        let (s, c) = (libm::sinf(ph), libm::cosf(ph));
        ia += f32::from(va) * s;
        qa += f32::from(va) * c;
        ib += f32::from(vb) * s;
        qb += f32::from(vb) * c;
    }
    let aa = libm::sqrtf(ia * ia + qa * qa);
    let ab = libm::sqrtf(ib * ib + qb * qb);
    (aa - ab) / (aa + ab)
}

/// Circle fit: f32 normal matrix AᵀA and Aᵀy of the rows (1, n_u, n_v), updated per sample,
/// solved per sample by nalgebra's LU. Circle in the XY plane about (`cu`, `cv`).
pub struct NaiveCircle {
    a: Matrix3<f32>,
    b: Vector3<f32>,
    /// (r0, e_u, e_v), µm, after the last sample.
    pub x: Vector3<f32>,
    cu: f32,
    cv: f32,
}

impl NaiveCircle {
    /// An empty fit about (`cu`, `cv`) mm.
    pub fn new(cu: f32, cv: f32) -> Self {
        Self {
            a: Matrix3::zeros(),
            b: Vector3::zeros(),
            x: Vector3::zeros(),
            cu,
            cv,
        }
    }

    /// Accumulates and solves; returns the unit direction n.
    #[inline(never)]
    pub fn update(&mut self, s: &Sample) -> Option<(f32, f32)> {
        if !s.flags.is_valid_for_metrology() {
            return None;
        }
        let (du, dv) = (s.axes[0] - self.cu, s.axes[1] - self.cv);
        let r = libm::sqrtf(du * du + dv * dv);
        let (nu, nv) = (du / r, dv / r);
        let g = Vector3::new(1.0, nu, nv);
        self.a += g * g.transpose();
        self.b += g * s.delta_l_um;
        if let Some(x) = self.a.lu().solve(&self.b) {
            self.x = x;
        }
        Some((nu, nv))
    }
}

/// ISO 230-4 tracker, naive: the naive circle fit, F extremes, and a `libm::atan2f` bin per
/// sample.
pub struct NaiveIso<const BINS: usize> {
    /// The circle fit.
    pub fit: NaiveCircle,
    bins: [(f32, f32, f32, u32); BINS],
    f_max: f32,
    f_min: f32,
}

impl<const BINS: usize> NaiveIso<BINS> {
    /// An empty tracker.
    pub fn new(cu: f32, cv: f32) -> Self {
        Self {
            fit: NaiveCircle::new(cu, cv),
            bins: [(0.0, 0.0, 0.0, 0); BINS],
            f_max: f32::NEG_INFINITY,
            f_min: f32::INFINITY,
        }
    }

    /// One sample.
    #[inline(never)]
    pub fn update(&mut self, s: &Sample) {
        let Some((nu, nv)) = self.fit.update(s) else {
            return;
        };
        let dl = s.delta_l_um;
        self.f_max = self.f_max.max(dl);
        self.f_min = self.f_min.min(dl);
        let mut th = libm::atan2f(nv, nu);
        if th < 0.0 {
            th += 2.0 * core::f32::consts::PI;
        }
        let k = ((th / (2.0 * core::f32::consts::PI) * BINS as f32) as usize).min(BINS - 1);
        if let Some(b) = self.bins.get_mut(k) {
            b.0 += dl;
            b.1 += nu;
            b.2 += nv;
            b.3 += 1;
        }
    }
}

/// Streaming SSM, naive: a ring of (u, y, P) in f32, G = Σ u uᵀ and b = Σ u y as f32 nalgebra
/// sums (add entering, subtract leaving samples), LU solve per sample.
pub struct NaiveSsm<const W: usize> {
    ring: [(Vector3<f32>, f32, Vector3<f32>); W],
    tail: usize,
    len: usize,
    g: Matrix3<f32>,
    b: Vector3<f32>,
    /// E, µm, after the last sample.
    pub e: Vector3<f32>,
    socket: Vector3<f32>,
    bar_mm: f32,
    radius_mm: f32,
}

impl<const W: usize> NaiveSsm<W> {
    /// An empty estimator.
    pub fn new(socket: [f32; 3], bar_mm: f32, radius_mm: f32) -> Self {
        Self {
            ring: [(Vector3::zeros(), 0.0, Vector3::zeros()); W],
            tail: 0,
            len: 0,
            g: Matrix3::zeros(),
            b: Vector3::zeros(),
            e: Vector3::zeros(),
            socket: Vector3::from(socket),
            bar_mm,
            radius_mm,
        }
    }

    fn pop(&mut self) {
        if let Some((u, y, _)) = self.ring.get(self.tail).copied() {
            self.g -= u * u.transpose();
            self.b -= u * y;
        }
        self.tail = (self.tail + 1) % W;
        self.len -= 1;
    }

    /// One sample.
    #[inline(never)]
    pub fn update(&mut self, s: &Sample) {
        if !s.flags.is_valid_for_metrology() {
            return;
        }
        let p = Vector3::new(s.axes[0], s.axes[1], s.axes[2]);
        let d = p - self.socket;
        let r = d.norm();
        let u = d / r;
        let y = s.delta_l_um + (self.bar_mm - r) * 1e3;
        while self.len > 0 {
            let Some((_, _, q)) = self.ring.get(self.tail).copied() else {
                break;
            };
            if (q - p).norm() > self.radius_mm {
                self.pop();
            } else {
                break;
            }
        }
        if self.len == W {
            self.pop();
        }
        let head = (self.tail + self.len) % W;
        if let Some(slot) = self.ring.get_mut(head) {
            *slot = (u, y, p);
            self.len += 1;
        }
        self.g += u * u.transpose();
        self.b += u * y;
        if let Some(e) = self.g.lu().solve(&self.b) {
            self.e = e;
        }
    }
}

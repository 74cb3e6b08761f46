//! The ball bar's own uncertainty (Type B; ISO/TR 230-9's "measuring instrument" inputs): what
//! every figure computed from ΔL inherits from the bar's calibrated length, its temperature and
//! the LVDT's scale. The inputs are configuration fields (`bar_u_length`, `bar_u_temp`,
//! `lvdt_u_scale`; the book's budget table under "Uncertainty").
//!
//! Sensitivities (GUM §5.1.2, analytic, first order):
//! - The pod measures ΔL = distance − L₂₀, computed as ΔL = x + L₂₀·α·(T − 20 °C): x the LVDT's
//!   reading, distance − L₂₀·(1 + α·(T − 20 °C)), the bar's expansion added back
//!   (`acquisition::thermal::bar_expansion_um`). An error δL₂₀ of the calibrated
//!   length, or δT of the measured temperature (δL = L₂₀·α·δT), shifts every ΔL of a run by the
//!   same amount: a **radial** figure (r0, F_max, F_min, the mean bi-directional radial
//!   deviation) moves by it 1:1; a **shape** figure (eccentricity, G, H, G(b), every diagnosis)
//!   does not (a constant has no eccentricity and no peak-to-valley).
//! - A relative scale error k of the LVDT multiplies every ΔL by (1 + k) (about ΔL = 0, where
//!   the calibration puts the bar's nominal length): every figure moves by k times its value.

use crate::config::Config;

/// How a figure depends on the bar (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FigureKind {
    /// Moves 1:1 with a constant ΔL offset (r0, F, the mean radial deviation), and with the
    /// scale.
    Radial,
    /// Moves with the scale only (eccentricity, G, H, G(b), the diagnoses).
    Shape,
}

/// The bar's uncertainty as it enters a figure (f32 on the FPU: the results are f32).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarBudget {
    /// Standard uncertainty of a constant offset of every ΔL, µm: the length calibration's and
    /// the temperature's (L₂₀·α·u_T) in quadrature.
    pub offset_um: f32,
    /// Relative standard uncertainty of the ΔL scale (1 = 100 %).
    pub scale: f32,
}

impl BarBudget {
    /// No uncertainty of the bar (a figure keeps its Type A u).
    pub const NONE: Self = Self {
        offset_um: 0.0,
        scale: 0.0,
    };

    /// The budget of the configured bar (length, CTE and the three inputs).
    pub fn from_config(c: &Config) -> Self {
        // L₂₀ in mm × α in ppm/K × u_T in K = 10⁻³ µm
        let thermal_um = c.bar_length_mm * c.bar_cte_ppm_per_k * c.bar_u_temp_k * 1e-3;
        let length_um = c.bar_u_length_um;
        Self {
            offset_um: crate::num::sqrtf(length_um * length_um + thermal_um * thermal_um),
            scale: c.lvdt_u_scale_ppm * 1e-6,
        }
    }

    /// The bar's shares of the standard uncertainty of a figure of kind `kind` and value
    /// `value` (same unit as the value; a radial figure in µm): [the offset's, u_offset for a
    /// radial figure, else 0; the scale's, |value|·u_k]. The figure's combined u is
    /// √(u_a² + both²), u_a its own (Type A).
    pub fn shares(&self, kind: FigureKind, value: f32) -> [f32; 2] {
        let offset = match kind {
            FigureKind::Radial => self.offset_um,
            FigureKind::Shape => 0.0,
        };
        [offset, libm::fabsf(value * self.scale)]
    }

    /// The combined standard uncertainty of a figure of kind `kind` and value `value` whose
    /// own (Type A) standard uncertainty is `u_a`: √(u_a² + both [`shares`](Self::shares)²),
    /// the figure's unit.
    pub fn combined(&self, kind: FigureKind, value: f32, u_a: f32) -> f32 {
        let [offset, scale] = self.shares(kind, value);
        crate::num::sqrtf(u_a * u_a + offset * offset + scale * scale)
    }
}

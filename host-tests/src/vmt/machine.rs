//! Machines of the virtual machine tool and their description files (TOML or JSON).
//!
//! - [`Machine002`]: the seed 002 multi-tasking machine `w-C'bZYXB(C1)-t`, all 13 deviations,
//!   on the literal HTM chain of [`crate::forward_seed002`] (eqs 2.10–2.21); the commands are
//!   the NC program's (`ballpod::identify::mill_turn::patterns::command`, Tables 2.2/2.3).
//! - [`CircleMachine`]: an XY machine for the ISO 230-4 circular test with linear-axis faults
//!   (squareness, scale, reversal/backlash, cyclic error, servo lag per axis).

use ballpod::acquisition::Sample;
use ballpod::app::Pattern;
use ballpod::app::bc_ballbar::{Setup, model_pattern};
use ballpod::config::CirclePlane;
use ballpod::identify::mill_turn::patterns::command;
use ballpod::identify::mill_turn::{Deviations, arcsec_to_urad};
use serde::{Deserialize, Serialize};

use crate::forward_seed002 as fwd;

/// Seed 002 machine description: positional deviations in µm, angular ones in arc-seconds
/// (thesis units), ball mounting offsets in µm. Signs: the printed HTMs (eqs 2.2–2.11).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Machine002 {
    /// δx_BT, µm.
    pub dx_bt_um: f64,
    /// δz_BT, µm.
    pub dz_bt_um: f64,
    /// α_BT, arc-seconds.
    pub alpha_bt_arcsec: f64,
    /// α_XB, arc-seconds.
    pub alpha_xb_arcsec: f64,
    /// β_XB, arc-seconds.
    pub beta_xb_arcsec: f64,
    /// γ_XB, arc-seconds.
    pub gamma_xb_arcsec: f64,
    /// γ_XY, arc-seconds (not identified by the ball-bar procedure; keep 0 for the table).
    pub gamma_xy_arcsec: f64,
    /// α_YZ, arc-seconds (aliases α_XB; keep 0).
    pub alpha_yz_arcsec: f64,
    /// β_YZ, arc-seconds (aliases β_XB; keep 0).
    pub beta_yz_arcsec: f64,
    /// δx_CZ, µm.
    pub dx_cz_um: f64,
    /// δy_CZ, µm.
    pub dy_cz_um: f64,
    /// α_CZ, arc-seconds.
    pub alpha_cz_arcsec: f64,
    /// β_CZ, arc-seconds.
    pub beta_cz_arcsec: f64,
    /// T-ball mounting offset in the spindle frame, µm (acts like δx_BT, δz_BT): the first
    /// tool length's (R_B: BX, BY, CR, CA), and CR2's unless `t_offset_2_um` is given.
    pub t_offset_um: [f64; 3],
    /// T-ball mounting offset on the second tool length (R′_B: CR2), µm; not given: the
    /// first's (the same mounting).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t_offset_2_um: Option<[f64; 3]>,
    /// W-ball mounting offset in the C frame, µm: its clamping on the C axis (BX, BY), and at
    /// R_C (CR, CA, CR2) unless `w_offset_c_um` is given.
    pub w_offset_um: [f64; 3],
    /// W-ball mounting offset after its clamping at R_C (CR, CA, CR2), µm; not given: the
    /// same as on the C axis (not clamped again).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub w_offset_c_um: Option<[f64; 3]>,
}

impl Default for Machine002 {
    /// The thesis's identified values (Table 4.5), with δx_BT = δz_BT = 0 (the thesis
    /// identifies only δx_CZ − δx_BT) and no squareness errors.
    fn default() -> Self {
        Self {
            dx_bt_um: 0.0,
            dz_bt_um: 0.0,
            alpha_bt_arcsec: 9.63,
            alpha_xb_arcsec: -20.89,
            beta_xb_arcsec: -24.11,
            gamma_xb_arcsec: 5.63,
            gamma_xy_arcsec: 0.0,
            alpha_yz_arcsec: 0.0,
            beta_yz_arcsec: 0.0,
            dx_cz_um: 53.13,
            dy_cz_um: -45.63,
            alpha_cz_arcsec: 1.10,
            beta_cz_arcsec: -25.16,
            t_offset_um: [0.0; 3],
            t_offset_2_um: None,
            w_offset_um: [0.0; 3],
            w_offset_c_um: None,
        }
    }
}

impl Machine002 {
    /// A machine without deviations or ball offsets.
    pub fn perfect() -> Self {
        Self {
            alpha_bt_arcsec: 0.0,
            alpha_xb_arcsec: 0.0,
            beta_xb_arcsec: 0.0,
            gamma_xb_arcsec: 0.0,
            dx_cz_um: 0.0,
            dy_cz_um: 0.0,
            alpha_cz_arcsec: 0.0,
            beta_cz_arcsec: 0.0,
            ..Self::default()
        }
    }

    /// The 13 deviations in the core's units (µm / µrad).
    pub fn deviations(&self) -> Deviations {
        let a = arcsec_to_urad;
        Deviations {
            dx_bt_um: self.dx_bt_um,
            dz_bt_um: self.dz_bt_um,
            alpha_bt_urad: a(self.alpha_bt_arcsec),
            alpha_xb_urad: a(self.alpha_xb_arcsec),
            beta_xb_urad: a(self.beta_xb_arcsec),
            gamma_xb_urad: a(self.gamma_xb_arcsec),
            gamma_xy_urad: a(self.gamma_xy_arcsec),
            alpha_yz_urad: a(self.alpha_yz_arcsec),
            beta_yz_urad: a(self.beta_yz_arcsec),
            dx_cz_um: self.dx_cz_um,
            dy_cz_um: self.dy_cz_um,
            alpha_cz_urad: a(self.alpha_cz_arcsec),
            beta_cz_urad: a(self.beta_cz_arcsec),
        }
    }

    /// The deviations as the seed 002 procedure can identify them: the T-ball's mounting
    /// offset is in δx_BT (+x_T), δz_BT (+z_T) and δy_CZ (−y_T) to first order — the bar
    /// cannot tell the ball's place on the spindle from the spindle's (the Monte Carlo tests
    /// `identify_mill_turn_mounting.rs` hold the identification to the same).
    pub fn as_identified(&self) -> Deviations {
        let mut d = self.deviations();
        d.dx_bt_um += self.t_offset_um[0];
        d.dy_cz_um -= self.t_offset_um[1];
        d.dz_bt_um += self.t_offset_um[2];
        d
    }

    /// At pattern angle `angle_rad` of `step`: the true bar-length deviation (µm, ball
    /// distance − L_B) and the axis positions the encoders read (X, Y, Z mm; B, C degrees).
    pub fn pose(&self, setup: &Setup, step: Pattern, angle_rad: f64) -> (f64, [f64; 5]) {
        let c = command(model_pattern(step), &setup.geometry(step), angle_rad);
        let o = &setup.offset;
        (
            self.model_delta_l_um(setup, step, [c.x_mm, c.y_mm, c.z_mm], c.b_rad, c.c_rad),
            [
                c.x_mm + o.x_mm,
                c.y_mm + o.y_mm,
                c.z_mm + o.z_mm,
                c.b_rad.to_degrees(),
                c.c_rad.to_degrees(),
            ],
        )
    }

    /// The true bar-length deviation (µm, ball distance − L_B) of `step`'s bar with the axes
    /// commanded to `axes` (machine coordinates: X, Y, Z mm; B, C degrees), wherever they are
    /// (on the pattern or between two of an NC program's blocks).
    pub fn delta_l_um(&self, setup: &Setup, step: Pattern, axes: &[f64; 5]) -> f64 {
        let o = &setup.offset;
        let [x, y, z, b_deg, c_deg] = *axes;
        let xyz = [x - o.x_mm, y - o.y_mm, z - o.z_mm];
        self.model_delta_l_um(setup, step, xyz, b_deg.to_radians(), c_deg.to_radians())
    }

    /// The same from model-frame X, Y, Z (mm) and B, C (rad).
    fn model_delta_l_um(
        &self,
        setup: &Setup,
        step: Pattern,
        [x, y, z]: [f64; 3],
        b_rad: f64,
        c_rad: f64,
    ) -> f64 {
        let g = setup.geometry(step);
        let d = self.deviations().to_array();
        let t_offset = match step {
            Pattern::Cr2 => self.t_offset_2_um.unwrap_or(self.t_offset_um),
            _ => self.t_offset_um,
        };
        let t = fwd::t_ball(&d, x, y, z, b_rad, g.r_b_mm, t_offset);
        let (xw, w_offset) = if model_pattern(step).is_b() {
            (0.0, self.w_offset_um)
        } else {
            (g.r_c_mm, self.w_offset_c_um.unwrap_or(self.w_offset_um))
        };
        let w = fwd::w_ball(&d, c_rad, g.z_c_mm, g.r_b_mm, xw, w_offset);
        let dist = ((t[0] - w[0]).powi(2) + (t[1] - w[1]).powi(2) + (t[2] - w[2]).powi(2)).sqrt();
        (dist - g.l_b_mm) * 1e3
    }
}

/// An XY machine for the ISO 230-4 circular test: socket at the origin, the tool ball on a
/// circle of the bar's radius, with linear-axis faults (error = actual − commanded).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CircleMachine {
    /// Circle radius = bar length, mm.
    pub radius_mm: f64,
    /// Feed, mm/min.
    pub feed_mm_per_min: f64,
    /// Out-of-squareness S, µrad: E_x = S·y (S > 0: the Y axis leans towards +X).
    pub squareness_urad: f64,
    /// X scale error, µm/m (E_x = k_x·x).
    pub scale_x_um_per_m: f64,
    /// Y scale error, µm/m.
    pub scale_y_um_per_m: f64,
    /// X reversal step (backlash), µm: E_x = −sign(v_x)·B_x/2.
    pub backlash_x_um: f64,
    /// Y reversal step (backlash), µm.
    pub backlash_y_um: f64,
    /// Cyclic radial error amplitude, µm (radial error A·cos(order·θ + φ)).
    pub cyclic_amplitude_um: f64,
    /// Cyclic error order (cycles per revolution, 4..=16 diagnosed: a third order is read as straightness).
    pub cyclic_order: u32,
    /// Cyclic error phase φ, degrees (not 0 by default: at φ = 0 an even order is the one
    /// phase the reversal-step shapes do not see, which hid a leak, issue 14).
    pub cyclic_phase_deg: f64,
    /// X servo lag, ms (x follows its command τ_x late).
    pub servo_lag_x_ms: f64,
    /// Y servo lag, ms.
    pub servo_lag_y_ms: f64,
    /// Quadratic straightness of X along Y, µm: E_x = A·(y/R)² (0 at y = 0, A at y = ±R).
    pub straightness_x_along_y_um: f64,
    /// Quadratic straightness of Y along X, µm: E_y = B·(x/R)² (0 at x = 0, B at x = ±R).
    pub straightness_y_along_x_um: f64,
    /// Where the socket really is minus where the pod believes it (X, Y), µm.
    pub socket_offset_um: [f64; 2],
    /// Thermal growth of X, µm per minute at x = R: E_x = g_x·t·x/R, t = time since the
    /// run's start.
    pub thermal_growth_x_um_per_min: f64,
    /// Thermal growth of Y, µm per minute at y = R: E_y = g_y·t·y/R.
    pub thermal_growth_y_um_per_min: f64,
    /// The served CNC's radial feed-in (and feed-out) of a self-triggered circle run
    /// (`run_trigger = FEED_IN`), mm; 0: a program without a feed-in.
    pub feed_in_mm: f64,
    /// X reversal spike, µm: after X reverses it stays behind its command at the end of its
    /// travel by h·e^(−Δt/τ) (Δt from the reversal; not at the run's start).
    pub reversal_spike_x_um: f64,
    /// Y reversal spike, µm.
    pub reversal_spike_y_um: f64,
    /// The spikes' time constant τ, ms.
    pub reversal_spike_ms: f64,
    /// X's lateral play, µm: its carriage runs p/2 towards +Y while X travels +, towards −Y
    /// while it travels − (E_y = (p/2)·sign(ẋ)).
    pub lateral_play_x_um: f64,
    /// Y's lateral play, µm (E_x = (p/2)·sign(ẏ)).
    pub lateral_play_y_um: f64,
    /// X's vibration, µm: E_x = A·sin(2πf·t), t from the run's start.
    pub vibration_x_um: f64,
    /// Y's vibration, µm: E_y = A·sin(2πf·t + 1 rad).
    pub vibration_y_um: f64,
    /// The vibration's frequency f, Hz.
    pub vibration_hz: f64,
    /// X's stick-slip, µm: after X reverses, E_x = a·sin(2πf_s·Δt) for `stick_slip_ms`
    /// (Δt from the reversal; not at the run's start).
    pub stick_slip_x_um: f64,
    /// Y's stick-slip, µm.
    pub stick_slip_y_um: f64,
    /// The stick-slip's frequency f_s, Hz.
    pub stick_slip_hz: f64,
    /// How long a stick-slip lasts after the reversal, ms.
    pub stick_slip_ms: f64,
}

impl Default for CircleMachine {
    /// Typical faults of a worn vertical machining centre.
    fn default() -> Self {
        Self {
            radius_mm: 150.0,
            feed_mm_per_min: 1000.0,
            squareness_urad: 20.0,
            scale_x_um_per_m: 15.0,
            scale_y_um_per_m: -5.0,
            backlash_x_um: 4.0,
            backlash_y_um: 2.0,
            cyclic_amplitude_um: 1.0,
            cyclic_order: 8,
            cyclic_phase_deg: 30.0,
            servo_lag_x_ms: 1.0,
            servo_lag_y_ms: 0.0,
            straightness_x_along_y_um: 0.0,
            straightness_y_along_x_um: 0.0,
            socket_offset_um: [0.0; 2],
            thermal_growth_x_um_per_min: 0.0,
            thermal_growth_y_um_per_min: 0.0,
            feed_in_mm: 1.0,
            reversal_spike_x_um: 0.0,
            reversal_spike_y_um: 0.0,
            reversal_spike_ms: 10.0,
            lateral_play_x_um: 0.0,
            lateral_play_y_um: 0.0,
            vibration_x_um: 0.0,
            vibration_y_um: 0.0,
            vibration_hz: 120.0,
            stick_slip_x_um: 0.0,
            stick_slip_y_um: 0.0,
            stick_slip_hz: 60.0,
            stick_slip_ms: 200.0,
        }
    }
}

impl CircleMachine {
    /// A machine without geometric or servo errors (R 150 mm, F1000): a test sets the one
    /// error it studies on top of it.
    pub fn perfect() -> Self {
        Self {
            squareness_urad: 0.0,
            scale_x_um_per_m: 0.0,
            scale_y_um_per_m: 0.0,
            backlash_x_um: 0.0,
            backlash_y_um: 0.0,
            cyclic_amplitude_um: 0.0,
            servo_lag_x_ms: 0.0,
            servo_lag_y_ms: 0.0,
            ..Self::default()
        }
    }

    /// Servo mismatch τ_x − τ_y, ms.
    pub fn servo_mismatch_ms(&self) -> f64 {
        self.servo_lag_x_ms - self.servo_lag_y_ms
    }

    /// At commanded angle `theta` (rad) moving with angular velocity sign `dir` (+1 CCW,
    /// −1 CW): the true bar deviation (µm) and the commanded axis positions (mm).
    pub fn pose(&self, theta: f64, dir: f64) -> (f64, [f64; 5]) {
        let r = self.radius_mm;
        let omega = dir * self.feed_mm_per_min / 60.0 / r; // rad/s
        // each axis reproduces its command τ late
        let th_x = theta - omega * self.servo_lag_x_ms * 1e-3;
        let th_y = theta - omega * self.servo_lag_y_ms * 1e-3;
        let (xa, ya) = (r * th_x.cos(), r * th_y.sin());
        let (vx, vy) = (-dir * theta.sin(), dir * theta.cos());
        let radial = self.cyclic_amplitude_um
            * (f64::from(self.cyclic_order) * theta + self.cyclic_phase_deg.to_radians()).cos();
        let ex_um = self.squareness_urad * 1e-3 * ya + self.scale_x_um_per_m * 1e-3 * xa
            - vx.signum() * self.backlash_x_um / 2.0
            + vy.signum() * self.lateral_play_y_um / 2.0
            + radial * theta.cos();
        let ey_um = self.scale_y_um_per_m * 1e-3 * ya - vy.signum() * self.backlash_y_um / 2.0
            + vx.signum() * self.lateral_play_x_um / 2.0
            + radial * theta.sin();
        // time since the run's start: every run starts at θ = 0 and turns at |ω|
        let t_min = theta.abs() / omega.abs() / 60.0;
        let ex_um = ex_um
            + self.straightness_x_along_y_um * (ya / r).powi(2)
            + self.thermal_growth_x_um_per_min * t_min * xa / r;
        let ey_um = ey_um
            + self.straightness_y_along_x_um * (xa / r).powi(2)
            + self.thermal_growth_y_um_per_min * t_min * ya / r;
        // reversal spikes: X reverses at |θ| = π, 2π, …, Y at π/2, 3π/2, … (the run's start
        // at θ = 0 is no reversal); outward, decaying from the latest
        let spike = |h: f64, first: f64| {
            let turned = theta.abs();
            if h == 0.0 || turned < first {
                return 0.0;
            }
            let since = (turned - first).rem_euclid(std::f64::consts::PI);
            h * (-since / omega.abs() / (self.reversal_spike_ms * 1e-3)).exp()
        };
        let ex_um =
            ex_um + theta.cos().signum() * spike(self.reversal_spike_x_um, std::f64::consts::PI);
        let ey_um = ey_um
            + theta.sin().signum() * spike(self.reversal_spike_y_um, std::f64::consts::FRAC_PI_2);
        // vibration in time; stick-slip from each axis's latest reversal, for stick_slip_ms
        let tau = std::f64::consts::TAU;
        let t_s = t_min * 60.0;
        let slip = |a: f64, first: f64| {
            let turned = theta.abs();
            if a == 0.0 || turned < first {
                return 0.0;
            }
            let since = (turned - first).rem_euclid(std::f64::consts::PI) / omega.abs();
            if since * 1e3 < self.stick_slip_ms {
                a * (tau * self.stick_slip_hz * since).sin()
            } else {
                0.0
            }
        };
        let ex_um = ex_um
            + self.vibration_x_um * (tau * self.vibration_hz * t_s).sin()
            + slip(self.stick_slip_x_um, std::f64::consts::PI);
        let ey_um = ey_um
            + self.vibration_y_um * (tau * self.vibration_hz * t_s + 1.0).sin()
            + slip(self.stick_slip_y_um, std::f64::consts::FRAC_PI_2);
        let (x, y) = (
            xa + ex_um * 1e-3 - self.socket_offset_um[0] * 1e-3,
            ya + ey_um * 1e-3 - self.socket_offset_um[1] * 1e-3,
        );
        (
            ((x * x + y * y).sqrt() - r) * 1e3,
            [r * theta.cos(), r * theta.sin(), 0.0, 0.0, 0.0],
        )
    }

    /// Samples of one direction at `rate_hz`.
    pub fn samples_per_rev(&self, rate_hz: f64) -> usize {
        (2.0 * std::f64::consts::PI * self.radius_mm / (self.feed_mm_per_min / 60.0) * rate_hz)
            .round() as usize
    }
}

/// The Z axis and the vertical planes of the machine whose XY plane is the [`CircleMachine`]:
/// with it, the three-plane summary's machine. Its circles in YZ and ZX (socket at the origin,
/// the circle machine's radius and feed) are each a [`CircleMachine`] of the plane's (u, v)
/// axes: E_u = S_uv·v, E_u = k_u·u, E_v = k_v·v, each axis's reversal step and servo lag (X
/// and Y as in the XY circle, Z here); the out-of-plane axis stands still (its errors are
/// second order on the bar).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ThreePlaneMachine {
    /// Out-of-squareness of Y and Z, µrad: E_y = S_yz·z (> 0: the angle between +Y and +Z is
    /// less than 90°).
    pub squareness_yz_urad: f64,
    /// Out-of-squareness of Z and X, µrad: E_z = S_zx·x.
    pub squareness_zx_urad: f64,
    /// Z scale error, µm/m (E_z = k_z·z).
    pub scale_z_um_per_m: f64,
    /// Z reversal step, µm.
    pub backlash_z_um: f64,
    /// The arc of the YZ and ZX tests, degrees (Ballbar 20's 220°: from −20° to 200°, above
    /// the table); 360: full circles.
    pub vertical_arc_deg: f64,
}

impl Default for ThreePlaneMachine {
    /// Z out of square with both, its scale apart from X's and Y's.
    fn default() -> Self {
        Self {
            squareness_yz_urad: -15.0,
            squareness_zx_urad: 30.0,
            scale_z_um_per_m: 25.0,
            backlash_z_um: 3.0,
            vertical_arc_deg: 220.0,
        }
    }
}

impl ThreePlaneMachine {
    /// The squareness of `plane`, µrad (XY: the circle machine's).
    pub fn squareness_urad(&self, xy: &CircleMachine, plane: CirclePlane) -> f64 {
        match plane {
            CirclePlane::XY => xy.squareness_urad,
            CirclePlane::YZ => self.squareness_yz_urad,
            CirclePlane::ZX => self.squareness_zx_urad,
        }
    }

    /// The scale errors of X, Y, Z, µm/m.
    pub fn scales_um_per_m(&self, xy: &CircleMachine) -> [f64; 3] {
        [
            xy.scale_x_um_per_m,
            xy.scale_y_um_per_m,
            self.scale_z_um_per_m,
        ]
    }

    /// The circle machine of the vertical `plane` (YZ or ZX; XY is `xy` itself).
    pub fn plane(&self, xy: &CircleMachine, plane: CirclePlane) -> CircleMachine {
        let (u, v, _) = crate::ncgen::plane_axes(plane);
        let scale = self.scales_um_per_m(xy);
        let backlash = [xy.backlash_x_um, xy.backlash_y_um, self.backlash_z_um];
        let lag = [xy.servo_lag_x_ms, xy.servo_lag_y_ms, 0.0];
        CircleMachine {
            radius_mm: xy.radius_mm,
            feed_mm_per_min: xy.feed_mm_per_min,
            squareness_urad: self.squareness_urad(xy, plane),
            scale_x_um_per_m: scale[u],
            scale_y_um_per_m: scale[v],
            backlash_x_um: backlash[u],
            backlash_y_um: backlash[v],
            servo_lag_x_ms: lag[u],
            servo_lag_y_ms: lag[v],
            ..CircleMachine::perfect()
        }
    }

    /// The data arc of a vertical plane's test: start and span, degrees.
    pub fn arc(&self) -> (f64, f64) {
        if self.vertical_arc_deg >= 360.0 {
            (0.0, 360.0)
        } else {
            (-20.0, self.vertical_arc_deg)
        }
    }

    /// A [`CircleMachine::pose`]'s axes (u, v in X, Y) moved to `plane`'s axes.
    pub fn axes(plane: CirclePlane, uv: [f64; 5]) -> [f64; 5] {
        let (u, v, _) = crate::ncgen::plane_axes(plane);
        let mut a = [0.0; 5];
        a[u] = uv[0];
        a[v] = uv[1];
        a
    }
}

/// The machine description file: any section may be left out (defaults above).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MachineFile {
    /// The seed 002 machine.
    pub seed002: Machine002,
    /// The circular-test machine.
    pub circle: CircleMachine,
    /// Its Z axis and vertical planes (the three-plane summary, with `circle` as XY).
    pub planes: ThreePlaneMachine,
    /// The instrument.
    pub instrument: super::sensors::Instrument,
}

impl MachineFile {
    /// Reads a TOML (`.toml`) or JSON (any other extension) description.
    pub fn read(path: &std::path::Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        if path.extension().is_some_and(|e| e == "toml") {
            toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
        } else {
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
        }
    }
}

/// A sample of an ideal XY circle about (0, 0) at `theta_rad` (CCW from +X) with the bar read to
/// first order in the eccentricity: ΔL = r0 + e_x cos θ + e_y sin θ, µm (the linearised
/// circle-fit model, ISO 230-4 Annex / DESIGN.md §numerics), at 20 °C.
pub fn linear_circle_sample(theta_rad: f64, radius_mm: f64, e_um: [f64; 2], r0_um: f64) -> Sample {
    let (s, c) = theta_rad.sin_cos();
    Sample {
        delta_l_um: (r0_um + e_um[0] * c + e_um[1] * s) as f32,
        axes: [
            (radius_mm * c) as f32,
            (radius_mm * s) as f32,
            0.0,
            0.0,
            0.0,
        ],
        temp_c: 20.0,
        ..Sample::default()
    }
}

//! Seed 000's two-step procedure (spec B.6): an SSM station set after the 3-DOF translation
//! (ΔV1), the rotation, and an SSM station set after it (ΔV2), from the pod's two-step set-up
//! (`ts_machine`, `ts_origin_*`, `ts_tool_z`, `ts_z_alpha_gamma`, `ts_reference_*`,
//! `ts_angle_*`) and its bar and dwell fields, for the four machine types of seed 000 Fig. 1.
//!
//! **Geometry** (seed 000 eqs 2/4, 8, 13/15, 14/16): the measured ball — the tool ball on a
//! spindle-head machine, the reference ball on the table of a table machine — is at
//! B = O + c(angles), O the origin after the translation (`ts_origin`: the pivot, or the table
//! origin) and c the machine's chain: RRTTT Rx(α)·Ry(β)·(0, 0, z_r) (words A, B); RTTTR spindle
//! Ry(β)·(0, 0, z_r) (word B); TTTRR Rx(α)·((0, 0, z_αγ) + Rz(γ)·r) (words A, C); RTTTR table
//! Rx(α)·r (word A), the words carrying the seed's angles. Location 1 is B at zero angles,
//! location 2 B at the angles, the linear axes unchanged. The socket — on the bed under the
//! spindle's ball, on the spindle over the table's — is mounted once where the bar reaches both
//! locations (on their bisecting plane, the bar's length from each), and each run's station set
//! ([`SsmTest`]) lies on the bar's sphere with its first station at the location.
//!
//! **Words.** The programmed X Y Z is the ball at zero angles (tool length compensation or the
//! work offset at the ball; no TCPM), so at the angles the ball is c(angles) − c(0) from the
//! programmed point and the second run's points are programmed that much short of the
//! stations. The rotation moves the ball off the bar's sphere: the program stops (`M0`) for the
//! bar to be taken off and put back. The pod's encoders read the programmed X Y Z, so the second
//! run's `ssm_socket` is the socket less that offset (the header says both values).

use std::fmt::Write as _;

use ballpod::config::{CirclePlane, Config, TwoStepMachine};

use super::ssm::{SsmTest, dwell_s, unit};
use super::{Dialect, NcError, num};

/// A two-step procedure ready to be written.
#[derive(Clone, Debug, PartialEq)]
pub struct TwoStepTest {
    /// The machine type.
    pub machine: TwoStepMachine,
    /// Origin after the translation (pivot or table origin), mm.
    pub origin_mm: [f64; 3],
    /// The ball from the origin at zero angles and at the angles, c(0) and c(angles), mm.
    pub chain_mm: [[f64; 3]; 2],
    /// The rotary words (letter, the seed's angle in degrees).
    pub rotary_deg: Vec<(char, f64)>,
    /// Socket centre, mm.
    pub socket_mm: [f64; 3],
    /// The station sets after the translation and after the rotation (tool-ball positions).
    pub runs: [SsmTest; 2],
}

/// Right-handed rotations of `v` by `deg` about X, Y, Z (seed 000 D1).
fn rx(deg: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    [v[0], c * v[1] - s * v[2], s * v[1] + c * v[2]]
}
fn ry(deg: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    [c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]]
}
fn rz(deg: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}

impl TwoStepTest {
    /// The procedure of the set-up in `cfg`; `separation_deg`, `stations`, `feed_mm_per_min`
    /// as for [`SsmTest`]. Refused with the field named: the machine or a field it needs not
    /// set, a rotation that moves the ball less than 1 mm or farther than the bar can span.
    pub fn from_config(
        cfg: &Config,
        separation_deg: f64,
        stations: usize,
        feed_mm_per_min: f64,
    ) -> Result<Self, NcError> {
        let t = &cfg.setup;
        let bad = |field: &'static str, what: &str| NcError {
            field,
            what: what.into(),
        };
        let set = |v: f32, field: &'static str| {
            Some(f64::from(v))
                .filter(|x| x.is_finite())
                .ok_or(bad(field, "not set"))
        };
        let machine = t.ts_machine;
        let origin_mm = [
            set(t.ts_origin_mm[0], "ts_origin_x")?,
            set(t.ts_origin_mm[1], "ts_origin_y")?,
            set(t.ts_origin_mm[2], "ts_origin_z")?,
        ];
        let angle = |k: usize, field| set(t.ts_angles_deg[k], field);
        let tool = || Ok::<_, NcError>([0.0, 0.0, set(t.ts_tool_z_mm, "ts_tool_z")?]);
        let reference = || {
            Ok::<_, NcError>([
                set(t.ts_reference_mm[0], "ts_reference_x")?,
                set(t.ts_reference_mm[1], "ts_reference_y")?,
                set(t.ts_reference_mm[2], "ts_reference_z")?,
            ])
        };
        // c(0), c(angles), the rotary words; the socket above the ball on a table machine
        let (chain_mm, rotary_deg, socket_above) = match machine {
            TwoStepMachine::Rrttt => {
                let (a, b, v) = (angle(0, "ts_angle_1")?, angle(1, "ts_angle_2")?, tool()?);
                ([v, rx(a, ry(b, v))], vec![('A', a), ('B', b)], false)
            }
            TwoStepMachine::RtttrSpindle => {
                let (b, v) = (angle(0, "ts_angle_1")?, tool()?);
                ([v, ry(b, v)], vec![('B', b)], false)
            }
            TwoStepMachine::Tttrr => {
                let (a, g) = (angle(0, "ts_angle_1")?, angle(1, "ts_angle_2")?);
                let z = set(t.ts_z_alpha_gamma_mm, "ts_z_alpha_gamma")?;
                let r = reference()?;
                let at = |a: f64, g: f64| {
                    let q = rz(g, r);
                    rx(a, [q[0], q[1], q[2] + z])
                };
                ([at(0.0, 0.0), at(a, g)], vec![('A', a), ('C', g)], true)
            }
            TwoStepMachine::RtttrTable => {
                let (a, r) = (angle(0, "ts_angle_1")?, reference()?);
                ([r, rx(a, r)], vec![('A', a)], true)
            }
            TwoStepMachine::None => return Err(bad("ts_machine", "not set")),
        };
        let p1: [f64; 3] = std::array::from_fn(|i| origin_mm[i] + chain_mm[0][i]);
        let p2: [f64; 3] = std::array::from_fn(|i| origin_mm[i] + chain_mm[1][i]);
        // the socket: on the bisecting plane, L from both, below (above) the ball
        let bar = f64::from(cfg.bar_length_mm);
        let d: [f64; 3] = std::array::from_fn(|i| p2[i] - p1[i]);
        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if dist < 1.0 {
            return Err(bad(
                "ts_angle_1",
                "the rotation moves the ball less than 1 mm: nothing to measure",
            ));
        }
        if dist >= 1.9 * bar {
            return Err(NcError {
                field: "bar_length",
                what: format!(
                    "the rotation moves the ball {} mm: more than the bar can span from one socket",
                    num(dist)
                ),
            });
        }
        let u = unit(d);
        // ∓Z made perpendicular to the move (∓X if the move is along Z)
        let side = if socket_above { 1.0 } else { -1.0 };
        let down = if u[2].abs() > 0.99 {
            [side, 0.0, 0.0]
        } else {
            [0.0, 0.0, side]
        };
        let along = down[0] * u[0] + down[1] * u[1] + down[2] * u[2];
        let n = unit(std::array::from_fn(|i| down[i] - along * u[i]));
        let h = (bar * bar - dist * dist / 4.0).sqrt();
        let socket_mm: [f64; 3] = std::array::from_fn(|i| (p1[i] + p2[i]) / 2.0 + h * n[i]);
        let run = |target: [f64; 3]| -> Result<SsmTest, NcError> {
            let mut c = *cfg;
            c.setup.ssm_socket_mm = socket_mm.map(|v| v as f32);
            let mut s =
                SsmTest::from_config(&c, target, separation_deg, stations, feed_mm_per_min)?;
            // the socket exactly (not through the f32 configuration field)
            s.socket_mm = socket_mm;
            s.towards = unit(std::array::from_fn(|i| target[i] - socket_mm[i]));
            s.dwell_s = dwell_s(cfg);
            Ok(s)
        };
        Ok(Self {
            machine,
            origin_mm,
            chain_mm,
            rotary_deg,
            socket_mm,
            runs: [run(p1)?, run(p2)?],
        })
    }

    /// The rotary words at the angles, or at zero.
    fn rotary(&self, at_angles: bool) -> String {
        let words: Vec<String> = self
            .rotary_deg
            .iter()
            .map(|(c, a)| format!("{c}{}", num(if at_angles { *a } else { 0.0 })))
            .collect();
        words.join(" ")
    }

    /// Where a programmed point is from the ball it makes at the angles: c(0) − c(angles).
    fn offset_mm(&self) -> [f64; 3] {
        let [c0, c1] = self.chain_mm;
        std::array::from_fn(|i| c0[i] - c1[i])
    }

    /// The part program in `dialect`.
    pub fn program(&self, dialect: Dialect) -> String {
        let xyz = |p: [f64; 3]| format!("X{} Y{} Z{}", num(p[0]), num(p[1]), num(p[2]));
        let off = self.offset_mm();
        let socket2: [f64; 3] = std::array::from_fn(|i| self.socket_mm[i] + off[i]);
        let name = TwoStepMachine::NAMES
            .get(self.machine as usize)
            .copied()
            .unwrap_or("?");
        let member = match self.machine {
            TwoStepMachine::Rrttt | TwoStepMachine::RtttrSpindle => {
                "spindle-head machine: tool length compensation on"
            }
            _ => "table machine: work offset at the table's ball",
        };
        let s = &self.runs[0];
        let header = [
            format!(
                "ballpod seed 000 two-step, {name}: SSM after the translation, rotation to {}, SSM after it",
                self.rotary(true)
            ),
            format!(
                "origin {} after the translation, the ball {} from it at zero angles; {member}, no TCPM",
                xyz(self.origin_mm),
                xyz(self.chain_mm[0])
            ),
            format!(
                "socket {}, bar {} mm; {} stations {} deg apart, dwell {} s, F{}",
                xyz(self.socket_mm),
                num(s.bar_mm),
                s.stations,
                num(s.separation_deg),
                num(s.dwell_s),
                num(s.feed_mm_per_min)
            ),
            format!(
                "pod set-up: ts_machine {name} and its ts_* fields; pattern SSM; run 1 ssm_socket {}, run 2 ssm_socket {}",
                xyz(self.socket_mm),
                xyz(socket2)
            ),
        ];
        let mut out = String::new();
        dialect.begin(&mut out, &header);
        let _ = writeln!(out, "{}", dialect.modal(CirclePlane::XY));
        for (k, run) in self.runs.iter().enumerate() {
            let offset = if k == 0 { [0.0; 3] } else { off };
            let first = run.stations_mm()[0];
            let p: [f64; 3] = std::array::from_fn(|i| first[i] + offset[i]);
            if k == 0 {
                dialect.comment(&mut out, "run 1, dV1: after the translation");
            } else {
                dialect.comment(
                    &mut out,
                    "take the bar off the ball: the rotation leaves the bar's sphere",
                );
                let _ = writeln!(out, "M0");
                dialect.comment(&mut out, "run 2, dV2: after the rotation");
            }
            let _ = writeln!(out, "G0 {} {}", xyz(p), self.rotary(k == 1));
            dialect.comment(
                &mut out,
                &format!(
                    "mount the bar; pod: ssm_socket {}, arm and start",
                    xyz(if k == 0 { self.socket_mm } else { socket2 })
                ),
            );
            let _ = writeln!(out, "M0");
            run.write_stations(&mut out, dialect, offset);
            dialect.comment(&mut out, "pod: stop the run");
        }
        dialect.end(&mut out);
        out
    }
}

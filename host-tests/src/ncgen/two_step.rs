//! Seed 000's two-step procedure (spec B.6) on a spindle-head machine — RRTTT (α about X, β
//! about Y: words A, B) or the spindle axis of an RTTTR machine (β about Y: word B): an SSM
//! station set after the 3-DOF translation (ΔV1), the rotation, and an SSM station set after it
//! (ΔV2), from the pod's two-step set-up (`ts_machine`, `ts_origin_*` the pivot after the
//! translation, `ts_tool_z` the signed tool vector z_r, `ts_angle_*`) and its bar and dwell
//! fields.
//!
//! **Geometry** (seed 000 eqs 2/4 and 13/15): the tool ball is at T = O + R·(0, 0, z_r), R =
//! Rx(α)·Ry(β) (RTTTR: Ry(β)), O the pivot. Location 1 is T at A0 B0, location 2 T at the
//! angles, the pivot unchanged. The socket is mounted once (seed 000: "on the bed") where the
//! bar reaches both: on the bisecting plane of the two locations, the bar's length from each,
//! below them. Each run's station set ([`SsmTest`]) lies on the bar's sphere with its first
//! station at the location.
//!
//! **Words.** Tool length compensation on, no TCPM: the programmed X Y Z is the tool ball at
//! A0 B0, i.e. O + (0, 0, z_r); at the angles the ball is `(R − I)·(0, 0, z_r)` from it, so
//! the second run's points are programmed that far from the stations. The rotation moves the
//! ball off the bar's sphere: the program stops (`M0`) for the bar to be taken off and put
//! back. The pod's encoders read the programmed X Y Z, so the second run's `ssm_socket` is the
//! socket less that offset (the header says both values).
//!
//! Machines with the rotary axes in the table (TTTRR, RTTTR table: the reference point on the
//! spindle) are refused: their station sets move the socket with the spindle.

use std::fmt::Write as _;

use ballpod::config::{CirclePlane, Config, TwoStepMachine};

use super::ssm::{SsmTest, dwell_s, unit};
use super::{Dialect, NcError, num};

/// A two-step procedure ready to be written.
#[derive(Clone, Debug, PartialEq)]
pub struct TwoStepTest {
    /// RRTTT or RTTTR spindle.
    pub machine: TwoStepMachine,
    /// Pivot after the translation, mm.
    pub origin_mm: [f64; 3],
    /// Signed tool vector z_r, mm.
    pub tool_z_mm: f64,
    /// Angles of the rotation, degrees: (α, β) for RRTTT, (β, –) for RTTTR spindle.
    pub angles_deg: [f64; 2],
    /// Socket centre, mm.
    pub socket_mm: [f64; 3],
    /// The station sets after the translation and after the rotation (tool-ball positions).
    pub runs: [SsmTest; 2],
}

/// R·v for R = Rx(α)·Ry(β) (right-handed, seed 000 D1).
fn rotate(alpha_deg: f64, beta_deg: f64, v: [f64; 3]) -> [f64; 3] {
    let (sa, ca) = alpha_deg.to_radians().sin_cos();
    let (sb, cb) = beta_deg.to_radians().sin_cos();
    // Ry(β)·v, then Rx(α)·that
    let w = [cb * v[0] + sb * v[2], v[1], -sb * v[0] + cb * v[2]];
    [w[0], ca * w[1] - sa * w[2], sa * w[1] + ca * w[2]]
}

impl TwoStepTest {
    /// The procedure of the set-up in `cfg`; `separation_deg`, `stations`, `feed_mm_per_min`
    /// as for [`SsmTest`]. Refused with the field named: a table-side machine, a field not
    /// set, a rotation that moves the ball farther than the bar can span.
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
        let (alpha, beta) = match machine {
            TwoStepMachine::Rrttt => (
                set(t.ts_angles_deg[0], "ts_angle_1")?,
                set(t.ts_angles_deg[1], "ts_angle_2")?,
            ),
            TwoStepMachine::RtttrSpindle => (0.0, set(t.ts_angles_deg[0], "ts_angle_1")?),
            TwoStepMachine::None => return Err(bad("ts_machine", "not set")),
            _ => {
                return Err(bad(
                    "ts_machine",
                    "TTTRR and RTTTR_TABLE put the reference point on the spindle: not generated (RRTTT and RTTTR_SPINDLE are)",
                ));
            }
        };
        let origin_mm = [
            set(t.ts_origin_mm[0], "ts_origin_x")?,
            set(t.ts_origin_mm[1], "ts_origin_y")?,
            set(t.ts_origin_mm[2], "ts_origin_z")?,
        ];
        let tool_z_mm = set(t.ts_tool_z_mm, "ts_tool_z")?;
        let tool = [0.0, 0.0, tool_z_mm];
        let p1: [f64; 3] = std::array::from_fn(|i| origin_mm[i] + tool[i]);
        let rt = rotate(alpha, beta, tool);
        let p2: [f64; 3] = std::array::from_fn(|i| origin_mm[i] + rt[i]);
        // the socket: on the bisecting plane, L from both, below them
        let bar = f64::from(cfg.bar_length_mm);
        let d: [f64; 3] = std::array::from_fn(|i| p2[i] - p1[i]);
        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if dist < 1.0 {
            return Err(bad(
                "ts_angle_1",
                "the rotation moves the tool ball less than 1 mm: nothing to measure",
            ));
        }
        if dist >= 1.9 * bar {
            return Err(NcError {
                field: "bar_length",
                what: format!(
                    "the rotation moves the tool ball {} mm: more than the bar can span from one socket",
                    num(dist)
                ),
            });
        }
        let u = unit(d);
        // −Z made perpendicular to the move (−X if the move is along Z)
        let down = if u[2].abs() > 0.99 {
            [-1.0, 0.0, 0.0]
        } else {
            [0.0, 0.0, -1.0]
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
            tool_z_mm,
            angles_deg: [alpha, beta],
            socket_mm,
            runs: [run(p1)?, run(p2)?],
        })
    }

    /// The rotary words at the angles (`A… B…` for RRTTT, `B…` for RTTTR spindle).
    fn rotary(&self, at_angles: bool) -> String {
        let [a, b] = if at_angles {
            self.angles_deg
        } else {
            [0.0, 0.0]
        };
        match self.machine {
            TwoStepMachine::Rrttt => format!("A{} B{}", num(a), num(b)),
            _ => format!("B{}", num(b)),
        }
    }

    /// Where a programmed point is from the tool ball it makes at the angles: (I − R)·(0, 0, z_r).
    fn offset_mm(&self) -> [f64; 3] {
        let [a, b] = self.angles_deg;
        let rt = rotate(a, b, [0.0, 0.0, self.tool_z_mm]);
        [-rt[0], -rt[1], self.tool_z_mm - rt[2]]
    }

    /// The part program in `dialect`.
    pub fn program(&self, dialect: Dialect) -> String {
        let xyz = |p: [f64; 3]| format!("X{} Y{} Z{}", num(p[0]), num(p[1]), num(p[2]));
        let off = self.offset_mm();
        let socket2: [f64; 3] = std::array::from_fn(|i| self.socket_mm[i] + off[i]);
        let name = match self.machine {
            TwoStepMachine::Rrttt => "RRTTT",
            _ => "RTTTR_SPINDLE",
        };
        let s = &self.runs[0];
        let header = [
            format!(
                "ballpod seed 000 two-step, {name}: SSM after the translation, rotation to {}, SSM after it",
                self.rotary(true)
            ),
            format!(
                "pivot {} after the translation, tool z_r {} mm; tool length compensation on, no TCPM",
                xyz(self.origin_mm),
                num(self.tool_z_mm)
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
                "pod set-up: ts_machine {name}, ts_origin, ts_tool_z, ts_angle as above; pattern SSM; run 1 ssm_socket {}, run 2 ssm_socket {}",
                xyz(self.socket_mm),
                xyz(socket2)
            ),
        ];
        let mut out = String::new();
        dialect.begin(&mut out, &header);
        let _ = writeln!(out, "{}", dialect.modal(CirclePlane::XY));
        for (k, run) in self.runs.iter().enumerate() {
            let (offset, first) = if k == 0 {
                ([0.0; 3], run.stations_mm()[0])
            } else {
                (off, run.stations_mm()[0])
            };
            let p: [f64; 3] = std::array::from_fn(|i| first[i] + offset[i]);
            if k == 0 {
                dialect.comment(&mut out, "run 1, dV1: after the translation");
            } else {
                dialect.comment(
                    &mut out,
                    "take the bar off the tool ball: the rotation leaves the bar's sphere",
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

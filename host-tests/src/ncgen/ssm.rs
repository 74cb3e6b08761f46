//! A single-socket-method station set (seed 000, spec B.2): the tool ball dwells at stations on
//! the sphere of the bar's length about the socket — the station towards the point whose
//! error is wanted and its neighbours `separation_deg` around it — long enough for the pod's
//! dwell detection, moving between them on the sphere with linear axes only (the rotary axes
//! are not programmed: the SSM's neighbours share their error only while the rotary axes
//! stand still).
//!
//! **Stations.** P₁ = P₀ + L·û towards the target; the others at `separation_deg` from û in
//! the azimuths 0°, 90° (two neighbours: spec TV-SSM-1's layout, non-coplanar with the socket)
//! or evenly around (three or more). **Moves** follow the great circle between stations in
//! `G1` segments short enough that their chords pass within 1 µm of the sphere (the bar's
//! length stays within 1 µm of L: the LVDT stays in its stroke and the moving samples count for
//! the streaming E). **Dwell**: `G4`, the pod's settling time plus twice its fewest averaged
//! samples at its sample rate (`ssm_settle`, `ssm_min_dwell`, `sample_rate`), rounded up to
//! 0.1 s.

use std::fmt::Write as _;

use ballpod::config::{CirclePlane, Config};

use super::{Dialect, NcError, num};

/// Largest distance of a move's chord inside the sphere, mm.
const CHORD_TOLERANCE_MM: f64 = 1e-3;

/// A station set ready to be written.
#[derive(Clone, Debug, PartialEq)]
pub struct SsmTest {
    /// Socket centre P₀, mm.
    pub socket_mm: [f64; 3],
    /// Bar length L, mm.
    pub bar_mm: f64,
    /// Unit vector from the socket towards the target.
    pub towards: [f64; 3],
    /// Angle of the neighbours from the first station, degrees.
    pub separation_deg: f64,
    /// Stations, the first included (3 … 8).
    pub stations: usize,
    /// Dwell at each station, s.
    pub dwell_s: f64,
    /// Feed between stations, mm/min.
    pub feed_mm_per_min: f64,
}

/// The dwell the pod's dwell detection needs, s: its settling time plus twice its fewest
/// averaged samples at its sample rate, rounded up to 0.1 s (less a rounding residue: 0.1 + 0.2
/// is not 0.3 in binary).
pub(super) fn dwell_s(cfg: &Config) -> f64 {
    let t = &cfg.setup;
    let needed = f64::from(t.ssm_settle_ms) * 1e-3
        + 2.0 * f64::from(t.ssm_min_dwell_samples) / f64::from(cfg.sample_rate_hz);
    (needed * 10.0 - 1e-9).ceil() / 10.0
}

pub(super) fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl SsmTest {
    /// The station set of the set-up in `cfg` (`ssm_socket_*`, `bar_length`, the dwell
    /// detection's fields) towards `target_mm`: the socket set, the target not at it, the
    /// separation in (0, 45]°, 3 … 8 stations, the feed > 0.
    pub fn from_config(
        cfg: &Config,
        target_mm: [f64; 3],
        separation_deg: f64,
        stations: usize,
        feed_mm_per_min: f64,
    ) -> Result<Self, NcError> {
        let t = &cfg.setup;
        let mut socket_mm = [0.0; 3];
        for (k, name) in ["ssm_socket_x", "ssm_socket_y", "ssm_socket_z"]
            .into_iter()
            .enumerate()
        {
            let v = f64::from(t.ssm_socket_mm[k]);
            if !v.is_finite() {
                return Err(NcError {
                    field: name,
                    what: "not set".into(),
                });
            }
            socket_mm[k] = v;
        }
        let d: [f64; 3] = std::array::from_fn(|k| target_mm[k] - socket_mm[k]);
        let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !(dist.is_finite() && dist > 1.0) {
            return Err(NcError {
                field: "--target",
                what: "must be finite and more than 1 mm from the socket".into(),
            });
        }
        if !(separation_deg > 0.0 && separation_deg <= 45.0) {
            return Err(NcError {
                field: "--separation-deg",
                what: format!("{separation_deg}: outside (0, 45]"),
            });
        }
        if !(3..=8).contains(&stations) {
            return Err(NcError {
                field: "--stations",
                what: format!("{stations}: outside [3, 8]"),
            });
        }
        if !(feed_mm_per_min.is_finite() && feed_mm_per_min > 0.0) {
            return Err(NcError {
                field: "--feed",
                what: format!("{feed_mm_per_min} mm/min: must be > 0"),
            });
        }
        Ok(Self {
            socket_mm,
            bar_mm: f64::from(cfg.bar_length_mm),
            towards: unit(d),
            separation_deg,
            stations,
            dwell_s: dwell_s(cfg),
            feed_mm_per_min,
        })
    }

    /// The stations' unit directions from the socket, the first towards the target.
    fn directions(&self) -> Vec<[f64; 3]> {
        let u = self.towards;
        // a tangent basis: the axis least aligned with û, made perpendicular
        let k = (0..3)
            .min_by(|&a, &b| u[a].abs().total_cmp(&u[b].abs()))
            .unwrap_or(0);
        let mut axis = [0.0; 3];
        axis[k] = 1.0;
        let e1 = unit(cross(u, axis));
        let e2 = cross(u, e1);
        let n = self.stations - 1;
        let (s, c) = self.separation_deg.to_radians().sin_cos();
        let mut out = vec![u];
        for j in 0..n {
            let az = if n == 2 {
                [0.0, std::f64::consts::FRAC_PI_2][j]
            } else {
                std::f64::consts::TAU * j as f64 / n as f64
            };
            let t: [f64; 3] = std::array::from_fn(|i| az.cos() * e1[i] + az.sin() * e2[i]);
            out.push(std::array::from_fn(|i| c * u[i] + s * t[i]));
        }
        out
    }

    /// The stations, mm.
    pub fn stations_mm(&self) -> Vec<[f64; 3]> {
        self.directions()
            .into_iter()
            .map(|d| std::array::from_fn(|i| self.socket_mm[i] + self.bar_mm * d[i]))
            .collect()
    }

    /// The points of the move from direction `a` to `b` on the sphere (great circle), `b`
    /// included, `a` not.
    fn path(&self, a: [f64; 3], b: [f64; 3]) -> Vec<[f64; 3]> {
        let dot = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
        let angle = dot.acos();
        // a chord of angle Δ passes L·(1 − cos(Δ/2)) inside the sphere
        let max_step = 2.0 * (1.0 - CHORD_TOLERANCE_MM / self.bar_mm).acos();
        let n = ((angle / max_step).ceil() as usize).max(1);
        (1..=n)
            .map(|k| {
                let f = k as f64 / n as f64;
                // slerp
                let (sa, sb) = if angle > 1e-12 {
                    (
                        ((1.0 - f) * angle).sin() / angle.sin(),
                        (f * angle).sin() / angle.sin(),
                    )
                } else {
                    (1.0 - f, f)
                };
                let d: [f64; 3] = std::array::from_fn(|i| sa * a[i] + sb * b[i]);
                std::array::from_fn(|i| self.socket_mm[i] + self.bar_mm * d[i])
            })
            .collect()
    }

    /// The part program in `dialect`.
    pub fn program(&self, dialect: Dialect) -> String {
        let xyz = |p: [f64; 3]| format!("X{} Y{} Z{}", num(p[0]), num(p[1]), num(p[2]));
        let stations = self.stations_mm();
        let [sx, sy, sz] = self.socket_mm;
        let header = [
            format!(
                "ballpod SSM station set, {} stations {} deg apart on the bar's sphere",
                self.stations,
                num(self.separation_deg)
            ),
            format!(
                "socket X {} Y {} Z {}, bar {} mm; first station towards the target",
                num(sx),
                num(sy),
                num(sz),
                num(self.bar_mm)
            ),
            format!(
                "dwell {} s per station, moves on the sphere within 1 um at F{}, rotary axes not moved",
                num(self.dwell_s),
                num(self.feed_mm_per_min)
            ),
            "pod set-up: pattern SSM, ssm_socket_x/y/z and bar_length as above; arm and start at the first station, stop after the last dwell".to_string(),
        ];
        let mut out = String::new();
        dialect.begin(&mut out, &header);
        let _ = writeln!(out, "{}", dialect.modal(CirclePlane::XY));
        dialect.comment(&mut out, "mount the bar at the first station");
        let _ = writeln!(out, "G0 {}", xyz(stations[0]));
        self.write_stations(&mut out, dialect, [0.0; 3]);
        dialect.end(&mut out);
        out
    }

    /// The station set from its first station (where the machine is): the moves on the sphere
    /// and a dwell at each station, every programmed point `offset_mm` from the station or path
    /// point it makes the tool ball reach.
    pub(super) fn write_stations(&self, out: &mut String, dialect: Dialect, offset_mm: [f64; 3]) {
        let xyz = |p: [f64; 3]| {
            let q: [f64; 3] = std::array::from_fn(|i| p[i] + offset_mm[i]);
            format!("X{} Y{} Z{}", num(q[0]), num(q[1]), num(q[2]))
        };
        let dirs = self.directions();
        let stations = self.stations_mm();
        let mut first_move = true;
        for (k, p) in stations.iter().enumerate() {
            if k > 0 {
                for q in self.path(dirs[k - 1], dirs[k]) {
                    if first_move {
                        let _ = writeln!(out, "G1 {} F{}", xyz(q), num(self.feed_mm_per_min));
                        first_move = false;
                    } else {
                        let _ = writeln!(out, "G1 {}", xyz(q));
                    }
                }
            }
            dialect.comment(out, &format!("station {} {}", k + 1, xyz(*p)));
            let _ = writeln!(out, "{}", dialect.dwell(self.dwell_s));
        }
    }
}

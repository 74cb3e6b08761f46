//! The differences between the controls the programs are written for, in one place. Motion
//! words (G0 G1 G2 G3 with X Y Z and I J K, F in mm/min) are the same RS274 / ISO 6983 in both.

use std::fmt::Write as _;

use ballpod::config::CirclePlane;

/// The control a program is written for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    /// LinuxCNC (RS274/NGC): ends with `M2`; probing `G38.2`; dwell `G4 P` seconds.
    LinuxCnc,
    /// ISO / Fanuc style: `%`, an `O` program number, upper-case comments, `M30`, `%`;
    /// probing `G31` (skip); dwell `G4 X` seconds.
    Fanuc,
}

impl Dialect {
    /// The file extension of its programs.
    pub fn extension(self) -> &'static str {
        match self {
            Self::LinuxCnc => "ngc",
            Self::Fanuc => "nc",
        }
    }

    /// A comment line (parentheses, which a comment must not contain; upper case on a Fanuc:
    /// older controls reject lower-case letters).
    pub fn comment(self, out: &mut String, text: &str) {
        let text: String = text
            .chars()
            .map(|c| if c == '(' || c == ')' { ' ' } else { c })
            .collect();
        let text = match self {
            Self::LinuxCnc => text,
            Self::Fanuc => text.to_ascii_uppercase(),
        };
        let _ = writeln!(out, "({text})");
    }

    /// The program's start: its framing and the header comments.
    pub fn begin(self, out: &mut String, header: &[String]) {
        if self == Self::Fanuc {
            let _ = writeln!(out, "%");
            let _ = writeln!(out, "O1000");
        }
        for h in header {
            self.comment(out, h);
        }
    }

    /// The modal set-up line: mm, absolute, feed per minute, the circle's plane.
    pub fn modal(self, plane: CirclePlane) -> String {
        let g = match plane {
            CirclePlane::XY => "G17",
            CirclePlane::ZX => "G18",
            CirclePlane::YZ => "G19",
        };
        format!("G21 G90 G94 {g}")
    }

    /// The probing move's G-code: LinuxCNC's straight probe (`G38.2`: an error if the probe
    /// does not trip), an ISO/Fanuc control's skip (`G31`).
    pub fn probe_word(self) -> &'static str {
        match self {
            Self::LinuxCnc => "G38.2",
            Self::Fanuc => "G31",
        }
    }

    /// A dwell of `seconds`: LinuxCNC's `G4 P` takes seconds, an ISO/Fanuc control's `G4 P`
    /// milliseconds, so there the seconds go in `X` (with the decimal point).
    pub fn dwell(self, seconds: f64) -> String {
        match self {
            Self::LinuxCnc => format!("G4 P{}", super::num(seconds)),
            Self::Fanuc => format!("G4 X{}", super::num(seconds)),
        }
    }

    /// The program's end.
    pub fn end(self, out: &mut String) {
        match self {
            Self::LinuxCnc => {
                let _ = writeln!(out, "M2");
            }
            Self::Fanuc => {
                let _ = writeln!(out, "M30");
                let _ = writeln!(out, "%");
            }
        }
    }
}

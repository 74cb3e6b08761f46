//! The command tree: a program message's header resolved to a [`Command`] (IEEE 488.2 common
//! commands, the SCPI subsystems, the configuration fields by name), the forms each accepts,
//! and the numeric and keyword parameters.

use super::parse::{Mnemonic, character, keyword};
use super::status::{ScpiError, code};
use crate::acquisition::MAX_AXES;
use crate::config::{AxisName, FIELDS, Field, FieldInfo};

/// Axis names with their SCPI forms.
pub(super) const AXIS_NAMES: [(AxisName, &str); 7] = [
    (AxisName::X, "X"),
    (AxisName::Y, "Y"),
    (AxisName::Z, "Z"),
    (AxisName::A, "A"),
    (AxisName::B, "B"),
    (AxisName::C, "C"),
    (AxisName::Unused, "NONE"),
];

/// A resolved command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Command {
    Idn,
    Rst,
    Cls,
    Opc,
    Wai,
    Esr,
    Ese,
    Sre,
    Stb,
    Sav,
    SystErr,
    SystVersion,
    SystCount,
    SystBootloader,
    ConfUnlock,
    ConfLock,
    ConfField(Field, &'static FieldInfo),
    ConfAxisName(usize),
    AxisPosition(usize),
    SessPattern,
    SessDirection,
    SessArm,
    SessStart,
    SessStop,
    SessAbort,
    SessClear,
    SessState,
    SessReason,
    SessCount,
    SessNote,
    StatPod,
    MeasDl,
    MeasAll,
    MeasValid,
    FetchResult,
    FetchBudget,
    FetchCatalog,
    FetchTouch,
    FetchTouchCount,
    DataLogCount,
    DataLog,
}

/// What a command accepts: query form, set form.
pub(super) const fn forms(c: Command) -> (bool, bool) {
    use Command::*;
    match c {
        Idn | Esr | Stb | SystErr | SystVersion | SystCount | SessState | SessReason
        | SessCount | SessNote | StatPod | MeasDl | MeasAll | MeasValid | FetchResult
        | FetchBudget | FetchCatalog | FetchTouch | FetchTouchCount | DataLogCount | DataLog => {
            (true, false)
        }
        Rst | Cls | Wai | Sav | SystBootloader | ConfUnlock | SessArm | SessStart | SessStop
        | SessAbort | SessClear => (false, true),
        Opc | Ese | Sre | ConfLock | ConfField(..) | ConfAxisName(_) | AxisPosition(_)
        | SessPattern | SessDirection => (true, true),
    }
}

pub(super) fn common(name: &[u8]) -> Option<Command> {
    const TABLE: [(&str, Command); 10] = [
        ("IDN", Command::Idn),
        ("RST", Command::Rst),
        ("CLS", Command::Cls),
        ("OPC", Command::Opc),
        ("WAI", Command::Wai),
        ("ESR", Command::Esr),
        ("ESE", Command::Ese),
        ("SRE", Command::Sre),
        ("STB", Command::Stb),
        ("SAV", Command::Sav),
    ];
    TABLE
        .iter()
        .find(|(n, _)| name.eq_ignore_ascii_case(n.as_bytes()))
        .map(|&(_, c)| c)
}

/// True for the fields that take a numeric suffix (an index).
pub(super) const fn indexed(f: Field) -> bool {
    matches!(
        f,
        Field::LvdtPolyUm(_) | Field::AxisCountsPerUnit(_) | Field::AxisMaxSpeed(_)
    )
}

/// `CONFigure:<field>[<k>]`: a [`FIELDS`] entry by name (case-insensitive).
pub(super) fn config_field(m: &Mnemonic<'_>) -> Result<Command, ScpiError> {
    if let Some(info) = FIELDS
        .iter()
        .find(|i| !indexed(i.field) && m.text.eq_ignore_ascii_case(i.name.as_bytes()))
    {
        return Ok(Command::ConfField(info.field, info));
    }
    let info = FIELDS
        .iter()
        .find(|i| indexed(i.field) && m.name.eq_ignore_ascii_case(i.name.as_bytes()))
        .ok_or(ScpiError::new(code::UNDEFINED_HEADER))?;
    let k = m.suffix.unwrap_or(1);
    let out_of_range = ScpiError::with(code::HEADER_SUFFIX_OUT_OF_RANGE, info.name);
    let field = match info.field {
        Field::LvdtPolyUm(_) if k <= 3 => Field::LvdtPolyUm(k as u8),
        Field::AxisCountsPerUnit(_) if (1..=MAX_AXES as u32).contains(&k) => {
            Field::AxisCountsPerUnit((k - 1) as u8)
        }
        Field::AxisMaxSpeed(_) if (1..=MAX_AXES as u32).contains(&k) => {
            Field::AxisMaxSpeed((k - 1) as u8)
        }
        _ => return Err(out_of_range),
    };
    Ok(Command::ConfField(field, info))
}

/// The encoder input (0-based) of an `AXIS<n>` node, n = 1 … [`MAX_AXES`].
pub(super) fn axis_input(a: &Mnemonic<'_>) -> Result<usize, ScpiError> {
    let k = a.suffix.unwrap_or(1);
    if !(1..=MAX_AXES as u32).contains(&k) {
        return Err(ScpiError::with(code::HEADER_SUFFIX_OUT_OF_RANGE, "AXIS"));
    }
    Ok((k - 1) as usize)
}

/// Resolves a compound header path (SCPI-99 Vol 1 §6: `[...]` nodes optional).
pub(super) fn resolve(path: &[Mnemonic<'_>]) -> Result<Command, ScpiError> {
    let undefined = ScpiError::new(code::UNDEFINED_HEADER);
    Ok(match path {
        [s, e] if s.is("SYSTem") && e.is("ERRor") => Command::SystErr,
        [s, e, n] if s.is("SYSTem") && e.is("ERRor") && n.is("NEXT") => Command::SystErr,
        [s, v] if s.is("SYSTem") && v.is("VERSion") => Command::SystVersion,
        [s, c] if s.is("SYSTem") && c.is("COUNt") => Command::SystCount,
        [s, b] if s.is("SYSTem") && b.is("BOOTloader") => Command::SystBootloader,
        [c, a, n] if c.is("CONFigure") && a.is_with_suffix("AXIS") && n.is("NAME") => {
            Command::ConfAxisName(axis_input(a)?)
        }
        [a, p] if a.is_with_suffix("AXIS") && p.is("POSition") => {
            Command::AxisPosition(axis_input(a)?)
        }
        [c, u] if c.is("CONFigure") && u.is("UNLock") => Command::ConfUnlock,
        [c, l] if c.is("CONFigure") && l.is("LOCK") => Command::ConfLock,
        [c, f] if c.is("CONFigure") => config_field(f)?,
        [s, x] if s.is("SESSion") => {
            const SESSION: [(&str, Command); 11] = [
                ("PATTern", Command::SessPattern),
                ("DIRection", Command::SessDirection),
                ("ARM", Command::SessArm),
                ("STARt", Command::SessStart),
                ("STOP", Command::SessStop),
                ("ABORt", Command::SessAbort),
                ("CLEar", Command::SessClear),
                ("STATe", Command::SessState),
                ("REASon", Command::SessReason),
                ("COUNt", Command::SessCount),
                ("NOTE", Command::SessNote),
            ];
            SESSION
                .iter()
                .find(|(f, _)| x.is(f))
                .map(|&(_, c)| c)
                .ok_or(undefined)?
        }
        [s, p] if s.is("STATus") && p.is("POD") => Command::StatPod,
        [m, x] if m.is("MEASure") && x.is("DL") => Command::MeasDl,
        [m, x] if m.is("MEASure") && x.is("ALL") => Command::MeasAll,
        [m, x] if m.is("MEASure") && x.is("VALid") => Command::MeasValid,
        [f, r] if f.is("FETCh") && r.is("RESult") => Command::FetchResult,
        [f, r, c] if f.is("FETCh") && r.is("RESult") && c.is("CATalog") => Command::FetchCatalog,
        [f, r, b] if f.is("FETCh") && r.is("RESult") && b.is("BUDGet") => Command::FetchBudget,
        [f, t] if f.is("FETCh") && t.is("TOUCh") => Command::FetchTouch,
        [f, t, c] if f.is("FETCh") && t.is("TOUCh") && c.is("COUNt") => Command::FetchTouchCount,
        [d, l] if d.is("DATA") && l.is("LOG") => Command::DataLog,
        [d, l, c] if d.is("DATA") && l.is("LOG") && c.is("COUNt") => Command::DataLogCount,
        _ => return Err(undefined),
    })
}

/// A parameter as decimal numeric program data (IEEE 488.2 §7.7.2).
pub(super) fn numeric(p: &[u8]) -> Result<f64, ScpiError> {
    match p.first() {
        Some(b'0'..=b'9' | b'+' | b'-' | b'.') => super::number::parse_decimal(p).map_err(|e| {
            ScpiError::new(match e {
                super::number::NumberError::InvalidCharacter => code::INVALID_CHARACTER_IN_NUMBER,
                super::number::NumberError::ExponentTooLarge => code::EXPONENT_TOO_LARGE,
                super::number::NumberError::TooManyDigits => code::TOO_MANY_DIGITS,
                super::number::NumberError::Suffix => code::INVALID_SUFFIX,
            })
        }),
        _ => Err(ScpiError::new(code::DATA_TYPE_ERROR)),
    }
}

/// A numeric parameter that may also be `MINimum`, `MAXimum` or `DEFault` (SCPI-99 Vol 1
/// §7.2.1.1).
/// True for the keywords a numeric parameter may take instead of a number (SCPI-99 §7.2.1).
pub(super) fn is_keyword_value(k: &[u8]) -> bool {
    keyword(k, "MINimum") || keyword(k, "MAXimum") || keyword(k, "DEFault")
}

pub(super) fn numeric_or_keyword(
    p: &[u8],
    min: f64,
    max: f64,
    default: f64,
) -> Result<f64, ScpiError> {
    if p.first().is_some_and(|c| c.is_ascii_alphabetic()) {
        let k = character(p)?;
        return if keyword(k, "MINimum") {
            Ok(min)
        } else if keyword(k, "MAXimum") {
            Ok(max)
        } else if keyword(k, "DEFault") {
            Ok(default)
        } else {
            Err(ScpiError::new(code::DATA_TYPE_ERROR))
        };
    }
    numeric(p)
}

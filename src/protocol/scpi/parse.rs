//! Lexical layer: a program message line → message units → header + parameter tokens
//! (IEEE 488.2 §7: program message syntax).

use super::status::{ScpiError, code};

/// Most mnemonics in one header (`CONFigure:AXIS<n>:NAME` has three).
pub const MAX_DEPTH: usize = 4;
/// Most parameters in one message unit.
pub const MAX_PARAMS: usize = 4;

/// One program mnemonic of a header (IEEE 488.2 §7.6.1.2), split into its name and numeric
/// suffix (SCPI-99 Vol 1 §6.2.5.2: `AXIS3` → `AXIS`, 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mnemonic<'a> {
    /// The whole mnemonic as sent (`NTC_R25`, `AXIS3`).
    pub text: &'a [u8],
    /// Without the trailing digits (`NTC_R`, `AXIS`).
    pub name: &'a [u8],
    /// The trailing digits as a number, if any.
    pub suffix: Option<u32>,
}

impl<'a> Mnemonic<'a> {
    fn new(text: &'a [u8]) -> Self {
        let digits = text.iter().rev().take_while(|c| c.is_ascii_digit()).count();
        let split = text.len() - digits;
        let name = text.get(..split).unwrap_or(text);
        let suffix = if digits == 0 {
            None
        } else {
            text.get(split..).map(|d| {
                d.iter().fold(0u32, |n, &c| {
                    n.saturating_mul(10).saturating_add(u32::from(c - b'0'))
                })
            })
        };
        Self { text, name, suffix }
    }

    /// True if this mnemonic, without a suffix, is the short or long form of `form`, written
    /// SCPI style (`SYSTem`: short form = the upper-case letters, long form = all of it),
    /// compared case-insensitively (IEEE 488.2 §7.6.1.3, SCPI-99 Vol 1 §6.2.1).
    pub fn is(&self, form: &str) -> bool {
        self.suffix.is_none() && keyword(self.text, form)
    }

    /// Like [`is`](Self::is) but on the name without its numeric suffix.
    pub fn is_with_suffix(&self, form: &str) -> bool {
        keyword(self.name, form)
    }
}

/// True if `text` is the short or long form of the SCPI-cased `form`, ignoring case.
pub fn keyword(text: &[u8], form: &str) -> bool {
    let f = form.as_bytes();
    let short_len = f.iter().take_while(|c| !c.is_ascii_lowercase()).count();
    let short = f.get(..short_len).unwrap_or(f);
    text.eq_ignore_ascii_case(f) || text.eq_ignore_ascii_case(short)
}

/// A parsed command program header.
#[derive(Clone, Debug)]
pub struct Header<'a> {
    /// A common command (`*IDN?`): its name without the star.
    pub common: Option<&'a [u8]>,
    /// The mnemonics of a compound header.
    pub path: heapless::Vec<Mnemonic<'a>, MAX_DEPTH>,
    /// Starts with `:` (from the root).
    pub absolute: bool,
    /// Ends with `?`.
    pub query: bool,
}

fn is_mnemonic_char(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// Splits a message unit into its header and the parameter text after the header separator.
pub fn header(unit: &[u8]) -> Result<(Header<'_>, &[u8]), ScpiError> {
    let mut h = Header {
        common: None,
        path: heapless::Vec::new(),
        absolute: false,
        query: false,
    };
    let mut pos = 0usize;
    let at = |p: usize| unit.get(p).copied();
    if at(0) == Some(b'*') {
        pos = 1;
        let len = unit
            .iter()
            .skip(1)
            .take_while(|c| c.is_ascii_alphabetic())
            .count();
        if len == 0 {
            return Err(ScpiError::new(code::SYNTAX_ERROR));
        }
        h.common = unit.get(1..1 + len);
        pos += len;
    } else {
        if at(0) == Some(b':') {
            h.absolute = true;
            pos = 1;
        }
        loop {
            match at(pos) {
                Some(c) if c.is_ascii_alphabetic() => {}
                Some(c) if !c.is_ascii() => return Err(ScpiError::new(code::INVALID_CHARACTER)),
                _ => return Err(ScpiError::new(code::SYNTAX_ERROR)),
            }
            let len = unit
                .iter()
                .skip(pos)
                .take_while(|&&c| is_mnemonic_char(c))
                .count();
            let text = unit.get(pos..pos + len).unwrap_or_default();
            if h.path.push(Mnemonic::new(text)).is_err() {
                return Err(ScpiError::new(code::UNDEFINED_HEADER));
            }
            pos += len;
            if at(pos) == Some(b':') {
                pos += 1;
            } else {
                break;
            }
        }
    }
    if at(pos) == Some(b'?') {
        h.query = true;
        pos += 1;
    }
    match at(pos) {
        None => Ok((h, &[])),
        Some(b' ' | b'\t') => Ok((h, unit.get(pos..).unwrap_or_default().trim_ascii())),
        Some(c) if !c.is_ascii() || c.is_ascii_control() => {
            Err(ScpiError::new(code::INVALID_CHARACTER))
        }
        Some(_) => Err(ScpiError::new(code::SYNTAX_ERROR)),
    }
}

/// Splits `text` at `sep` outside quoted strings (`'…'` or `"…"`, IEEE 488.2 §7.7.5).
/// Calls `each` with every piece, trimmed; stops at the first error it returns.
pub fn split<'a, E>(
    text: &'a [u8],
    sep: u8,
    mut each: impl FnMut(&'a [u8]) -> Result<(), E>,
) -> Result<(), E> {
    let mut quote: Option<u8> = None;
    let mut start = 0usize;
    for (i, &c) in text.iter().enumerate() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == b'"' || c == b'\'' => quote = Some(c),
            None if c == sep => {
                each(text.get(start..i).unwrap_or_default().trim_ascii())?;
                start = i + 1;
            }
            None => {}
        }
    }
    each(text.get(start..).unwrap_or_default().trim_ascii())
}

/// The parameter tokens of a message unit (IEEE 488.2 §7.4.1: separated by commas).
pub fn params(text: &[u8]) -> Result<heapless::Vec<&[u8], MAX_PARAMS>, ScpiError> {
    let mut v = heapless::Vec::new();
    if text.is_empty() {
        return Ok(v);
    }
    split(text, b',', |p| {
        if p.is_empty() {
            return Err(ScpiError::new(code::MISSING_PARAMETER));
        }
        v.push(p)
            .map_err(|_| ScpiError::new(code::PARAMETER_NOT_ALLOWED))
    })?;
    Ok(v)
}

/// A parameter as character program data (IEEE 488.2 §7.7.1: a letter, then letters, digits
/// or `_`).
pub fn character(p: &[u8]) -> Result<&[u8], ScpiError> {
    match p.first() {
        Some(c) if c.is_ascii_alphabetic() => {
            if p.iter().all(|&c| is_mnemonic_char(c)) {
                Ok(p)
            } else {
                Err(ScpiError::new(code::INVALID_CHARACTER_DATA))
            }
        }
        Some(b'"' | b'\'') => Err(ScpiError::new(code::STRING_DATA_NOT_ALLOWED)),
        Some(b'#') => Err(ScpiError::new(code::BLOCK_DATA_NOT_ALLOWED)),
        _ => Err(ScpiError::new(code::DATA_TYPE_ERROR)),
    }
}

//! Carrying out one program message: each unit resolved ([`super::commands`]), checked
//! against its forms and the lock, set or queried on the [`App`], answered in IEEE 488.2
//! forms; a refusal becomes its SCPI error.

use super::number::{SCPI_NAN, Text, push_bytes, push_fixed, push_i64, push_significant, push_u64};
use super::parse::{Header, MAX_DEPTH, Mnemonic, character, keyword};
use super::status::{ScpiError, code, esr};
use crate::app::device::NOT_MEASURED;
use crate::app::{
    Command as AppCommand, CommandError, Direction, LIVE, Pattern, RESULT_COUNT, ResultId,
    ResultInfo, StatusWord,
};
use crate::config::{AxisName, Config, ConfigError, Field};
use crate::protocol::download::{CsvCursor, csv_len, write_csv};

use super::commands::*;
use super::{Download, Exec, IDN_MAKER_MODEL, IDN_VERSION, RESPONSE_DECIMALS, Response};

/// Appends the header of an IEEE 488.2 §8.7.9 definite length arbitrary block of `len` bytes:
/// `#`, the number of length digits, the length.
pub(super) fn push_block_header<const C: usize>(r: &mut Text<C>, len: usize) {
    let mut digits: Text<24> = Text::new();
    push_u64(&mut digits, len as u64);
    push_bytes(r, b"#");
    push_u64(r, digits.len() as u64);
    push_bytes(r, &digits);
}

/// Appends counters comma-separated; with `device`, a figure not measured ([`NOT_MEASURED`])
/// as NaN.
pub(super) fn push_counters<const C: usize>(r: &mut Text<C>, values: &[u32], device: bool) {
    for (k, &v) in values.iter().enumerate() {
        if k > 0 {
            push_bytes(r, b",");
        }
        if device && v == NOT_MEASURED {
            push_bytes(r, SCPI_NAN);
        } else {
            push_u64(r, u64::from(v));
        }
    }
}

/// The SCPI error of a command the application refused: a value out of its field's range → -222
/// naming the field; anything else (state, geometry not set, a change while a run is armed or
/// running, a cross-field rule) → -221 with the application's reason.
pub(super) fn refusal(e: CommandError) -> ScpiError {
    let (detail, suffix) = e.text();
    let code = match e {
        CommandError::Config(ConfigError::OutOfRange {
            field: Field::PeriodsPerSample | Field::AxisCounterReach(_),
            ..
        }) => code::SETTINGS_CONFLICT,
        CommandError::Config(ConfigError::OutOfRange { .. }) => code::DATA_OUT_OF_RANGE,
        _ => code::SETTINGS_CONFLICT,
    };
    ScpiError::with_suffix(code, detail, suffix)
}

impl<F: FnMut(&[u8]), const N: usize> Exec<'_, F, N> {
    /// Sends the rest of a pulled download through `out` (more input arrived first).
    pub(super) fn finish_download(&mut self) {
        if let Some(mut d) = self.download.take() {
            if let Some((_, _, separate)) = d.counting {
                // input arrived while the length was still being counted: the whole block now
                d.header.clear();
                if separate {
                    push_bytes(&mut d.header, b";");
                }
                push_block_header(&mut d.header, csv_len(self.log, &d.meta));
            }
            (self.out)(d.header.get(d.header_sent..).unwrap_or(&[]));
            let out = &mut *self.out;
            while d.cursor.next_line(self.log, &d.meta, &mut |l| out(l)) {}
            out(b"\n");
        }
    }

    /// Executes one program message (IEEE 488.2 §7.3: units separated by `;`).
    pub(super) fn line(&mut self, line: &[u8]) {
        self.responded = false;
        // The path of the previous compound command, for relative headers (SCPI-99 Vol 1 §6.2.4).
        let mut prefix: heapless::Vec<Mnemonic<'_>, MAX_DEPTH> = heapless::Vec::new();
        let _ = super::parse::split(line, b';', |unit| {
            if unit.is_empty() {
                return Ok(());
            }
            if self.download.is_some() {
                // Pull mode: the log block must be the last response of its message.
                self.status.push(ScpiError::with(
                    code::QUERY_AFTER_BLOCK,
                    "DATA:LOG? must end its line",
                ));
                return Err(());
            }
            match self.unit(unit, &mut prefix) {
                Ok(()) => Ok(()),
                Err(e) => {
                    self.status.push(e);
                    // A command error leaves the rest of the message unparseable: drop it.
                    if (-199..=-100).contains(&e.code) {
                        Err(())
                    } else {
                        Ok(())
                    }
                }
            }
        });
        if self.responded && self.download.is_none() {
            (self.out)(b"\n");
        }
    }

    /// Executes one message unit.
    fn unit<'l>(
        &mut self,
        unit: &'l [u8],
        prefix: &mut heapless::Vec<Mnemonic<'l>, MAX_DEPTH>,
    ) -> Result<(), ScpiError> {
        let (h, param_text) = super::parse::header(unit)?;
        let params = super::parse::params(param_text)?;
        let cmd = match h.common {
            Some(name) => common(name).ok_or(ScpiError::new(code::UNDEFINED_HEADER))?,
            None => self.resolve_path(&h, prefix)?,
        };
        let (query_ok, set_ok) = forms(cmd);
        if (h.query && !query_ok) || (!h.query && !set_ok) {
            return Err(ScpiError::new(code::UNDEFINED_HEADER));
        }
        if h.query {
            self.query(cmd, &params)
        } else {
            self.set(cmd, &params)
        }
    }

    /// Resolves a compound header, relative to `prefix` unless it starts with `:`; a relative
    /// header that does not resolve is tried from the root too (lenient, as most instruments).
    fn resolve_path<'l>(
        &self,
        h: &Header<'l>,
        prefix: &mut heapless::Vec<Mnemonic<'l>, MAX_DEPTH>,
    ) -> Result<Command, ScpiError> {
        let mut full: heapless::Vec<Mnemonic<'l>, { 2 * MAX_DEPTH }> = heapless::Vec::new();
        let mut cmd = Err(ScpiError::new(code::UNDEFINED_HEADER));
        if !h.absolute && !prefix.is_empty() {
            let _ = full.extend_from_slice(prefix);
            let _ = full.extend_from_slice(&h.path);
            cmd = resolve(&full);
        }
        if cmd.is_err() {
            full.clear();
            let _ = full.extend_from_slice(&h.path);
            cmd = resolve(&full);
        }
        let cmd = cmd?;
        prefix.clear();
        if let Some((_, parents)) = full.split_last() {
            for m in parents.iter().take(MAX_DEPTH) {
                let _ = prefix.push(*m);
            }
        }
        Ok(cmd)
    }

    /// Starts a response unit (IEEE 488.2 §8.4.1: units separated by `;`).
    fn respond(&mut self, r: &[u8]) {
        if self.responded {
            (self.out)(b";");
        }
        (self.out)(r);
        self.responded = true;
    }

    /// Hands a session command to the application.
    fn act(&mut self, c: AppCommand) -> Result<(), ScpiError> {
        self.app.execute(c).map_err(refusal)
    }

    /// Rejects configuration writes unless this port was unlocked.
    fn unlocked_for(&self, what: &'static str) -> Result<(), ScpiError> {
        if *self.config_unlocked {
            Ok(())
        } else {
            Err(ScpiError::with(code::COMMAND_PROTECTED, what))
        }
    }

    fn set(&mut self, cmd: Command, p: &[&[u8]]) -> Result<(), ScpiError> {
        let arg = |n: usize| -> Result<&[u8], ScpiError> {
            match p.len() {
                l if l < n + 1 => Err(ScpiError::new(code::MISSING_PARAMETER)),
                l if l > n + 1 => Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                _ => p
                    .get(n)
                    .copied()
                    .ok_or(ScpiError::new(code::MISSING_PARAMETER)),
            }
        };
        let none = || {
            if p.is_empty() {
                Ok(())
            } else {
                Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED))
            }
        };
        match cmd {
            Command::Rst => {
                // IEEE 488.2 §10.32: device reset; the status registers and the queue stay.
                none()?;
                self.act(AppCommand::Reset)?;
                *self.config_unlocked = false;
            }
            Command::Cls => {
                none()?;
                self.status.clear();
            }
            Command::Opc => {
                // Every command completes before the next is parsed (IEEE 488.2 §12.5.2).
                none()?;
                self.status.esr |= esr::OPC;
            }
            Command::Wai => none()?,
            Command::Ese | Command::Sre => {
                let v = numeric(arg(0)?)?;
                if !(-0.5..255.5).contains(&v) {
                    return Err(ScpiError::new(code::DATA_OUT_OF_RANGE));
                }
                let b = libm::round(v) as u8;
                if cmd == Command::Ese {
                    self.status.ese = b;
                } else {
                    self.status.sre = b & !super::status::stb::MSS;
                }
            }
            Command::Sav => {
                let v = numeric(arg(0)?)?;
                if v != 0.0 {
                    return Err(ScpiError::with(code::DATA_OUT_OF_RANGE, "one register: 0"));
                }
                self.unlocked_for("*SAV: CONF:UNL first")?;
                self.act(AppCommand::StoreSettings)?;
            }
            Command::SystBootloader => {
                none()?;
                self.unlocked_for("SYST:BOOT: CONF:UNL first")?;
                self.app.request_bootloader().map_err(refusal)?;
            }
            Command::ConfUnlock => {
                none()?;
                *self.config_unlocked = true;
            }
            Command::ConfLock => {
                none()?;
                *self.config_unlocked = false;
            }
            Command::ConfField(field, info) => {
                self.unlocked_for("CONF:UNL first")?;
                let a = arg(0)?;
                let choice = match character(a) {
                    // a code field given by name: one of its choices, else -224 (a number
                    // is taken as the code itself below)
                    Ok(name) if !info.choices().is_empty() && !is_keyword_value(name) => {
                        Some(info.choice(name).map(f64::from).ok_or(ScpiError {
                            code: code::ILLEGAL_PARAMETER_VALUE,
                            detail: crate::app::field_name(field),
                            suffix: ": unknown code name",
                        })?)
                    }
                    _ => None,
                };
                let v = match choice {
                    Some(v) => v,
                    None => {
                        let default = Config::default().field_value(field).unwrap_or(info.min);
                        numeric_or_keyword(a, info.min, info.max, default)?
                    }
                };
                if v.is_nan() {
                    // A set-up field's default is "not set": as over CANopen, only restoring
                    // the defaults clears it (src/config.rs, `FieldInfo::optional`).
                    return Err(ScpiError {
                        code: code::ILLEGAL_PARAMETER_VALUE,
                        detail: crate::app::field_name(field),
                        suffix: " has no default (restoring the defaults clears it)",
                    });
                }
                self.app.set_field(field, v).map_err(refusal)?;
            }
            Command::AxisPosition(i) => {
                let v = numeric(arg(0)?)?;
                if !(v.abs() <= crate::config::POS_MM) {
                    return Err(ScpiError::with(
                        code::DATA_OUT_OF_RANGE,
                        "axis position out of range",
                    ));
                }
                self.app.reference_axis(i, v).map_err(refusal)?;
            }
            Command::ConfAxisName(i) => {
                self.unlocked_for("CONF:UNL first")?;
                let k = character(arg(0)?)?;
                let name = AXIS_NAMES
                    .iter()
                    .find(|(_, f)| keyword(k, f))
                    .map(|&(n, _)| n)
                    .ok_or(ScpiError::with(
                        code::ILLEGAL_PARAMETER_VALUE,
                        "X|Y|Z|A|B|C|NONE",
                    ))?;
                self.app
                    .configure(|c| {
                        if let Some(a) = c.axes.get_mut(i) {
                            a.name = name;
                        }
                    })
                    .map_err(refusal)?;
            }
            Command::SessPattern => {
                let k = character(arg(0)?)?;
                let pattern = Pattern::from_name(k).ok_or(ScpiError::with(
                    code::ILLEGAL_PARAMETER_VALUE,
                    "CIRCLE|BX|BY|CR|CA|CR2|SSM|PROBE",
                ))?;
                self.app.set_pattern(pattern).map_err(refusal)?;
            }
            Command::SessDirection => {
                let k = character(arg(0)?)?;
                let direction = Direction::from_name(k)
                    .ok_or(ScpiError::with(code::ILLEGAL_PARAMETER_VALUE, "CW|CCW"))?;
                self.app.set_direction(direction).map_err(refusal)?;
            }
            Command::SessArm
            | Command::SessStart
            | Command::SessStop
            | Command::SessAbort
            | Command::SessClear => {
                none()?;
                self.act(match cmd {
                    Command::SessArm => AppCommand::Arm,
                    Command::SessStart => AppCommand::Start,
                    Command::SessStop => AppCommand::Stop,
                    Command::SessAbort => AppCommand::Abort,
                    _ => AppCommand::Clear,
                })?;
            }
            _ => return Err(ScpiError::new(code::UNDEFINED_HEADER)),
        }
        Ok(())
    }

    fn query(&mut self, cmd: Command, p: &[&[u8]]) -> Result<(), ScpiError> {
        let mut r = Response::new();
        let none = || {
            if p.is_empty() {
                Ok(())
            } else {
                Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED))
            }
        };
        let fixed = |r: &mut Response, v: f32| {
            push_fixed(r, f64::from(v), RESPONSE_DECIMALS, false, SCPI_NAN)
        };
        match cmd {
            Command::Idn => {
                none()?;
                push_bytes(&mut r, IDN_MAKER_MODEL.as_bytes());
                if self.serial == 0 {
                    push_bytes(&mut r, b"0");
                } else {
                    push_bytes(&mut r, &crate::num::hex8(self.serial));
                }
                push_bytes(&mut r, b",");
                push_bytes(&mut r, IDN_VERSION.as_bytes());
            }
            Command::Opc => {
                none()?;
                push_bytes(&mut r, b"1");
            }
            Command::Esr => {
                // IEEE 488.2 §10.12: read and clear.
                none()?;
                push_u64(&mut r, u64::from(self.status.esr));
                self.status.esr = 0;
            }
            Command::Ese => {
                none()?;
                push_u64(&mut r, u64::from(self.status.ese));
            }
            Command::Sre => {
                none()?;
                push_u64(&mut r, u64::from(self.status.sre));
            }
            Command::Stb => {
                none()?;
                push_u64(&mut r, u64::from(self.status.status_byte()));
            }
            Command::SystErr => {
                none()?;
                let e = self.status.pop();
                push_i64(&mut r, i64::from(e.code));
                push_bytes(&mut r, b",\"");
                push_bytes(&mut r, e.message().as_bytes());
                if !e.detail.is_empty() {
                    push_bytes(&mut r, b";");
                    push_bytes(&mut r, e.detail.as_bytes());
                    push_bytes(&mut r, e.suffix.as_bytes());
                }
                push_bytes(&mut r, b"\"");
            }
            Command::SystVersion => {
                none()?;
                push_bytes(&mut r, b"1999.0");
            }
            Command::ConfLock => {
                none()?;
                push_bytes(&mut r, if *self.config_unlocked { b"0" } else { b"1" });
            }
            Command::ConfField(field, info) => {
                let v = match p {
                    [] => self.app.config().field_value(field),
                    [k] => {
                        let k = character(k)?;
                        if keyword(k, "MINimum") {
                            Some(info.min)
                        } else if keyword(k, "MAXimum") {
                            Some(info.max)
                        } else if keyword(k, "DEFault") {
                            Config::default().field_value(field)
                        } else {
                            return Err(ScpiError::new(code::ILLEGAL_PARAMETER_VALUE));
                        }
                    }
                    _ => return Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                };
                let v = v.unwrap_or(f64::NAN);
                match info.choices().get(v as usize).filter(|_| v >= 0.0) {
                    // a code field answers its code's name
                    Some(name) => {
                        push_bytes(&mut r, name.as_bytes());
                    }
                    None => {
                        // f32 fields as typed (7 digits); the f64 encoder scale with 15; a
                        // set-up field that is not set answers 9.91E+37 (SCPI NaN)
                        let digits = if matches!(field, Field::AxisCountsPerUnit(_)) {
                            15
                        } else {
                            7
                        };
                        push_significant(&mut r, v, digits, SCPI_NAN);
                    }
                }
            }
            Command::ConfAxisName(i) => {
                none()?;
                let name = self
                    .app
                    .config()
                    .axes
                    .get(i)
                    .map_or(AxisName::Unused, |a| a.name);
                let form = AXIS_NAMES
                    .iter()
                    .find(|(n, _)| *n == name)
                    .map_or("NONE", |&(_, f)| f);
                push_bytes(&mut r, form.as_bytes());
            }
            Command::SessPattern => {
                none()?;
                push_bytes(&mut r, self.app.pattern().name().as_bytes());
            }
            Command::SessDirection => {
                none()?;
                push_bytes(&mut r, self.app.direction().name().as_bytes());
            }
            Command::SessState => {
                none()?;
                push_bytes(&mut r, self.app.session().name().as_bytes());
            }
            Command::SessReason => {
                none()?;
                let name = self.app.abort_reason().map_or("NONE", |a| a.name());
                push_bytes(&mut r, name.as_bytes());
            }
            Command::SessNote => {
                // what the last procedure step could not do, quoted (empty: nothing)
                none()?;
                let (a, b) = self.app.procedure_note().map_or(("", ""), |e| e.text());
                push_bytes(&mut r, b"\"");
                push_bytes(&mut r, a.as_bytes());
                push_bytes(&mut r, b.as_bytes());
                push_bytes(&mut r, b"\"");
            }
            Command::SessCount => {
                none()?;
                push_counters(&mut r, &self.app.run_counters().as_array(), false);
            }
            Command::SystCount => {
                none()?;
                push_counters(&mut r, &self.app.device_counters().0, true);
            }
            Command::StatPod => {
                none()?;
                let mut w = self.app.live().status.0;
                if !self.status.is_empty() {
                    w |= StatusWord::ERROR;
                }
                push_u64(&mut r, u64::from(w));
            }
            Command::AxisPosition(i) => {
                none()?;
                fixed(&mut r, self.app.axis_position(i).unwrap_or(f32::NAN));
            }
            Command::MeasDl => {
                none()?;
                fixed(
                    &mut r,
                    self.app
                        .live()
                        .get(crate::app::Live::DeltaL)
                        .unwrap_or(f32::NAN),
                );
            }
            Command::MeasAll => {
                // invalid values (bit clear in the mask) read 9.91E+37, SCPI's NaN
                none()?;
                let l = self.app.live();
                push_u64(&mut r, u64::from(l.sample_counter));
                for v in l.values {
                    push_bytes(&mut r, b",");
                    fixed(&mut r, v);
                }
                push_bytes(&mut r, b",");
                push_u64(&mut r, u64::from(l.status.0));
                push_bytes(&mut r, b",");
                push_u64(&mut r, u64::from(l.valid));
            }
            Command::MeasValid => {
                // the names of the valid live values, quoted
                none()?;
                let l = self.app.live();
                let mut first = true;
                for (k, (name, _)) in LIVE.iter().enumerate() {
                    if l.valid & (1 << k) != 0 {
                        if !first {
                            push_bytes(&mut r, b",");
                        }
                        first = false;
                        push_bytes(&mut r, b"\"");
                        push_bytes(&mut r, name.as_bytes());
                        push_bytes(&mut r, b"\"");
                    }
                }
            }
            Command::FetchResult | Command::FetchBudget => {
                let arg = match p {
                    [] => return Err(ScpiError::new(code::MISSING_PARAMETER)),
                    [a] => *a,
                    _ => return Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                };
                let id = if arg.first().is_some_and(|c| c.is_ascii_alphabetic()) {
                    ResultId::from_name(character(arg)?).ok_or(ScpiError::with(
                        code::ILLEGAL_PARAMETER_VALUE,
                        "result name (FETC:RES:CAT?)",
                    ))?
                } else {
                    let v = numeric(arg)?;
                    if !(v >= 0.0 && v <= (RESULT_COUNT - 1) as f64 && v == libm::round(v)) {
                        return Err(ScpiError::with(
                            code::DATA_OUT_OF_RANGE,
                            "result index (FETC:RES:CAT?)",
                        ));
                    }
                    ResultId::from_index(v as usize)
                        .ok_or(ScpiError::new(code::DATA_OUT_OF_RANGE))?
                };
                let entry = self.app.result(id);
                let info = id.info();
                let unit = info.unit.as_str();
                if !entry.valid {
                    return Err(ScpiError::with_suffix(
                        code::DATA_CORRUPT_OR_STALE,
                        info.name,
                        self.app.why_invalid(id).unwrap_or(" has no valid value"),
                    ));
                }
                if matches!(cmd, Command::FetchBudget) {
                    // u, then the largest contributors and their shares, largest first
                    fixed(&mut r, entry.std_uncertainty);
                    for (c, share) in entry.largest_contributors().into_iter().flatten() {
                        push_bytes(&mut r, b",");
                        for b in c.name().bytes() {
                            push_bytes(&mut r, &[b.to_ascii_uppercase()]);
                        }
                        push_bytes(&mut r, b",");
                        fixed(&mut r, share);
                    }
                } else {
                    fixed(&mut r, entry.value);
                    push_bytes(&mut r, b",");
                    fixed(&mut r, entry.std_uncertainty);
                    push_bytes(&mut r, b",");
                    for c in unit.bytes() {
                        push_bytes(&mut r, &[c.to_ascii_uppercase()]);
                    }
                }
            }
            Command::FetchCatalog => {
                none()?;
                // one response unit per name: the catalogue is longer than a response buffer
                for (k, info) in ResultInfo::all().enumerate() {
                    let mut n = Response::new();
                    if k > 0 {
                        push_bytes(&mut n, b",");
                    }
                    push_bytes(&mut n, b"\"");
                    push_bytes(&mut n, info.name.as_bytes());
                    push_bytes(&mut n, b"\"");
                    if k == 0 {
                        self.respond(&n);
                    } else {
                        (self.out)(&n);
                    }
                }
                return Ok(());
            }
            Command::FetchTouchCount => {
                none()?;
                push_u64(&mut r, self.app.touch_points().len() as u64);
            }
            Command::FetchTouch => {
                // touch point k (1-based) of the last PROBE run: x,y,z in mm
                let k = match p {
                    [] => return Err(ScpiError::new(code::MISSING_PARAMETER)),
                    [a] => numeric(a)?,
                    _ => return Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                };
                let points = self.app.touch_points();
                let point = (k >= 1.0 && k == libm::round(k))
                    .then(|| points.get(k as usize - 1))
                    .flatten()
                    .ok_or(ScpiError::with(
                        code::DATA_OUT_OF_RANGE,
                        "touch point 1..FETC:TOUC:COUN?",
                    ))?;
                for (i, v) in point.iter().enumerate() {
                    if i > 0 {
                        push_bytes(&mut r, b",");
                    }
                    push_fixed(&mut r, *v, RESPONSE_DECIMALS, false, SCPI_NAN);
                }
            }
            Command::DataLogCount => {
                none()?;
                push_u64(&mut r, self.log.len() as u64);
            }
            Command::DataLog => {
                none()?;
                // The run's metadata if the application recorded it at arm, else the pod's now.
                let meta = self.log.meta().copied().unwrap_or(*self.app.run_meta());
                if self.pull_mode {
                    // the length is counted by the pulls, which send the header when it is known
                    *self.download = Some(Download {
                        cursor: CsvCursor::new(),
                        meta,
                        counting: Some((CsvCursor::new(), 0, self.responded)),
                        header: Text::new(),
                        header_sent: 0,
                    });
                    self.responded = true;
                } else {
                    push_block_header(&mut r, csv_len(self.log, &meta));
                    self.respond(&r);
                    let out = &mut *self.out;
                    write_csv(self.log, &meta, &mut |chunk| out(chunk));
                }
                return Ok(());
            }
            _ => return Err(ScpiError::new(code::UNDEFINED_HEADER)),
        }
        self.respond(&r);
        Ok(())
    }
}

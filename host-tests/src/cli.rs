//! The host commands' command lines.

use ballpod::config::Config;

/// The command line parsed into `A`. The cargo aliases (`cargo sim`, `cargo replay`, …) end in
/// `--`, so `cargo sim -- --seed 3` hands the binary a leading `--`: it is dropped, and both
/// spellings work.
pub fn parse<A: clap::Parser>() -> A {
    let mut raw: Vec<String> = std::env::args().collect();
    if raw.get(1).is_some_and(|a| a == "--") {
        raw.remove(1);
    }
    A::parse_from(raw)
}

/// The default configuration with `sets` applied, each checked as a client's write, then the
/// whole (a cross-field rule such as excitation / sample rate holds after all are set).
pub fn settings(sets: &[String]) -> Result<Config, String> {
    let mut c = Config::default();
    for s in sets {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| format!("{s}: not NAME=VALUE"))?;
        let field = Config::field_by_name(name).ok_or_else(|| format!("{name}: no such field"))?;
        let info = Config::field_info(field).ok_or_else(|| format!("{name}: no such field"))?;
        let v = match value.parse::<f64>() {
            Ok(v) => v,
            Err(_) => info
                .choice(value.as_bytes())
                .map(f64::from)
                .ok_or_else(|| format!("{name}: {value} is neither a number nor a choice"))?,
        };
        Config::check_write(field, v).map_err(|e| format!("{name}={value}: {e:?}"))?;
        c.set_field(field, v);
    }
    c.validate().map_err(|e| format!("{e:?}"))?;
    Ok(c)
}

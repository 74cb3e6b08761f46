//! The core's layers: which module of `src/` may import which, one row per module from the
//! bottom up ([`LAYERS`]), and what the sources actually import ([`core_imports`]: `crate::…`
//! paths in code, comments left out). `tests/layers.rs` fails when the two differ or a row
//! imports from its own level or above; `gen-docs` writes the table with who imports whom
//! (`docs/src/reference/module-layers.md`). The firmware (`src/main.rs`, `src/board/`) stands
//! on top of all of them and is not a row.
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// One module of the core and what it may import.
pub struct Layer {
    /// Level, 1 at the bottom: a module imports only from lower levels.
    pub level: u8,
    /// The module (`src/<module>.rs` or `src/<module>/`).
    pub module: &'static str,
    /// The core modules it imports — exactly these.
    pub imports: &'static [&'static str],
    /// Its one job.
    pub job: &'static str,
}

/// The layer table.
pub const LAYERS: &[Layer] = &[
    Layer {
        level: 1,
        module: "num",
        imports: &[],
        job: "small numerics written for the M4F, CRC-32, finiteness checks",
    },
    Layer {
        level: 1,
        module: "units",
        imports: &[],
        job: "the units of the configuration fields and the results",
    },
    Layer {
        level: 1,
        module: "in_place",
        imports: &[],
        job: "building the large state in its final place",
    },
    Layer {
        level: 2,
        module: "config",
        imports: &["num", "units"],
        job: "the configuration: every field declared once (unit, default, range, when it takes effect); its encoding",
    },
    Layer {
        level: 3,
        module: "acquisition",
        imports: &["config", "num"],
        job: "raw sensor readings → calibrated, flagged samples",
    },
    Layer {
        level: 3,
        module: "settings",
        imports: &["config", "num"],
        job: "the configuration in two power-safe flash slots",
    },
    Layer {
        level: 4,
        module: "metrology",
        imports: &["acquisition", "config", "in_place", "num"],
        job: "samples → SSM errors, circle fits, ISO 230-4 figures, point fits",
    },
    Layer {
        level: 5,
        module: "identify",
        imports: &["config", "metrology", "num"],
        job: "test results → machine deviations and corrections",
    },
    Layer {
        level: 6,
        module: "app",
        imports: &[
            "acquisition",
            "config",
            "identify",
            "in_place",
            "metrology",
            "num",
            "units",
        ],
        job: "the pod application: session, runs, estimators, results, jobs, the log",
    },
    Layer {
        level: 7,
        module: "protocol",
        imports: &["acquisition", "app", "config", "num"],
        job: "the bytes of the ports: CANopen, SCPI, the stream and the log's text, SLCAN",
    },
    Layer {
        level: 8,
        module: "boot",
        imports: &["protocol"],
        job: "why the last run ended and what the boot found, as the ports report it",
    },
    Layer {
        level: 9,
        module: "pod",
        imports: &["acquisition", "app", "boot", "config", "protocol"],
        job: "the pod every shell drives: the application with its ports, log and stream",
    },
];

/// What each core module imports: module → imported module → the files that do.
pub type Imports = BTreeMap<String, BTreeMap<String, BTreeSet<String>>>;

/// Reads every `.rs` file of the core under `src` (not `lib.rs`, `main.rs`, `board/`); an
/// import is a `crate::<module>` path to another of these modules.
pub fn core_imports(src: &Path) -> std::io::Result<Imports> {
    let mut out = Imports::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir)? {
            let path = entry?.path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let Ok(rel) = path.strip_prefix(src) else {
                continue;
            };
            let rel = rel.to_string_lossy().replace('\\', "/");
            if !rel.ends_with(".rs")
                || rel == "lib.rs"
                || rel == "main.rs"
                || rel.starts_with("board/")
            {
                continue;
            }
            let module = rel.split('/').next().unwrap_or("").trim_end_matches(".rs");
            let text = std::fs::read_to_string(&path)?;
            let targets = out.entry(module.to_string()).or_default();
            for target in crate_paths(&text) {
                if target != module {
                    targets.entry(target).or_default().insert(rel.clone());
                }
            }
        }
    }
    // items of the crate root (`lib.rs`: `FIRMWARE_VERSION`) are no module's
    let modules: BTreeSet<String> = out.keys().cloned().collect();
    for targets in out.values_mut() {
        targets.retain(|t, _| modules.contains(t));
    }
    Ok(out)
}

/// The first segment of every `crate::…` path in `text`'s code (`crate::{a, b::c}` gives `a`
/// and `b`), line comments left out.
fn crate_paths(text: &str) -> BTreeSet<String> {
    let code: String = text
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let ident = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = BTreeSet::new();
    let mut rest = code.as_str();
    while let Some(at) = rest.find("crate::") {
        let before = rest[..at].chars().last();
        rest = &rest[at + "crate::".len()..];
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            continue; // e.g. `ballpod_crate::`
        }
        if let Some(group) = rest.strip_prefix('{') {
            // the top-level items of the group
            let mut depth = 0;
            let mut item_start = true;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        rest = &group[i..];
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && !c.is_whitespace() => {
                        let name = ident(&group[i..]);
                        if !name.is_empty() {
                            out.insert(name);
                        }
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else {
            let name = ident(rest);
            if !name.is_empty() {
                out.insert(name);
            }
        }
    }
    out
}

/// Who imports `module` among the core's modules.
pub fn importers(imports: &Imports, module: &str) -> Vec<String> {
    imports
        .iter()
        .filter(|(_, targets)| targets.contains_key(module))
        .map(|(m, _)| m.clone())
        .collect()
}

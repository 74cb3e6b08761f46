//! The core's layer rule (`ballpod_host::layers::LAYERS`): every module imports exactly what its
//! row says, and only from lower levels — no import circle, no arrow up. The sources are read
//! as text (`crate::` paths in code); the firmware (`main.rs`, `board/`) is on top of all.
use std::path::Path;

use ballpod_host::layers::{LAYERS, core_imports};

fn src() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../src"))
}

#[test]
fn every_row_imports_only_from_lower_levels() {
    for row in LAYERS {
        for &m in row.imports {
            let below = LAYERS.iter().find(|r| r.module == m);
            assert!(
                below.is_some_and(|b| b.level < row.level),
                "{} (level {}) may import {m}, which is not a lower level",
                row.module,
                row.level
            );
        }
    }
}

#[test]
fn each_module_imports_exactly_what_its_row_says() {
    let imports = core_imports(src()).expect("the core's sources");
    let rows: Vec<&str> = LAYERS.iter().map(|r| r.module).collect();
    for module in imports.keys() {
        assert!(
            rows.contains(&module.as_str()),
            "src/{module}: no row in LAYERS"
        );
    }
    let mut wrong = Vec::new();
    for row in LAYERS {
        let actual = imports.get(row.module);
        assert!(actual.is_some(), "LAYERS names {}, not in src/", row.module);
        let actual = actual.into_iter().flatten();
        for (target, files) in actual {
            if !row.imports.contains(&target.as_str()) {
                wrong.push(format!(
                    "{} imports {target} ({files:?}): not in its row",
                    row.module
                ));
            }
        }
        for &m in row.imports {
            if !imports.get(row.module).is_some_and(|a| a.contains_key(m)) {
                wrong.push(format!(
                    "{}'s row names {m}, which it does not import",
                    row.module
                ));
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The reader sees what a `use` says, in its forms, and not what a comment says nor a
/// crate-root item (`crate::FIRMWARE_VERSION`).
#[test]
fn the_reader_finds_imports_in_every_form_and_none_in_comments() {
    let dir = std::env::temp_dir().join(format!("ballpod-layers-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("app")).unwrap();
    for module in [
        "config.rs",
        "num.rs",
        "metrology.rs",
        "protocol.rs",
        "pod.rs",
    ] {
        std::fs::write(dir.join(module), "").unwrap();
    }
    std::fs::write(
        dir.join("app/x.rs"),
        "use crate::{config::{A, B}, num};\n// crate::protocol in a comment\n\
         /// [`crate::pod`] in a doc\nfn f() { crate::metrology::g(); }\npub(crate) fn h() -> &str { crate::VERSION }\n",
    )
    .unwrap();
    let imports = core_imports(&dir).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let app: Vec<&str> = imports["app"].keys().map(String::as_str).collect();
    assert_eq!(app, ["config", "metrology", "num"]);
}

/// Longest source file of the core without a reason, lines.
const LONGEST_WITHOUT_REASON: usize = 800;

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("a source directory") {
        let path = entry.expect("an entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn a_file_longer_than_800_lines_says_why_in_its_module_doc() {
    let mut files = Vec::new();
    rust_files(src(), &mut files);
    assert!(
        files.len() > 50,
        "the core's sources: {} files",
        files.len()
    );
    let mut unexplained = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let lines = text.lines().count();
        let doc: String = text
            .lines()
            .filter(|l| l.starts_with("//!"))
            .collect::<Vec<_>>()
            .join(" ");
        if lines > LONGEST_WITHOUT_REASON && !doc.contains("on purpose") {
            unexplained.push(format!("{} ({lines} lines)", f.display()));
        }
    }
    assert!(
        unexplained.is_empty(),
        "split these, or say in the module doc why the file is long \"on purpose\": {unexplained:?}"
    );
}

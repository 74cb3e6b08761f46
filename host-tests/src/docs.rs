//! The user documentation (README.md and the book in `docs/src/`), for the tests that run its
//! examples and check its links (the docs' examples are executed).

use std::path::{Path, PathBuf};

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("host-tests/ has a parent")
        .to_path_buf()
}

/// Every documentation page: README.md, then the book's Markdown files in path order.
pub fn pages() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("dir entry").path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let root = root();
    let mut out = vec![root.join("README.md")];
    walk(&root.join("docs/src"), &mut out);
    out
}

/// The page holding `marker` (it must be in exactly one page: an example has one home) and the
/// page's text from the marker on.
pub fn from(marker: &str) -> String {
    let mut found = Vec::new();
    for p in pages() {
        let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        if let Some(at) = text.find(marker) {
            found.push((p, text[at..].to_string()));
        }
    }
    match found.len() {
        1 => found.remove(0).1,
        0 => panic!("{marker} is in no documentation page: the example moved"),
        _ => panic!(
            "{marker} is in {} pages: {:?}",
            found.len(),
            found.iter().map(|(p, _)| p).collect::<Vec<_>>()
        ),
    }
}

/// The first fenced block of `lang` (e.g. `toml`) after `marker`, without its fences.
pub fn block_after(marker: &str, lang: &str) -> String {
    let rest = from(marker);
    let open = format!("```{lang}\n");
    let start = rest
        .find(&open)
        .unwrap_or_else(|| panic!("a {lang} block after {marker}"))
        + open.len();
    let len = rest[start..].find("```").expect("block end");
    rest[start..start + len].to_string()
}

/// The steps of a `console` block's lines: each line `$ COMMAND` starts a step, the lines up to
/// the next such line are what COMMAND prints (lines before the first command are not output).
pub fn console_steps<'a>(lines: impl IntoIterator<Item = &'a str>) -> Vec<(String, Vec<String>)> {
    let mut steps: Vec<(String, Vec<String>)> = Vec::new();
    for line in lines {
        if let Some(command) = line.strip_prefix("$ ") {
            steps.push((command.to_string(), Vec::new()));
        } else if let Some((_, printed)) = steps.last_mut() {
            printed.push(line.to_string());
        }
    }
    steps
}

//! The README's examples, for the tests that run them (the docs' examples are executed).

/// README.md at the repository root.
pub fn text() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md"))
        .expect("README.md beside host-tests/")
}

/// The README from `heading` on (panics if the heading is not there: the example moved).
pub fn from(heading: &str) -> String {
    let readme = text();
    let at = readme
        .find(heading)
        .unwrap_or_else(|| panic!("{heading} in README"));
    readme[at..].to_string()
}

/// The first fenced block of `lang` (e.g. `toml`) after `heading`, without its fences.
pub fn block_after(heading: &str, lang: &str) -> String {
    let rest = from(heading);
    let open = format!("```{lang}\n");
    let start = rest
        .find(&open)
        .unwrap_or_else(|| panic!("a {lang} block after {heading}"))
        + open.len();
    let len = rest[start..].find("```").expect("block end");
    rest[start..start + len].to_string()
}

//! The documentation as users reach it: the generated reference pages equal what the code
//! generates (a hand edit or a code change without `gen-docs` fails, naming the page), every
//! relative link of README.md and the book resolves to a page and a heading, every page of the
//! book is in its summary, the README stays a front page, and the reference's SCPI commands
//! and error numbers are the server's own (every command resolves, every error number the
//! server can queue is listed).
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use ballpod::acquisition::MAX_AXES;
use ballpod::app::App;
use ballpod::app::log::SampleLog;
use ballpod::config::Config;
use ballpod::protocol::scpi::ScpiServer;
use ballpod::protocol::scpi::reference::{COMMAND_VARIANTS, ERRORS, commands};
use ballpod_host::docs::{pages, root};
use ballpod_host::docs_ref;

const REGENERATE: &str =
    "cargo run --manifest-path host-tests/Cargo.toml --target host-tuple --bin gen-docs";

#[test]
fn the_committed_reference_pages_are_what_the_code_generates() {
    let dir = root().join(docs_ref::DIR);
    let mut stale = Vec::new();
    for page in docs_ref::pages() {
        let path = dir.join(page.file);
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        if committed != page.text {
            stale.push(format!("{}/{}", docs_ref::DIR, page.file));
        }
    }
    assert!(
        stale.is_empty(),
        "generated reference pages out of date (or edited by hand): {stale:?}; run `{REGENERATE}`"
    );
    // and nothing else lives among them
    let files: BTreeSet<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let generated: BTreeSet<String> = docs_ref::pages()
        .iter()
        .map(|p| p.file.to_string())
        .collect();
    assert_eq!(
        files,
        generated,
        "{} holds generated pages only",
        docs_ref::DIR
    );
}

#[test]
fn the_committed_signature_plots_are_what_the_forward_model_draws() {
    use ballpod_host::report::svg::{SIGNATURE_DIR, signature_plots};
    let dir = root().join(SIGNATURE_DIR);
    let plots = signature_plots();
    let stale: Vec<&String> = plots
        .iter()
        .filter(|(file, svg)| std::fs::read_to_string(dir.join(file)).unwrap_or_default() != *svg)
        .map(|(file, _)| file)
        .collect();
    assert!(
        stale.is_empty(),
        "signature plots out of date: {stale:?}; run `{REGENERATE}`"
    );
    // each is shown on the circle page
    let circle = std::fs::read_to_string(root().join("docs/src/methods/circle.md")).unwrap();
    for (file, _) in &plots {
        assert!(
            circle.contains(&format!("images/signatures/{file}")),
            "circle.md does not show {file}"
        );
    }
}

/// mdBook's heading id (`normalize_id`): alphanumerics, `_` and `-` kept (lower-cased),
/// whitespace to `-`, everything else dropped; inline code and emphasis marks are not text.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_lowercase().next().unwrap_or(c))
            } else if c.is_whitespace() {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// The lines of a page outside its fenced blocks.
fn prose_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut fenced = false;
    text.lines().filter(move |line| {
        if line.starts_with("```") {
            fenced = !fenced;
            return false;
        }
        !fenced
    })
}

/// The ids of a page's headings (outside fenced blocks), with mdBook's `-1`, `-2` for repeats.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in prose_lines(text) {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if (1..=6).contains(&hashes) && line[hashes..].starts_with(' ') {
            let base = slug(&line[hashes..]);
            let mut id = base.clone();
            let mut k = 1;
            while out.contains(&id) {
                id = format!("{base}-{k}");
                k += 1;
            }
            out.insert(id);
        }
    }
    out
}

/// The targets of a page's inline links `[text](target)` outside fenced and inline code.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in prose_lines(text) {
        // drop inline code spans
        let mut plain = String::new();
        for (k, part) in line.split('`').enumerate() {
            if k % 2 == 0 {
                plain.push_str(part);
            }
        }
        let mut rest = plain.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            out.push(after[..end].to_string());
            rest = &after[end..];
        }
    }
    out
}

fn relative(path: &Path) -> String {
    path.strip_prefix(root())
        .unwrap_or(path)
        .display()
        .to_string()
}

#[test]
fn every_link_of_the_readme_and_the_book_resolves() {
    let mut broken = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for target in links(&text) {
            if target.starts_with("http://")
                || target.starts_with("https://")
                || target.starts_with("mailto:")
            {
                continue;
            }
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let dest: PathBuf = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(file)
            };
            if !dest.exists() {
                broken.push(format!("{}: {target} (no such file)", relative(&page)));
                continue;
            }
            if let Some(anchor) = anchor {
                let is_md = dest.extension().is_some_and(|x| x == "md");
                let ids = anchors(&std::fs::read_to_string(&dest).unwrap_or_default());
                if is_md && !ids.contains(anchor) {
                    broken.push(format!("{}: {target} (no such heading)", relative(&page)));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn every_page_of_the_book_is_in_its_summary_and_every_entry_exists() {
    let src = root().join("docs/src");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).unwrap();
    let listed: BTreeSet<PathBuf> = links(&summary)
        .into_iter()
        .map(|l| src.join(l.split('#').next().unwrap()))
        .collect();
    for p in &listed {
        assert!(
            p.exists(),
            "SUMMARY.md lists {} which does not exist",
            relative(p)
        );
    }
    for p in pages().into_iter().skip(1) {
        if p.file_name().is_some_and(|n| n == "SUMMARY.md") {
            continue;
        }
        assert!(
            listed.contains(&p),
            "{} is not in docs/src/SUMMARY.md (a page no reader can reach)",
            relative(&p)
        );
    }
}

/// One definition per term: the glossary introduces each term in bold (`- **Term**`), and no
/// other page sets a glossary term in bold — the book's way of defining one — but links the
/// glossary instead (a term defined twice is how two definitions drift apart).
#[test]
fn no_page_defines_a_glossary_term_again() {
    let glossary = std::fs::read_to_string(root().join("docs/src/glossary.md")).unwrap();
    let terms: Vec<String> = glossary
        .lines()
        .filter_map(|l| l.strip_prefix("- **")?.split_once("**"))
        .map(|(t, _)| t.to_lowercase())
        .collect();
    assert!(terms.len() > 40, "the glossary's terms: {terms:?}");
    let mut again = Vec::new();
    for page in pages() {
        if page.ends_with("glossary.md") {
            continue;
        }
        let text = std::fs::read_to_string(&page).unwrap();
        for line in prose_lines(&text) {
            for (k, bold) in line.split("**").enumerate() {
                if k % 2 == 1 && terms.contains(&bold.trim().to_lowercase()) {
                    again.push(format!("{}: **{bold}**", relative(&page)));
                }
            }
        }
    }
    assert!(
        again.is_empty(),
        "glossary terms set in bold (defined again) outside the glossary — link the glossary instead:\n{}",
        again.join("\n")
    );
}

#[test]
fn the_readme_is_a_front_page() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(
        lines <= 120,
        "README.md has {lines} lines (a front page: ≤ 120)"
    );
}

/// The number of variants of the SCPI server's command enum, counted in its source.
fn command_enum_variants() -> usize {
    let src = std::fs::read_to_string(root().join("src/protocol/scpi/commands.rs")).unwrap();
    let body = src
        .split_once("enum Command {")
        .expect("the command enum")
        .1
        .split_once('}')
        .expect("its end")
        .0;
    body.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("//"))
        .count()
}

#[test]
fn the_scpi_reference_lists_every_command_and_each_one_resolves() {
    assert_eq!(
        COMMAND_VARIANTS,
        command_enum_variants(),
        "scpi::reference lists every command the server resolves"
    );
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let log: SampleLog<32> = SampleLog::new();
    for c in commands() {
        let mut scpi = ScpiServer::new();
        let mut out = Vec::new();
        let line = format!("{};:SYST:ERR?\n", c.example);
        scpi.feed(line.as_bytes(), &mut app, &log, &mut |b: &[u8]| {
            out.extend_from_slice(b)
        });
        let reply = String::from_utf8_lossy(&out).into_owned();
        let err = reply.trim_end().rsplit(';').next().unwrap_or_default();
        // a state refusal (-221, -230) is fine here; a command error (-1xx) is not
        assert!(
            !err.starts_with("-1"),
            "{}: `{}` answers {reply:?}",
            c.syntax,
            c.example
        );
    }
}

#[test]
fn the_error_reference_lists_every_error_number_the_server_queues() {
    // every error constant of scpi::status::code (but 0, "No error") is listed once
    let src = std::fs::read_to_string(root().join("src/protocol/scpi/status.rs")).unwrap();
    let defined: BTreeSet<i16> = src
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub const "))
        .filter_map(|l| l.split_once(": i16 = "))
        .filter_map(|(_, v)| v.trim_end_matches(';').parse().ok())
        .filter(|&c: &i16| c != 0)
        .collect();
    let listed: BTreeSet<i16> = ERRORS.iter().map(|(c, _)| *c).collect();
    assert_eq!(listed.len(), ERRORS.len(), "an error listed twice");
    assert_eq!(defined, listed);
    // and each one is queued somewhere in the server (a constant nobody raises is dead)
    let server: String = [
        "mod.rs",
        "commands.rs",
        "exec.rs",
        "parse.rs",
        "status.rs",
        "number.rs",
    ]
    .iter()
    .map(|f| std::fs::read_to_string(root().join("src/protocol/scpi").join(f)).unwrap())
    .collect();
    for line in src.lines() {
        if let Some((name, _)) = line
            .trim()
            .strip_prefix("pub const ")
            .and_then(|l| l.split_once(": i16 = "))
            && name != "NO_ERROR"
        {
            let uses = server.matches(&format!("code::{name}")).count();
            assert!(uses > 1, "code::{name} is never queued");
        }
    }
}

/// The worked examples of the circle and seed 002 pages are what `sim` prints today with its
/// default options and `--thesis` (the simulator's output, not the pages' own arithmetic):
/// each page's text block is a run of consecutive lines of its output (`--thesis` only appends
/// the thesis mode's lines to the default output).
#[test]
fn the_worked_examples_are_what_sim_prints() {
    let out_dir = std::env::temp_dir().join(format!("ballpod-docs-sim-{}", std::process::id()));
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_sim"))
        .arg("--thesis")
        .arg("--out")
        .arg(&out_dir)
        .output()
        .expect("sim runs");
    let _ = std::fs::remove_dir_all(&out_dir);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let printed: Vec<String> = String::from_utf8_lossy(&run.stdout)
        .lines()
        .map(|l| l.trim_end().to_string())
        .collect();
    for marker in [
        "runs the circle after the seed 002 procedure",
        "runs the procedure with the Table 4.3 set-up above",
        "With `--thesis` the simulator appends the thesis mode",
    ] {
        let block: Vec<String> = ballpod_host::docs::block_after(marker, "text")
            .lines()
            .map(|l| l.trim_end().to_string())
            .collect();
        let found = printed.windows(block.len()).any(|w| w == block.as_slice());
        assert!(
            found,
            "the worked example after {marker:?} is not what `sim` prints now:\n{}",
            printed.join("\n")
        );
    }
}

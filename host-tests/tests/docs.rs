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
    let results = std::fs::read_to_string(out_dir.join("results.json"));
    let _ = std::fs::remove_dir_all(&out_dir);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    // the figures the pages quote from the results.json `sim` writes, to the digits they give
    let results: ballpod_host::replay::Report =
        serde_json::from_str(&results.expect("sim writes results.json")).expect("its JSON");
    let checked = quoted_results_are_these(
        "methods/circle.md",
        "In its `results.json` every figure carries its u",
        &results,
    );
    assert!(checked >= 20, "circle.md: only {checked} figures found");
    let seed002 = "methods/seed002-ballbar.md";
    let marker = "In its `results.json` the model fit's residual";
    assert_eq!(quoted_results_are_these(seed002, marker, &results), 1);
    let rms = figure(&results.results, "model_residual_rms").value;
    assert!(
        rms.abs() < 1e-9,
        "{seed002}: model_residual_rms {rms} is not below 1e-9 µm"
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

/// Checks each `name value [± u]` the paragraph of `page` starting at `marker` quotes, a name
/// being a result of `report`, written as the book writes it ([`shown`]) to the decimals the page
/// gives; the number of names checked.
fn quoted_results_are_these(
    page: &str,
    marker: &str,
    report: &ballpod_host::replay::Report,
) -> usize {
    let text = std::fs::read_to_string(root().join("docs/src").join(page)).expect(page);
    let start = text
        .find(marker)
        .unwrap_or_else(|| panic!("{page}: no {marker:?}"));
    let paragraph = text[start..].split("\n\n").next().unwrap_or_default();
    let words: Vec<&str> = paragraph
        .split_whitespace()
        .map(|w| {
            w.trim_start_matches('(')
                .trim_end_matches([',', ';', ':', ')', '.'])
        })
        .collect();
    let number = |w: &str| w.replace('−', "-").parse::<f64>().is_ok();
    let decimals = |w: &str| w.split_once('.').map_or(0, |(_, d)| d.len());
    let mut checked = 0;
    for (k, w) in words.iter().enumerate() {
        let Some(value) = words.get(k + 1).filter(|w| number(w)) else {
            continue;
        };
        let Some(f) = report.results.iter().find(|f| f.name == *w) else {
            continue;
        };
        assert_eq!(*value, shown(f.value, decimals(value)), "{page}: {w}");
        if words.get(k + 2) == Some(&"±") {
            let u = words.get(k + 3).expect("a u after ±");
            assert_eq!(*u, shown(u_of(f), decimals(u)), "{page}: {w}'s u");
        }
        checked += 1;
    }
    checked
}

// The worked examples of the method pages that `replay` makes of committed inputs
// (host-tests/tests/data/docs/, written by `make_inputs.py` there): each page's commands, run
// as the page shows them, print what it shows, and its tables and the numbers its prose copies
// are the output's, to the digits it gives.

/// A scratch directory (the process id in its name), removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("ballpod-docs-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        Self(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Runs the `console` block after `marker` as a reader at the repository root would: each line
/// `$ cargo BIN [--] ARGS` runs this crate's binary BIN (`replay`, `ncgen`) in `dir`, a
/// repository file (`host-tests/…`) by its path from the root and anything else (an output) in
/// `dir`; what it prints must be the lines that follow it in the block, exactly.
fn run_console_block(marker: &str, dir: &Path) {
    let block = ballpod_host::docs::block_after(marker, "console");
    let steps = ballpod_host::docs::console_steps(block.lines().map(str::trim_end));
    assert!(
        !steps.is_empty(),
        "no command in the console block after {marker:?}"
    );
    for (command, expected) in steps {
        let mut words = command.split_whitespace();
        assert_eq!(words.next(), Some("cargo"), "`{command}`");
        let bin = match words.next() {
            Some("replay") => env!("CARGO_BIN_EXE_replay"),
            Some("ncgen") => env!("CARGO_BIN_EXE_ncgen"),
            other => panic!("`{command}`: {other:?} is not a binary this test runs"),
        };
        let args: Vec<std::ffi::OsString> = words
            .skip_while(|w| *w == "--")
            .map(|w| {
                if w.starts_with("host-tests/") {
                    root().join(w).into_os_string()
                } else {
                    w.into()
                }
            })
            .collect();
        let run = std::process::Command::new(bin)
            .args(args)
            .current_dir(dir)
            .output()
            .expect("the binary runs");
        assert!(
            run.status.success(),
            "`{command}`: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let printed: Vec<String> = String::from_utf8_lossy(&run.stdout)
            .lines()
            .map(|l| l.trim_end().to_string())
            .collect();
        assert_eq!(
            printed, expected,
            "`{command}` (the console block after {marker:?}) prints otherwise now"
        );
    }
}

/// The `results.json` a replay wrote.
fn replayed(path: &Path) -> ballpod_host::replay::Report {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The figure `name`.
fn figure<'a>(
    figures: &'a [ballpod_host::replay::Figure],
    name: &str,
) -> &'a ballpod_host::replay::Figure {
    figures
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("no {name} among {figures:?}"))
}

/// A figure's u.
fn u_of(f: &ballpod_host::replay::Figure) -> f32 {
    f.u.unwrap_or_else(|| panic!("{}: u not evaluated", f.name))
}

/// The share of a figure's u that the contributor `name` gives.
fn share(f: &ballpod_host::replay::Figure, name: &str) -> f32 {
    f.contributors
        .iter()
        .find(|c| c.name == name)
        .map(|c| c.u)
        .unwrap_or_else(|| panic!("{}: no {name} share in {:?}", f.name, f.contributors))
}

/// `v` to `decimals` decimals as the book writes it (its minus sign −).
fn shown(v: f32, decimals: usize) -> String {
    format!("{v:.decimals$}").replace('-', "−")
}

/// `value ± u`, both to `decimals` decimals.
fn pm(value: f32, u: f32, decimals: usize) -> String {
    format!("{} ± {}", shown(value, decimals), shown(u, decimals))
}

/// The cells of the first table row after `marker` whose first cell starts with `first`.
fn table_row(marker: &str, first: &str) -> Vec<String> {
    let text = ballpod_host::docs::from(marker);
    let line = text
        .lines()
        .find(|l| l.starts_with("| ") && l[2..].starts_with(first))
        .unwrap_or_else(|| panic!("no table row {first:?} after {marker:?}"));
    line.trim_end()
        .trim_start_matches('|')
        .trim_end_matches('|')
        .split('|')
        .map(|c| c.trim().to_string())
        .collect()
}

/// The page's text from `marker` on with its line breaks as spaces (prose wraps anywhere).
fn prose_from(marker: &str) -> String {
    ballpod_host::docs::from(marker)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// centreline.md's worked example: `replay` of the committed dial readings prints what the page
/// shows; its table (value ± the `type_a` share), the gauge's shares, u, the errors against the
/// axis the readings were computed for, and the same readings without noise are the output's.
#[test]
fn the_dial_gauge_example_is_what_replay_prints() {
    let dir = Scratch::new("dial");
    let marker = "`dial.toml`, is `[dial]`";
    run_console_block(marker, &dir.0);
    let r = replayed(&dir.0.join("dial-out/results.json"));
    let (x, z) = (
        figure(&r.host, "dial_tilt_x"),
        figure(&r.host, "dial_tilt_z"),
    );
    for f in [x, z] {
        let row = table_row(marker, &format!("`{}`", f.name));
        assert_eq!(row[2], pm(f.value, share(f, "type_a"), 3), "{row:?}");
        assert_eq!(f.dof, Some(1), "{f:?}");
    }
    // the axis of make_inputs.py: normalize(150e-6, 1, −80e-6), in µrad
    let norm = (150e-6f64.powi(2) + 1.0 + 80e-6f64.powi(2)).sqrt();
    let truth = [150.0 / norm, -80.0 / norm];
    let err = [0, 1].map(|k| f64::from([x, z][k].value) - truth[k]);
    let ratio = [0, 1].map(|k| err[k].abs() / f64::from(u_of([x, z][k])));
    let prose = prose_from(marker);
    for want in [
        format!(
            "adds {} and {} µrad to that share",
            shown(share(x, "gauge_scale"), 2),
            shown(share(z, "gauge_scale"), 2)
        ),
        format!(
            "makes u {} and {} µrad",
            shown(u_of(x), 2),
            shown(u_of(z), 2)
        ),
        format!(
            "The errors, {} and {} µrad, are {:.2}u and {:.2}u",
            shown(err[0] as f32, 2),
            shown(err[1] as f32, 2),
            ratio[0],
            ratio[1]
        ),
        "(`dof` 1)".to_string(),
    ] {
        assert!(prose.contains(&want), "centreline.md does not say {want:?}");
    }
    // the same readings without noise
    let marker = "session file `dial_noiseless.toml`)";
    run_console_block(marker, &dir.0);
    let r = replayed(&dir.0.join("dial-noiseless-out/results.json"));
    let want = format!(
        "give ({}, {}) µrad",
        shown(figure(&r.host, "dial_tilt_x").value, 4),
        shown(figure(&r.host, "dial_tilt_z").value, 4)
    );
    assert!(prose.contains(&want), "centreline.md does not say {want:?}");
}

/// volumetric.md's worked example: `replay` of the committed stop readings prints what the page
/// shows; its table is the figures and the points of `vector_curves.csv` as that file writes
/// them, and the Siemens table's line it quotes is one of `comp_siemens_840d.csv`.
#[test]
fn the_vector_method_example_is_what_replay_prints() {
    let dir = Scratch::new("vector");
    let marker = "`vector.toml`, has a `[vector]` table";
    run_console_block(marker, &dir.0);
    let out = dir.0.join("vector-out");
    let r = replayed(&out.join("results.json"));
    for name in ["vector_S_xy", "vector_S_yz", "vector_S_zx"] {
        let f = figure(&r.host, name);
        let row = table_row(marker, &format!("`{name}`"));
        assert_eq!(row[2], pm(f.value, u_of(f), 2), "{row:?}");
    }
    let noise = figure(&r.host, "vector_reading_std");
    assert_eq!(
        table_row(marker, "`vector_reading_std`")[2],
        shown(noise.value, 3)
    );
    // the curves' points as vector_curves.csv writes them (axis, position, D_x, D_y, D_z, their u)
    let curves = std::fs::read_to_string(out.join("vector_curves.csv")).unwrap();
    let point = |axis: &str, at: &str, k: usize| -> String {
        let prefix = format!("{axis},{at},");
        let f: Vec<&str> = curves
            .lines()
            .find(|l| l.starts_with(&prefix))
            .unwrap_or_else(|| panic!("no {axis} {at} in vector_curves.csv:\n{curves}"))
            .split(',')
            .collect();
        format!("{} ± {}", f[2 + k], f[5 + k]).replace('-', "−")
    };
    for (row, axis, at, k) in [
        ("D_x(x) at X 0", "X", "0", 0),
        ("D_y(y) at Y 400", "Y", "400", 1),
        ("D_x(y) at Y 400", "Y", "400", 0),
    ] {
        assert_eq!(table_row(marker, row)[2], point(axis, at, k), "{row}");
    }
    // the Siemens tables: nine of 11 points, the quoted line one of them, its value in µm
    let comp = std::fs::read_to_string(out.join("comp_siemens_840d.csv")).unwrap();
    let rows: Vec<&str> = comp
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .collect();
    assert_eq!(rows.len(), 9 * 11, "{comp}");
    let page = ballpod_host::docs::from(marker);
    let line = page
        .split("e.g. `")
        .nth(1)
        .and_then(|r| r.split('`').next())
        .expect("a quoted table line");
    assert!(
        rows.contains(&line),
        "comp_siemens_840d.csv has no line {line}:\n{comp}"
    );
    let mm: f64 = line.split(',').nth(4).unwrap().parse().unwrap();
    let um = format!("{:.4}", mm * 1e3).replace('-', "−");
    let want = format!("the compensation {um} µm in mm");
    assert!(
        prose_from(marker).contains(&want),
        "volumetric.md does not say {want:?}"
    );
}

/// rtest.md's worked example: `replay` of the committed K4a readings, absolute and with
/// `zero = "first_pose"`, and of the K1 readings prints what the page shows; its table is the
/// figures with their shares, and the prose's COA head share and K1's AOC are the output's.
#[test]
fn the_rtest_example_is_what_replay_prints() {
    let dir = Scratch::new("rtest");
    let marker = "`rtest.toml` (absolute readings)";
    run_console_block(marker, &dir.0);
    let absolute = replayed(&dir.0.join("rtest-out/results.json"));
    let first_pose = replayed(&dir.0.join("rtest-first-pose-out/results.json"));
    for p in [
        "XOW", "YOW", "ZOW", "YOA", "ZOA", "BOA", "COA", "XOC", "YOC", "AOC", "BOC",
    ] {
        let name = format!("rtest_{p}");
        let row = table_row(marker, &format!("{p} ("));
        let a = figure(&absolute.host, &name);
        assert_eq!(row[2], pm(a.value, u_of(a), 3), "{row:?}");
        let fp = first_pose
            .host
            .iter()
            .find(|f| f.name == name)
            .map_or_else(|| "not reported".to_string(), |f| pm(f.value, u_of(f), 3));
        assert_eq!(row[3], fp, "{row:?}");
        assert_eq!(
            row[4],
            format!(
                "{}, {}",
                shown(share(a, "type_a"), 3),
                shown(share(a, "head_scale"), 3)
            ),
            "{row:?}"
        );
    }
    // the Least squares section's COA head share is this example's
    let page = std::fs::read_to_string(root().join("docs/src/methods/rtest.md")).unwrap();
    let prose = page.split_whitespace().collect::<Vec<_>>().join(" ");
    let coa = figure(&absolute.host, "rtest_COA");
    let want = format!(
        "COA's share is {:.1} % of its value",
        share(coa, "head_scale") / coa.value.abs() * 100.0
    );
    assert!(prose.contains(&want), "rtest.md does not say {want:?}");
    // K1 alone: AOC only
    let marker = "session file `rtest_k1.toml`)";
    run_console_block(marker, &dir.0);
    let k1 = replayed(&dir.0.join("rtest-k1-out/results.json"));
    let names: Vec<&str> = k1.host.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["rtest_AOC"]);
    let aoc = &k1.host[0];
    let want = format!(
        "`rtest_AOC`, {}″ (Type A {}″, head {}″)",
        pm(aoc.value, u_of(aoc), 3),
        shown(share(aoc, "type_a"), 3),
        shown(share(aoc, "head_scale"), 3)
    );
    assert!(prose.contains(&want), "rtest.md does not say {want:?}");
}

/// ssm.md's worked example: `ncgen two-step` of the committed set-up writes the header the page
/// shows, and `replay` of the committed stream of its two SSM runs prints what the page shows;
/// its table (E of each run, the two-step angles) and the prose's samples, cond, shares and
/// lever-arm figures are the output's.
#[test]
fn the_two_step_example_is_what_ncgen_and_replay_print() {
    let dir = Scratch::new("two-step");
    run_console_block(
        "`host-tests/tests/data/docs/two_step_setup.toml` holds",
        &dir.0,
    );
    let program = std::fs::read_to_string(dir.0.join("two-step.ngc")).unwrap();
    let header = ballpod_host::docs::block_after(
        "writes the program `two-step.ngc` with this header",
        "text",
    );
    let want: Vec<&str> = header.lines().collect();
    let got: Vec<&str> = program.lines().take(want.len()).collect();
    assert_eq!(got, want, "`ncgen two-step` writes another header now");

    let marker = "with 0.1 µm noise (seeded):";
    run_console_block(marker, &dir.0);
    let r = replayed(&dir.0.join("two-step-out/results.json"));
    assert_eq!(r.runs.len(), 2);
    let (run1, run2) = (&r.runs[0], &r.runs[1]);
    for run in [run1, run2] {
        assert_eq!(run.samples, run1.samples, "{run:?}");
        assert_eq!(
            run.counters.get("used"),
            Some(&(run.samples as u32)),
            "{run:?}"
        );
        assert_eq!(figure(&run.results, "ssm_stations").value, 3.0, "{run:?}");
    }
    let e = |run: &ballpod_host::replay::RunReport| {
        let c = ["ssm_ex", "ssm_ey", "ssm_ez"].map(|n| {
            let f = figure(&run.results, n);
            pm(f.value, u_of(f), 2)
        });
        format!("({})", c.join(", "))
    };
    assert_eq!(table_row(marker, "run 1 E")[2], e(run1));
    assert_eq!(table_row(marker, "run 2 E")[2], e(run2));
    for name in ["ts_d_alpha", "ts_d_beta"] {
        let f = figure(&r.results, name);
        assert_eq!(
            table_row(marker, &format!("`{name}`"))[2],
            pm(f.value, u_of(f), 2)
        );
        assert!(
            f.contributors.iter().all(|c| c.name != "socket"),
            "the socket has a share in {f:?}"
        );
    }
    let type_a = |run: &ballpod_host::replay::RunReport| {
        ["ssm_ex", "ssm_ey", "ssm_ez"].map(|n| shown(share(figure(&run.results, n), "type_a"), 2))
    };
    let (a1, a2) = (type_a(run1), type_a(run2));
    let cond = |run: &ballpod_host::replay::RunReport| figure(&run.results, "ssm_cond").value;
    let prose = prose_from(marker);
    for want in [
        format!(
            "Each run has {} samples, all used, 3 stations and `ssm_cond` {} (run 2: {})",
            run1.samples,
            shown(cond(run1), 2),
            shown(cond(run2), 2)
        ),
        format!(
            "(`ssm_u_socket`, {} µm",
            share(figure(&run1.results, "ssm_ex"), "socket")
        ),
        format!(
            "({}) µm in run 1 and ({}) µm in run 2",
            a1.join(", "),
            a2.join(", ")
        ),
        format!("0.1 µm × cond/3 = {:.2} µm", 0.1 * cond(run1) / 3.0),
        format!("√({}² + {}²) µm", a1[0], a2[0]),
    ] {
        assert!(prose.contains(&want), "ssm.md does not say {want:?}");
    }
}

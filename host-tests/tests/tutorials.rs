//! The book's tutorials run as written: every `docs/src/tutorial-*.md` page is executed step
//! by step in a fresh folder, and each command's output is compared with the page's.
//!
//! A page's fenced blocks are read in order:
//! - a block whose first line is `# file: PATH` is written to PATH (a set-up, a script);
//! - a `console` block holds steps: a line `$ COMMAND` runs COMMAND with bash, the lines up to
//!   the next `$ ` are its expected standard output. `cargo NAME [--] ARGS` runs this crate's
//!   binary NAME (as the project's cargo aliases do); a command ending in ` &` runs in the
//!   background until the page ends, and only its first line is compared;
//! - in expected output, a line `...` matches any lines, a line ending in `...` any line that
//!   starts with what comes before; an HTML comment `<!-- tutorial: numbers within X -->`
//!   before a block lets each number of its output differ by X (a served run's timing varies),
//!   else output must be equal.
//!
//! A step that fails names the page, the step and what differs.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One thing a page asks for, in order.
#[derive(Debug)]
enum Step {
    /// Write a file.
    File { path: String, text: String },
    /// Run a command; its expected output, the tolerance of its numbers.
    Run {
        command: String,
        expected: Vec<String>,
        tolerance: f64,
    },
}

/// The steps of a tutorial page.
fn steps(page: &str) -> Vec<Step> {
    let mut out = Vec::new();
    let mut lines = page.lines();
    let mut tolerance = 0.0;
    while let Some(line) = lines.next() {
        if let Some(t) = line
            .trim()
            .strip_prefix("<!-- tutorial: numbers within ")
            .and_then(|r| r.strip_suffix(" -->"))
        {
            tolerance = t.parse().expect("a number after `numbers within`");
            continue;
        }
        let Some(info) = line.strip_prefix("```") else {
            continue;
        };
        let block: Vec<&str> = lines
            .by_ref()
            .take_while(|l| !l.starts_with("```"))
            .collect();
        if info == "console" {
            out.extend(
                ballpod_host::docs::console_steps(block.iter().copied())
                    .into_iter()
                    .map(|(command, expected)| Step::Run {
                        command,
                        expected,
                        tolerance,
                    }),
            );
        } else if let Some(path) = block.first().and_then(|l| l.strip_prefix("# file: ")) {
            out.push(Step::File {
                path: path.trim().to_string(),
                text: block.join("\n") + "\n",
            });
        }
        tolerance = 0.0;
    }
    out
}

/// A line cut into numbers and the text between them.
fn pieces(line: &str) -> Vec<Result<f64, String>> {
    let mut out: Vec<Result<f64, String>> = Vec::new();
    let b = line.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let start = i;
        let digit_at = |k: usize| b.get(k).is_some_and(u8::is_ascii_digit);
        let number_starts = digit_at(i) || (b[i] == b'-' && digit_at(i + 1));
        if number_starts {
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || (b[i] == b'.' && digit_at(i + 1))) {
                i += 1;
            }
            out.push(Ok(line[start..i].parse().expect("digits")));
        } else {
            // one character (µ, ″ are more than a byte)
            i += line[i..].chars().next().map_or(1, char::len_utf8);
            match out.last_mut() {
                Some(Err(text)) => text.push_str(&line[start..i]),
                _ => out.push(Err(line[start..i].to_string())),
            }
        }
    }
    out
}

/// Whether an output line is the expected one (numbers within `tolerance`).
fn line_matches(expected: &str, actual: &str, tolerance: f64) -> bool {
    if let Some(prefix) = expected.strip_suffix("...") {
        return actual.starts_with(prefix);
    }
    if tolerance == 0.0 {
        return expected == actual;
    }
    let (e, a) = (pieces(expected), pieces(actual));
    e.len() == a.len()
        && e.iter().zip(&a).all(|(e, a)| match (e, a) {
            (Ok(x), Ok(y)) => (x - y).abs() <= tolerance,
            (Err(x), Err(y)) => x == y,
            _ => false,
        })
}

/// Whether the output is the expected (`...` lines match any lines).
fn output_matches(expected: &[String], actual: &[&str], tolerance: f64) -> bool {
    match expected.split_first() {
        None => actual.is_empty(),
        Some((e, rest)) if e == "..." => {
            (0..=actual.len()).any(|k| output_matches(rest, &actual[k..], tolerance))
        }
        Some((e, rest)) => actual.split_first().is_some_and(|(a, more)| {
            line_matches(e, a, tolerance) && output_matches(rest, more, tolerance)
        }),
    }
}

/// A folder with `cargo`: a script that runs this crate's binaries as the project's aliases
/// would (`cargo sim -- ARGS` → the `sim` binary with ARGS).
fn cargo_shim(dir: &Path) -> PathBuf {
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_sim"))
        .parent()
        .expect("the binaries' folder")
        .to_path_buf();
    let shim = dir.join(".shim");
    std::fs::create_dir_all(&shim).unwrap();
    let script = format!(
        "#!/bin/sh\nname=$1; shift; [ \"$1\" = \"--\" ] && shift\nexec \"{}/$name\" \"$@\"\n",
        bin_dir.display()
    );
    let path = shim.join("cargo");
    std::fs::write(&path, script).unwrap();
    Command::new("chmod").arg("+x").arg(&path).status().unwrap();
    shim
}

/// Runs a page's steps; the first failure, named.
fn run_page(name: &str) -> Result<(), String> {
    let page = std::fs::read_to_string(root().join("docs/src").join(name)).unwrap();
    let dir = std::env::temp_dir().join(format!("ballpod-tutorial-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let shim = cargo_shim(&dir);
    let path = format!(
        "{}:{}",
        shim.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut background: Vec<Child> = Vec::new();
    let result = (|| {
        for (k, step) in steps(&page).into_iter().enumerate() {
            let n = k + 1;
            match step {
                Step::File { path, text } => {
                    let p = dir.join(&path);
                    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
                    std::fs::write(p, text).map_err(|e| format!("{name} step {n}: {path}: {e}"))?;
                }
                Step::Run {
                    command,
                    expected,
                    tolerance,
                } => {
                    let said = |why: String| format!("{name} step {n} (`$ {command}`): {why}");
                    let mut cmd = Command::new("bash");
                    cmd.current_dir(&dir).env("PATH", &path);
                    if let Some(c) = command.strip_suffix(" &") {
                        let mut child = cmd
                            .arg("-c")
                            .arg(format!("exec {c}"))
                            .stdout(Stdio::piped())
                            .stderr(Stdio::null())
                            .spawn()
                            .map_err(|e| said(e.to_string()))?;
                        let out = child.stdout.take().unwrap();
                        background.push(child);
                        let (tx, rx) = mpsc::channel();
                        std::thread::spawn(move || {
                            let mut first = String::new();
                            let _ = BufReader::new(out).read_line(&mut first);
                            let _ = tx.send(first);
                        });
                        let first = rx
                            .recv_timeout(Duration::from_secs(120))
                            .map_err(|_| said("no output in 120 s".into()))?;
                        let first = first.trim_end();
                        if !output_matches(&expected[..1.min(expected.len())], &[first], tolerance)
                        {
                            return Err(said(format!(
                                "printed {first:?}, the page shows {expected:?}"
                            )));
                        }
                    } else {
                        let out = cmd
                            .arg("-c")
                            .arg(&command)
                            .output()
                            .map_err(|e| said(e.to_string()))?;
                        let text = String::from_utf8_lossy(&out.stdout);
                        let lines: Vec<&str> = text.lines().collect();
                        if !out.status.success() {
                            return Err(said(format!(
                                "exit {:?}: {}{}",
                                out.status.code(),
                                text,
                                String::from_utf8_lossy(&out.stderr)
                            )));
                        }
                        if !output_matches(&expected, &lines, tolerance) {
                            return Err(said(format!(
                                "printed\n{}\nthe page shows\n{}",
                                lines.join("\n"),
                                expected.join("\n")
                            )));
                        }
                    }
                }
            }
        }
        Ok(())
    })();
    for mut c in background {
        let _ = c.kill();
        let _ = c.wait();
    }
    if result.is_ok() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

#[test]
fn the_comparison_is_strict_where_the_page_is() {
    // what the runner itself must catch: another word, another number, a missing line
    assert!(line_matches(
        "G_ccw 21.97,0.03,UM",
        "G_ccw 21.99,0.03,UM",
        0.1
    ));
    assert!(!line_matches(
        "G_ccw 21.97,0.03,UM",
        "G_ccw 22.17,0.03,UM",
        0.1
    ));
    assert!(!line_matches(
        "G_ccw 21.97,0.03,UM",
        "G_cw 21.97,0.03,UM",
        0.1
    ));
    assert!(!line_matches("x 1", "x 1.0001", 0.0));
    // units of more than a byte between numbers
    assert!(line_matches(
        "+53.1 µm (u 0.1 µm)",
        "+53.2 µm (u 0.1 µm)",
        0.2
    ));
    assert!(!line_matches("+53.1 µm", "+53.1 mm", 0.2));
    assert!(line_matches(
        "{\"can_port\":...",
        "{\"can_port\":4242}",
        0.0
    ));
    let lines = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(output_matches(
        &lines(&["a", "...", "z"]),
        &["a", "b", "c", "z"],
        0.0
    ));
    assert!(!output_matches(&lines(&["a", "z"]), &["a", "b", "z"], 0.0));
    assert!(!output_matches(&lines(&["a", "b"]), &["a"], 0.0));
}

#[test]
fn every_tutorial_runs_as_written() {
    let mut pages: Vec<String> = std::fs::read_dir(root().join("docs/src"))
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("tutorial-") && n.ends_with(".md"))
        .collect();
    pages.sort();
    assert!(!pages.is_empty(), "no tutorial page in docs/src");
    let failures: Vec<String> = pages.iter().filter_map(|p| run_page(p).err()).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

//! The commands of the docs, run as `rustdoc` runs doctests and `mdbook test` a book's code: every
//! `ftpd3d …` command in a fenced block of README.md and docs/*.md runs here with a tiny budget, so
//! a doc that drifts from the tool fails CI.
//!
//! - **Commands.** In ```` ```sh ```` blocks every line, joined over `\` continuations, its `#`
//!   comment dropped and split at `&&`, `||`, `;` and `|`, whose program is `ftpd3d`,
//!   `target/release/ftpd3d` or `cargo run --release --`. In ```` ```text ```` blocks (transcripts)
//!   the lines after `$ `; the lines up to the next `$ ` are its output. Lines of other programs
//!   (setup and gallery scripts, `cargo test`, `cargo xtask`, Python, valgrind, the Slurm scripts,
//!   which `merge::slurm_examples_split_run_and_merge_without_slurm` runs) are not run here.
//! - **How.** A doc's commands run in order in one temporary directory with `scenes/` linked to the
//!   shipped scenes, so relative outputs (`-o a.exr`, the default `out/…`) land there and a later
//!   `merge`, `separatrices` or `--resume` reads what an earlier command of the same doc wrote;
//!   `*` in an argument is expanded there as a shell would. Budgets are made tiny ([`tiny`]):
//!   `--res` ≤ 16, `--size` within 16×16, `--volume` ≤ 8 a side, `--spp`, `--pass-spp` and
//!   `--batches` ≤ 8, converge's `--max-spp` ≤ 16 and `--start-spp` ≤ 4, each added where a run
//!   would otherwise take the default; `--time`, `--target-error` and `--checkpoint-every` stay as
//!   written, since the sample budget ends the run first.
//! - **Checks.** Exit status 0; every EXR or VTI the command writes has valid cells, a finite σ
//!   (`ftpd`) in each and σ > 0 somewhere; with `--window U0,V0,U1,V1` the field's plane is that
//!   window; a file a line's comment names (`# out/x.vti`) is there afterwards; every command but
//!   `bench`, `--explain`, `--help` and `--version` writes a field.
//!   A `view` command serves until stopped: it must print its URL, serve the page and a PNG of
//!   the field, and end within 5 s of SIGTERM.
//! - **Error examples.** A transcript whose output has a line `error: MESSAGE` must fail with that
//!   line on stderr (`…` in it stands for text that depends on the machine). It runs as written,
//!   without a budget substituted, since a bad value is refused before any work.
//! - **Synopses.** A block after a `<!-- synopsis -->` line shows placeholders (`FILE`, `[flags]`):
//!   not run, but every flag it names must be one the command's `--help` lists.
//! - **Skips.** [`SKIP`] names each command that cannot run here and why; an entry that matches no
//!   command fails the test, so the list cannot outlive what it excuses.

use crate::support::{TempDir, exr_parts, ftpd3d_attribute, ftpd3d_in, read_vti, temp_dir};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// Commands that cannot run on a test machine: (doc, a piece of the command's text, why).
const SKIP: &[(&str, &str, &str)] = &[];

const SUBCOMMANDS: &[&str] = &["bench", "merge", "converge", "separatrices", "help", "view"];

/// What a command of a doc must do.
#[derive(Debug, PartialEq)]
enum Expect {
    Success,
    /// Fail with this line on stderr (`…`: any text).
    Fails(String),
}

/// One `ftpd3d` command of a doc.
#[derive(Debug, PartialEq)]
struct DocCommand {
    /// Where it starts: `docs/guide.md:549`.
    at: String,
    /// The line as written, continuations joined.
    text: String,
    /// Its arguments after the program, quotes removed.
    args: Vec<String>,
    /// Its `#` comment, if any.
    comment: String,
    expect: Expect,
}

/// What a doc shows: commands to run, synopsis lines to check against `--help`, lines it cannot
/// read as commands.
#[derive(Debug, Default)]
struct Extracted {
    commands: Vec<DocCommand>,
    synopses: Vec<(String, Vec<String>)>,
    unreadable: Vec<String>,
}

/// The commands of `text` (markdown), named `doc` in their places.
fn extract(doc: &str, text: &str) -> Extracted {
    let mut out = Extracted::default();
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    let mut previous = "";
    while i < lines.len() {
        let line = lines[i];
        let trimmed = line.trim_start();
        // An opening fence: three or more backticks and an info string without one.
        let fence = trimmed.starts_with("```") && !trimmed.trim_start_matches('`').contains('`');
        if !fence {
            if !line.trim().is_empty() {
                previous = line.trim();
            }
            i += 1;
            continue;
        }
        let indent = line.len() - trimmed.len();
        let lang = trimmed[3..]
            .split_whitespace()
            .next()
            .unwrap_or("")
            .to_string();
        let synopsis = previous == "<!-- synopsis -->";
        let first = i + 1;
        let mut body = Vec::new();
        i += 1;
        while i < lines.len() && !lines[i].trim_start().starts_with("```") {
            let l = lines[i];
            let strip = l.len() - l.trim_start().len();
            body.push(&l[strip.min(indent)..]);
            i += 1;
        }
        i += 1;
        previous = "";
        let script = matches!(lang.as_str(), "sh" | "bash" | "shell");
        if !script && !matches!(lang.as_str(), "text" | "console" | "") {
            continue;
        }
        let logical = logical_lines(&body, first + 1);
        for (k, (n, l)) in logical.iter().enumerate() {
            let at = format!("{doc}:{n}");
            let command = if script {
                l.as_str()
            } else if let Some(c) = l.strip_prefix("$ ") {
                c
            } else {
                continue;
            };
            let (code, comment) = split_comment(command);
            for segment in segments(&code, !synopsis) {
                let (rest, assigns) = strip_assignments(&segment);
                let mut head = rest.split_whitespace();
                let first = head.next().unwrap_or("");
                let ours = first == "ftpd3d"
                    || first.ends_with("/ftpd3d")
                    || (first == "cargo" && head.next() == Some("run"));
                if !ours {
                    continue;
                }
                let words = match words(rest) {
                    Ok(_) if assigns => Err("sets environment variables, which this test does not"),
                    w => w,
                };
                let words = match words {
                    Ok(w) => w,
                    Err(e) => {
                        out.unreadable
                            .push(format!("{at}: `{}`: {e}", segment.trim()));
                        continue;
                    }
                };
                let Some(args) = ftpd3d_args(&words) else {
                    continue;
                };
                if synopsis {
                    out.synopses.push((at.clone(), args));
                    continue;
                }
                // A transcript's output runs to its next command.
                let error = logical[k + 1..]
                    .iter()
                    .take_while(|(_, o)| !o.starts_with("$ "))
                    .find_map(|(_, o)| o.starts_with("error: ").then(|| o.trim().to_string()));
                let expect = match error {
                    Some(e) if !script => Expect::Fails(e),
                    _ => Expect::Success,
                };
                out.commands.push(DocCommand {
                    at: at.clone(),
                    text: command.trim().to_string(),
                    args,
                    comment: comment.clone(),
                    expect,
                });
            }
        }
    }
    out
}

/// The lines of a block with `\` continuations joined, each with its line number in the file.
fn logical_lines(body: &[&str], first: usize) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut open = false;
    for (k, l) in body.iter().enumerate() {
        let (text, continues) = match l.trim_end().strip_suffix('\\') {
            Some(t) => (t.to_string(), true),
            None => (l.to_string(), false),
        };
        match out.last_mut() {
            Some((_, acc)) if open => acc.push_str(&format!(" {}", text.trim())),
            _ => out.push((first + k, text)),
        }
        open = continues;
    }
    out
}

/// A shell line split into its code and its `#` comment (a `#` that starts a word outside quotes).
fn split_comment(line: &str) -> (String, String) {
    let mut quote = None;
    let mut prev = ' ';
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, '#') if prev.is_whitespace() => {
                return (line[..i].to_string(), line[i + 1..].trim().to_string());
            }
            _ => {}
        }
        prev = c;
    }
    (line.to_string(), String::new())
}

/// The commands of a line, split at `&&`, `||`, `;`, `&` and (`pipes`) `|` outside quotes.
fn segments(code: &str, pipes: bool) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quote = None;
    for c in code.chars() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, ';' | '&') | (None, '|') if c != '|' || pipes => {
                if !out.last().unwrap().trim().is_empty() {
                    out.push(String::new());
                }
                continue;
            }
            _ => {}
        }
        out.last_mut().unwrap().push(c);
    }
    out.retain(|s| !s.trim().is_empty());
    out
}

/// A command without the variable assignments before it (`A=1 B=2 cmd`), and whether it had any.
fn strip_assignments(segment: &str) -> (&str, bool) {
    let mut rest = segment.trim_start();
    let mut any = false;
    loop {
        let token = rest.split_whitespace().next().unwrap_or("");
        let name = token.split('=').next().unwrap_or("");
        let assignment = token.contains('=')
            && !name.is_empty()
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !assignment {
            return (rest, any);
        }
        rest = rest[token.len()..].trim_start();
        any = true;
    }
}

/// The words of a command as the shell gives them: quotes removed; a variable is refused, as this
/// test would not know its value.
fn words(segment: &str) -> Result<Vec<String>, &'static str> {
    let mut out = Vec::new();
    let mut word: Option<String> = None;
    let mut quote = None;
    for c in segment.chars() {
        match (quote, c) {
            (None, '"' | '\'') => {
                quote = Some(c);
                word.get_or_insert_with(String::new);
            }
            (Some(q), _) if c == q => quote = None,
            (None, c) if c.is_whitespace() => out.extend(word.take()),
            (q, '$') if q != Some('\'') => return Err("uses a shell variable"),
            _ => word.get_or_insert_with(String::new).push(c),
        }
    }
    if quote.is_some() {
        return Err("an unclosed quote");
    }
    out.extend(word);
    Ok(out)
}

/// The arguments of `words` when its program is ftpd3d.
fn ftpd3d_args(words: &[String]) -> Option<Vec<String>> {
    let first = words.first()?;
    if first == "ftpd3d" || first.ends_with("/ftpd3d") {
        return Some(words[1..].to_vec());
    }
    if words.len() >= 2 && first == "cargo" && words[1] == "run" {
        let dash = words.iter().position(|w| w == "--").unwrap_or(words.len());
        let other = ["--example", "--bin", "-p", "--package"];
        if words[..dash].iter().any(|w| other.contains(&w.as_str())) {
            return None;
        }
        return Some(words[dash.min(words.len() - 1) + 1..].to_vec());
    }
    None
}

/// `args` with a tiny budget (see the module's text); an error for a budget flag written
/// `--flag=value`, which this cannot shrink.
fn tiny(args: &[String]) -> Result<Vec<String>, String> {
    let budgets = [
        "--res",
        "--spp",
        "--pass-spp",
        "--batches",
        "--size",
        "--volume",
        "--max-spp",
        "--start-spp",
    ];
    if let Some(b) = budgets
        .iter()
        .find(|b| args.iter().any(|a| a.starts_with(&format!("{b}="))))
    {
        return Err(format!(
            "write `{b} N`, not `{b}=N`: the test shrinks the budget by flag"
        ));
    }
    let mut a = args.to_vec();
    let has = |a: &[String], f: &str| a.iter().any(|w| w == f);
    match a.first().map(String::as_str) {
        Some("merge" | "separatrices" | "help") => {}
        Some("converge") => {
            cap(&mut a, "--res", 16, true);
            cap(&mut a, "--max-spp", 16, true);
            cap(&mut a, "--start-spp", 4, false);
        }
        Some("bench") => {
            cap(&mut a, "--res", 16, true);
            cap(&mut a, "--spp", 8, true);
        }
        _ if ["--explain", "--help", "-h", "--version", "-V"]
            .iter()
            .any(|f| has(&a, f)) => {}
        _ => {
            if has(&a, "--volume") {
                cap(&mut a, "--volume", 8, false);
            } else if has(&a, "--camera") || has(&a, "--eye") {
                if !has(&a, "--size") {
                    a.extend(["--size".into(), "16,16".into()]);
                }
                cap(&mut a, "--size", 16, false);
            } else {
                cap(&mut a, "--res", 16, true);
            }
            cap(&mut a, "--spp", 8, true);
            cap(&mut a, "--pass-spp", 8, false);
            cap(&mut a, "--batches", 8, false);
        }
    }
    Ok(a)
}

/// The value of `flag` at most `max`: each of a list `A,B,C`, a list of two (`--size W,H`) scaled
/// to keep its aspect; added as `flag max` where absent and `add`. A value that is not a number is
/// left for the tool to refuse.
fn cap(args: &mut Vec<String>, flag: &str, max: u64, add: bool) {
    let Some(i) = args.iter().position(|a| a == flag) else {
        if add {
            args.extend([flag.to_string(), max.to_string()]);
        }
        return;
    };
    let Some(value) = args.get(i + 1) else { return };
    let Ok(n) = value
        .split(',')
        .map(str::parse::<u64>)
        .collect::<Result<Vec<u64>, _>>()
    else {
        return;
    };
    let largest = n.iter().copied().max().unwrap_or(0);
    let small: Vec<u64> = if flag == "--size" && largest > max {
        let scale = max as f64 / largest as f64;
        n.iter()
            .map(|v| ((*v as f64 * scale).round() as u64).max(1))
            .collect()
    } else {
        n.iter().map(|v| (*v).min(max)).collect()
    };
    args[i + 1] = small
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(",");
}

/// Whether `text` holds the pieces of `pattern` between its `…`, in order.
fn matches(text: &str, pattern: &str) -> bool {
    let mut rest = text;
    for piece in pattern.split('…') {
        match rest.find(piece) {
            Some(i) => rest = &rest[i + piece.len()..],
            None => return false,
        }
    }
    true
}

/// `args` with each word holding `*` replaced by the files of `dir` it matches, sorted (kept as
/// it is when none does, as the shell does).
fn expand_globs(dir: &Path, args: Vec<String>) -> Vec<String> {
    let wildcard = |pattern: &str, name: &str| {
        let pieces: Vec<&str> = pattern.split('*').collect();
        let (head, tail) = (pieces[0], pieces[pieces.len() - 1]);
        if !name.starts_with(head) || name.len() < head.len() + tail.len() {
            return false;
        }
        let mut rest = &name[head.len()..name.len() - tail.len()];
        for p in &pieces[1..pieces.len() - 1] {
            match rest.find(p) {
                Some(i) => rest = &rest[i + p.len()..],
                None => return false,
            }
        }
        name.ends_with(tail)
    };
    args.into_iter()
        .flat_map(|a| {
            if !a.contains('*') {
                return vec![a];
            }
            let (parent, pattern) = a.rsplit_once('/').unwrap_or(("", &a));
            let mut found: Vec<String> = std::fs::read_dir(dir.join(parent))
                .into_iter()
                .flatten()
                .filter_map(|e| e.ok()?.file_name().into_string().ok())
                .filter(|n| wildcard(pattern, n))
                .map(|n| {
                    if parent.is_empty() {
                        n
                    } else {
                        format!("{parent}/{n}")
                    }
                })
                .collect();
            found.sort();
            if found.is_empty() { vec![a] } else { found }
        })
        .collect()
}

/// The files under `dir` (not through links) with their modification times.
fn snapshot(dir: &Path) -> HashMap<PathBuf, SystemTime> {
    let mut out = HashMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let Ok(meta) = std::fs::symlink_metadata(e.path()) else {
                continue;
            };
            if meta.is_dir() {
                todo.push(e.path());
            } else if meta.is_file() {
                out.insert(e.path(), meta.modified().unwrap());
            }
        }
    }
    out
}

/// What is wrong with a field file, if anything: no valid cell, a valid cell with a σ that is not
/// finite, σ = 0 everywhere, or (`window`) a plane other than the window.
fn check_field(path: &Path, window: Option<[f64; 4]>) -> Result<(), String> {
    let read = |f: &dyn Fn() -> (Vec<f32>, Vec<bool>, Option<String>)| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))
            .map_err(|_| "unreadable (the reader panicked, see above)".to_string())
    };
    let (sigma, valid, size) = if path.extension().is_some_and(|e| e == "vti") {
        read(&|| {
            let v = read_vti(path);
            let valid = v.u8s("valid").iter().map(|x| *x > 0).collect();
            (v.f32s("ftpd").to_vec(), valid, None)
        })?
    } else {
        read(&|| {
            let parts = exr_parts(path);
            let channel = |name: &str| -> Vec<f32> {
                let list = &parts[0].channel_data.list;
                let c = list.iter().find(|c| c.name.to_string() == name);
                c.unwrap_or_else(|| panic!("no channel {name}"))
                    .sample_data
                    .values_as_f32()
                    .collect()
            };
            let valid = channel("valid").iter().map(|x| *x > 0.0).collect();
            (
                channel("ftpd"),
                valid,
                ftpd3d_attribute(&parts[0], "plane.size"),
            )
        })?
    };
    let cells: Vec<f32> = sigma
        .iter()
        .zip(&valid)
        .filter(|(_, v)| **v)
        .map(|(s, _)| *s)
        .collect();
    if cells.is_empty() {
        return Err("no valid cell".into());
    }
    if let Some(s) = cells.iter().find(|s| !s.is_finite()) {
        return Err(format!("a valid cell has σ = {s}"));
    }
    if !cells.iter().any(|s| *s > 0.0) {
        return Err(format!("σ = 0 in all {} valid cells", cells.len()));
    }
    if let Some([u0, v0, u1, v1]) = window {
        let want = [u1 - u0, v1 - v0];
        let got: Vec<f64> = size
            .as_deref()
            .unwrap_or("")
            .split(',')
            .filter_map(|x| x.parse().ok())
            .collect();
        let close = got.len() == 2 && (0..2).all(|k| (got[k] - want[k]).abs() <= 1e-9 * want[k]);
        if !close {
            return Err(format!(
                "the plane is {} (ftpd3d.plane.size), not the window's {},{}",
                size.unwrap_or_default(),
                want[0],
                want[1]
            ));
        }
    }
    Ok(())
}

/// The value of `flag` in `args`.
fn value<'a>(args: &'a [String], flag: &str) -> Option<&'a str> {
    let i = args.iter().position(|a| a == flag)?;
    args.get(i + 1).map(String::as_str)
}

/// Runs the commands of one doc in order in a fresh directory; what went wrong, one line each.
fn run_doc(doc: &str, commands: &[DocCommand]) -> (TempDir, Vec<String>) {
    let dir = temp_dir("docs_commands", &doc.replace(['/', '.'], "_"));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::os::unix::fs::symlink(root.join("scenes"), dir.join("scenes")).unwrap();
    let mut failures = Vec::new();
    for c in commands {
        let mut fail = |why: String| failures.push(format!("{}: `{}`: {why}", c.at, c.text));
        let args = match (&c.expect, tiny(&c.args)) {
            (Expect::Fails(_), _) => c.args.clone(),
            (Expect::Success, Ok(a)) => a,
            (Expect::Success, Err(e)) => {
                fail(e);
                continue;
            }
        };
        let args = expand_globs(&dir, args);
        if args.first().is_some_and(|a| a == "view") && c.expect == Expect::Success {
            // A server runs until stopped: it must serve its picture and stop on SIGTERM.
            let refs: Vec<&str> = args[1..].iter().map(String::as_str).collect();
            if let Err(e) = crate::view::doc_command_serves_and_stops(&dir, &refs) {
                fail(e);
            }
            continue;
        }
        let before = snapshot(&dir);
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let run = ftpd3d_in(&dir, &refs);
        let shown: Vec<String> = args
            .iter()
            .map(|a| {
                if a.contains(' ') {
                    format!("\"{a}\"")
                } else {
                    a.clone()
                }
            })
            .collect();
        let ran = format!("ran as `ftpd3d {}`", shown.join(" "));
        if let Expect::Fails(message) = &c.expect {
            if run.ok || !matches(&run.err, message) {
                fail(format!(
                    "{ran}: expected to fail with `{message}`, {}; stderr:\n{}",
                    if run.ok {
                        "it succeeded"
                    } else {
                        "it failed otherwise"
                    },
                    run.err
                ));
            }
            continue;
        }
        if !run.ok {
            fail(format!("{ran}: failed:\n{}", run.err));
            continue;
        }
        let after = snapshot(&dir);
        let mut written: Vec<&PathBuf> = after
            .iter()
            .filter(|(p, t)| before.get(*p) != Some(t))
            .map(|(p, _)| p)
            .filter(|p| p.extension().is_some_and(|e| e == "exr" || e == "vti"))
            .collect();
        written.sort();
        let window = value(&args, "--window").and_then(|w| {
            let v: Vec<f64> = w.split(',').filter_map(|x| x.parse().ok()).collect();
            <[f64; 4]>::try_from(v).ok()
        });
        for p in &written {
            if let Err(e) = check_field(p, window) {
                fail(format!(
                    "{ran}: {}: {e}",
                    p.strip_prefix(&*dir).unwrap().display()
                ));
            }
        }
        let writes_nothing = args.first().is_some_and(|a| a == "bench")
            || ["--explain", "--help", "-h", "--version", "-V"]
                .iter()
                .any(|f| args.iter().any(|a| a == f));
        if written.is_empty() && !writes_nothing {
            fail(format!("{ran}: wrote no field (.exr or .vti)"));
        }
        let exts = [".exr", ".vti", ".vtp", ".svg", ".png", ".csv"];
        for named in c.comment.split_whitespace() {
            let named = named.trim_matches(|ch: char| ",;:()".contains(ch));
            let a_file = named.contains('/') && exts.iter().any(|e| named.ends_with(e));
            if a_file && !dir.join(named).is_file() {
                fail(format!(
                    "{ran}: its comment names {named}, which it did not write"
                ));
            }
        }
    }
    (dir, failures)
}

/// README.md and docs/*.md with their texts.
fn docs() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut names = vec!["README.md".to_string()];
    let mut pages: Vec<String> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    pages.sort();
    names.extend(pages);
    names
        .into_iter()
        .map(|n| {
            let text = std::fs::read_to_string(root.join(&n)).unwrap();
            (n, text)
        })
        .collect()
}

#[test]
fn every_command_of_the_docs_runs_as_shown() {
    let mut failures = Vec::new();
    let mut used = vec![false; SKIP.len()];
    let mut plans = Vec::new();
    let mut synopses = Vec::new();
    for (doc, text) in docs() {
        let e = extract(&doc, &text);
        failures.extend(e.unreadable);
        synopses.extend(e.synopses);
        let mut run = Vec::new();
        for c in e.commands {
            match SKIP
                .iter()
                .position(|(d, piece, _)| *d == doc && c.text.contains(piece))
            {
                Some(k) => {
                    used[k] = true;
                    eprintln!("skipped {}: `{}`: {}", c.at, c.text, SKIP[k].2);
                }
                None => run.push(c),
            }
        }
        plans.push((doc, run));
    }
    let count: usize = plans.iter().map(|(_, r)| r.len()).sum();
    assert!(count >= 30, "only {count} commands found in the docs");
    for (k, (doc, piece, _)) in SKIP.iter().enumerate() {
        if !used[k] {
            failures.push(format!(
                "SKIP: no command of {doc} holds `{piece}`: remove the entry"
            ));
        }
    }
    failures.extend(check_synopses(&synopses));
    // One thread a doc: each runs its commands in order, the docs side by side.
    let results: Vec<(TempDir, Vec<String>)> = std::thread::scope(|s| {
        let handles: Vec<_> = plans
            .iter()
            .map(|(doc, run)| s.spawn(move || run_doc(doc, run)))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut dirs = Vec::new();
    for (dir, f) in results {
        failures.extend(f);
        dirs.push(dir);
    }
    // The directories are kept when this fails (TempDir), to look at the files.
    assert!(
        failures.is_empty(),
        "{} of the docs' {count} commands do not do what the docs show:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Every flag a synopsis line names is one its command's `--help` lists.
fn check_synopses(synopses: &[(String, Vec<String>)]) -> Vec<String> {
    let mut helps: HashMap<&str, String> = HashMap::new();
    let mut failures = Vec::new();
    for (at, args) in synopses {
        let sub = args
            .first()
            .map(String::as_str)
            .filter(|a| SUBCOMMANDS.contains(a))
            .unwrap_or("");
        let help = helps.entry(sub).or_insert_with(|| {
            let run = ftpd3d_in(
                Path::new("."),
                &[sub, "--help"][usize::from(sub.is_empty())..],
            );
            assert!(run.ok, "ftpd3d {sub} --help: {}", run.err);
            run.out
        });
        let flags = args
            .iter()
            .flat_map(|a| a.split(['[', ']', '|', ',', ';', '.', '=']))
            .filter(|w| {
                w.starts_with('-')
                    && w[1..].starts_with(|c: char| c.is_ascii_alphabetic() || c == '-')
            });
        for flag in flags {
            let listed = help.match_indices(flag).any(|(i, _)| {
                !help[i + flag.len()..].starts_with(|c: char| c.is_ascii_alphanumeric() || c == '-')
            });
            if !listed {
                failures.push(format!(
                    "{at}: synopsis names {flag}, which `ftpd3d {sub} --help` does not list"
                ));
            }
        }
    }
    failures
}

#[test]
fn commands_are_read_as_the_shell_reads_them() {
    let md = r#"Text.

```sh
ftpd3d --scene a.obj \
  --slice z=0   # writes out/a_z0.exr
scripts/setup.sh && cargo run --release -- --scene "b c.obj" -o x.exr
cargo xtask converge --baseline /bin/ftpd3d-1 --slice z=0
cargo run --release --example radiance_png -- f.exr o.png
target/release/ftpd3d merge part_*.exr -o all.exr; ftpd3d --help | head
```

```text
$ ftpd3d --scene c.obj --volume 2000
scene c.obj: 12 triangles
error: --volume 2000: … would fit
$ ftpd3d --scene c.obj --explain
features   diffuse
```

<!-- synopsis -->
```sh
ftpd3d merge a.exr ... -o all.exr [--no-png]
```

```python
ftpd3d.Scene("x")
```
"#;
    let e = extract("t.md", md);
    let got: Vec<(&str, String, &str, &Expect)> = e
        .commands
        .iter()
        .map(|c| {
            (
                c.at.as_str(),
                c.args.join(" "),
                c.comment.as_str(),
                &c.expect,
            )
        })
        .collect();
    let fails = Expect::Fails("error: --volume 2000: … would fit".into());
    assert_eq!(
        got,
        [
            (
                "t.md:4",
                "--scene a.obj --slice z=0".into(),
                "writes out/a_z0.exr",
                &Expect::Success
            ),
            (
                "t.md:6",
                "--scene b c.obj -o x.exr".into(),
                "",
                &Expect::Success
            ),
            (
                "t.md:9",
                "merge part_*.exr -o all.exr".into(),
                "",
                &Expect::Success
            ),
            ("t.md:9", "--help".into(), "", &Expect::Success),
            ("t.md:13", "--scene c.obj --volume 2000".into(), "", &fails),
            (
                "t.md:16",
                "--scene c.obj --explain".into(),
                "",
                &Expect::Success
            ),
        ]
    );
    assert_eq!(e.synopses.len(), 1);
    assert_eq!(e.synopses[0].0, "t.md:22");
    assert!(e.unreadable.is_empty(), "{:?}", e.unreadable);
    assert!(matches(
        "error: --volume 2000: 8e9 voxels … 442 would fit",
        "error: --volume 2000: … would fit"
    ));
    assert!(!matches(
        "error: --volume 2000: too big",
        "error: --volume 2000: … would fit"
    ));
    let e = extract("v.md", "```sh\nftpd3d --scene $SCENE\n```\n");
    assert_eq!(
        e.unreadable,
        ["v.md:2: `ftpd3d --scene $SCENE`: uses a shell variable"]
    );
}

#[test]
fn budgets_are_made_tiny() {
    let t = |a: &str| {
        let args: Vec<String> = a.split_whitespace().map(String::from).collect();
        tiny(&args).map(|v| v.join(" "))
    };
    assert_eq!(
        t("--scene s.obj --slice z=0 --res 512 --spp 256 --batches 16").unwrap(),
        "--scene s.obj --slice z=0 --res 16 --spp 8 --batches 8"
    );
    assert_eq!(
        t("--scene s.obj --slice z=0 --res 8 --time 2h").unwrap(),
        "--scene s.obj --slice z=0 --res 8 --time 2h --spp 8"
    );
    assert_eq!(
        t("--scene s.obj --volume 96,48,8 --spp 4").unwrap(),
        "--scene s.obj --volume 8,8,8 --spp 4"
    );
    assert_eq!(
        t("--scene s.toml --camera arcade --size 320,240").unwrap(),
        "--scene s.toml --camera arcade --size 16,12 --spp 8"
    );
    assert_eq!(
        t("--scene s.obj --eye 0,1,3 --target 0,1,0").unwrap(),
        "--scene s.obj --eye 0,1,3 --target 0,1,0 --size 16,16 --spp 8"
    );
    assert_eq!(
        t("converge --scene s.obj --slice z=0 --start-spp 8 --out-dir d").unwrap(),
        "converge --scene s.obj --slice z=0 --start-spp 4 --out-dir d --res 16 --max-spp 16"
    );
    assert_eq!(
        t("merge a.exr b.exr -o all.exr").unwrap(),
        "merge a.exr b.exr -o all.exr"
    );
    assert_eq!(
        t("--scene s.obj --explain").unwrap(),
        "--scene s.obj --explain"
    );
    assert!(t("--scene s.obj --slice z=0 --res=512").is_err());
}

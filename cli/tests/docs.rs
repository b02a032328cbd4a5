//! The documentation's console examples run as tests: every ```` ```console ````
//! block of README.md and docs/*.md is a transcript, and each `$ ` command in
//! it is run (through `sh -c`, the `itgfx` under test first on `PATH`) and
//! its output compared with the lines the transcript shows.
//!
//! A transcript's rules, so that examples stay readable:
//! * A command is a line starting with `$ `; a trailing `\` continues it on
//!   the next line. The lines up to the next command (trailing blank lines
//!   dropped) are its expected output, stdout first, then stderr; none means
//!   the output is not checked, only the exit code.
//! * Two spaces and `#` start a reader's comment, stripped before comparing
//!   (`H_P  9.228819 bits     # Table 6: 9.229`). A comment saying
//!   `exit code N` sets the expected exit code (default 0).
//! * `[..]` or `…` inside a line matches any text (timings, long JSON); a line
//!   that is only `...` or `…` matches any number of lines.
//! * Each file's commands share one fresh working directory, in order, so an
//!   example can make the input the next one reads. `../shared` from there is
//!   the shared data folder beside the checkout (`../shared/data/meshes/…`
//!   works as in the prose); files whose examples need it fail when it is
//!   missing rather than skip.
//!
//! Only `console` blocks run; `sh` blocks show how to build or run long jobs.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// One `$ ` command of a transcript and what it should print.
#[derive(Debug)]
struct Example {
    /// File and line, for messages.
    at: String,
    command: String,
    expected: Vec<String>,
    exit: i32,
}

/// Strips a reader's comment (`  # …`) and trailing space; returns the line
/// and the comment.
fn split_comment(line: &str) -> (&str, Option<&str>) {
    match line.find("  #") {
        Some(i) => (line[..i].trim_end(), Some(line[i + 3..].trim())),
        None => (line.trim_end(), None),
    }
}

/// The examples of every `console` block in `text`.
fn examples(file: &str, text: &str) -> Vec<Example> {
    let mut out: Vec<Example> = Vec::new();
    let mut in_block = false;
    let mut continuing = false;
    for (k, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") {
            in_block = !in_block && trimmed.trim_start_matches('`').trim() == "console";
            continuing = false;
            continue;
        }
        if !in_block {
            continue;
        }
        if continuing {
            let ex = out.last_mut().unwrap();
            let part = line.trim();
            continuing = part.ends_with('\\');
            ex.command.push(' ');
            ex.command.push_str(part.trim_end_matches('\\').trim());
            continue;
        }
        if let Some(cmd) = line.strip_prefix("$ ") {
            continuing = cmd.trim_end().ends_with('\\');
            out.push(Example {
                at: format!("{file}:{}", k + 1),
                command: cmd.trim_end().trim_end_matches('\\').trim().to_string(),
                expected: Vec::new(),
                exit: 0,
            });
            continue;
        }
        let Some(ex) = out.last_mut() else { panic!("{file}:{}: output before any `$ ` command", k + 1) };
        let (body, comment) = split_comment(line);
        if let Some(c) = comment
            && let Some(n) = c.strip_prefix("exit code ")
        {
            ex.exit = n.trim().parse().unwrap_or_else(|_| panic!("{file}:{}: bad exit code {n:?}", k + 1));
        }
        ex.expected.push(body.to_string());
    }
    assert!(!in_block, "{file}: a console block is not closed");
    for ex in &mut out {
        while ex.expected.last().is_some_and(|l| l.is_empty()) {
            ex.expected.pop();
        }
    }
    out
}

/// Whether `actual` matches `pattern`, where `[..]` and `…` match any text.
fn line_matches(pattern: &str, actual: &str) -> bool {
    let pattern = pattern.replace('…', "[..]");
    let parts: Vec<&str> = pattern.split("[..]").collect();
    if parts.len() == 1 {
        return pattern == actual.trim_end();
    }
    let actual = actual.trim_end();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !actual.starts_with(first) || actual.len() < first.len() + last.len() || !actual.ends_with(last) {
        return false;
    }
    let mut rest = &actual[first.len()..actual.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}

/// Whether the actual lines match the expected ones (`...` lines match any run).
fn lines_match(expected: &[String], actual: &[&str]) -> bool {
    match expected.first() {
        None => actual.is_empty(),
        Some(e) if e == "..." || e == "…" => (0..=actual.len()).any(|k| lines_match(&expected[1..], &actual[k..])),
        Some(e) => !actual.is_empty() && line_matches(e, actual[0]) && lines_match(&expected[1..], &actual[1..]),
    }
}

/// Runs every example of one markdown file in a fresh directory.
fn run_file(rel: &str) {
    let root = root();
    let text = std::fs::read_to_string(root.join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"));
    let examples = examples(rel, &text);
    if examples.is_empty() {
        return;
    }
    let base = std::env::temp_dir().join(format!("itgfx-docs-{}-{}", rel.replace('/', "-"), std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let work = base.join("work");
    std::fs::create_dir_all(&work).unwrap();
    let shared = root.join("..").join("shared");
    if shared.is_dir() {
        std::os::unix::fs::symlink(&shared, base.join("shared")).unwrap();
    }
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_itgfx")).parent().unwrap().to_path_buf();
    let path = format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap_or_default());
    let mut failures = Vec::new();
    for ex in &examples {
        let out = Command::new("sh")
            .arg("-c")
            .arg(&ex.command)
            .current_dir(&work)
            .env("PATH", &path)
            .output()
            .unwrap_or_else(|e| panic!("{}: sh: {e}", ex.at));
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let actual: Vec<&str> = stdout.lines().chain(stderr.lines()).collect();
        let code = out.status.code().unwrap_or(-1);
        let output_ok = ex.expected.is_empty() || lines_match(&ex.expected, &actual);
        if code != ex.exit || !output_ok {
            failures.push(format!(
                "{}: `{}`\n  exit {code} (expected {})\n  expected:\n    {}\n  actual:\n    {}",
                ex.at,
                ex.command,
                ex.exit,
                ex.expected.join("\n    "),
                actual.join("\n    ")
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&base);
    assert!(failures.is_empty(), "{} of {} examples differ:\n{}", failures.len(), examples.len(), failures.join("\n"));
}

#[test]
fn readme_examples_run_as_shown() {
    run_file("README.md");
}

#[test]
fn docs_examples_run_as_shown() {
    let mut files: Vec<String> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().into_string().unwrap();
            name.ends_with(".md").then(|| format!("docs/{name}"))
        })
        .collect();
    files.sort();
    for f in &files {
        run_file(f);
    }
}

#[test]
fn transcript_rules() {
    let text =
        "```console\n$ echo a \\\n  b\na b  # exit code 0\n\n$ false\n  # exit code 1\n```\n```sh\n$ never\n```\n";
    let ex = examples("t.md", text);
    assert_eq!(ex.len(), 2);
    assert_eq!(ex[0].command, "echo a b");
    assert_eq!(ex[0].expected, ["a b"]);
    assert_eq!(ex[1].exit, 1);
    assert!(line_matches("seconds  [..] s", "seconds  5.25 s"));
    assert!(line_matches("{\"a\":1, …}", "{\"a\":1, \"b\":2}"));
    assert!(!line_matches("H_P  9.22 bits", "H_P  9.23 bits"));
    assert!(!line_matches("a[..]b", "ba"));
    let e: Vec<String> = ["x", "...", "z"].map(String::from).to_vec();
    assert!(lines_match(&e, &["x", "y", "y", "z"]));
    assert!(lines_match(&e, &["x", "z"]));
    assert!(!lines_match(&e, &["x", "y"]));
}

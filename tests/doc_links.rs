//! Broken links in the documentation: README.md, ARCHITECTURE.md and
//! every `docs/*.md`.
//!
//! Every markdown link or image whose target is relative (not `http://`, `https://`,
//! `mailto:` or another scheme) must name a file or folder that exists, relative to
//! the file that links to it. A `#anchor` into a markdown file (or into the linking
//! file itself) must name one of its headings, slugged as GitHub does: lowercase,
//! punctuation other than `-` and `_` dropped, spaces turned into `-`, and `-1`, `-2`,
//! ... added to repeated headings. Each failure names the file, the link and why.
//!
//! No device, no dependency: it reads the files and looks at the file system.

mod common;

use std::collections::HashMap;
use std::fs;
use std::path::{Component, Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The markdown files whose links are checked, relative to the repository root.
fn documents(root: &Path) -> Vec<PathBuf> {
    let mut files = vec![PathBuf::from("README.md"), PathBuf::from("ARCHITECTURE.md")];
    let mut pages: Vec<PathBuf> = fs::read_dir(root.join("docs"))
        .expect("docs/ can be listed")
        .map(|entry| entry.expect("a docs/ entry").path())
        .filter(|path| path.extension().is_some_and(|e| e == "md") && path.is_file())
        .map(|path| PathBuf::from("docs").join(path.file_name().unwrap()))
        .collect();
    pages.sort();
    files.extend(pages);
    files
}

/// A link found in a markdown file: its target as written, and its line.
#[derive(Debug, PartialEq)]
struct Link {
    target: String,
    line: usize,
}

/// The lines of `text` outside fenced code blocks, each with its line number
/// (from 1).
fn outside_fences(text: &str) -> Vec<(usize, &str)> {
    let mut lines = Vec::new();
    let mut fence: Option<String> = None;
    for (index, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some(open) = &fence {
            if trimmed.starts_with(open.as_str()) {
                fence = None;
            }
            continue;
        }
        if let Some(marker) = fence_marker(trimmed) {
            fence = Some(marker);
            continue;
        }
        lines.push((index + 1, line));
    }
    lines
}

/// The lines of `text` outside fenced code blocks, with inline code spans blanked,
/// each with its line number (from 1).
fn prose_lines(text: &str) -> Vec<(usize, String)> {
    outside_fences(text)
        .into_iter()
        .map(|(number, line)| (number, blank_code_spans(line)))
        .collect()
}

/// The run of backticks or tildes that opens a fenced code block, if `trimmed` (a
/// line without its indentation) opens one.
fn fence_marker(trimmed: &str) -> Option<String> {
    let marker: String = trimmed
        .chars()
        .take_while(|&c| c == '`' || c == '~')
        .collect();
    let fenced = marker.len() >= 3 && marker.chars().all(|c| c == marker.chars().next().unwrap());
    fenced.then_some(marker)
}

/// `line` with the contents of inline code spans (`` `...` ``) replaced by spaces, so
/// that code such as `` `a[i](x)` `` is not read as a link.
fn blank_code_spans(line: &str) -> String {
    let chars: Vec<char> = line.chars().collect();
    let mut out = String::with_capacity(line.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        let run = chars[i..].iter().take_while(|&&c| c == '`').count();
        // The closing run of the same length, if any.
        let mut j = i + run;
        let mut close = None;
        while j < chars.len() {
            if chars[j] == '`' {
                let len = chars[j..].iter().take_while(|&&c| c == '`').count();
                if len == run {
                    close = Some(j);
                    break;
                }
                j += len;
            } else {
                j += 1;
            }
        }
        match close {
            Some(end) => {
                out.extend(std::iter::repeat_n(' ', end + run - i));
                i = end + run;
            }
            None => {
                out.extend(&chars[i..i + run]);
                i += run;
            }
        }
    }
    out
}

/// The inline links and images (`[text](target)`, `![alt](target "title")`) and the
/// reference definitions (`[label]: target`) of a markdown text.
fn links(text: &str) -> Vec<Link> {
    let mut found = Vec::new();
    for (number, line) in prose_lines(text) {
        let chars: Vec<char> = line.chars().collect();
        // Reference definitions: `[label]: target` at the start of a line.
        let trimmed = line.trim_start();
        if trimmed.starts_with('[')
            && !trimmed.starts_with("[^")
            && let Some(close) = trimmed.find("]:")
            && !trimmed[1..close].contains('[')
        {
            let rest = trimmed[close + 2..].trim();
            if let Some(target) = rest.split_whitespace().next() {
                found.push(Link {
                    target: target.trim_matches(|c| c == '<' || c == '>').to_string(),
                    line: number,
                });
            }
        }
        // Inline links: `](` closes the text, the target runs to the matching `)`.
        let mut i = 0;
        while i + 1 < chars.len() {
            if chars[i] == ']' && chars[i + 1] == '(' && opens_link_text(&chars, i) {
                let start = i + 2;
                let mut depth = 1;
                let mut j = start;
                while j < chars.len() {
                    match chars[j] {
                        '(' => depth += 1,
                        ')' => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    j += 1;
                }
                if j < chars.len() {
                    let inside: String = chars[start..j].iter().collect();
                    let inside = inside.trim();
                    let target = if let Some(rest) = inside.strip_prefix('<') {
                        rest.split('>').next().unwrap_or("").to_string()
                    } else {
                        inside.split_whitespace().next().unwrap_or("").to_string()
                    };
                    found.push(Link {
                        target,
                        line: number,
                    });
                    i = j;
                }
            }
            i += 1;
        }
    }
    found
}

/// Whether the `]` at `close` ends a link text: a `[` before it on the line, with
/// brackets balanced between them.
fn opens_link_text(chars: &[char], close: usize) -> bool {
    let mut depth = 0;
    for k in (0..close).rev() {
        match chars[k] {
            ']' => depth += 1,
            '[' if depth == 0 => return true,
            '[' => depth -= 1,
            _ => {}
        }
    }
    false
}

/// Whether a link leaves the repository: `http://`, `https://`, `mailto:` or any
/// other `scheme:`.
fn is_external(target: &str) -> bool {
    let lower = target.to_ascii_lowercase();
    if lower.starts_with("http://") || lower.starts_with("https://") || lower.starts_with("mailto:")
    {
        return true;
    }
    match target.find(':') {
        Some(colon) => {
            let scheme = &target[..colon];
            !scheme.is_empty()
                && scheme.chars().next().unwrap().is_ascii_alphabetic()
                && scheme
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '+' || c == '-' || c == '.')
        }
        None => false,
    }
}

/// `%XX` escapes decoded (a link to `my%20file.md` names `my file.md`).
fn percent_decode(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && bytes[i + 1].is_ascii_hexdigit()
            && bytes[i + 2].is_ascii_hexdigit()
        {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).unwrap();
            out.push(u8::from_str_radix(hex, 16).unwrap());
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `path` with `.` and `..` resolved lexically.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other),
        }
    }
    out
}

/// GitHub's anchor for a heading's text: inline links reduced to their text,
/// lowercase, every character but letters, digits, spaces, `-` and `_` dropped,
/// spaces turned into `-`.
fn slug(heading: &str) -> String {
    let text = strip_inline_links(heading);
    text.trim()
        .to_lowercase()
        .chars()
        .filter(|&c| c.is_alphanumeric() || c == ' ' || c == '-' || c == '_')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// `[text](target)` reduced to `text`.
fn strip_inline_links(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(open) = rest.find('[') {
        let after = &rest[open + 1..];
        match after.find("](") {
            Some(close) => match after[close + 2..].find(')') {
                Some(end) => {
                    out.push_str(&rest[..open]);
                    out.push_str(&after[..close]);
                    rest = &after[close + 2 + end + 1..];
                }
                None => break,
            },
            None => break,
        }
    }
    out.push_str(rest);
    out
}

/// The anchors of a markdown text's ATX headings (`#` to `######`), outside code
/// blocks, repeated headings numbered as GitHub numbers them.
fn anchors(text: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = Vec::new();
    for (_, line) in outside_fences(text) {
        let trimmed = line.trim_start();
        // Headings start at the margin (up to three spaces); indented ones are code.
        if line.len() - trimmed.len() > 3 {
            continue;
        }
        let hashes = trimmed.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&hashes) {
            continue;
        }
        let rest = &trimmed[hashes..];
        if !(rest.is_empty() || rest.starts_with(' ')) {
            continue;
        }
        let text = rest.trim().trim_end_matches('#').trim();
        let base = slug(text);
        let count = seen.entry(base.clone()).or_insert(0);
        out.push(if *count == 0 {
            base.clone()
        } else {
            format!("{base}-{count}")
        });
        *count += 1;
    }
    out
}

/// What is wrong with one link of `file` (relative to `root`), if anything.
fn check_link(root: &Path, file: &Path, link: &Link) -> Option<String> {
    let target = link.target.as_str();
    if target.is_empty() {
        return Some("empty target".to_string());
    }
    if is_external(target) {
        return None;
    }
    let (path_part, anchor) = match target.split_once('#') {
        Some((path, anchor)) => (path, Some(anchor)),
        None => (target, None),
    };
    // A query (`?raw=true`) is not part of the file's name.
    let path_part = path_part.split('?').next().unwrap_or("");
    let linked = if path_part.is_empty() {
        file.to_path_buf()
    } else if let Some(from_root) = path_part.strip_prefix('/') {
        normalise(Path::new(&percent_decode(from_root)))
    } else {
        let folder = file.parent().unwrap_or(Path::new(""));
        normalise(&folder.join(percent_decode(path_part)))
    };
    let absolute = root.join(&linked);
    if !absolute.exists() {
        return Some(format!("{} does not exist", linked.display()));
    }
    let anchor = anchor?;
    if anchor.is_empty() {
        return Some("empty anchor `#`".to_string());
    }
    if absolute.extension().is_none_or(|e| e != "md") {
        // Anchors into other files (line numbers in source, say) are not checked.
        return None;
    }
    let text = match fs::read_to_string(&absolute) {
        Ok(text) => text,
        Err(e) => return Some(format!("{} cannot be read: {e}", linked.display())),
    };
    let anchors = anchors(&text);
    let wanted = percent_decode(anchor).to_lowercase();
    if anchors.contains(&wanted) {
        None
    } else {
        Some(format!(
            "{} has no heading with the anchor `#{wanted}`",
            linked.display()
        ))
    }
}

/// Every broken link of the given files, one line each.
fn broken_links(root: &Path, files: &[PathBuf]) -> Vec<String> {
    let mut problems = Vec::new();
    for file in files {
        let text = match fs::read_to_string(root.join(file)) {
            Ok(text) => text,
            Err(e) => {
                problems.push(format!("{}: cannot be read: {e}", file.display()));
                continue;
            }
        };
        for link in links(&text) {
            if let Some(why) = check_link(root, file, &link) {
                problems.push(format!(
                    "{}:{}: link `{}`: {why}",
                    file.display(),
                    link.line,
                    link.target
                ));
            }
        }
    }
    problems
}

#[test]
fn documentation_links_resolve() {
    let root = root();
    let files = documents(&root);
    assert!(
        files.iter().any(|f| f.starts_with("docs")),
        "no docs/*.md found"
    );
    let problems = broken_links(&root, &files);
    assert!(
        problems.is_empty(),
        "{} broken link(s) in the documentation:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn the_book_lists_every_page() {
    let root = root();
    let summary = fs::read_to_string(root.join("docs/SUMMARY.md")).expect("docs/SUMMARY.md");
    let listed: Vec<String> = links(&summary).into_iter().map(|l| l.target).collect();
    let mut missing = Vec::new();
    for file in documents(&root) {
        let Ok(page) = file.strip_prefix("docs") else {
            continue;
        };
        let page = page.display().to_string();
        if page != "SUMMARY.md" && !listed.contains(&page) {
            missing.push(page);
        }
    }
    assert!(
        missing.is_empty(),
        "docs/SUMMARY.md does not list: {}",
        missing.join(", ")
    );
}

// The checker itself, on texts made to fail.

#[test]
fn finds_links_but_not_code() {
    let text = "See [a](a.md) and ![pic](img/p.png \"title\").\n\
                `[not](a link)` and\n\
                ```\n[nor](this.md)\n```\n\
                [ref]: other.md#part\n\
                [nested [brackets]](b.md#x) [c](<with space.md>)\n";
    let targets: Vec<String> = links(text).into_iter().map(|l| l.target).collect();
    assert_eq!(
        targets,
        [
            "a.md",
            "img/p.png",
            "other.md#part",
            "b.md#x",
            "with space.md"
        ]
    );
}

#[test]
fn slugs_follow_github() {
    assert_eq!(
        slug("Quick start (Debian / Ubuntu)"),
        "quick-start-debian--ubuntu"
    );
    assert_eq!(slug("`[render]` (optional)"), "render-optional");
    assert_eq!(
        slug("Choosing the strategy: `--strategy auto`"),
        "choosing-the-strategy---strategy-auto"
    );
    assert_eq!(slug("snake_case and CamelCase"), "snake_case-and-camelcase");
    assert_eq!(slug("See [the page](x.md)"), "see-the-page");
    assert_eq!(
        anchors("# A\n## A\n```\n# not\n```\n### A b #\n"),
        ["a", "a-1", "a-b"]
    );
}

#[test]
fn external_links_are_not_checked() {
    for target in ["https://wgpu.rs", "http://x", "mailto:a@b", "ftp://host/f"] {
        assert!(is_external(target), "{target}");
    }
    for target in ["docs/x.md", "x.md#a:b", "../README.md", "#anchor"] {
        assert!(!is_external(target), "{target}");
    }
}

#[test]
fn broken_links_are_reported() {
    let dir = common::TempDir::new("doc-links", "broken");
    fs::create_dir_all(dir.join("docs")).unwrap();
    fs::write(
        dir.join("README.md"),
        "# Top\n\n[ok](docs/page.md#a-heading) [self](#top) [gone](docs/missing.md)\n\
         [bad anchor](docs/page.md#no-such-heading) [bad self](#nowhere)\n\
         [web](https://example.com/missing)\n",
    )
    .unwrap();
    fs::write(
        dir.join("docs/page.md"),
        "## A heading\n\n[up](../README.md#top) [sideways](other.md)\n",
    )
    .unwrap();
    let files = [PathBuf::from("README.md"), PathBuf::from("docs/page.md")];
    let problems = broken_links(&dir, &files);
    assert_eq!(problems.len(), 4, "{problems:#?}");
    assert!(
        problems[0].starts_with("README.md:3: link `docs/missing.md`: "),
        "{problems:#?}"
    );
    assert!(
        problems[0].ends_with("docs/missing.md does not exist"),
        "{problems:#?}"
    );
    assert!(
        problems[1].contains("`docs/page.md#no-such-heading`"),
        "{problems:#?}"
    );
    assert!(problems[1].contains("no heading with the anchor `#no-such-heading`"));
    assert!(problems[2].contains("README.md has no heading with the anchor `#nowhere`"));
    assert!(
        problems[3].starts_with("docs/page.md:3: link `other.md`: docs/other.md does not exist")
    );
}

//! Every relative link in the repository's Markdown (README.md,
//! BENCHMARKS.md and everything under docs/) resolves to a file or folder of
//! the repository: committed reports must open where they are read.

use std::path::{Path, PathBuf};

/// The Markdown files whose links are checked.
fn documents(root: &Path) -> Vec<PathBuf> {
    let mut out = vec![root.join("README.md"), root.join("BENCHMARKS.md")];
    let mut folders = vec![root.join("docs")];
    while let Some(dir) = folders.pop() {
        for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    out
}

/// The targets of inline links and images (`[text](target)`,
/// `![alt](target "title")`) and of reference definitions (`[id]: target`),
/// outside fenced code blocks and inline code spans.
fn link_targets(markdown: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Inline code spans hold commands, not links.
        let text: String = line.split('`').step_by(2).collect::<Vec<_>>().join(" ");
        let trimmed = text.trim_start();
        if trimmed.starts_with('[')
            && let Some((label, rest)) = trimmed[1..].split_once("]:")
            && !label.contains(']')
        {
            if let Some(target) = rest.split_whitespace().next() {
                out.push(target.trim_matches(['<', '>']).to_string());
            }
            continue;
        }
        let mut rest = text.as_str();
        while let Some(i) = rest.find("](") {
            rest = &rest[i + 2..];
            let end = rest.find(')').unwrap_or(rest.len());
            if let Some(target) = rest[..end].split_whitespace().next() {
                out.push(target.trim_matches(['<', '>']).to_string());
            }
            rest = &rest[end..];
        }
    }
    out
}

/// A link that leaves the repository's files: a URL (`https:`, `mailto:`) or
/// an anchor within the page.
fn is_external(target: &str) -> bool {
    target.starts_with('#')
        || target.split_once(':').is_some_and(|(scheme, _)| {
            !scheme.is_empty() && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
        })
}

#[test]
fn every_relative_link_in_the_docs_resolves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in documents(root) {
        let text = std::fs::read_to_string(&doc).unwrap_or_else(|e| panic!("{}: {e}", doc.display()));
        for target in link_targets(&text).into_iter().filter(|t| !is_external(t)) {
            let file = target.split('#').next().unwrap_or_default();
            let resolved = doc.parent().unwrap().join(file);
            checked += 1;
            if !resolved.exists() {
                broken.push(format!("{}: {target}", doc.strip_prefix(root).unwrap().display()));
            }
        }
    }
    assert!(broken.is_empty(), "{} of {checked} relative links do not resolve:\n{}", broken.len(), broken.join("\n"));
    // The committed reports embed their figures: the check saw them.
    assert!(checked > 100, "only {checked} relative links found: is the parser broken?");
}

#[test]
fn links_are_found_where_markdown_puts_them() {
    let md = "See [a](docs/a.md#x) and ![b](b.svg \"title\").\n\
              `[not](code.md)` and\n```\n[nor](fenced.md)\n```\n[ref]: <c.png>\n[web](https://x.y/z)";
    let targets = link_targets(md);
    assert_eq!(targets, ["docs/a.md#x", "b.svg", "c.png", "https://x.y/z"]);
    let local: Vec<&String> = targets.iter().filter(|t| !is_external(t)).collect();
    assert_eq!(local, ["docs/a.md#x", "b.svg", "c.png"]);
    assert!(is_external("#section") && is_external("mailto:a@b.c"));
}

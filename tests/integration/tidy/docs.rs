//! The docs cite only files the repository holds (links, their anchors,
//! `docs/` paths), and nothing outside it.

use std::collections::BTreeSet;

use driveset_test_support::workspace_root;

use super::{files, read, rel, report, skipped_blocks};

/// GitHub's anchor of a heading's text: lower case, spaces to `-`,
/// punctuation other than `-` and `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a markdown file's headings (outside code fences); a
/// repeated heading's anchor gets `-1`, `-2`, ...
fn anchors(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut fence = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fence = !fence;
            continue;
        }
        if fence {
            continue;
        }
        if let Some(h) = line.strip_prefix('#') {
            let h = h.trim_start_matches('#');
            if !h.starts_with(' ') {
                continue;
            }
            let s = slug(h);
            let mut a = s.clone();
            let mut k = 1;
            while out.contains(&a) {
                a = format!("{s}-{k}");
                k += 1;
            }
            out.insert(a);
        }
    }
    out
}

/// The markdown link targets of a line: `[text](target)`.
fn link_targets(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let Some(end) = after.find(')') else { break };
        let target = after[..end].split_whitespace().next().unwrap_or("");
        out.push(target);
        rest = &after[end..];
    }
    out
}

/// The paths under `docs/` ending `.md` that a line mentions (from the
/// repository root: not the tail of a longer path).
fn docs_mentions(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    for (at, _) in line.match_indices("docs/") {
        let before = line[..at].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || "_-./".contains(c)) {
            continue;
        }
        let tail = &line[at..];
        let end = tail
            .find(|c: char| !(c.is_alphanumeric() || "_-./".contains(c)))
            .unwrap_or(tail.len());
        let path = tail[..end].trim_end_matches('.');
        if path.ends_with(".md") {
            out.push(path);
        }
    }
    out
}

#[test]
fn tidy_the_docs_cite_only_files_that_exist() {
    let root = workspace_root();
    let mut problems = Vec::new();
    let md = files(&root, &[".md"]);
    for file in &md {
        let path = rel(&root, file);
        let text = read(file);
        let dir = file.parent().expect("a folder");
        let mut fence = false;
        for (i, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("```") {
                fence = !fence;
            }
            if fence {
                continue;
            }
            for target in link_targets(line) {
                if target.contains("://") || target.starts_with("mailto:") || target.is_empty() {
                    continue;
                }
                let (file_part, anchor) = target.split_once('#').unwrap_or((target, ""));
                let linked = if file_part.is_empty() {
                    file.clone()
                } else {
                    dir.join(file_part)
                };
                if !linked.exists() {
                    problems.push(format!(
                        "{path}:{}: the link `{target}` points to {}, which the repository does not hold: point it to a file that exists (docs/architecture.md, docs/file-formats.md, ...) or cite a vendor spec by file name and section",
                        i + 1,
                        rel(&root, &linked)
                    ));
                    continue;
                }
                if !anchor.is_empty()
                    && linked.extension().is_some_and(|e| e == "md")
                    && !anchors(&read(&linked)).contains(anchor)
                {
                    problems.push(format!(
                        "{path}:{}: the link `{target}`: {} has no heading with the anchor `#{anchor}`: link a heading it has",
                        i + 1,
                        rel(&root, &linked)
                    ));
                }
            }
        }
    }
    let rs = files(&root.join("crates"), &[".rs"])
        .into_iter()
        .chain(files(&root.join("tests"), &[".rs"]));
    for file in md.iter().cloned().chain(rs) {
        let path = rel(&root, &file);
        for (i, line) in read(&file).lines().enumerate() {
            for mention in docs_mentions(line) {
                if !root.join(mention).is_file() {
                    problems.push(format!(
                        "{path}:{}: `{mention}` names a file the repository does not hold: name one under docs/ that exists",
                        i + 1
                    ));
                }
            }
        }
    }
    report("citations in the docs", &problems);
}

#[test]
fn tidy_no_reference_to_design_notes_outside_the_repository() {
    let root = workspace_root();
    // spelled in pieces so that this file does not hold them itself
    let design = concat!("DESIGN", ".md");
    let outside = [concat!("shared", "/specs/"), concat!("/work", "/")];
    let mut problems = Vec::new();
    let text_files = files(
        &root,
        &[
            ".rs", ".md", ".toml", ".txt", ".sh", ".py", ".js", ".json", ".yml", ".yaml",
        ],
    );
    for file in text_files {
        let path = rel(&root, &file);
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue; // not UTF-8: no prose to check
        };
        // the schema files' comments are hashed into their fingerprints
        // (journals record them), so their spec paths stay as written
        let check_outside = path.ends_with(".md") || path.ends_with(".rs");
        for (i, line) in text.lines().enumerate() {
            if line.contains(design) {
                problems.push(format!(
                    "{path}:{}: names {design}, which the repository does not hold: cite the repository's own docs (docs/architecture.md, docs/journals.md, ...) instead",
                    i + 1
                ));
            }
            if let Some(o) = outside.iter().find(|o| check_outside && line.contains(**o)) {
                problems.push(format!(
                    "{path}:{}: names a path outside the repository (`{o}`): cite a vendor spec by its file name and section, and the repository's files by their path in it",
                    i + 1
                ));
            }
        }
    }
    report("references outside the repository", &problems);
}

/// The helpers the checks stand on: test modules (and a module named by the
/// caller) skipped to their closing brace, GitHub's anchors, link targets and
/// `docs/` mentions.
#[test]
fn tidy_the_source_and_link_readers() {
    let src = [
        "use a;",
        "mod store {",
        "    fn f() {",
        "    }",
        "}",
        "fn g() {}",
        "#[cfg(test)]",
        "#[allow(dead_code)]",
        "mod tests {",
        "    use std::fs;",
        "}",
        "fn h() {}",
    ];
    assert_eq!(skipped_blocks(&src, None), [(6, 10)]);
    assert_eq!(skipped_blocks(&src, Some("store")), [(1, 4), (6, 10)]);
    assert_eq!(
        slug(" Changing the rate on an open port (`--transfer-baud`)"),
        "changing-the-rate-on-an-open-port---transfer-baud"
    );
    let a = anchors("# A\n## The bus\n```\n# not a heading\n```\n## The bus\n#hashtag\n");
    assert_eq!(
        a.into_iter().collect::<Vec<_>>(),
        ["a", "the-bus", "the-bus-1"]
    );
    assert_eq!(
        link_targets("see [x](ports.md#a \"t\") and [y](../TESTING.md), (z)"),
        ["ports.md#a", "../TESTING.md"]
    );
    // built with format! so that this file names no missing docs itself
    let line = format!(
        "{d}a.md, ({d}errata/b.md). ../{d}c.md x{d}d.md {d}e.txt",
        d = "docs/"
    );
    assert_eq!(
        docs_mentions(&line),
        [concat!("docs", "/a.md"), concat!("docs", "/errata/b.md")]
    );
}

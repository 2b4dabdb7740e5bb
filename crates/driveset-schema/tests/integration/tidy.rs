//! Tidy tests over the workspace's sources (as rust-analyzer's are): rules
//! of `docs/architecture.md` that a reader of the code could break without
//! any other test noticing.
//!
//! **Family facts only in the descriptor** (docs/architecture.md, "The
//! family descriptor"): outside `driveset-schema/src/family.rs` (and its
//! `family/` files) and the simulator, which may know its families, source
//! code does not name a family (`Family::Mc6000`, `Vf1000`, `Tmd`, `Ecs`)
//! but asks its [`driveset_schema::Descriptor`]. Test modules (`mod tests`
//! after `#[cfg(test)]`, `tests.rs` files, `tests/` trees) and comments may
//! name families.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Files that still name families, with how many references each holds,
/// until the helpers who own them convert them to descriptor questions.
/// A count may only go down: lower (or remove) the entry when you convert
/// a file; never add one.
const FAMILY_VARIANTS_STILL_TO_CONVERT: &[(&str, usize)] = &[];

/// The families' variant names.
const VARIANTS: [&str; 4] = ["Mc6000", "Vf1000", "Tmd", "Ecs"];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("workspace root")
}

/// Every `.rs` file under `crates/*/src`, as paths relative to the
/// workspace root with `/` separators.
fn source_files(root: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for krate in std::fs::read_dir(root.join("crates")).expect("crates/") {
        let src = krate.expect("entry").path().join("src");
        let mut dirs = vec![src];
        while let Some(d) = dirs.pop() {
            let Ok(entries) = std::fs::read_dir(&d) else {
                continue;
            };
            for e in entries {
                let p = e.expect("entry").path();
                if p.is_dir() {
                    dirs.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let rel = p.strip_prefix(root).expect("under the root");
                    out.push(rel.to_string_lossy().replace('\\', "/"));
                }
            }
        }
    }
    out.sort();
    out
}

/// Whether `path` may name families: the descriptor, the simulator, test
/// files.
fn may_name_families(path: &str) -> bool {
    path == "crates/driveset-schema/src/family.rs"
        || path.starts_with("crates/driveset-schema/src/family/")
        || path.starts_with("crates/driveset-sim/")
        || path.ends_with("/tests.rs")
}

/// How many `Family::<variant>` references the code of `text` holds
/// (comments and the test module at its end left out).
fn family_references(text: &str) -> usize {
    let lines: Vec<&str> = text.lines().collect();
    let mut n = 0;
    for (i, line) in lines.iter().enumerate() {
        if line.trim() == "#[cfg(test)]"
            && lines
                .get(i + 1)
                .is_some_and(|l| l.trim_start().starts_with("mod tests"))
        {
            break;
        }
        if line.trim_start().starts_with("//") {
            continue;
        }
        // a trailing comment (` //`; `sim://` has no blank before it)
        let mut rest = line.find(" //").map_or(*line, |at| &line[..at]);
        while let Some(at) = rest.find("Family::") {
            rest = &rest[at + "Family::".len()..];
            let ident: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if VARIANTS.contains(&ident.as_str()) {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn family_references_counts_code_only() {
    let text = "let a = Family::Mc6000; // Family::Tmd\n/// [`Family::Ecs`]\nlet b = (Family::Vf1000, Family::ALL, Family::parse(x), Family::Tmd);\n#[cfg(test)]\nmod tests {\n    Family::Ecs\n}\n";
    assert_eq!(family_references(text), 3);
}

#[test]
fn family_facts_stay_in_the_descriptor() {
    let root = workspace();
    let files = source_files(&root);
    assert!(files.len() > 100, "{} source files found", files.len());
    let allowed: BTreeMap<&str, usize> = FAMILY_VARIANTS_STILL_TO_CONVERT.iter().copied().collect();
    let mut problems = Vec::new();
    let mut seen = BTreeMap::new();
    for f in &files {
        if may_name_families(f) {
            continue;
        }
        let text = std::fs::read_to_string(root.join(f)).expect("read a source file");
        let n = family_references(&text);
        if n == 0 {
            continue;
        }
        seen.insert(f.as_str(), n);
        match allowed.get(f.as_str()) {
            None => problems.push(format!(
                "{f}: {n} Family:: variant reference(s): ask the family's Descriptor instead (driveset-schema/src/family.rs)"
            )),
            Some(&a) if n > a => problems.push(format!(
                "{f}: {n} Family:: variant references, {a} allowed: ask the family's Descriptor instead of naming a family"
            )),
            Some(&a) if n < a => problems.push(format!(
                "{f}: {n} Family:: variant references, the allowlist still says {a}: lower its entry in FAMILY_VARIANTS_STILL_TO_CONVERT"
            )),
            Some(_) => {}
        }
    }
    for (f, a) in &allowed {
        if !seen.contains_key(f) {
            problems.push(format!(
                "{f}: no Family:: variant reference left (allowlist says {a}): remove its entry from FAMILY_VARIANTS_STILL_TO_CONVERT"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

//! **Family facts only in the descriptor** (docs/architecture.md, "The
//! family descriptor"): outside `driveset-schema/src/family.rs` (and its
//! `family/` files) and the simulator, which may know its families, source
//! code does not name a family (`Family::Mc6000`, `Vf1000`, `Tmd`, `Ecs`)
//! but asks its [`driveset_schema::Descriptor`]. Test modules (`mod tests`
//! after `#[cfg(test)]`, `tests.rs` files, `tests/` trees) and comments may
//! name families.

use std::collections::BTreeMap;

use super::{Source, report, sources};

/// Files that still name families, with how many references each holds,
/// until the helpers who own them convert them to descriptor questions.
/// A count may only go down: lower (or remove) the entry when you convert
/// a file; never add one.
const FAMILY_VARIANTS_STILL_TO_CONVERT: &[(&str, usize)] = &[];

/// The families' variant names.
const VARIANTS: [&str; 4] = ["Mc6000", "Vf1000", "Tmd", "Ecs"];

/// Whether `path` may name families: the descriptor, the simulator, test
/// files.
fn may_name_families(path: &str) -> bool {
    path == "crates/driveset-schema/src/family.rs"
        || path.starts_with("crates/driveset-schema/src/family/")
        || path.starts_with("crates/driveset-sim/")
        || path.ends_with("/tests.rs")
}

/// How many `Family::<variant>` references the code of `source` holds
/// (comments and test modules left out).
fn family_references(source: &Source) -> usize {
    let mut n = 0;
    for (_, line) in source.code() {
        // a trailing comment (` //`; `sim://` has no blank before it)
        let mut rest = line.find(" //").map_or(line, |at| &line[..at]);
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
    let source = Source::new("crates/x/src/lib.rs", text.to_string(), false);
    assert_eq!(family_references(&source), 3);
}

#[test]
fn family_facts_stay_in_the_descriptor() {
    let allowed: BTreeMap<&str, usize> = FAMILY_VARIANTS_STILL_TO_CONVERT.iter().copied().collect();
    let mut problems = Vec::new();
    let mut seen = BTreeMap::new();
    for source in sources() {
        let f = &source.path;
        if may_name_families(f) {
            continue;
        }
        let n = family_references(source);
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
                "{f}: {n} Family:: variant references, the allowlist still says {a}: lower its entry in FAMILY_VARIANTS_STILL_TO_CONVERT (tests/integration/tidy/family.rs)"
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
    report("family facts (docs/architecture.md)", &problems);
}

//! The upload runner names nothing of the transfer-rate switch that wraps
//! it (docs/architecture.md, "Crates and their arrows").

use super::{report, sources_under};

/// The upload runner's folder, which names nothing of the transfer-rate
/// switch (docs/architecture.md, "Crates and their arrows": the switch
/// wraps an upload, never the other way round; what both carry, the
/// transfer report, is `driveset_engine::rate_report`'s).
const UPLOAD_DIR: &str = "crates/driveset-engine/src/upload";

/// The lines of `text` (the file `path`) that name the `transfer` module:
/// included, since a doc link to it is a reference as well.
fn transfer_mentions(path: &str, text: &str) -> Vec<String> {
    fn ident(c: char) -> bool {
        c.is_alphanumeric() || c == '_'
    }
    let names_it = |line: &str| {
        line.match_indices("transfer").any(|(i, w)| {
            let before = &line[..i];
            let after = &line[i + w.len()..];
            let whole = !before.ends_with(ident) && !after.starts_with(ident);
            whole && (before.ends_with("::") || after.starts_with("::"))
        })
    };
    text.lines()
        .enumerate()
        .filter(|(_, l)| names_it(l))
        .map(|(i, l)| {
            format!(
                "{path}:{}: names the transfer-rate switch (`{}`): upload/ knows nothing of it; put what both need beside them (`rate_report.rs`)",
                i + 1,
                l.trim()
            )
        })
        .collect()
}

#[test]
fn tidy_upload_does_not_name_the_transfer_switch() {
    let mut problems = Vec::new();
    for source in sources_under(&format!("{UPLOAD_DIR}/")) {
        problems.extend(transfer_mentions(&source.path, &source.text));
    }
    report("upload/ names crate::transfer", &problems);
}

/// The check itself: a `use` of the module, a path through it and a doc
/// link to it are found; a field, a report type and a word are not.
#[test]
fn tidy_the_transfer_check_sees_a_use_of_transfer() {
    let text = "use crate::transfer::TransferReport;\nuse crate::transfer;\n/// see [`crate::transfer`]\nlet t = driveset_engine::transfer::decide(c, r, &[], &[]);\nself.opts.transfer.clone();\nuse crate::rate_report::TransferReport;\n// the transfer rate: transfer_rate, retransfer::x\n";
    let found = transfer_mentions("u.rs", text);
    let lines: Vec<&str> = found
        .iter()
        .map(|p| p.split(": names").next().expect("line"))
        .collect();
    assert_eq!(
        lines,
        ["u.rs:1", "u.rs:2", "u.rs:3", "u.rs:4"],
        "{found:#?}"
    );
}

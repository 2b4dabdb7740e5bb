//! A synthetic plant history for the scale bench (`benches/scale.rs`) and
//! its small CI variant (the tests below): a line `plant` of `drives`
//! drives with `codes` codes each, and `sessions` commissioning sessions,
//! session `i` writing drive `i % drives` and changing one of its codes
//! (the next in turn), every code of the drive on record. Sessions are
//! labelled by sweep (`sweep-N`: sessions `N * drives ..`), so an as-built
//! at a label has every drive.

use driveset_engine::history::{CodeRecord, DriveRecord, Slot, Unit};

use crate::HistoryError;
use crate::store::{SessionEnd, SessionStart, Store};

/// The size of a plant's history.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plant {
    /// Drives of the line.
    pub drives: usize,
    /// Codes of each drive.
    pub codes: usize,
    /// Sessions, one drive record each.
    pub sessions: usize,
}

/// The name of drive `d`.
pub fn drive_name(d: usize) -> String {
    format!("d{d:03}")
}

/// The name of code `c`.
pub fn code_name(c: usize) -> String {
    format!("C{c:04}")
}

/// The value text of a code at version `v`.
fn value(v: u64) -> String {
    format!("{v} Hz")
}

/// The operator of session `i`.
pub fn operator(i: usize) -> String {
    format!("op{}", i % 7)
}

fn at(i: usize) -> String {
    let t = jiff::Timestamp::from_second(1_700_000_000 + i as i64).unwrap_or_default();
    format!("{t:.3}")
}

/// What the generated history leaves each drive holding: `values[d][c]`
/// is the version of code `c` of drive `d` (its text [`value_text`]).
pub struct Generated {
    /// The versions.
    pub values: Vec<Vec<u64>>,
}

/// The text the history holds for version `v`.
pub fn value_text(v: u64) -> String {
    value(v)
}

/// Append the history of `p` to `store`, `per_batch` sessions a
/// transaction; `progress` is told the sessions done.
pub fn generate(
    store: &mut Store,
    p: &Plant,
    per_batch: usize,
    mut progress: impl FnMut(usize),
) -> Result<Generated, HistoryError> {
    let mut values = vec![vec![0u64; p.codes]; p.drives];
    let mut i = 0;
    while i < p.sessions {
        let end = (i + per_batch.max(1)).min(p.sessions);
        store.batch(|st| {
            for s in i..end {
                session(st, p, s, &mut values)?;
            }
            Ok(())
        })?;
        i = end;
        progress(i);
    }
    Ok(Generated { values })
}

fn session(
    st: &mut Store,
    p: &Plant,
    i: usize,
    values: &mut [Vec<u64>],
) -> Result<(), HistoryError> {
    let d = i % p.drives;
    let sweep = i / p.drives;
    let changed = sweep % p.codes;
    let id = format!("bench-{i:09}");
    st.open_session(&SessionStart {
        id: id.clone(),
        command: "commission".into(),
        args: vec!["driveset".into(), "commission".into(), "plant.toml".into()],
        version: "bench".into(),
        station: format!("station-{}", i % 8),
        os_user: "bench".into(),
        operator: Some(operator(i)),
        reason: Some(format!("sweep {sweep}")),
        label: Some(format!("sweep-{sweep}")),
        manifest: Some("plant.toml".into()),
        git_commit: Some(format!("{:040x}", sweep)),
        git_dirty: Some(false),
        started: at(i),
        pid: 1,
        forward_to: None,
    })?;
    let before = values[d][changed];
    let after = i as u64 + 1;
    let codes = (0..p.codes)
        .map(|c| {
            if c == changed {
                CodeRecord {
                    code: code_name(c),
                    old: Some(value(before)),
                    new: Some(value(after)),
                    verified: Some(value(after)),
                    outcome: "verified".into(),
                    phase: Some("eeprom".into()),
                }
            } else {
                let v = value(values[d][c]);
                CodeRecord {
                    code: code_name(c),
                    old: Some(v.clone()),
                    new: Some(v.clone()),
                    verified: Some(v),
                    outcome: "unchanged".into(),
                    phase: None,
                }
            }
        })
        .collect();
    values[d][changed] = after;
    let record = DriveRecord {
        slot: Slot {
            line: Some("plant".into()),
            drive: Some(drive_name(d)),
            bus: format!("bus{}", d / 30),
            address: (d % 30 + 1) as u8,
        },
        unit: Unit {
            family: "lecom".into(),
            device_type: Some("8200".into()),
            software: Some("1.20".into()),
            identity: vec![("C0093".into(), "8200".into())],
        },
        schema: "lenze-tmd".into(),
        set_fingerprint: Some(format!("sha256:set-{d}-{after}")),
        fingerprint_before: Some(format!("sha256:{d}-{before}")),
        fingerprint_after: Some(format!("sha256:{d}-{after}")),
        result: "verified".into(),
        cause: None,
        error: None,
        journal: None,
        codes,
    };
    st.drive(&id, &at(i), &record)?;
    st.close_session(
        &id,
        &SessionEnd {
            ended: at(i),
            outcome: "ok".into(),
            exit_code: Some(0),
            detail: None,
            closed_by: None,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::query::{At, LogFilter};
    use crate::store::Verdict;

    /// The scale bench's CI variant: a small plant, the answers checked
    /// against what the generator left (no timing).
    #[test]
    fn the_bench_history_answers_blame_log_and_as_built() {
        let dir = tempfile::tempdir().unwrap();
        let mut store = crate::open_sqlite(&dir.path().join("h.sqlite")).unwrap();
        let p = Plant {
            drives: 10,
            codes: 6,
            sessions: 250,
        };
        let g = generate(&mut store, &p, 40, |_| {}).unwrap();
        // drive d003 is written by sessions 3, 13, ... 243; the last that
        // changed C0002 is of sweep 20 (20 % 6 == 2): session 203
        let b = store.blame(None, "d003", "C0002").unwrap().unwrap();
        assert_eq!(b.who.session, "bench-000000203");
        assert_eq!(b.who.operator.as_deref(), Some(operator(203).as_str()));
        assert_eq!(b.new.as_deref(), Some("204 Hz"));
        assert_eq!(b.old.as_deref(), Some("144 Hz")); // session 143, sweep 14
        assert_eq!(b.who.label.as_deref(), Some("sweep-20"));
        let log = store
            .log(&LogFilter {
                drive: Some("d003".into()),
                limit: 1000,
                ..LogFilter::default()
            })
            .unwrap();
        assert_eq!(log.len(), 25);
        assert_eq!(log[0].who.session, "bench-000000003");
        assert_eq!(log[24].codes_written, 1);
        let names: Vec<String> = (0..p.drives).map(drive_name).collect();
        let built = store.as_built("plant", &names, &At::Latest).unwrap();
        assert_eq!(built.drives.len(), 10);
        for (d, h) in built.drives.iter().enumerate() {
            for (c, v) in g.values[d].iter().enumerate() {
                assert_eq!(h.values[&code_name(c)], value_text(*v), "d{d} c{c}");
            }
        }
        // at a label: the sweep's end
        let at = store
            .as_built("plant", &names, &At::Label("sweep-3".into()))
            .unwrap();
        assert_eq!(
            at.drives[9].put_by.as_ref().unwrap().session,
            "bench-000000039"
        );
        assert_eq!(at.drives[9].values["C0003"], "40 Hz");
        match store.verify().unwrap() {
            Verdict::Intact { records, .. } => assert_eq!(records, 750),
            v => panic!("{v:?}"),
        }
    }
}

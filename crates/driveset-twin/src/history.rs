//! What the plant history records of a capture (docs/history.md): a
//! capture is on record, each drive's values read and their fingerprint;
//! a line drive's capture as `status` records it (what it holds of its
//! set, or that it differs). A rehearsal is not (it reads no drive).

use driveset_engine::client::{IdentProtocol, Identity};
use driveset_engine::history::{self, DriveRecord, Slot, Unit};
use driveset_engine::line::manifest::Drive;
use driveset_schema::{ResolvedSet, Schema};
use driveset_sim::twin::Twin;

/// Every value a capture read, as a set of `schema` (its fingerprint is
/// what the history records of a `twin capture`).
fn read_set(schema: &Schema, twin: &Twin) -> ResolvedSet {
    let mut set = ResolvedSet::new(schema);
    set.values = twin.values.clone();
    set
}

/// The history record of one drive's capture (`twin capture`): every
/// value read, and their fingerprint.
pub fn drive_record(slot: Slot, twin: &Twin, schema: &Schema, identity: &Identity) -> DriveRecord {
    let read = read_set(schema, twin);
    DriveRecord::of_read(
        slot,
        Unit::of(schema, identity),
        &schema.id,
        read.fingerprint(),
        "read",
        history::values_read(schema, &read),
    )
}

/// The history record of a line drive's capture: each code of its set,
/// what the drive holds (`read`) or that it differs (`drift`), as `status`
/// records it; a drive whose set waits for the learned schema (empty
/// here): every value read.
pub fn line_record(
    slot: Slot,
    d: &Drive,
    twin: &Twin,
    schema: &Schema,
    identity: &Identity,
) -> DriveRecord {
    let unit = Unit::of(schema, identity);
    if d.set.values.is_empty() {
        let read = read_set(schema, twin);
        return DriveRecord::of_read(
            slot,
            unit,
            &schema.id,
            read.fingerprint(),
            "read",
            history::values_read(schema, &read),
        );
    }
    let mut live = d.set.clone();
    live.values = d
        .set
        .values
        .keys()
        .filter_map(|k| Some((*k, twin.values.get(k)?.clone())))
        .collect();
    let mut record = DriveRecord::of_read(
        slot,
        unit,
        &schema.id,
        live.fingerprint(),
        if live.values == d.set.values {
            "unchanged"
        } else {
            "drift"
        },
        history::read_codes(schema, &live, &d.set),
    );
    record.set_fingerprint = Some(d.set.fingerprint());
    record
}

/// The history record of a line drive that could not be captured
/// (`error`: why).
pub fn failed_record(slot: Slot, d: &Drive, error: String) -> DriveRecord {
    DriveRecord {
        result: "failed".into(),
        error: Some(error),
        fingerprint_before: None,
        fingerprint_after: None,
        ..DriveRecord::of_read(
            slot,
            Unit {
                family: IdentProtocol::Family(d.schema.family).name().to_string(),
                ..Unit::default()
            },
            &d.schema.id,
            String::new(),
            "failed",
            Vec::new(),
        )
    }
}

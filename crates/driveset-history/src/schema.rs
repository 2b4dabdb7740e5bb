//! The tables (docs/history.md, "Tables") and their migrations: the
//! schema version is kept in `meta`, each migration runs once, in order,
//! in one transaction that holds every other writer off (SQLite `BEGIN
//! IMMEDIATE`, PostgreSQL an advisory lock), so stations that first use a
//! shared store at once create it once.

use crate::HistoryError;
use crate::db::{Db, Val};

/// The schema version this build writes.
pub const SCHEMA_VERSION: i64 = 1;

/// Version 1, both databases.
const V1: &str = "
CREATE TABLE chain (
    seq BIGINT PRIMARY KEY,
    kind TEXT NOT NULL,
    session_id TEXT NOT NULL,
    prev_hash TEXT NOT NULL,
    hash TEXT NOT NULL
);
CREATE TABLE sessions (
    seq BIGINT PRIMARY KEY,
    id TEXT NOT NULL UNIQUE,
    command TEXT NOT NULL,
    args TEXT NOT NULL,
    version TEXT NOT NULL,
    station TEXT NOT NULL,
    os_user TEXT NOT NULL,
    operator TEXT,
    reason TEXT,
    label TEXT,
    manifest TEXT,
    git_commit TEXT,
    git_dirty BIGINT,
    started TEXT NOT NULL,
    pid BIGINT NOT NULL,
    forward_to TEXT
);
CREATE TABLE session_ends (
    seq BIGINT PRIMARY KEY,
    session_id TEXT NOT NULL UNIQUE,
    ended TEXT NOT NULL,
    outcome TEXT NOT NULL,
    exit_code BIGINT,
    detail TEXT,
    closed_by TEXT
);
CREATE TABLE drives (
    seq BIGINT PRIMARY KEY,
    session_id TEXT NOT NULL,
    at TEXT NOT NULL,
    line TEXT,
    drive TEXT,
    bus TEXT NOT NULL,
    address BIGINT NOT NULL,
    family TEXT NOT NULL,
    device_type TEXT,
    software TEXT,
    identity TEXT NOT NULL,
    schema_id TEXT NOT NULL,
    set_fingerprint TEXT,
    fingerprint_before TEXT,
    fingerprint_after TEXT,
    result TEXT NOT NULL,
    cause TEXT,
    error TEXT,
    journal TEXT,
    codes_written BIGINT NOT NULL
);
CREATE TABLE codes (
    drive_seq BIGINT NOT NULL,
    ord BIGINT NOT NULL,
    code TEXT NOT NULL,
    old TEXT,
    new TEXT,
    verified TEXT,
    outcome TEXT NOT NULL,
    phase TEXT,
    PRIMARY KEY (drive_seq, ord)
);
CREATE TABLE forwarded (
    session_id TEXT NOT NULL,
    target TEXT NOT NULL,
    at TEXT NOT NULL,
    PRIMARY KEY (session_id, target)
);
CREATE INDEX drives_by_drive ON drives (drive, seq);
CREATE INDEX drives_by_slot ON drives (line, drive, seq);
CREATE INDEX drives_by_session ON drives (session_id);
CREATE INDEX codes_by_code ON codes (code, drive_seq);
CREATE INDEX sessions_by_label ON sessions (label);
";

/// Version 1, PostgreSQL only: the tables refuse UPDATE, DELETE and
/// TRUNCATE to every role that does not disable triggers (driveset's
/// role is no superuser; docs/history.md, "Append only").
const V1_POSTGRES: &str = "
CREATE FUNCTION driveset_append_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    RAISE EXCEPTION 'the driveset history is append-only: % on % refused', TG_OP, TG_TABLE_NAME;
END
$$;
";

/// The tables of the chain (the append-only triggers cover them).
pub const TABLES: [&str; 5] = ["chain", "sessions", "session_ends", "drives", "codes"];

/// Bring the database to [`SCHEMA_VERSION`] (module docs). A database of
/// a newer version is refused: this build would misread it.
pub fn migrate(db: &mut dyn Db) -> Result<(), HistoryError> {
    let postgres = db.kind() == "postgresql";
    if postgres {
        db.batch("BEGIN; SELECT pg_advisory_xact_lock(3131031)")?;
    } else {
        db.batch("BEGIN IMMEDIATE")?;
    }
    let r = migrate_locked(db, postgres);
    match r {
        Ok(()) => db.commit(),
        Err(e) => {
            db.rollback();
            Err(e)
        }
    }
}

fn migrate_locked(db: &mut dyn Db, postgres: bool) -> Result<(), HistoryError> {
    db.batch("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")?;
    let rows = db.query(
        "SELECT value FROM meta WHERE key = $1",
        &[Val::t("schema_version")],
    )?;
    let have: i64 = match rows.first() {
        Some(r) => r[0].str().parse().map_err(|_| {
            HistoryError::Db(format!("meta schema_version `{}` is no number", r[0].str()))
        })?,
        None => 0,
    };
    if have > SCHEMA_VERSION {
        return Err(HistoryError::NewerSchema {
            found: have,
            known: SCHEMA_VERSION,
        });
    }
    if have < 1 {
        db.batch(V1)?;
        if postgres {
            db.batch(V1_POSTGRES)?;
            for t in TABLES {
                db.batch(&format!(
                    "CREATE TRIGGER {t}_append_only BEFORE UPDATE OR DELETE ON {t} \
                     FOR EACH ROW EXECUTE FUNCTION driveset_append_only();
                     CREATE TRIGGER {t}_no_truncate BEFORE TRUNCATE ON {t} \
                     FOR EACH STATEMENT EXECUTE FUNCTION driveset_append_only();"
                ))?;
            }
        }
    }
    if have == 0 {
        db.exec(
            "INSERT INTO meta (key, value) VALUES ($1, $2)",
            &[Val::t("schema_version"), Val::t(SCHEMA_VERSION.to_string())],
        )?;
    } else if have < SCHEMA_VERSION {
        db.exec(
            "UPDATE meta SET value = $2 WHERE key = $1",
            &[Val::t("schema_version"), Val::t(SCHEMA_VERSION.to_string())],
        )?;
    }
    Ok(())
}

//! The store: appending records to the chain (a session opened, a drive,
//! a session closed), walking it ([`Store::verify`]), writing it out as
//! JSON Lines ([`Store::export`]) and forwarding sessions a station kept
//! locally to the shared store ([`Store::forward_to`]).
//!
//! **The chain** (docs/history.md, "Tamper evidence"). Every record is a
//! row of `chain` (`seq`, `kind`, `session_id`, `prev_hash`, `hash`) and
//! its content in its table (`sessions`, `drives` with its `codes`,
//! `session_ends`). `hash` = sha256 of the previous record's hash, a
//! newline and the record's canonical content (a JSON array of its
//! columns in the order of [`SESSION_COLUMNS`] ..., a drive's codes
//! included). Records are only ever inserted; a record is appended in one
//! transaction that holds the chain for its writer alone, so two stations
//! writing at once keep one chain.

use sha2::{Digest, Sha256};

use driveset_engine::history::DriveRecord;

use crate::HistoryError;
use crate::db::{Db, Durability, Row, Val};

/// The first record's `prev_hash`.
pub const GENESIS: &str = "0000000000000000000000000000000000000000000000000000000000000000";

/// A session's columns, in content order.
pub const SESSION_COLUMNS: &str = "id, command, args, version, station, os_user, operator, reason, label, manifest, git_commit, git_dirty, started, pid, forward_to";
/// A session end's columns, in content order.
pub const END_COLUMNS: &str = "session_id, ended, outcome, exit_code, detail, closed_by";
/// A drive's columns, in content order.
pub const DRIVE_COLUMNS: &str = "session_id, at, line, drive, bus, address, family, device_type, software, identity, schema_id, set_fingerprint, fingerprint_before, fingerprint_after, result, cause, error, journal, codes_written";
/// A code's columns, in content order.
pub const CODE_COLUMNS: &str = "ord, code, old, new, verified, outcome, phase";

/// A session as it is opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SessionStart {
    /// Its id (unique across stations).
    pub id: String,
    /// The command (`commission`, `upload` ...).
    pub command: String,
    /// The command line, secrets masked.
    pub args: Vec<String>,
    /// The driveset version.
    pub version: String,
    /// The station (host name).
    pub station: String,
    /// The OS user.
    pub os_user: String,
    /// `--operator` / `DRIVESET_OPERATOR`.
    pub operator: Option<String>,
    /// `--reason`.
    pub reason: Option<String>,
    /// The label (`--label`, the manifest's).
    pub label: Option<String>,
    /// The line manifest.
    pub manifest: Option<String>,
    /// The sets' git commit.
    pub git_commit: Option<String>,
    /// Whether the work tree had changes.
    pub git_dirty: Option<bool>,
    /// When (RFC 3339 UTC, milliseconds).
    pub started: String,
    /// The process id (a session left open by a killed process is found
    /// by it).
    pub pid: u32,
    /// The shared store this session is owed to (masked), when it was
    /// recorded locally because that store could not be reached.
    pub forward_to: Option<String>,
}

impl SessionStart {
    fn row(&self) -> Row {
        vec![
            Val::t(&self.id),
            Val::t(&self.command),
            Val::t(serde_json::to_string(&self.args).unwrap_or_default()),
            Val::t(&self.version),
            Val::t(&self.station),
            Val::t(&self.os_user),
            Val::ot(self.operator.clone()),
            Val::ot(self.reason.clone()),
            Val::ot(self.label.clone()),
            Val::ot(self.manifest.clone()),
            Val::ot(self.git_commit.clone()),
            Val::Int(self.git_dirty.map(i64::from)),
            Val::t(&self.started),
            Val::i(i64::from(self.pid)),
            Val::ot(self.forward_to.clone()),
        ]
    }
}

/// How a session ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SessionEnd {
    /// When.
    pub ended: String,
    /// `ok`, `differs`, `failed`, `refused`, `interrupted`.
    pub outcome: String,
    /// The process's exit code (none for a session `recover` closed).
    pub exit_code: Option<u8>,
    /// What the command said when it failed; for a closed interrupted
    /// session what `recover` found.
    pub detail: Option<String>,
    /// The session that closed it, when not its own.
    pub closed_by: Option<String>,
}

/// A session left open (its process was killed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OpenSession {
    /// Its id.
    pub id: String,
    /// Its command.
    pub command: String,
    /// Its station.
    pub station: String,
    /// Its process.
    pub pid: u32,
    /// When it started.
    pub started: String,
}

/// What [`Store::verify`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// The chain holds: this many records, the last hash.
    Intact {
        /// Records walked.
        records: u64,
        /// The last record's hash (the store's head).
        head: String,
    },
    /// The first broken record.
    Broken {
        /// Its sequence number.
        seq: i64,
        /// Its kind (`session`, `drive`, `end`).
        kind: String,
        /// Its session.
        session_id: String,
        /// What is wrong.
        why: String,
    },
}

/// A store, migrated.
pub struct Store {
    db: Box<dyn Db>,
    /// The store as messages name it (a password masked).
    pub shown: String,
    /// Inside [`Store::batch`]: the chain's last record, kept rather than
    /// read again for every record.
    head: Option<(i64, String)>,
    in_batch: bool,
}

fn hash(prev: &str, content: &str) -> String {
    let mut h = Sha256::new();
    h.update(prev.as_bytes());
    h.update(b"\n");
    h.update(content.as_bytes());
    hex::encode(h.finalize())
}

fn json(v: &Val) -> serde_json::Value {
    match v {
        Val::Int(Some(n)) => serde_json::Value::from(*n),
        Val::Text(Some(s)) => serde_json::Value::from(s.as_str()),
        Val::Int(None) | Val::Text(None) => serde_json::Value::Null,
    }
}

fn row_json(kind: &str, row: &[Val]) -> Vec<serde_json::Value> {
    let mut out = vec![serde_json::Value::from(kind)];
    out.extend(row.iter().map(json));
    out
}

fn placeholders(from: usize, n: usize) -> String {
    (from..from + n)
        .map(|i| format!("${i}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn drive_row(session_id: &str, at: &str, r: &DriveRecord) -> Row {
    vec![
        Val::t(session_id),
        Val::t(at),
        Val::ot(r.slot.line.clone()),
        Val::ot(r.slot.drive.clone()),
        Val::t(&r.slot.bus),
        Val::i(i64::from(r.slot.address)),
        Val::t(&r.unit.family),
        Val::ot(r.unit.device_type.clone()),
        Val::ot(r.unit.software.clone()),
        Val::t(serde_json::to_string(&r.unit.identity).unwrap_or_default()),
        Val::t(&r.schema),
        Val::ot(r.set_fingerprint.clone()),
        Val::ot(r.fingerprint_before.clone()),
        Val::ot(r.fingerprint_after.clone()),
        Val::t(&r.result),
        Val::ot(r.cause.clone()),
        Val::ot(r.error.clone()),
        Val::ot(r.journal.clone()),
        Val::i(
            r.codes
                .iter()
                .filter(|c| crate::query::WRITTEN.contains(&c.outcome.as_str()))
                .count() as i64,
        ),
    ]
}

fn code_rows(r: &DriveRecord) -> Vec<Row> {
    r.codes
        .iter()
        .enumerate()
        .map(|(i, c)| {
            vec![
                Val::i(i as i64),
                Val::t(&c.code),
                Val::ot(c.old.clone()),
                Val::ot(c.new.clone()),
                Val::ot(c.verified.clone()),
                Val::t(&c.outcome),
                Val::ot(c.phase.clone()),
            ]
        })
        .collect()
}

/// A record's content as the chain hashes it.
fn content(kind: &str, row: &[Val], codes: &[Row]) -> String {
    let mut v = row_json(kind, row);
    if kind == "drive" {
        v.push(serde_json::Value::Array(
            codes
                .iter()
                .map(|c| serde_json::Value::Array(c.iter().map(json).collect()))
                .collect(),
        ));
    }
    serde_json::Value::Array(v).to_string()
}

/// One session with everything recorded of it, to forward it.
#[derive(Debug, Clone)]
pub struct SessionDump {
    start: Row,
    drives: Vec<(Row, Vec<Row>)>,
    end: Option<Row>,
}

impl Store {
    /// A store over `db`, migrated to this build's schema.
    pub fn over(mut db: Box<dyn Db>, shown: String) -> Result<Self, HistoryError> {
        crate::schema::migrate(&mut *db)?;
        Ok(Store {
            db,
            shown,
            head: None,
            in_batch: false,
        })
    }

    /// `sqlite` or `postgresql`.
    pub fn kind(&self) -> &'static str {
        self.db.kind()
    }

    /// The database, for queries.
    pub(crate) fn db(&mut self) -> &mut dyn Db {
        &mut *self.db
    }

    /// Append one record in the open append transaction: its content row
    /// and the chain row, hashed after the chain's last.
    fn link(
        &mut self,
        kind: &str,
        session_id: &str,
        row: &[Val],
        codes: &[Row],
    ) -> Result<i64, HistoryError> {
        // inside a batch the head is the batch's last record (the batch
        // holds the chain alone); else the chain's, read under the lock
        let (seq, prev) = match self.head.take().filter(|_| self.in_batch) {
            Some((seq, hash)) => (seq + 1, hash),
            None => {
                let last = self
                    .db
                    .query("SELECT seq, hash FROM chain ORDER BY seq DESC LIMIT 1", &[])?;
                match last.first() {
                    Some(r) => (r[0].int().unwrap_or(0) + 1, r[1].str()),
                    None => (1, GENESIS.to_string()),
                }
            }
        };
        let h = hash(&prev, &content(kind, row, codes));
        let (table, columns) = match kind {
            "session" => ("sessions", SESSION_COLUMNS),
            "drive" => ("drives", DRIVE_COLUMNS),
            _ => ("session_ends", END_COLUMNS),
        };
        let mut params = vec![Val::i(seq)];
        params.extend(row.iter().cloned());
        self.db.exec(
            &format!(
                "INSERT INTO {table} (seq, {columns}) VALUES ({})",
                placeholders(1, params.len())
            ),
            &params,
        )?;
        // many rows a statement
        for chunk in codes.chunks(64) {
            let values: Vec<String> = (0..chunk.len())
                .map(|i| format!("({})", placeholders(1 + i * 8, 8)))
                .collect();
            let sql = format!(
                "INSERT INTO codes (drive_seq, {CODE_COLUMNS}) VALUES {}",
                values.join(", ")
            );
            let mut p = Vec::with_capacity(chunk.len() * 8);
            for c in chunk {
                p.push(Val::i(seq));
                p.extend(c.iter().cloned());
            }
            self.db.exec(&sql, &p)?;
        }
        self.db.exec(
            "INSERT INTO chain (seq, kind, session_id, prev_hash, hash) VALUES ($1, $2, $3, $4, $5)",
            &[
                Val::i(seq),
                Val::t(kind),
                Val::t(session_id),
                Val::t(prev),
                Val::t(&h),
            ],
        )?;
        if self.in_batch {
            self.head = Some((seq, h));
        }
        Ok(seq)
    }

    /// Run `f` (appends) as one transaction: a bulk load (the scale
    /// bench) commits once, not per record.
    pub fn batch<T>(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<T, HistoryError>,
    ) -> Result<T, HistoryError> {
        self.db.begin_append(Durability::Flushed)?;
        self.in_batch = true;
        let r = f(self);
        self.in_batch = false;
        self.head = None;
        match r {
            Ok(t) => {
                self.db.commit()?;
                Ok(t)
            }
            Err(e) => {
                self.db.rollback();
                Err(e)
            }
        }
    }

    /// Run `f` as one append transaction committed as far as
    /// `durability` (inside a batch: as part of it).
    fn append<T>(
        &mut self,
        durability: Durability,
        f: impl FnOnce(&mut Self) -> Result<T, HistoryError>,
    ) -> Result<T, HistoryError> {
        if self.in_batch {
            return f(self);
        }
        self.db.begin_append(durability)?;
        match f(self) {
            Ok(t) => {
                self.db.commit()?;
                Ok(t)
            }
            Err(e) => {
                self.db.rollback();
                Err(e)
            }
        }
    }

    /// Open a session (before the run's first write), flushed to the disk
    /// before it returns.
    pub fn open_session(&mut self, s: &SessionStart) -> Result<(), HistoryError> {
        let row = s.row();
        self.append(Durability::Flushed, |st| {
            st.link("session", &s.id, &row, &[]).map(|_| ())
        })
    }

    /// Put one drive on record in session `session_id`, at `at`; gives
    /// its place in the chain (`seq`). Committed, kept if the process is
    /// killed next, but not waited for on the disk: the session's close
    /// flushes it (docs/history.md, "Recording's cost").
    pub fn drive(
        &mut self,
        session_id: &str,
        at: &str,
        r: &DriveRecord,
    ) -> Result<i64, HistoryError> {
        let row = drive_row(session_id, at, r);
        let codes = code_rows(r);
        self.append(Durability::Written, |st| {
            st.link("drive", session_id, &row, &codes)
        })
    }

    /// Put drives on record in session `session_id`, each `(at, record)`,
    /// in one transaction (as [`Store::drive`] each); gives their places
    /// in the chain.
    pub fn drives(
        &mut self,
        session_id: &str,
        records: &[(String, DriveRecord)],
    ) -> Result<Vec<i64>, HistoryError> {
        let rows: Vec<(Vec<Val>, Vec<Row>)> = records
            .iter()
            .map(|(at, r)| (drive_row(session_id, at, r), code_rows(r)))
            .collect();
        self.append(Durability::Written, |st| {
            rows.iter()
                .map(|(row, codes)| st.link("drive", session_id, row, codes))
                .collect()
        })
    }

    /// Close session `session_id`, flushed to the disk with every record
    /// before it.
    pub fn close_session(&mut self, session_id: &str, e: &SessionEnd) -> Result<(), HistoryError> {
        let row = vec![
            Val::t(session_id),
            Val::t(&e.ended),
            Val::t(&e.outcome),
            Val::Int(e.exit_code.map(i64::from)),
            Val::ot(e.detail.clone()),
            Val::ot(e.closed_by.clone()),
        ];
        self.append(Durability::Flushed, |st| {
            st.link("end", session_id, &row, &[]).map(|_| ())
        })
    }

    /// The sessions of `station` that were opened and never closed.
    pub fn open_sessions(&mut self, station: &str) -> Result<Vec<OpenSession>, HistoryError> {
        let rows = self.db.query(
            "SELECT s.id, s.command, s.station, s.pid, s.started FROM sessions s \
             WHERE s.station = $1 AND NOT EXISTS \
             (SELECT 1 FROM session_ends e WHERE e.session_id = s.id) ORDER BY s.seq",
            &[Val::t(station)],
        )?;
        Ok(rows
            .iter()
            .map(|r| OpenSession {
                id: r[0].str(),
                command: r[1].str(),
                station: r[2].str(),
                pid: r[3].int().unwrap_or(0) as u32,
                started: r[4].str(),
            })
            .collect())
    }

    /// Walk the chain from the first record: each record's `prev_hash` is
    /// the hash before it and its hash is that of its content as its rows
    /// hold it now; sequence numbers have no gap and every content row has
    /// its chain record. Names the first record that breaks.
    pub fn verify(&mut self) -> Result<Verdict, HistoryError> {
        const PAGE: i64 = 2000;
        let mut prev = GENESIS.to_string();
        let mut expect = 1i64;
        let mut records = 0u64;
        loop {
            let chain = self.db.query(
                "SELECT seq, kind, session_id, prev_hash, hash FROM chain WHERE seq >= $1 ORDER BY seq LIMIT $2",
                &[Val::i(expect), Val::i(PAGE)],
            )?;
            if chain.is_empty() {
                break;
            }
            for c in &chain {
                let seq = c[0].int().unwrap_or(0);
                let kind = c[1].str();
                let session_id = c[2].str();
                let broken = |why: String| Verdict::Broken {
                    seq,
                    kind: kind.clone(),
                    session_id: session_id.clone(),
                    why,
                };
                if seq != expect {
                    return Ok(Verdict::Broken {
                        seq: expect,
                        kind: "?".into(),
                        session_id: String::new(),
                        why: format!("record {expect} is missing (the next is {seq})"),
                    });
                }
                if c[3].str() != prev {
                    return Ok(broken(format!(
                        "its prev_hash {} is not the hash of record {} ({prev})",
                        c[3].str(),
                        seq - 1
                    )));
                }
                let Some((row, codes)) = self.content_rows(&kind, seq)? else {
                    return Ok(broken("its content row is missing".into()));
                };
                let session_of = row.first().map(Val::str).unwrap_or_default();
                if session_of != session_id {
                    return Ok(broken(format!(
                        "its content names session {session_of}, its chain record {session_id}"
                    )));
                }
                let h = hash(&prev, &content(&kind, &row, &codes));
                if h != c[4].str() {
                    return Ok(broken(format!(
                        "its content does not hash to its recorded hash (recorded {}, content {h})",
                        c[4].str()
                    )));
                }
                prev = h;
                expect += 1;
                records += 1;
            }
        }
        // content rows outside the chain
        let counted: i64 = [
            "SELECT COUNT(*) FROM sessions",
            "SELECT COUNT(*) FROM drives",
            "SELECT COUNT(*) FROM session_ends",
        ]
        .iter()
        .map(|q| self.db.query(q, &[]).map(|r| r[0][0].int().unwrap_or(0)))
        .sum::<Result<i64, _>>()?;
        if counted != records as i64 {
            return Ok(Verdict::Broken {
                seq: records as i64 + 1,
                kind: "?".into(),
                session_id: String::new(),
                why: format!(
                    "{counted} content rows but {records} chain records: a row was added outside the chain"
                ),
            });
        }
        let stray = self.db.query(
            "SELECT c.drive_seq FROM codes c WHERE NOT EXISTS (SELECT 1 FROM drives d WHERE d.seq = c.drive_seq) LIMIT 1",
            &[],
        )?;
        if let Some(r) = stray.first() {
            return Ok(Verdict::Broken {
                seq: r[0].int().unwrap_or(0),
                kind: "drive".into(),
                session_id: String::new(),
                why: "a code row names a drive record that is not there".into(),
            });
        }
        Ok(Verdict::Intact {
            records,
            head: prev,
        })
    }

    /// The content row (first column: the session id) and, for a drive,
    /// its code rows, of record `seq`.
    fn content_rows(
        &mut self,
        kind: &str,
        seq: i64,
    ) -> Result<Option<(Row, Vec<Row>)>, HistoryError> {
        let (table, columns) = match kind {
            "session" => ("sessions", SESSION_COLUMNS),
            "drive" => ("drives", DRIVE_COLUMNS),
            "end" => ("session_ends", END_COLUMNS),
            _ => return Ok(None),
        };
        let rows = self.db.query(
            &format!("SELECT {columns} FROM {table} WHERE seq = $1"),
            &[Val::i(seq)],
        )?;
        let Some(row) = rows.into_iter().next() else {
            return Ok(None);
        };
        let codes = if kind == "drive" {
            self.db.query(
                &format!("SELECT {CODE_COLUMNS} FROM codes WHERE drive_seq = $1 ORDER BY ord"),
                &[Val::i(seq)],
            )?
        } else {
            Vec::new()
        };
        Ok(Some((row, codes)))
    }

    /// Every record as one JSON object a line (docs/history.md, "Export"):
    /// `seq`, `kind`, `session`, `prev_hash`, `hash` and `content` (the
    /// array the hash covers), in chain order, to `out`.
    pub fn export(&mut self, out: &mut dyn std::io::Write) -> Result<u64, HistoryError> {
        let mut from = 1i64;
        let mut n = 0u64;
        loop {
            let chain = self.db.query(
                "SELECT seq, kind, session_id, prev_hash, hash FROM chain WHERE seq >= $1 ORDER BY seq LIMIT 2000",
                &[Val::i(from)],
            )?;
            if chain.is_empty() {
                return Ok(n);
            }
            for c in &chain {
                let seq = c[0].int().unwrap_or(0);
                let kind = c[1].str();
                let (row, codes) = self.content_rows(&kind, seq)?.unwrap_or_default();
                let content: serde_json::Value =
                    serde_json::from_str(&content(&kind, &row, &codes)).unwrap_or_default();
                let line = serde_json::json!({
                    "seq": seq,
                    "kind": kind,
                    "session": c[2].str(),
                    "prev_hash": c[3].str(),
                    "hash": c[4].str(),
                    "content": content,
                });
                writeln!(out, "{line}").map_err(|e| HistoryError::Db(e.to_string()))?;
                from = seq + 1;
                n += 1;
            }
        }
    }

    /// The closed sessions recorded here that are owed to `target` (the
    /// shared store, masked) and not yet forwarded to it.
    pub fn owed_to(&mut self, target: &str) -> Result<Vec<String>, HistoryError> {
        let rows = self.db.query(
            "SELECT s.id FROM sessions s WHERE s.forward_to = $1 \
             AND EXISTS (SELECT 1 FROM session_ends e WHERE e.session_id = s.id) \
             AND NOT EXISTS (SELECT 1 FROM forwarded f WHERE f.session_id = s.id AND f.target = $1) \
             ORDER BY s.seq",
            &[Val::t(target)],
        )?;
        Ok(rows.iter().map(|r| r[0].str()).collect())
    }

    /// Everything recorded of session `id`.
    pub fn dump(&mut self, id: &str) -> Result<SessionDump, HistoryError> {
        let seqs = self.db.query(
            "SELECT seq, kind FROM chain WHERE session_id = $1 ORDER BY seq",
            &[Val::t(id)],
        )?;
        let mut dump = SessionDump {
            start: Vec::new(),
            drives: Vec::new(),
            end: None,
        };
        for s in seqs {
            let kind = s[1].str();
            let Some((row, codes)) = self.content_rows(&kind, s[0].int().unwrap_or(0))? else {
                continue;
            };
            match kind.as_str() {
                "session" => dump.start = row,
                "drive" => dump.drives.push((row, codes)),
                _ => dump.end = Some(row),
            }
        }
        Ok(dump)
    }

    /// Append `dump` to this store's chain unless a session of its id is
    /// here already (then it was forwarded before: `false`). One
    /// transaction: the session arrives whole or not at all.
    pub fn import(&mut self, id: &str, dump: &SessionDump) -> Result<bool, HistoryError> {
        self.append(Durability::Flushed, |st| {
            let have = st
                .db
                .query("SELECT 1 FROM sessions WHERE id = $1", &[Val::t(id)])?;
            if !have.is_empty() {
                return Ok(false);
            }
            st.link("session", id, &dump.start, &[])?;
            for (row, codes) in &dump.drives {
                st.link("drive", id, row, codes)?;
            }
            if let Some(end) = &dump.end {
                st.link("end", id, end, &[])?;
            }
            Ok(true)
        })
    }

    /// Note that session `id` was forwarded to `target`.
    pub fn mark_forwarded(&mut self, id: &str, target: &str, at: &str) -> Result<(), HistoryError> {
        self.db.exec(
            "INSERT INTO forwarded (session_id, target, at) VALUES ($1, $2, $3)",
            &[Val::t(id), Val::t(target), Val::t(at)],
        )?;
        Ok(())
    }

    /// Forward every session owed to `shared` (module docs): each exactly
    /// once, whatever failed between the copy and its note here (the
    /// shared store refuses a second copy of a session id). Gives the ids
    /// forwarded now.
    pub fn forward_to(
        &mut self,
        shared: &mut Store,
        at: &str,
    ) -> Result<Vec<String>, HistoryError> {
        let target = shared.shown.clone();
        let mut done = Vec::new();
        for id in self.owed_to(&target)? {
            let dump = self.dump(&id)?;
            if shared.import(&id, &dump)? {
                done.push(id.clone());
            }
            self.mark_forwarded(&id, &target, at)?;
        }
        Ok(done)
    }
}

//! The questions a plant asks of its history (docs/history.md,
//! "Queries"): [`Store::log`] (who did what to which drive, filtered),
//! [`Store::blame`] (who last changed a code of a drive, from what to
//! what, why, with which commit), [`Store::as_built`] (what every drive of
//! a line held at a label or a time, and the run that put it there) and
//! [`Store::changes`] / [`as_built_diff`] (what changed between two of
//! those).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::HistoryError;
use crate::db::Val;
use crate::store::Store;

/// The code outcomes that wrote a value to the drive.
pub const WRITTEN: [&str; 2] = ["verified", "written"];

/// What `history log` selects.
#[derive(Debug, Clone, Default)]
pub struct LogFilter {
    /// `--line`.
    pub line: Option<String>,
    /// `--drive`.
    pub drive: Option<String>,
    /// `--unit`: the unit's family, TYPE, software or an identity value.
    pub unit: Option<String>,
    /// `--code`: records that wrote this code (or found it drifted).
    pub code: Option<String>,
    /// `--since` (RFC 3339, inclusive).
    pub since: Option<String>,
    /// `--until` (RFC 3339, exclusive).
    pub until: Option<String>,
    /// `--label`.
    pub label: Option<String>,
    /// At most this many records, the newest.
    pub limit: u32,
}

/// A session as a record shows who ran it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Who {
    /// Session id.
    pub session: String,
    /// Command.
    pub command: String,
    /// Station.
    pub station: String,
    /// OS user.
    pub os_user: String,
    /// Operator.
    pub operator: Option<String>,
    /// Reason.
    pub reason: Option<String>,
    /// Label.
    pub label: Option<String>,
    /// The sets' commit.
    pub git_commit: Option<String>,
    /// Whether the work tree had changes.
    pub git_dirty: Option<bool>,
}

const WHO_COLUMNS: &str = "s.id, s.command, s.station, s.os_user, s.operator, s.reason, s.label, s.git_commit, s.git_dirty";

fn who(r: &[Val]) -> Who {
    Who {
        session: r[0].str(),
        command: r[1].str(),
        station: r[2].str(),
        os_user: r[3].str(),
        operator: r[4].text().map(str::to_string),
        reason: r[5].text().map(str::to_string),
        label: r[6].text().map(str::to_string),
        git_commit: r[7].text().map(str::to_string),
        git_dirty: r[8].int().map(|n| n != 0),
    }
}

/// One drive record of the log.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LogRow {
    /// Its place in the chain.
    pub seq: i64,
    /// When it was recorded.
    pub at: String,
    /// The run.
    #[serde(flatten)]
    pub who: Who,
    /// Line.
    pub line: Option<String>,
    /// Drive.
    pub drive: Option<String>,
    /// Bus.
    pub bus: String,
    /// Address.
    pub address: i64,
    /// Unit family.
    pub family: String,
    /// Unit TYPE.
    pub device_type: Option<String>,
    /// Unit software.
    pub software: Option<String>,
    /// Result.
    pub result: String,
    /// Codes written.
    pub codes_written: i64,
    /// Fingerprint after.
    pub fingerprint_after: Option<String>,
    /// With `--code`: that code's old and new value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub change: Option<(Option<String>, Option<String>)>,
}

/// Who last changed a code.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Blame {
    /// The drive.
    pub drive: String,
    /// The line.
    pub line: Option<String>,
    /// The code.
    pub code: String,
    /// When.
    pub at: String,
    /// Who, why, with which commit.
    #[serde(flatten)]
    pub who: Who,
    /// From.
    pub old: Option<String>,
    /// To.
    pub new: Option<String>,
    /// Read back after the write.
    pub verified: Option<String>,
}

/// What a drive held, as the history knows it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Held {
    /// The drive.
    pub drive: String,
    /// Its bus.
    pub bus: String,
    /// Its address.
    pub address: i64,
    /// Fingerprint of what it held.
    pub fingerprint: String,
    /// The unit: family.
    pub family: String,
    /// TYPE.
    pub device_type: Option<String>,
    /// Software.
    pub software: Option<String>,
    /// Identity codes.
    pub identity: Vec<(String, String)>,
    /// Code -> value (display texts; a password `<secret>`).
    pub values: BTreeMap<String, String>,
    /// The last record of it (when the history last saw it so).
    pub seen: String,
    /// The run that put the fingerprint there (the last that wrote it).
    pub put_by: Option<Who>,
    /// When that run wrote it.
    pub put_at: Option<String>,
}

/// A line as built.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct AsBuilt {
    /// The line.
    pub line: String,
    /// At what (`latest`, a label or a time).
    pub at: String,
    /// Every drive of the manifest the history knows, in manifest order.
    pub drives: Vec<Held>,
    /// The manifest's drives the history has nothing of (as of `at`).
    pub unknown: Vec<String>,
}

/// As of when ([`Store::as_built`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum At {
    /// Everything recorded.
    Latest,
    /// Up to the last record of the line in a session with this label.
    Label(String),
    /// Up to this instant (RFC 3339), inclusive.
    Time(String),
}

impl At {
    /// A time when `s` reads as one (`2026-12-03`, `2026-12-03T10:00:00Z`),
    /// else a label.
    pub fn parse(s: &str) -> At {
        if let Ok(t) = s.parse::<jiff::Timestamp>() {
            return At::Time(format!("{t:.3}"));
        }
        if let Ok(d) = s.parse::<jiff::civil::Date>() {
            // the whole day, UTC
            return At::Time(format!("{d}T23:59:59.999Z"));
        }
        At::Label(s.to_string())
    }

    fn name(&self) -> String {
        match self {
            At::Latest => "latest".into(),
            At::Label(l) => format!("label {l}"),
            At::Time(t) => t.clone(),
        }
    }
}

impl Store {
    /// `history log` (module docs): the newest `limit` records that pass
    /// `f`, oldest first.
    pub fn log(&mut self, f: &LogFilter) -> Result<Vec<LogRow>, HistoryError> {
        let mut cond = Vec::new();
        let mut params: Vec<Val> = Vec::new();
        let mut add = |c: &str, v: &Option<String>, params: &mut Vec<Val>| {
            if let Some(v) = v {
                params.push(Val::t(v));
                cond.push(c.replace('?', &format!("${}", params.len())));
            }
        };
        add("d.line = ?", &f.line, &mut params);
        add("d.drive = ?", &f.drive, &mut params);
        add(
            "(d.family = ? OR d.device_type = ? OR d.software = ? OR d.identity LIKE '%\"' || ? || '\"%')",
            &f.unit,
            &mut params,
        );
        add("d.at >= ?", &f.since, &mut params);
        add("d.at < ?", &f.until, &mut params);
        add("s.label = ?", &f.label, &mut params);
        let code_param = f.code.as_ref().map(|c| {
            params.push(Val::t(c));
            params.len()
        });
        if let Some(n) = code_param {
            cond.push(format!(
                "EXISTS (SELECT 1 FROM codes c WHERE c.drive_seq = d.seq AND c.code = ${n} \
                 AND c.outcome IN ('verified', 'written', 'failed', 'restored', 'drift'))"
            ));
        }
        let wher = if cond.is_empty() {
            String::new()
        } else {
            format!("WHERE {}", cond.join(" AND "))
        };
        params.push(Val::i(i64::from(f.limit.max(1))));
        let sql = format!(
            "SELECT d.seq, d.at, {WHO_COLUMNS}, d.line, d.drive, d.bus, d.address, d.family, \
             d.device_type, d.software, d.result, d.codes_written, d.fingerprint_after \
             FROM drives d JOIN sessions s ON s.id = d.session_id {wher} \
             ORDER BY d.seq DESC LIMIT ${}",
            params.len()
        );
        let rows = self.db().query(&sql, &params)?;
        let mut out = Vec::with_capacity(rows.len());
        for r in rows.iter().rev() {
            let seq = r[0].int().unwrap_or(0);
            let change = match &f.code {
                Some(c) => self
                    .db()
                    .query(
                        "SELECT old, new FROM codes WHERE drive_seq = $1 AND code = $2",
                        &[Val::i(seq), Val::t(c)],
                    )?
                    .first()
                    .map(|c| {
                        (
                            c[0].text().map(str::to_string),
                            c[1].text().map(str::to_string),
                        )
                    }),
                None => None,
            };
            out.push(LogRow {
                seq,
                at: r[1].str(),
                who: who(&r[2..11]),
                line: r[11].text().map(str::to_string),
                drive: r[12].text().map(str::to_string),
                bus: r[13].str(),
                address: r[14].int().unwrap_or(0),
                family: r[15].str(),
                device_type: r[16].text().map(str::to_string),
                software: r[17].text().map(str::to_string),
                result: r[18].str(),
                codes_written: r[19].int().unwrap_or(0),
                fingerprint_after: r[20].text().map(str::to_string),
                change,
            });
        }
        Ok(out)
    }

    /// `history blame`: the last record that wrote `code` of `drive` (of
    /// `line`, when given) with a value other than the one it held.
    pub fn blame(
        &mut self,
        line: Option<&str>,
        drive: &str,
        code: &str,
    ) -> Result<Option<Blame>, HistoryError> {
        let mut params = vec![Val::t(code), Val::t(drive)];
        let line_cond = match line {
            Some(l) => {
                params.push(Val::t(l));
                " AND line = $3"
            }
            None => "",
        };
        let sql = format!(
            "SELECT c.drive_seq, c.old, c.new, c.verified FROM codes c \
             WHERE c.code = $1 AND c.outcome IN ('verified', 'written') \
             AND (c.old IS NULL OR c.new IS NULL OR c.old <> c.new) \
             AND c.drive_seq IN (SELECT seq FROM drives WHERE drive = $2{line_cond}) \
             ORDER BY c.drive_seq DESC LIMIT 1"
        );
        let rows = self.db().query(&sql, &params)?;
        let Some(c) = rows.first() else {
            return Ok(None);
        };
        let seq = c[0].int().unwrap_or(0);
        let d = self.db().query(
            &format!(
                "SELECT d.at, d.line, {WHO_COLUMNS} FROM drives d \
                 JOIN sessions s ON s.id = d.session_id WHERE d.seq = $1"
            ),
            &[Val::i(seq)],
        )?;
        let Some(d) = d.first() else {
            return Ok(None);
        };
        Ok(Some(Blame {
            drive: drive.to_string(),
            line: d[1].text().map(str::to_string),
            code: code.to_string(),
            at: d[0].str(),
            who: who(&d[2..11]),
            old: c[1].text().map(str::to_string),
            new: c[2].text().map(str::to_string),
            verified: c[3].text().map(str::to_string),
        }))
    }

    /// `history diff`: what changed on `line` (its `drives`) from as
    /// built at `a` to as built at `b` ([`as_built_diff`]).
    pub fn changes(
        &mut self,
        line: &str,
        drives: &[String],
        a: &At,
        b: &At,
    ) -> Result<Vec<Difference>, HistoryError> {
        let built_a = self.as_built(line, drives, a)?;
        let built_b = self.as_built(line, drives, b)?;
        Ok(as_built_diff(&built_a, &built_b))
    }

    /// `history as-built`: what each of `drives` (of `line`) held as of
    /// `at` (module docs).
    pub fn as_built(
        &mut self,
        line: &str,
        drives: &[String],
        at: &At,
    ) -> Result<AsBuilt, HistoryError> {
        // the cut: a chain position, and for a time an instant
        let (cut, until) = match at {
            At::Latest => (i64::MAX, None),
            At::Time(t) => (i64::MAX, Some(t.clone())),
            At::Label(l) => {
                // from the label's sessions (its index) to their drives;
                // the line is picked here, so no plan walks the line's
                // every record
                let r = self.db().query(
                    "SELECT d.seq, d.line FROM sessions s JOIN drives d ON d.session_id = s.id \
                     WHERE s.label = $1",
                    &[Val::t(l)],
                )?;
                let cut = r
                    .iter()
                    .filter(|r| r[1].text() == Some(line))
                    .filter_map(|r| r[0].int())
                    .max()
                    .unwrap_or(0);
                (cut, None)
            }
        };
        let until = until.unwrap_or_else(|| "9999".into());
        let mut out = AsBuilt {
            line: line.to_string(),
            at: at.name(),
            drives: Vec::new(),
            unknown: Vec::new(),
        };
        for name in drives {
            let base = [Val::t(line), Val::t(name), Val::i(cut), Val::t(&until)];
            let last = self.db().query(
                "SELECT seq, at, bus, address, fingerprint_after, family, device_type, software, identity \
                 FROM drives WHERE line = $1 AND drive = $2 AND seq <= $3 AND at <= $4 \
                 AND fingerprint_after IS NOT NULL ORDER BY seq DESC LIMIT 1",
                &base,
            )?;
            let Some(last) = last.first() else {
                out.unknown.push(name.clone());
                continue;
            };
            let fp = last[4].str();
            let mut p = base.to_vec();
            p.push(Val::t(&fp));
            let with_values = self.db().query(
                "SELECT seq FROM drives WHERE line = $1 AND drive = $2 AND seq <= $3 AND at <= $4 \
                 AND fingerprint_after = $5 AND result <> 'already-verified' \
                 ORDER BY seq DESC LIMIT 1",
                &p,
            )?;
            let mut values = BTreeMap::new();
            if let Some(v) = with_values.first() {
                let codes = self.db().query(
                    "SELECT code, old, verified, outcome FROM codes WHERE drive_seq = $1 ORDER BY ord",
                    &[Val::i(v[0].int().unwrap_or(0))],
                )?;
                for c in codes {
                    let held = match c[3].str().as_str() {
                        "verified" | "unchanged" => c[2].text(),
                        "read" | "drift" | "restored" => c[1].text(),
                        _ => None,
                    };
                    if let Some(h) = held {
                        values.insert(c[0].str(), h.to_string());
                    }
                }
            }
            let put = self.db().query(
                &format!(
                    "SELECT d.at, {WHO_COLUMNS} FROM drives d JOIN sessions s ON s.id = d.session_id \
                     WHERE d.line = $1 AND d.drive = $2 AND d.seq <= $3 AND d.at <= $4 \
                     AND d.fingerprint_after = $5 AND d.codes_written > 0 \
                     ORDER BY d.seq DESC LIMIT 1"
                ),
                &p,
            )?;
            out.drives.push(Held {
                drive: name.clone(),
                bus: last[2].str(),
                address: last[3].int().unwrap_or(0),
                fingerprint: fp,
                family: last[5].str(),
                device_type: last[6].text().map(str::to_string),
                software: last[7].text().map(str::to_string),
                identity: serde_json::from_str(&last[8].str()).unwrap_or_default(),
                values,
                seen: last[1].str(),
                put_by: put.first().map(|r| who(&r[1..10])),
                put_at: put.first().map(|r| r[0].str()),
            });
        }
        Ok(out)
    }
}

/// One difference between two as-built states.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Difference {
    /// The drive.
    pub drive: String,
    /// The code, or `unit` (another unit in the slot), or `drive` (known
    /// at one side only).
    pub what: String,
    /// At A.
    pub a: Option<String>,
    /// At B.
    pub b: Option<String>,
}

/// What changed from `a` to `b`, drive by drive in `a`'s then `b`'s order.
pub fn as_built_diff(a: &AsBuilt, b: &AsBuilt) -> Vec<Difference> {
    let mut out = Vec::new();
    let bmap: BTreeMap<&str, &Held> = b.drives.iter().map(|h| (h.drive.as_str(), h)).collect();
    let amap: BTreeMap<&str, &Held> = a.drives.iter().map(|h| (h.drive.as_str(), h)).collect();
    for ha in &a.drives {
        let Some(hb) = bmap.get(ha.drive.as_str()) else {
            out.push(Difference {
                drive: ha.drive.clone(),
                what: "drive".into(),
                a: Some(ha.fingerprint.clone()),
                b: None,
            });
            continue;
        };
        if ha.identity != hb.identity {
            let unit = |h: &Held| {
                h.identity
                    .iter()
                    .map(|(c, v)| format!("{c}={v}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            out.push(Difference {
                drive: ha.drive.clone(),
                what: "unit".into(),
                a: Some(unit(ha)),
                b: Some(unit(hb)),
            });
        }
        if ha.fingerprint == hb.fingerprint {
            continue;
        }
        let codes: std::collections::BTreeSet<&String> =
            ha.values.keys().chain(hb.values.keys()).collect();
        for c in codes {
            let (va, vb) = (ha.values.get(c), hb.values.get(c));
            if va != vb {
                out.push(Difference {
                    drive: ha.drive.clone(),
                    what: c.clone(),
                    a: va.cloned(),
                    b: vb.cloned(),
                });
            }
        }
    }
    for hb in &b.drives {
        if !amap.contains_key(hb.drive.as_str()) {
            out.push(Difference {
                drive: hb.drive.clone(),
                what: "drive".into(),
                a: None,
                b: Some(hb.fingerprint.clone()),
            });
        }
    }
    out
}

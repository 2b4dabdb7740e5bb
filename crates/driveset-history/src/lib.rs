//! driveset-history: the plant history (docs/history.md). Every command
//! that writes a drive or reads its set appends a session to a store —
//! SQLite in `.driveset/history.sqlite` by default, or a PostgreSQL server
//! many commissioning stations share — as records of a hash chain
//! (`store.rs`), which `driveset history verify` walks. The engine's
//! [`driveset_engine::history::History`] seam is implemented here by a
//! run's open session (`run.rs`: the session a command opens, drive
//! records put into the store by a thread of their own, closing it, the
//! links a line report carries to it); this crate does the storing and the
//! queries (`query.rs`) and how `driveset history` prints them
//! (`render.rs`), with one SQL text for both databases (`db.rs`) and
//! versioned migrations (`schema.rs`). The CLI keeps the flags that choose
//! a store and when a command opens its session.

pub mod db;
pub mod generate;
pub mod query;
pub mod render;
pub mod run;
pub mod schema;
pub mod store;

use std::path::{Path, PathBuf};

pub use store::{OpenSession, SessionEnd, SessionStart, Store, Verdict};

/// The default store, beside the journals (`.driveset/journal`).
pub const DEFAULT_SQLITE: &str = ".driveset/history.sqlite";

/// What went wrong with a store.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// The store could not be opened or reached.
    #[error("history store {store} cannot be opened: {detail}")]
    Open {
        /// The store, password masked.
        store: String,
        /// Why.
        detail: String,
    },
    /// A statement failed.
    #[error("history store: {0}")]
    Db(String),
    /// The store was written by a newer driveset.
    #[error(
        "the history store has schema version {found}; this driveset knows up to {known}: use a newer driveset"
    )]
    NewerSchema {
        /// In the store.
        found: i64,
        /// Known here.
        known: i64,
    },
    /// `--history` / `DRIVESET_HISTORY` not understood.
    #[error(
        "history store `{0}` not understood: give sqlite:PATH, postgresql://USER@HOST/DB (or postgres://), or off"
    )]
    BadTarget(String),
}

/// Where the history goes (`--history`, `DRIVESET_HISTORY`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// An SQLite file.
    Sqlite(PathBuf),
    /// A PostgreSQL server (the connection URL as given).
    Postgres(String),
    /// Nothing is recorded.
    Off,
}

impl Target {
    /// `sqlite:PATH`, `postgresql://...` / `postgres://...`, or `off`.
    pub fn parse(s: &str) -> Result<Target, HistoryError> {
        if s == "off" {
            Ok(Target::Off)
        } else if let Some(p) = s.strip_prefix("sqlite:") {
            if p.is_empty() {
                return Err(HistoryError::BadTarget(s.to_string()));
            }
            Ok(Target::Sqlite(PathBuf::from(p)))
        } else if s.starts_with("postgresql://") || s.starts_with("postgres://") {
            Ok(Target::Postgres(s.to_string()))
        } else {
            Err(HistoryError::BadTarget(mask_url(s)))
        }
    }

    /// The default: SQLite beside the journals.
    pub fn default_sqlite() -> Target {
        Target::Sqlite(PathBuf::from(DEFAULT_SQLITE))
    }

    /// As messages and records name it: a password masked.
    pub fn shown(&self) -> String {
        match self {
            Target::Sqlite(p) => format!("sqlite:{}", p.display()),
            Target::Postgres(u) => mask_url(u),
            Target::Off => "off".into(),
        }
    }

    /// Open the store, creating and migrating it on first use; `None` for
    /// [`Target::Off`].
    pub fn open(&self) -> Result<Option<Store>, HistoryError> {
        match self {
            Target::Off => Ok(None),
            Target::Sqlite(p) => {
                if p == Path::new(DEFAULT_SQLITE) {
                    keep_out_of_git(p);
                }
                open_sqlite(p).map(Some)
            }
            Target::Postgres(url) => {
                let shown = mask_url(url);
                let db = db::Postgres::connect(url, &shown)?;
                Store::over(Box::new(db), shown).map(Some)
            }
        }
    }
}

/// The default store's directory (`.driveset`) keeps itself out of git
/// as the journals' does: created the one way the engine creates it
/// ([`driveset_engine::journal::ensure_dir`], a `.gitignore` of `*` in the
/// topmost directory it creates).
fn keep_out_of_git(path: &Path) {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        let _ = driveset_engine::journal::ensure_dir(dir);
    }
}

/// Open (creating its directory and the file) the SQLite store at `path`.
pub fn open_sqlite(path: &Path) -> Result<Store, HistoryError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| HistoryError::Open {
            store: format!("sqlite:{}", path.display()),
            detail: e.to_string(),
        })?;
    }
    let db = db::Sqlite::open(path)?;
    Store::over(Box::new(db), format!("sqlite:{}", path.display()))
}

/// `url` with the password of its user part, and any `password=` key of
/// its query, replaced by `***`.
pub fn mask_url(url: &str) -> String {
    let mut out = url.to_string();
    if let Some(scheme_end) = out.find("://") {
        let rest = &out[scheme_end + 3..];
        let auth_end = rest.find(['/', '?']).unwrap_or(rest.len());
        if let Some(at) = rest[..auth_end].rfind('@')
            && let Some(colon) = rest[..at].find(':')
        {
            let (a, b) = (scheme_end + 3 + colon + 1, scheme_end + 3 + at);
            out.replace_range(a..b, "***");
        }
    }
    mask_key(&out, "password=")
}

fn mask_key(s: &str, key: &str) -> String {
    let Some(i) = s.find(key) else {
        return s.to_string();
    };
    let start = i + key.len();
    let end = s[start..].find(['&', ' ']).map_or(s.len(), |j| start + j);
    format!("{}***{}", &s[..start], mask_key(&s[end..], key))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_and_passwords_are_masked() {
        assert_eq!(Target::parse("off").unwrap(), Target::Off);
        assert_eq!(
            Target::parse("sqlite:/tmp/h.sqlite").unwrap(),
            Target::Sqlite(PathBuf::from("/tmp/h.sqlite"))
        );
        let t = Target::parse("postgresql://drv:s3cret@db.plant/history?sslmode=disable").unwrap();
        assert_eq!(
            t.shown(),
            "postgresql://drv:***@db.plant/history?sslmode=disable"
        );
        assert_eq!(
            mask_url("postgresql:///history?host=/run/pg&user=d&password=abc&x=1"),
            "postgresql:///history?host=/run/pg&user=d&password=***&x=1"
        );
        assert_eq!(
            mask_url("postgresql://drv@db/history"),
            "postgresql://drv@db/history"
        );
        let e = Target::parse("mysql://root:pw@x/y")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "history store `mysql://root:***@x/y` not understood: give sqlite:PATH, postgresql://USER@HOST/DB (or postgres://), or off"
        );
        assert!(Target::parse("sqlite:").is_err());
    }
}

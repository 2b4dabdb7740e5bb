//! The two databases behind one small interface ([`Db`]): SQLite
//! (`rusqlite`, the library bundled) and PostgreSQL (the synchronous
//! `postgres` client). The store's SQL is written once, with `$1`
//! placeholders, in the subset both speak; values are integers and texts
//! ([`Val`]).

use std::path::Path;

use crate::HistoryError;

/// A value going in or coming out: an integer or a text, either may be NULL.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Val {
    /// A 64-bit integer (`BIGINT`).
    Int(Option<i64>),
    /// A text.
    Text(Option<String>),
}

impl Val {
    /// A text.
    pub fn t(s: impl Into<String>) -> Val {
        Val::Text(Some(s.into()))
    }

    /// A text or NULL.
    pub fn ot(s: Option<impl Into<String>>) -> Val {
        Val::Text(s.map(Into::into))
    }

    /// An integer.
    pub fn i(n: i64) -> Val {
        Val::Int(Some(n))
    }

    /// The integer, if it is one.
    pub fn int(&self) -> Option<i64> {
        match self {
            Val::Int(n) => *n,
            Val::Text(_) => None,
        }
    }

    /// The text, if it is one.
    pub fn text(&self) -> Option<&str> {
        match self {
            Val::Text(s) => s.as_deref(),
            Val::Int(_) => None,
        }
    }

    /// The text, `""` for NULL.
    pub fn str(&self) -> String {
        self.text().unwrap_or_default().to_string()
    }
}

/// A row of a query.
pub type Row = Vec<Val>;

/// How far an append's commit goes before it returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// To the disk (SQLite `synchronous = FULL`: the WAL is fsynced;
    /// PostgreSQL: the WAL is flushed). It flushes every commit before it
    /// too: the WAL is one log.
    Flushed,
    /// To the database's log, not waiting for the disk (SQLite
    /// `synchronous = NORMAL` in WAL mode, PostgreSQL `synchronous_commit
    /// = off`): kept when the process is killed, lost with the commits
    /// after the last flushed one when the machine loses power; the
    /// database stays consistent either way.
    Written,
}

/// What the store asks of a database.
pub trait Db: Send {
    /// Run statements without parameters (a migration).
    fn batch(&mut self, sql: &str) -> Result<(), HistoryError>;
    /// Run one statement.
    fn exec(&mut self, sql: &str, params: &[Val]) -> Result<u64, HistoryError>;
    /// Run one query.
    fn query(&mut self, sql: &str, params: &[Val]) -> Result<Vec<Row>, HistoryError>;
    /// Begin the transaction an append runs in, holding the chain for
    /// this writer alone until [`Db::commit`], which goes as far as
    /// `durability`.
    fn begin_append(&mut self, durability: Durability) -> Result<(), HistoryError>;
    /// Commit.
    fn commit(&mut self) -> Result<(), HistoryError>;
    /// Roll back (after a failed append).
    fn rollback(&mut self);
    /// `sqlite` or `postgresql`.
    fn kind(&self) -> &'static str;
}

/// SQLite in a file.
pub struct Sqlite {
    conn: rusqlite::Connection,
    /// The connection's `synchronous` setting.
    durability: Durability,
}

fn sq(e: rusqlite::Error) -> HistoryError {
    HistoryError::Db(e.to_string())
}

/// `$n` placeholders as SQLite writes them (`?n`).
fn sqlite_sql(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len());
    let mut chars = sql.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '$' && chars.peek().is_some_and(char::is_ascii_digit) {
            out.push('?');
        } else {
            out.push(c);
        }
    }
    out
}

impl Sqlite {
    /// Open (creating) the database file at `path`.
    pub fn open(path: &Path) -> Result<Self, HistoryError> {
        let conn = rusqlite::Connection::open(path).map_err(|e| HistoryError::Open {
            store: format!("sqlite:{}", path.display()),
            detail: e.to_string(),
        })?;
        conn.busy_timeout(std::time::Duration::from_secs(60))
            .map_err(sq)?;
        conn.execute_batch("PRAGMA journal_mode = WAL; PRAGMA synchronous = FULL;")
            .map_err(sq)?;
        Ok(Sqlite {
            conn,
            durability: Durability::Flushed,
        })
    }
}

impl rusqlite::ToSql for Val {
    fn to_sql(&self) -> rusqlite::Result<rusqlite::types::ToSqlOutput<'_>> {
        match self {
            Val::Int(n) => n.to_sql(),
            Val::Text(s) => s.to_sql(),
        }
    }
}

impl Db for Sqlite {
    fn batch(&mut self, sql: &str) -> Result<(), HistoryError> {
        self.conn.execute_batch(sql).map_err(sq)
    }

    fn exec(&mut self, sql: &str, params: &[Val]) -> Result<u64, HistoryError> {
        let mut st = self.conn.prepare_cached(&sqlite_sql(sql)).map_err(sq)?;
        st.execute(rusqlite::params_from_iter(params.iter()))
            .map(|n| n as u64)
            .map_err(sq)
    }

    fn query(&mut self, sql: &str, params: &[Val]) -> Result<Vec<Row>, HistoryError> {
        let mut st = self.conn.prepare_cached(&sqlite_sql(sql)).map_err(sq)?;
        let n = st.column_count();
        let mut rows = st
            .query(rusqlite::params_from_iter(params.iter()))
            .map_err(sq)?;
        let mut out = Vec::new();
        while let Some(r) = rows.next().map_err(sq)? {
            let mut row = Vec::with_capacity(n);
            for i in 0..n {
                use rusqlite::types::ValueRef;
                row.push(match r.get_ref(i).map_err(sq)? {
                    ValueRef::Null => Val::Text(None),
                    ValueRef::Integer(v) => Val::Int(Some(v)),
                    ValueRef::Real(v) => Val::Text(Some(v.to_string())),
                    ValueRef::Text(t) | ValueRef::Blob(t) => {
                        Val::Text(Some(String::from_utf8_lossy(t).into_owned()))
                    }
                });
            }
            out.push(row);
        }
        Ok(out)
    }

    fn begin_append(&mut self, durability: Durability) -> Result<(), HistoryError> {
        if self.durability != durability {
            self.conn
                .execute_batch(match durability {
                    Durability::Flushed => "PRAGMA synchronous = FULL",
                    Durability::Written => "PRAGMA synchronous = NORMAL",
                })
                .map_err(sq)?;
            self.durability = durability;
        }
        self.conn.execute_batch("BEGIN IMMEDIATE").map_err(sq)
    }

    fn commit(&mut self) -> Result<(), HistoryError> {
        self.conn.execute_batch("COMMIT").map_err(sq)
    }

    fn rollback(&mut self) {
        let _ = self.conn.execute_batch("ROLLBACK");
    }

    fn kind(&self) -> &'static str {
        "sqlite"
    }
}

/// A PostgreSQL server.
pub struct Postgres {
    client: postgres::Client,
    /// Statements prepared once per connection (a query is one round trip,
    /// not two).
    prepared: std::collections::HashMap<String, postgres::Statement>,
}

fn pg(e: postgres::Error) -> HistoryError {
    // the server's own message (a trigger's refusal says why)
    match e.as_db_error() {
        Some(d) => HistoryError::Db(d.message().to_string()),
        None => HistoryError::Db(e.to_string()),
    }
}

impl Postgres {
    /// Connect to `url` (`postgresql://...`); `shown` is the URL with its
    /// password masked, for messages.
    pub fn connect(url: &str, shown: &str) -> Result<Self, HistoryError> {
        let mut config: postgres::Config =
            url.parse()
                .map_err(|e: postgres::Error| HistoryError::Open {
                    store: shown.to_string(),
                    detail: e.to_string(),
                })?;
        if config.get_connect_timeout().is_none() {
            config.connect_timeout(std::time::Duration::from_secs(5));
        }
        let client = config
            .connect(postgres::NoTls)
            .map_err(|e| HistoryError::Open {
                store: shown.to_string(),
                detail: e.to_string(),
            })?;
        Ok(Postgres {
            client,
            prepared: std::collections::HashMap::new(),
        })
    }

    /// `params` for `stmt`: a NULL goes as the type the statement's
    /// parameter has (a NULL read from SQLite has no type of its own).
    fn params<'a>(
        stmt: &postgres::Statement,
        params: &'a [Val],
    ) -> Vec<&'a (dyn postgres::types::ToSql + Sync)> {
        static NO_INT: Option<i64> = None;
        static NO_TEXT: Option<String> = None;
        params
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let int = stmt
                    .params()
                    .get(i)
                    .is_some_and(|t| *t == postgres::types::Type::INT8);
                match v {
                    Val::Int(None) | Val::Text(None) if int => {
                        &NO_INT as &(dyn postgres::types::ToSql + Sync)
                    }
                    Val::Int(None) | Val::Text(None) => &NO_TEXT,
                    Val::Int(n) => n,
                    Val::Text(s) => s,
                }
            })
            .collect()
    }
}

impl Postgres {
    fn prepare(&mut self, sql: &str) -> Result<postgres::Statement, HistoryError> {
        if let Some(s) = self.prepared.get(sql) {
            return Ok(s.clone());
        }
        let s = self.client.prepare(sql).map_err(pg)?;
        self.prepared.insert(sql.to_string(), s.clone());
        Ok(s)
    }
}

impl Db for Postgres {
    fn batch(&mut self, sql: &str) -> Result<(), HistoryError> {
        self.client.batch_execute(sql).map_err(pg)
    }

    fn exec(&mut self, sql: &str, params: &[Val]) -> Result<u64, HistoryError> {
        let stmt = self.prepare(sql)?;
        self.client
            .execute(&stmt, &Self::params(&stmt, params))
            .map_err(pg)
    }

    fn query(&mut self, sql: &str, params: &[Val]) -> Result<Vec<Row>, HistoryError> {
        use postgres::types::Type;
        let stmt = self.prepare(sql)?;
        let rows = self
            .client
            .query(&stmt, &Self::params(&stmt, params))
            .map_err(pg)?;
        let mut out = Vec::with_capacity(rows.len());
        for r in rows {
            let mut row = Vec::with_capacity(r.len());
            for (i, c) in r.columns().iter().enumerate() {
                let v = match *c.type_() {
                    Type::INT8 => Val::Int(r.try_get(i).map_err(pg)?),
                    Type::INT4 => {
                        Val::Int(r.try_get::<_, Option<i32>>(i).map_err(pg)?.map(i64::from))
                    }
                    _ => Val::Text(r.try_get(i).map_err(pg)?),
                };
                row.push(v);
            }
            out.push(row);
        }
        Ok(out)
    }

    fn begin_append(&mut self, durability: Durability) -> Result<(), HistoryError> {
        self.client
            .batch_execute(match durability {
                Durability::Flushed => "BEGIN; LOCK TABLE chain IN EXCLUSIVE MODE",
                Durability::Written => {
                    "BEGIN; SET LOCAL synchronous_commit = off; LOCK TABLE chain IN EXCLUSIVE MODE"
                }
            })
            .map_err(pg)
    }

    fn commit(&mut self) -> Result<(), HistoryError> {
        self.client.batch_execute("COMMIT").map_err(pg)
    }

    fn rollback(&mut self) {
        let _ = self.client.batch_execute("ROLLBACK");
    }

    fn kind(&self) -> &'static str {
        "postgresql"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_become_sqlites() {
        assert_eq!(
            sqlite_sql("SELECT a FROM t WHERE b = $1 AND c = $12 AND d = '$x'"),
            "SELECT a FROM t WHERE b = ?1 AND c = ?12 AND d = '$x'"
        );
    }
}

//! The studio's persistent store: one SQLite database, `studio.sqlite3`, in the state directory.
//!
//! It holds three tables — the machines, the jobs (with the drawing's bytes, its name and the layout and plot
//! options as JSON) and each job's history of attempts (start, end, plot time, outcome). The schema is versioned
//! by SQLite's `user_version`: [`MIGRATIONS`] lists every change since the first version, and opening a database
//! applies the ones it lacks, each in its own transaction, so an interrupted migration leaves the previous version
//! whole. A database whose version is newer than this build knows is refused, never guessed at.
//!
//! The file is written in WAL mode with `synchronous=FULL`: a change that returned is on disk, even if the process
//! is killed the next instant or the power goes, and a reader never sees half of a change. Every change the queue
//! makes goes through `Store::change`, one `BEGIN IMMEDIATE` transaction.

use std::path::{Path, PathBuf};
use std::time::Duration;

use rusqlite::{Connection, OptionalExtension, Transaction, TransactionBehavior};

use super::error::{Result, StudioError};

/// The database's file name in the state directory.
pub const FILE_NAME: &str = "studio.sqlite3";

/// How long a change waits for another connection's transaction to end before it gives up.
pub const BUSY_WAIT: Duration = Duration::from_secs(5);

/// The schema's changes, in order: the database's `user_version` is the number of them applied.
///
/// 1. machines, jobs and their history;
/// 2. the attempt count, the operator's stop request, the resume-from-journal mark and the `interrupted` state
///    (the jobs table is rebuilt, since SQLite cannot change a column's check in place), and an index for the
///    queue's order.
pub const MIGRATIONS: &[&str] = &[
    // Version 1.
    "CREATE TABLE machines (
         name TEXT PRIMARY KEY NOT NULL,
         device TEXT NOT NULL,
         firmware TEXT NOT NULL,
         profile TEXT,
         added INTEGER NOT NULL
     );
     CREATE TABLE jobs (
         id INTEGER PRIMARY KEY AUTOINCREMENT,
         created INTEGER NOT NULL,
         machine TEXT REFERENCES machines(name),
         drawing_name TEXT NOT NULL,
         drawing BLOB NOT NULL,
         options TEXT NOT NULL,
         state TEXT NOT NULL CHECK (state IN ('queued', 'plotting', 'paused', 'done', 'failed', 'cancelled')),
         position INTEGER NOT NULL,
         claimed_by TEXT REFERENCES machines(name)
     );
     CREATE TABLE history (
         id INTEGER PRIMARY KEY AUTOINCREMENT,
         job INTEGER NOT NULL REFERENCES jobs(id),
         machine TEXT NOT NULL,
         started INTEGER NOT NULL,
         ended INTEGER,
         plot_ms INTEGER,
         outcome TEXT
     );",
    // Version 2.
    "CREATE TABLE jobs_v2 (
         id INTEGER PRIMARY KEY AUTOINCREMENT,
         created INTEGER NOT NULL,
         machine TEXT REFERENCES machines(name),
         drawing_name TEXT NOT NULL,
         drawing BLOB NOT NULL,
         options TEXT NOT NULL,
         state TEXT NOT NULL CHECK (state IN
             ('queued', 'plotting', 'paused', 'interrupted', 'done', 'failed', 'cancelled')),
         position INTEGER NOT NULL,
         claimed_by TEXT REFERENCES machines(name),
         attempts INTEGER NOT NULL DEFAULT 0,
         stop_requested INTEGER NOT NULL DEFAULT 0,
         resume INTEGER NOT NULL DEFAULT 0
     );
     INSERT INTO jobs_v2 (id, created, machine, drawing_name, drawing, options, state, position, claimed_by, attempts)
         SELECT id, created, machine, drawing_name, drawing, options, state, position, claimed_by,
                (SELECT count(*) FROM history WHERE history.job = jobs.id)
         FROM jobs;
     DROP TABLE jobs;
     ALTER TABLE jobs_v2 RENAME TO jobs;
     CREATE INDEX jobs_by_state ON jobs(state, position);
     CREATE INDEX history_by_job ON history(job);",
];

/// The schema version this build writes: the number of [`MIGRATIONS`].
pub const SCHEMA_VERSION: i64 = 2;
const _: () = assert!(MIGRATIONS.len() == 2, "SCHEMA_VERSION is the number of migrations");

/// An open studio database.
#[derive(Debug)]
pub struct Store {
    conn: Connection,
    path: PathBuf,
}

impl Store {
    /// Opens (or creates) the database in the state directory `dir` (created if missing) and brings its schema up
    /// to date. `plotter_host::state_dir::state_dir()` is the user's; tests pass a folder of their own.
    pub fn open_in(dir: &Path) -> Result<Store> {
        std::fs::create_dir_all(dir).map_err(|source| StudioError::Folder { path: dir.to_path_buf(), source })?;
        Store::open(&dir.join(FILE_NAME))
    }

    /// Opens (or creates) the database file at `path` and brings its schema up to date; refuses a database from a
    /// newer version.
    pub fn open(path: &Path) -> Result<Store> {
        let open_err = |source| StudioError::Open { path: path.to_path_buf(), source };
        let conn = Connection::open(path).map_err(open_err)?;
        conn.busy_timeout(BUSY_WAIT).map_err(open_err)?;
        // Reading the version is the first read of the file: a file that is not a database fails here.
        let found: i64 = conn.query_row("PRAGMA user_version", [], |r| r.get(0)).map_err(open_err)?;
        if found > SCHEMA_VERSION {
            return Err(StudioError::Newer { path: path.to_path_buf(), found, supported: SCHEMA_VERSION });
        }
        let mode: String = conn.query_row("PRAGMA journal_mode = WAL", [], |r| r.get(0)).map_err(open_err)?;
        if !mode.eq_ignore_ascii_case("wal") {
            return Err(StudioError::Corrupt { what: format!("journal mode \"{mode}\" where WAL was asked") });
        }
        // References are checked after the migrations: a migration that rebuilds a table (SQLite's way to change
        // a column) drops the old one, which the checks would refuse; each migration checks them itself instead.
        conn.execute_batch("PRAGMA synchronous = FULL; PRAGMA foreign_keys = OFF;").map_err(open_err)?;
        let mut store = Store { conn, path: path.to_path_buf() };
        store.migrate()?;
        store.conn.execute_batch("PRAGMA foreign_keys = ON").map_err(open_err)?;
        Ok(store)
    }

    /// Applies the migrations the database lacks, each in one transaction with its version bump.
    fn migrate(&mut self) -> Result<()> {
        loop {
            let path = self.path.clone();
            let tx = self
                .conn
                .transaction_with_behavior(TransactionBehavior::Immediate)
                .map_err(|source| StudioError::Db { doing: "starting a schema migration", source })?;
            // Read again inside the transaction: another process may have migrated meanwhile.
            let version: i64 = tx
                .query_row("PRAGMA user_version", [], |r| r.get(0))
                .map_err(|source| StudioError::Db { doing: "reading the schema version", source })?;
            if version > SCHEMA_VERSION {
                return Err(StudioError::Newer { path, found: version, supported: SCHEMA_VERSION });
            }
            let Some(step) = usize::try_from(version).ok().and_then(|v| MIGRATIONS.get(v)) else {
                return Ok(());
            };
            tx.execute_batch(step).map_err(|source| StudioError::Db { doing: "migrating the schema", source })?;
            let dangling: Option<String> = tx
                .query_row("PRAGMA foreign_key_check", [], |r| r.get(0))
                .optional()
                .map_err(|source| StudioError::Db { doing: "checking a migration", source })?;
            if let Some(table) = dangling {
                return Err(StudioError::Corrupt {
                    what: format!("rows in table {table} that refer to rows missing after migration {}", version + 1),
                });
            }
            tx.execute_batch(&format!("PRAGMA user_version = {}", version + 1))
                .and_then(|()| tx.commit())
                .map_err(|source| StudioError::Db { doing: "migrating the schema", source })?;
        }
    }

    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The schema version of the open database (after its migration: [`SCHEMA_VERSION`]).
    pub fn schema_version(&self) -> Result<i64> {
        self.conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .map_err(|source| StudioError::Db { doing: "reading the schema version", source })
    }

    /// Runs `change` in one `BEGIN IMMEDIATE` transaction: all of it is kept if it returns `Ok`, none of it
    /// otherwise.
    pub(crate) fn change<T>(&mut self, change: impl FnOnce(&Transaction<'_>) -> Result<T>) -> Result<T> {
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(|source| StudioError::Db { doing: "starting a change", source })?;
        let value = change(&tx)?;
        tx.commit().map_err(|source| StudioError::Db { doing: "saving a change", source })?;
        Ok(value)
    }

    /// The connection, for reads.
    pub(crate) fn conn(&self) -> &Connection {
        &self.conn
    }

    /// SQLite's own check of the file (`PRAGMA integrity_check`): `"ok"` when the database is whole.
    pub fn integrity_check(&self) -> Result<String> {
        self.conn
            .query_row("PRAGMA integrity_check", [], |r| r.get(0))
            .optional()
            .map(|v| v.unwrap_or_default())
            .map_err(|source| StudioError::Db { doing: "checking the file", source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("plotter-store-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn a_new_database_is_at_the_current_version_in_wal_mode() {
        let dir = temp_dir("new");
        let store = Store::open_in(&dir).unwrap();
        assert_eq!(store.schema_version().unwrap(), 2);
        let mode: String = store.conn().query_row("PRAGMA journal_mode", [], |r| r.get(0)).unwrap();
        assert_eq!(mode, "wal");
        let sync: i64 = store.conn().query_row("PRAGMA synchronous", [], |r| r.get(0)).unwrap();
        assert_eq!(sync, 2); // FULL
        assert_eq!(store.integrity_check().unwrap(), "ok");
        drop(store);
        // Opening again changes nothing.
        assert_eq!(Store::open_in(&dir).unwrap().schema_version().unwrap(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_database_from_a_newer_version_is_refused_by_name() {
        let dir = temp_dir("newer");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        Connection::open(&path).unwrap().execute_batch("PRAGMA user_version = 7").unwrap();
        let err = Store::open(&path).unwrap_err();
        assert!(matches!(err, StudioError::Newer { found: 7, supported: 2, .. }), "{err:?}");
        let text = err.to_string();
        assert!(text.starts_with(&path.display().to_string()) && text.contains("schema version 7"), "{text}");
        // Refused without a change: still version 7, no tables added.
        let conn = Connection::open(&path).unwrap();
        assert_eq!(conn.query_row("PRAGMA user_version", [], |r| r.get::<_, i64>(0)).unwrap(), 7);
        let tables: i64 = conn.query_row("SELECT count(*) FROM sqlite_master", [], |r| r.get(0)).unwrap();
        assert_eq!(tables, 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_that_is_not_a_database_is_a_clear_error() {
        let dir = temp_dir("garbage");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        std::fs::write(&path, vec![b'x'; 4096]).unwrap();
        let err = Store::open(&path).unwrap_err();
        assert!(matches!(err, StudioError::Open { .. }), "{err:?}");
        assert!(err.to_string().contains("cannot open the studio's database"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_version_1_database_written_by_hand_is_migrated_with_its_jobs() {
        let dir = temp_dir("v1");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(FILE_NAME);
        // Version 1 as it was written, in raw SQL of its own (not the migration text).
        let conn = Connection::open(&path).unwrap();
        conn.execute_batch(
            "CREATE TABLE machines (name TEXT PRIMARY KEY NOT NULL, device TEXT NOT NULL, firmware TEXT NOT NULL,
                 profile TEXT, added INTEGER NOT NULL);
             CREATE TABLE jobs (id INTEGER PRIMARY KEY AUTOINCREMENT, created INTEGER NOT NULL,
                 machine TEXT REFERENCES machines(name), drawing_name TEXT NOT NULL, drawing BLOB NOT NULL,
                 options TEXT NOT NULL,
                 state TEXT NOT NULL CHECK (state IN ('queued','plotting','paused','done','failed','cancelled')),
                 position INTEGER NOT NULL, claimed_by TEXT REFERENCES machines(name));
             CREATE TABLE history (id INTEGER PRIMARY KEY AUTOINCREMENT, job INTEGER NOT NULL REFERENCES jobs(id),
                 machine TEXT NOT NULL, started INTEGER NOT NULL, ended INTEGER, plot_ms INTEGER, outcome TEXT);
             INSERT INTO machines VALUES ('left', '/dev/ttyACM0', 'ours', NULL, 1000);
             INSERT INTO jobs VALUES (1, 1001, 'left', 'a.svg', x'3c7376672f3e', '{}', 'done', 1, 'left');
             INSERT INTO jobs VALUES (2, 1002, NULL, 'b.svg', x'00ff', '{\"copies\":2}', 'queued', 2, NULL);
             INSERT INTO history VALUES (1, 1, 'left', 1100, 1200, 90, 'done');
             PRAGMA user_version = 1;",
        )
        .unwrap();
        drop(conn);
        let store = Store::open(&path).unwrap();
        assert_eq!(store.schema_version().unwrap(), 2);
        // id, drawing name, drawing, options, state, position, attempts.
        type JobRow = (i64, String, Vec<u8>, String, String, i64, i64);
        let rows: Vec<JobRow> = store
            .conn()
            .prepare("SELECT id, drawing_name, drawing, options, state, position, attempts FROM jobs ORDER BY id")
            .unwrap()
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?, r.get(6)?)))
            .unwrap()
            .collect::<rusqlite::Result<_>>()
            .unwrap();
        assert_eq!(
            rows,
            vec![
                (1, "a.svg".into(), b"<svg/>".to_vec(), "{}".into(), "done".into(), 1, 1),
                (2, "b.svg".into(), vec![0, 255], "{\"copies\":2}".into(), "queued".into(), 2, 0),
            ]
        );
        // Version 2's new state is accepted now, and an unknown one still is not.
        store.conn().execute("UPDATE jobs SET state = 'interrupted' WHERE id = 2", []).unwrap();
        assert!(store.conn().execute("UPDATE jobs SET state = 'lost' WHERE id = 2", []).is_err());
        // The next job number continues after the migrated ones.
        store
            .conn()
            .execute("INSERT INTO jobs (created, drawing_name, drawing, options, state, position) VALUES (1, 'c', x'', '{}', 'queued', 3)", [])
            .unwrap();
        assert_eq!(store.conn().last_insert_rowid(), 3);
        assert_eq!(store.integrity_check().unwrap(), "ok");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

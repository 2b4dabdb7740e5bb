//! The engine's [`Environment`] for real runs: system time (UTC), the git
//! commit of the sets ([`crate::git::info`], spawning `git`), and
//! the line run's small files on the file system (the resume state,
//! learned schemas), written to a temporary name and renamed into place.

use std::io;
use std::path::Path;

use driveset_engine::env::Environment;
use driveset_engine::line::report::GitInfo;

/// The system: clock, git, file system.
#[derive(Debug, Clone, Copy, Default)]
pub struct SystemEnv;

impl Environment for SystemEnv {
    fn now_utc(&self) -> jiff::Timestamp {
        jiff::Timestamp::now()
    }

    fn git_info(&self, dir: &Path) -> Option<GitInfo> {
        crate::git::info(dir)
    }

    fn read_file(&self, path: &Path) -> io::Result<Option<String>> {
        match std::fs::metadata(path) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            _ => {}
        }
        // the one file reader: regular files only, size checked first
        let bytes =
            driveset_schema::input::read_input(path, driveset_schema::input::InputKind::LINE_STATE)
                .map_err(|e| io::Error::other(format!("{}; {}", e.message, e.help)))?;
        String::from_utf8(bytes)
            .map(Some)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))
    }

    fn write_file(&self, path: &Path, text: &str) -> io::Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)?;
        }
        crate::report::write_atomic(path, text.as_bytes())
    }

    fn create_dir(&self, dir: &Path) -> io::Result<()> {
        std::fs::create_dir_all(dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_round_trip_and_a_missing_file_is_none() {
        let d = tempfile::tempdir().unwrap();
        let env = SystemEnv;
        let p = d.path().join("a/b/state.json");
        assert_eq!(env.read_file(&p).unwrap(), None);
        env.write_file(&p, "{}\n").unwrap();
        assert_eq!(env.read_file(&p).unwrap().as_deref(), Some("{}\n"));
        env.write_file(&p, "[]\n").unwrap();
        assert_eq!(env.read_file(&p).unwrap().as_deref(), Some("[]\n"));
        // no temporary file is left next to it
        let names: Vec<String> = std::fs::read_dir(d.path().join("a/b"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["state.json"]);
        let now = env.now_utc();
        assert!(now.as_second() > 1_700_000_000, "{now}");
    }
}

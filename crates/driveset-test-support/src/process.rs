//! Child processes a test starts (the built `driveset sim`, a Python
//! peer): stopped with a signal and a bounded wait, spoken to line by line
//! (`LinePeer`), and killed and reaped when dropped, so a test that fails
//! early leaves nothing running.

use std::io::{BufRead, BufReader, Read, Write};
use std::ops::{Deref, DerefMut};
use std::process::{Child, ChildStdin, ChildStdout, Command, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// A child process the test owns; killed and reaped when dropped. Derefs
/// to its [`Child`] (`id`, `stdout`, `try_wait`, ...).
pub struct Spawned {
    child: Child,
    what: String,
}

impl Spawned {
    /// `child`, named `what` in messages ("driveset sim", "sdo_server.py").
    pub fn new(child: Child, what: &str) -> Spawned {
        Spawned {
            child,
            what: what.to_string(),
        }
    }

    /// Wait until the process exits; panics naming it after `within`.
    pub fn wait_within(&mut self, within: Duration) -> ExitStatus {
        let give_up = Instant::now() + within;
        loop {
            if let Some(status) = self.child.try_wait().expect("wait for a child process") {
                return status;
            }
            assert!(
                Instant::now() < give_up,
                "{} did not exit within {within:?}",
                self.what
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Send `signal` (`-TERM`, `-INT`, `-KILL`) with kill(1), then
    /// [`wait_within`](Self::wait_within).
    pub fn signal(&mut self, signal: &str, within: Duration) -> ExitStatus {
        let sent = send_signal(self.child.id(), signal);
        assert!(
            sent,
            "kill {signal} {} ({}) failed",
            self.child.id(),
            self.what
        );
        self.wait_within(within)
    }

    /// The first line the process printed, with its `\n` (none when the
    /// process closed stdout first), and its stdout for the rest; panics
    /// when stdout was not piped.
    pub fn first_line(&mut self) -> (String, BufReader<ChildStdout>) {
        let stdout = self
            .child
            .stdout
            .take()
            .unwrap_or_else(|| panic!("{}: stdout not piped", self.what));
        let mut out = BufReader::new(stdout);
        let mut line = String::new();
        out.read_line(&mut line)
            .unwrap_or_else(|e| panic!("{}: reading its first line: {e}", self.what));
        (line, out)
    }
}

impl Deref for Spawned {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.child
    }
}

impl DerefMut for Spawned {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.child
    }
}

impl Drop for Spawned {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Send `signal` (`-TERM`, `-KILL`, ...) to process `pid` with kill(1);
/// whether kill succeeded.
pub fn send_signal(pid: u32, signal: &str) -> bool {
    Command::new("kill")
        .args([signal, &pid.to_string()])
        .status()
        .is_ok_and(|s| s.success())
}

/// A child process spoken to line by line over its stdin and stdout (the
/// interop tests' Python peers, `sdo_server.py`); what it writes to stderr
/// is kept for the messages. Killed when dropped.
pub struct LinePeer {
    child: Spawned,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    stderr: Arc<Mutex<String>>,
    /// How long one line may take (a hang guard, not a timing assertion).
    guard: Duration,
    /// Said with its stderr ("a ModuleNotFoundError means: ...").
    hint: String,
}

impl LinePeer {
    /// Start `command` (its stdin, stdout and stderr piped here), named
    /// `what` in messages; each line may take up to `guard`.
    pub fn spawn(mut command: Command, what: &str, guard: Duration) -> LinePeer {
        let child = command
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot run {what}: {e}"));
        let mut child = Spawned::new(child, what);
        let stdout = child.stdout.take().expect("stdout piped");
        let mut err = child.stderr.take().expect("stderr piped");
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let stderr = Arc::new(Mutex::new(String::new()));
        let sink = Arc::clone(&stderr);
        std::thread::spawn(move || {
            let mut buf = [0u8; 1024];
            while let Ok(n) = err.read(&mut buf) {
                if n == 0 {
                    break;
                }
                sink.lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        });
        LinePeer {
            stdin: child.stdin.take(),
            child,
            lines,
            stderr,
            guard,
            hint: String::new(),
        }
    }

    /// Say `hint` with the peer's stderr in every message.
    pub fn with_hint(mut self, hint: &str) -> LinePeer {
        self.hint = format!(" ({hint})");
        self
    }

    /// What the peer wrote to stderr so far, headed by its name and hint.
    pub fn stderr(&self) -> String {
        let text = self
            .stderr
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        format!("{} stderr{}:\n{text}", self.child.what, self.hint)
    }

    /// Write `line` and a line end to the peer.
    pub fn send(&mut self, line: &str) {
        let what = &self.child.what;
        let stdin = self
            .stdin
            .as_mut()
            .unwrap_or_else(|| panic!("{what}: stdin already closed"));
        writeln!(stdin, "{line}")
            .and_then(|()| stdin.flush())
            .unwrap_or_else(|e| panic!("write to {what}: {e}"));
    }

    /// The peer's next line; panics with its stderr when it says nothing
    /// within the guard or ends.
    pub fn line(&mut self) -> String {
        match self.lines.recv_timeout(self.guard) {
            Ok(l) => l,
            Err(RecvTimeoutError::Timeout) => panic!(
                "{} said nothing for {:?}\n{}",
                self.child.what,
                self.guard,
                self.stderr()
            ),
            Err(RecvTimeoutError::Disconnected) => {
                let _ = self.child.wait();
                // let the stderr reader catch the last words
                std::thread::sleep(Duration::from_millis(100));
                panic!("{} ended early\n{}", self.child.what, self.stderr())
            }
        }
    }

    /// Send `command`, expect `reply`, close stdin and wait (within the
    /// guard) for the exit: how it exited and its [`stderr`](Self::stderr).
    pub fn quit(mut self, command: &str, reply: &str) -> (ExitStatus, String) {
        self.send(command);
        let got = self.line();
        assert_eq!(got, reply, "{}", self.stderr());
        drop(self.stdin.take());
        let guard = self.guard;
        let status = self.child.wait_within(guard);
        (status, self.stderr())
    }
}

/// `crates/driveset-engine/tests/python/sdo_server.py` (a canopen
/// LocalNode behind python-can's slcan interface) on `port` as node
/// `node`, `extra` further arguments (an EDS to import), answered
/// `ready`; each line may take up to `guard`. Panics naming
/// `scripts/setup-python` when the interpreter is missing (call
/// [`crate::python_or_skip`] first to skip instead).
pub fn sdo_server(port: &str, node: u8, extra: &[&str], guard: Duration) -> LinePeer {
    let python = crate::python();
    assert!(
        python.exists(),
        "{} is missing: run scripts/setup-python (installs the pinned python-can and canopen \
         into target/py), or set DRIVESET_PYTHON to a Python that has them",
        python.display()
    );
    let mut command = Command::new(&python);
    command
        .arg(crate::workspace_root().join("crates/driveset-engine/tests/python/sdo_server.py"))
        .arg(port)
        .arg(node.to_string())
        .args(extra);
    let mut peer = LinePeer::spawn(command, "sdo_server.py", guard)
        .with_hint("a ModuleNotFoundError means: run scripts/setup-python");
    let first = peer.line();
    assert_eq!(first, "ready", "{}", peer.stderr());
    peer
}

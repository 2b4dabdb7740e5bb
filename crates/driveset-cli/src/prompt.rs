//! The questions a writing command asks on a terminal before it writes
//! (`replace`, `commission --assign`): whether one may be asked at all, and
//! one answer read from stdin.

use std::io::{BufRead, IsTerminal, Write};

use crate::fail::Fail;

/// Whether a prompt may be shown: stdin is a terminal. `Err` explains
/// what to give instead. (The hidden `--prompt-stdin` of the tests reads
/// stdin anyway: its callers do not ask this.)
pub fn confirm_allowed(what: &str) -> Result<(), Fail> {
    if std::io::stdin().is_terminal() {
        Ok(())
    } else {
        Err(Fail::input(format!(
            "{what} asks before writing, and stdin is not a terminal; give --yes to run without asking (nothing was written)"
        )))
    }
}

/// Print `prompt` on stderr and read one line of stdin: `Ok(line)`
/// trimmed; end of input is an empty answer.
pub fn ask(prompt: &str) -> Result<String, Fail> {
    eprint!("{prompt}");
    let _ = std::io::stderr().flush();
    let mut line = String::new();
    std::io::stdin()
        .lock()
        .read_line(&mut line)
        .map_err(|e| Fail::input(format!("cannot read stdin: {e}")))?;
    Ok(line.trim().to_string())
}

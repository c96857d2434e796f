//! Running one demo step: this same binary as a child process with exactly the arguments it
//! prints, so every step can be re-run by hand.

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// One step: what it does, its arguments, and where its stdout goes (None: the terminal).
pub(super) struct Step {
    pub(super) what: &'static str,
    pub(super) args: Vec<String>,
    pub(super) stdout: Option<PathBuf>,
}

pub(super) fn step(what: &'static str, args: &[&str], stdout: Option<PathBuf>) -> Step {
    Step {
        what,
        args: args.iter().map(|s| s.to_string()).collect(),
        stdout,
    }
}

fn quote(s: &str) -> String {
    if s.chars()
        .all(|c| c.is_ascii_alphanumeric() || "-_./=:,".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

pub(super) fn run_step(exe: &Path, s: &Step, n: usize, total: usize) -> Result<()> {
    let mut shown = format!(
        "lidarqa {}",
        s.args
            .iter()
            .map(|a| quote(a))
            .collect::<Vec<_>>()
            .join(" ")
    );
    if let Some(out) = &s.stdout {
        shown += &format!(" > {}", quote(&out.display().to_string()));
    }
    eprintln!("[{n}/{total}] {}\n    $ {shown}", s.what);
    let mut cmd = Command::new(exe);
    cmd.args(&s.args).stdin(Stdio::null());
    match &s.stdout {
        Some(path) => {
            let file =
                std::fs::File::create(path).with_context(|| format!("{}", path.display()))?;
            cmd.stdout(file);
        }
        None => {
            cmd.stdout(Stdio::null());
        }
    }
    let status = cmd
        .status()
        .with_context(|| format!("running {}", exe.display()))?;
    if !status.success() {
        if let Some(path) = &s.stdout {
            let _ = std::fs::remove_file(path);
        }
        bail!(
            "step {n} ({}) failed; the products of the steps before it are in place. Re-run it with: {shown}",
            s.what
        );
    }
    Ok(())
}

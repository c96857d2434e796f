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

pub(super) fn step<S: AsRef<str>>(what: &'static str, args: &[S], stdout: Option<PathBuf>) -> Step {
    Step {
        what,
        args: args.iter().map(|s| s.as_ref().to_string()).collect(),
        stdout,
    }
}

/// `lidarqa tpu` over the strips of `strips_dir` with the simulator's trajectory and its σ
/// (`sbet.out`, `smrmsg.out` there), `extra` flags before the outputs.
pub(super) fn tpu_args(
    strips_dir: &str,
    sensor: &str,
    extra: &[&str],
    output_dir: &str,
    summary: &str,
) -> Vec<String> {
    let (sbet, smrmsg) = (
        format!("{strips_dir}/sbet.out"),
        format!("{strips_dir}/smrmsg.out"),
    );
    let head = [
        "tpu",
        strips_dir,
        "--trajectory",
        &sbet,
        "--smrmsg",
        &smrmsg,
        "--sensor",
        sensor,
    ];
    let tail = ["-o", output_dir, "--summary", summary];
    head.iter()
        .chain(extra)
        .chain(&tail)
        .map(|s| s.to_string())
        .collect()
}

/// Runs `steps` in order with the binary `exe`, calling `after(i)` once step `i` (from 0) has
/// succeeded; the first failure stops the run.
pub(super) fn run_steps(
    exe: &Path,
    steps: &[Step],
    mut after: impl FnMut(usize) -> Result<()>,
) -> Result<()> {
    for (i, s) in steps.iter().enumerate() {
        run_step(exe, s, i + 1, steps.len())?;
        after(i)?;
    }
    Ok(())
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

fn run_step(exe: &Path, s: &Step, n: usize, total: usize) -> Result<()> {
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

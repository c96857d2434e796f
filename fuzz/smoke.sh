#!/usr/bin/env bash
# Fuzz smoke run for CI: every target for SECONDS (default 12) from its seeds and the
# inputs of past crashes (regressions/TARGET). A crash fails the run (exit 1) and leaves the
# input in fuzz/artifacts/TARGET/. Without a nightly toolchain this prints a warning and exits 0:
# the smoke run must never fail CI for want of tools.
#
#   bash fuzz/smoke.sh [SECONDS]
#
# To stay within a few minutes on a fresh 2-core machine it does not install cargo-fuzz (a
# minute or two of compiling): it builds the targets with the flags `cargo fuzz build -s none`
# uses (libFuzzer coverage instrumentation, debug assertions and overflow checks, release
# optimisation, no AddressSanitizer, which lidarqa's safe Rust does not need for a smoke run and
# which doubles build and run time) into fuzz/target/smoke/ (apart from cargo-fuzz's builds,
# which use other flags), and runs the binaries directly. The long campaigns use cargo-fuzz with ASan: fuzz/campaign.sh.
set -uo pipefail
cd "$(dirname "$0")"
seconds="${1:-12}"

warn() { echo "warning: fuzz smoke run skipped: $*" >&2; exit 0; }

command -v rustup >/dev/null 2>&1 || warn "rustup not found"
if ! rustup run nightly rustc --version >/dev/null 2>&1; then
  rustup toolchain install nightly --profile minimal >/dev/null 2>&1 \
    || warn "the nightly toolchain is not installed and could not be installed"
fi
triple=$(rustup run nightly rustc -vV | sed -n 's/^host: //p')
[ -n "$triple" ] || warn "cannot tell the host triple"

targets=$(sed -n '/^\[\[bin\]\]/,/^$/s/^name = "\(.*\)"/\1/p' Cargo.toml)
[ -n "$targets" ] || { echo "error: no [[bin]] targets in fuzz/Cargo.toml" >&2; exit 1; }

# `--target` keeps the instrumentation flags away from build scripts and proc macros, as
# cargo-fuzz does; no debug info, to build faster.
flags="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4"
flags="$flags -Cllvm-args=-sanitizer-coverage-inline-8bit-counters"
flags="$flags -Cllvm-args=-sanitizer-coverage-pc-table"
flags="$flags -Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing"
flags="$flags -Cdebug-assertions -Coverflow-checks"
build_start=$(date +%s)
if ! RUSTFLAGS="$flags" CARGO_PROFILE_RELEASE_DEBUG=false \
    cargo +nightly build --quiet --release --target "$triple" --target-dir target/smoke --bins; then
  echo "error: the fuzz targets do not build" >&2
  exit 1
fi
echo "fuzz targets built in $(( $(date +%s) - build_start )) s"

status=0
for t in $targets; do
  mkdir -p "corpus/$t" "artifacts/$t"
  dirs=("corpus/$t" "seeds/$t")
  [ -d "regressions/$t" ] && dirs+=("regressions/$t")
  log="$(mktemp)"
  start=$(date +%s)
  if "target/smoke/$triple/release/$t" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20 \
      -artifact_prefix="artifacts/$t/" "${dirs[@]}" >"$log" 2>&1; then
    runs=$(grep -o 'Done [0-9]* runs' "$log" | tail -1)
    echo "fuzz $t: ok, ${runs:-? runs} in $(( $(date +%s) - start )) s"
  else
    echo "fuzz $t: CRASH (input in fuzz/artifacts/$t/)"
    grep -E 'panicked|ERROR|SUMMARY|Test unit written' "$log" | head -20
    status=1
  fi
  rm -f "$log"
done
exit $status

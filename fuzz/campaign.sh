#!/usr/bin/env bash
# The long fuzz campaigns: each target for SECONDS (default 600) on ONE core, one
# target after another, logs in fuzz/logs/TARGET.log and a line per target in
# fuzz/logs/summary.txt (executions, crashes).
#
#   bash fuzz/campaign.sh [SECONDS] [TARGET...]
set -uo pipefail
cd "$(dirname "$0")"
seconds="${1:-600}"
shift || true
targets="${*:-$(cargo +nightly fuzz list)}"
mkdir -p logs
cargo +nightly fuzz build || exit 1
for t in $targets; do
  mkdir -p "corpus/$t"
  log="logs/$t.log"
  start=$(date +%s)
  dirs=("corpus/$t" "seeds/$t")
  [ -d "regressions/$t" ] && dirs+=("regressions/$t")
  cargo +nightly fuzz run "$t" "${dirs[@]}" -- \
    -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=20 \
    -print_final_stats=1 >"$log" 2>&1
  rc=$?
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  crashes=$(ls "artifacts/$t" 2>/dev/null | wc -l)
  echo "$t: exit $rc, $(( $(date +%s) - start )) s, ${runs:-?} executions, corpus $(ls "corpus/$t" | wc -l) files, artifacts $crashes" \
    | tee -a logs/summary.txt
done

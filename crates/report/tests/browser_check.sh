#!/usr/bin/env bash
# Renders a lidarqa report in headless Chromium and checks that every plot really draws.
#
# Usage: crates/report/tests/browser_check.sh [REPORT.html] [OUT_DIR]
#
# Without REPORT.html, builds the full fixture report of crates/report/tests/report.rs (every
# product present, the bathymetry section included) with `cargo test`; the report of
# `lidarqa demo --bathymetry` can be given as REPORT.html. Checks, in the browser's own layout:
#   - every <svg id="plot-…"> of the file is in the DOM, with a non-zero size;
#   - every non-empty <text> label of every plot has a non-zero box, inside its plot;
#   - no two labels of one plot overlap;
#   - the page loads nothing (the report has no external reference; Chromium runs with networking
#     off).
# Writes OUT_DIR/report.png (a full-page screenshot, to look at) and OUT_DIR/probe.txt.
# Exits 0 with a message when Chromium is not installed (`apt-get install chromium`).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"

browser=""
for b in chromium chromium-browser google-chrome google-chrome-stable; do
    if command -v "$b" >/dev/null 2>&1; then
        browser="$b"
        break
    fi
done
if [[ -z "$browser" ]]; then
    echo "browser_check: chromium not found, skipped (apt-get install chromium to run it)"
    exit 0
fi

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
out="${2:-$work/out}"
mkdir -p "$out"

report="${1:-}"
if [[ -z "$report" ]]; then
    report="$work/report.html"
    (cd "$root" && LIDARQA_REPORT_KEEP="$report" cargo test -q -p lidarqa-report --test report \
        full_report_has_every_section_and_plot >/dev/null)
fi
[[ -f "$report" ]] || { echo "browser_check: $report: no such file" >&2; exit 1; }

fail=0
err() { echo "browser_check: FAIL: $*" >&2; fail=1; }

# The file itself: no external reference, no script.
if grep -Eq 'https?://|<script|<link|@import|url\(' "$report"; then
    err "$report has an external reference or a script"
fi

mapfile -t expected < <(grep -o '<svg id="plot-[^"]*"' "$report" | sed 's/<svg id="//; s/"$//')
if [[ ${#expected[@]} -eq 0 ]]; then
    err "$report has no plots"
fi

chrome() {
    # No network, no profile, no first-run: the page must render from the file alone.
    timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-background-networking \
        --disable-component-update --disable-sync --no-first-run --disable-extensions \
        --hide-scrollbars --user-data-dir="$(mktemp -d -p "$work")" "$@" 2>/dev/null
}

# 1. The report as it is: every expected svg in the DOM.
chrome --dump-dom "file://$report" >"$work/dom.html"
for id in "${expected[@]}"; do
    grep -q "<svg id=\"$id\"" "$work/dom.html" || err "$id is not in the DOM"
done

# 2. A copy with a probe script (the report itself has none) that measures the layout.
probe_js='<pre id="lidarqa-probe">
<script>
(function () {
  var out = [];
  out.push("page " + document.documentElement.scrollHeight);
  document.querySelectorAll("svg.plot").forEach(function (svg) {
    var r = svg.getBoundingClientRect();
    var texts = [], empty = 0, zero = 0, outside = 0;
    svg.querySelectorAll("text").forEach(function (t) {
      if (!t.textContent.trim()) { empty++; return; }
      var b = t.getBoundingClientRect();
      if (b.width <= 0 || b.height <= 0) { zero++; return; }
      if (b.left < r.left - 1 || b.right > r.right + 1 || b.top < r.top - 1 || b.bottom > r.bottom + 1) {
        outside++;
        out.push("outside " + svg.id + " " + JSON.stringify(t.textContent));
      }
      texts.push([b, t.textContent]);
    });
    var overlaps = 0;
    for (var i = 0; i < texts.length; i++) {
      for (var j = i + 1; j < texts.length; j++) {
        var a = texts[i][0], b = texts[j][0];
        var ox = Math.min(a.right, b.right) - Math.max(a.left, b.left);
        var oy = Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top);
        if (ox > 1 && oy > 1) {
          overlaps++;
          out.push("overlap " + svg.id + " " + JSON.stringify(texts[i][1]) + " " + JSON.stringify(texts[j][1]));
        }
      }
    }
    out.push("svg " + svg.id + " " + Math.round(r.width) + " " + Math.round(r.height) +
             " texts " + texts.length + " zero " + zero + " outside " + outside + " overlaps " + overlaps);
  });
  document.getElementById("lidarqa-probe").textContent = "\n" + out.join("\n") + "\n";
})();
</script></pre>'
python3 - "$report" "$work/probe.html" "$probe_js" <<'EOF' 2>/dev/null || awk -v js="$probe_js" '{ sub(/<\/body>/, js "</body>") } 1' "$report" >"$work/probe.html"
import sys
src, dst, js = sys.argv[1], sys.argv[2], sys.argv[3]
html = open(src, encoding="utf-8").read()
open(dst, "w", encoding="utf-8").write(html.replace("</body>", js + "</body>", 1))
EOF
chrome --dump-dom "file://$work/probe.html" >"$work/probe_dom.html"
sed -n '/<pre id="lidarqa-probe">/,/<\/pre>/p' "$work/probe_dom.html" | grep -E '^(page|svg|overlap|outside) ' >"$out/probe.txt" || true

for id in "${expected[@]}"; do
    line="$(grep "^svg $id " "$out/probe.txt" || true)"
    if [[ -z "$line" ]]; then
        err "$id was not measured"
        continue
    fi
    read -r _ _ w h _ n _ zero _ outside _ overlaps <<<"$line"
    ((w > 0 && h > 0)) || err "$id has size ${w}x${h}"
    ((n > 0)) || err "$id has no visible text label"
    ((zero == 0)) || err "$id has $zero labels of zero size"
    ((outside == 0)) || err "$id has $outside labels outside the plot"
    ((overlaps == 0)) || err "$id has $overlaps overlapping labels"
done
grep -E '^(overlap|outside) ' "$out/probe.txt" >&2 || true

# 3. A full-page screenshot to look at.
height="$(awk '/^page /{print $2}' "$out/probe.txt")"
height="${height:-6000}"
chrome --window-size=900,"$height" --screenshot="$out/report.png" "file://$report" >/dev/null || err "no screenshot"

if ((fail)); then
    echo "browser_check: $report: FAILED (details in $out/probe.txt)" >&2
    exit 1
fi
echo "browser_check: $report: ${#expected[@]} plots render with readable labels; screenshot $out/report.png"

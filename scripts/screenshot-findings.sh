#!/usr/bin/env bash
# The README's screenshot of the findings page, from a finished reproduction, so it cannot
# go stale: headless Chromium renders FINDINGS_HTML at 1400 px wide and writes the top of
# the page (the headline, the legend and the first central claims) as a PNG.
#
#   scripts/screenshot-findings.sh [FINDINGS_HTML] [OUT_PNG]
#   defaults: results/paper/findings.html, docs/img/findings.png
#
# Needs chromium (Debian: apt-get install chromium). Run it after `tmo reproduce --preset
# paper` and commit the PNG with the docs that quote the same run's headline.
set -euo pipefail
page="$(realpath "${1:-results/paper/findings.html}")"
out="${2:-docs/img/findings.png}"
[ -f "$page" ] || { echo "no findings page at $page: run tmo reproduce first" >&2; exit 2; }
browser="$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)"
[ -n "$browser" ] || { echo "no chromium on the PATH (Debian: apt-get install chromium)" >&2; exit 2; }
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --user-data-dir="$profile" --window-size=1400,1800 \
    --screenshot="$(realpath -m "$out")" "file://$page" 2>/dev/null
echo "wrote $out from $page"

#!/usr/bin/env bash
# The README's screenshot of the findings page, from a finished reproduction, so it cannot
# go stale: headless Chromium renders FINDINGS_HTML at 1400 px wide and writes the top of
# the page (the headline, the standings and the evidence: each prediction and what came of
# it) as a PNG, and the headline it shows, as text, beside it (OUT_PNG with .headline.txt
# for .png). A test (tests/cli_docs.rs) holds that headline to the README's, so a README
# quoting another run than its screenshot fails until the screenshot is made again.
#
#   scripts/screenshot-findings.sh [FINDINGS_HTML] [OUT_PNG]
#   defaults: results/paper/findings.html, docs/img/findings.png
#
# The README quotes the quick preset's headline: run `tmo reproduce --preset quick`, then
# this, and commit the PNG and its .headline.txt with the README that quotes them.
# Needs chromium (Debian: apt-get install chromium).
set -euo pipefail
page="$(realpath "${1:-results/paper/findings.html}")"
out="${2:-docs/img/findings.png}"
[ -f "$page" ] || { echo "no findings page at $page: run tmo reproduce first" >&2; exit 2; }
browser="$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)"
[ -n "$browser" ] || { echo "no chromium on the PATH (Debian: apt-get install chromium)" >&2; exit 2; }
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
# Without the background-networking flags Chromium tries to reach Google's hosts at every
# start, which a closed network refuses.
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars --disable-quic \
    --no-first-run --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$profile" --window-size=1400,1300 \
    --screenshot="$(realpath -m "$out")" "file://$page" 2>/dev/null
# The headline: the page's first bold paragraph (the summary line `tmo reproduce` prints).
headline="$(grep -o -m1 '^<p><b>[^<]*</b>' "$page" | sed -e 's/^<p><b>//' -e 's/<\/b>$//' \
    -e 's/&amp;/\&/g' -e 's/&lt;/</g' -e 's/&gt;/>/g' -e 's/&quot;/"/g')"
[ -n "$headline" ] || { echo "no headline in $page" >&2; exit 2; }
printf '%s\n' "$headline" > "${out%.png}.headline.txt"
echo "wrote $out and ${out%.png}.headline.txt from $page"

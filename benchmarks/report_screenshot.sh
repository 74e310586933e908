#!/bin/sh
# Render a study's HTML report in headless Chromium and save a PNG screenshot,
# to check that the self-contained page (inline SVG, no external assets)
# displays in a real browser. Installs Debian's chromium when missing.
#
#   benchmarks/report_screenshot.sh [pipeline] [out.png]
#   (default: pipelines/quickstart.yaml → report_screenshot.png)
set -eu
pipeline=${1:-pipelines/quickstart.yaml}
out=${2:-report_screenshot.png}
case "$out" in /*) ;; *) out="$(pwd)/$out" ;; esac
if ! command -v chromium >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
cargo run --release --quiet -- run "$pipeline" --progress none >/dev/null
name=$(sed -n 's/^name: *//p' "$pipeline" | head -n 1)
page="$(pwd)/results/$name/report/report/index.html"
test -f "$page" || { echo "no report at $page" >&2; exit 1; }
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
# The flags keep Chromium from reaching the network (closed here) and from
# needing a GPU or a sandbox (running as root in a container).
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$profile" --hide-scrollbars --window-size=1200,2400 \
    --screenshot="$out" "file://$page" 2>/dev/null
test -s "$out" && echo "screenshot of $page written to $out"

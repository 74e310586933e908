#!/bin/sh
# Render studies' HTML reports in headless Chromium and save PNG screenshots,
# to see each self-contained page (inline SVG, no external assets) as a
# browser shows it. Installs Debian's chromium when missing.
#
#   benchmarks/report_screenshot.sh [pipeline ...]   (default: every study
#   in pipelines/ that has a report stage) → screenshots/<name>.png
#
# SCREENSHOT_HEIGHT sets the page height in px (default 6000: most of a
# report; Chromium cuts the page there). Each section (every <h2 id=…>) is
# also shot on its own, 1280 × SECTION_HEIGHT px (default 2400) from its
# heading: screenshots/<name>/<section>.png, so every part of a long report
# can be looked at. Existing results are used when the report is cached.
set -eu
out_dir=${SCREENSHOT_DIR:-screenshots}
height=${SCREENSHOT_HEIGHT:-6000}
mkdir -p "$out_dir"
case "$out_dir" in /*) ;; *) out_dir="$(pwd)/$out_dir" ;; esac
if ! command -v chromium >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
if [ "$#" -eq 0 ]; then
    set -- $(grep -l "kind: report" pipelines/*.yaml)
fi
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
for pipeline in "$@"; do
    cargo run --release --quiet -- run "$pipeline" --progress none >/dev/null
    name=$(sed -n 's/^name: *//p' "$pipeline" | head -n 1)
    page="$(pwd)/results/$name/report/report/index.html"
    test -f "$page" || { echo "no report at $page" >&2; exit 1; }
    # The flags keep Chromium from reaching the network (closed here) and
    # from needing a GPU or a sandbox (running as root in a container).
    chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
        --disable-background-networking --disable-component-update --disable-sync \
        --user-data-dir="$profile/chromium" --hide-scrollbars --window-size=1280,"$height" \
        --screenshot="$out_dir/$name.png" "file://$page" 2>/dev/null
    test -s "$out_dir/$name.png" && echo "$name: screenshot of $page in $out_dir/$name.png"
    mkdir -p "$out_dir/$name"
    # A section is shot from a copy of the page that hides everything
    # before its heading (CSS :has; headless Chromium does not scroll to
    # a #fragment before its screenshot).
    for section in $(grep -o '<h2 id="[^"]*"' "$page" | sed 's/<h2 id="//; s/"$//'); do
        sed "s|</head>|<style>body > *:has(~ #$section){display:none}</style></head>|" \
            "$page" > "$profile/section.html"
        chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
            --disable-background-networking --disable-component-update --disable-sync \
            --user-data-dir="$profile/chromium" --hide-scrollbars \
            --window-size=1280,"${SECTION_HEIGHT:-2400}" \
            --screenshot="$out_dir/$name/$section.png" "file://$profile/section.html" 2>/dev/null
    done
    echo "$name: $(ls "$out_dir/$name" | wc -l) section screenshot(s) in $out_dir/$name/"
    problems=$(grep -c . "$(dirname "$page")/figures/style.txt" || true)
    echo "$name: $problems style problem(s) in figures/style.txt"
done

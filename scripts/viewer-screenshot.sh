#!/usr/bin/env bash
# Screenshot of a viewer.html in headless Chromium, with the flags the browser tests use
# (SwiftShader WebGL, nothing fetched): scripts/viewer-screenshot.sh PAGE.html OUT.png [WxH]
set -euo pipefail
page=$(realpath "$1")
out=$(realpath -m "$2")
size=${3:-1400,900}
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
# TMPDIR: a killed Chromium (the timeout) leaves its singleton socket directory there.
TMPDIR="$profile" timeout 120 chromium --headless=new --use-angle=swiftshader --enable-unsafe-swiftshader --no-sandbox \
  --no-first-run --disable-background-networking --disable-component-update --disable-sync \
  --host-resolver-rules='MAP * ~NOTFOUND' --window-size="$size" --virtual-time-budget=8000 \
  --user-data-dir="$profile" --screenshot="$out" "file://$page" 2>/dev/null
echo "wrote $out"

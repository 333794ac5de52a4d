#!/usr/bin/env bash
# Studio CI steps (issue 4), kept out of .ci/run until verified end to end.
set -euo pipefail
cd "$(dirname "$0")/.."
step() { printf '\n==> %s (%ss)\n' "$*" "$SECONDS"; }
# --- studio ---
# The web studio: bundle built from a clean clone (wasm-bindgen-cli installed by build-web.sh at
# Cargo.lock's version if missing), then a real headless chromium (Debian's) loads it, opens a
# map through the file picker, drops a landmark set, moves parameters and checks the published
# ranking changed; screenshots and timing.json go to target/studio-web-test/.
step "studio: chromium and the browser test's npm packages"
if ! command -v chromium >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
(cd studio/web-test && npm ci --no-audit --no-fund)

step "studio: web bundle (studio/build-web.sh)"
studio/build-web.sh

step "studio: browser test (headless chromium + playwright-core)"
node studio/web-test/browser-test.mjs
# --- end studio ---

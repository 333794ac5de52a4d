#!/usr/bin/env bash
# Builds the studio's web bundle into target/studio-web/ (index.html at its root; under
# $CARGO_TARGET_DIR when set), servable by any static file server, e.g.
# `python3 -m http.server -d target/studio-web 8080`.
#
# Needs the wasm32-unknown-unknown target and wasm-bindgen-cli at exactly the wasm-bindgen
# version of Cargo.lock (installed with cargo if missing: no download from anywhere else).
# Usage: studio/build-web.sh [--dev]   (--dev: debug build, faster to compile, much larger)
set -euo pipefail
cd "$(dirname "$0")/.."
profile=release
if [[ "${1:-}" == "--dev" ]]; then profile=debug; fi

rustup target list --installed 2>/dev/null | grep -qx wasm32-unknown-unknown || rustup target add wasm32-unknown-unknown

want=$(awk '/^name = "wasm-bindgen"$/ { getline; gsub(/version = |"/, ""); print; exit }' Cargo.lock)
if [[ -z "$want" ]]; then echo "build-web.sh: no wasm-bindgen in Cargo.lock" >&2; exit 1; fi
have=$(wasm-bindgen --version 2>/dev/null | awk '{print $2}' || true)
if [[ "$have" != "$want" ]]; then
  echo "build-web.sh: installing wasm-bindgen-cli $want (found '${have:-none}')"
  # Without --locked: the CLI's own lockfile does not build with this toolchain.
  cargo install wasm-bindgen-cli --version "$want"
fi

flags=()
if [[ "$profile" == release ]]; then flags+=(--release); fi
# No debug info in the bundle (the workspace release profile keeps some for native profiling).
CARGO_PROFILE_RELEASE_DEBUG=0 cargo build -p fitslam-studio --lib --target wasm32-unknown-unknown "${flags[@]}"

target_dir=${CARGO_TARGET_DIR:-target}
out=$target_dir/studio-web
rm -rf "$out"
mkdir -p "$out"
wasm-bindgen --target web --no-typescript --out-dir "$out" --out-name fitslam_studio \
  "$target_dir/wasm32-unknown-unknown/$profile/fitslam_studio.wasm"
cp studio/web/index.html "$out/index.html"

# Size: binaryen's wasm-opt from npm (studio/web-test's devDependencies, `npm ci` there), when
# present. Never Debian's binaryen (wasm-opt 108): its output fails in the browser.
wasm_opt=studio/web-test/node_modules/.bin/wasm-opt
if [[ "$profile" == release && -x "$wasm_opt" ]]; then
  before=$(stat -c %s "$out/fitslam_studio_bg.wasm")
  "$wasm_opt" -Oz --enable-bulk-memory --enable-nontrapping-float-to-int --enable-sign-ext \
    --enable-mutable-globals --enable-reference-types --enable-multivalue \
    "$out/fitslam_studio_bg.wasm" -o "$out/fitslam_studio_bg.opt.wasm"
  mv "$out/fitslam_studio_bg.opt.wasm" "$out/fitslam_studio_bg.wasm"
  echo "build-web.sh: wasm-opt -Oz: $before -> $(stat -c %s "$out/fitslam_studio_bg.wasm") bytes"
elif [[ "$profile" == release ]]; then
  echo "build-web.sh: no npm wasm-opt (cd studio/web-test && npm ci): bundle not size-optimised"
fi

wasm_bytes=$(stat -c %s "$out/fitslam_studio_bg.wasm")
total=$(du -cb "$out"/* | tail -n1 | cut -f1)
gz=$(gzip -9 -c "$out/fitslam_studio_bg.wasm" | wc -c)
awk -v p="$profile" -v o="$out" -v w="$wasm_bytes" -v g="$gz" -v t="$total" 'BEGIN {
  printf "build-web.sh: %s bundle in %s: wasm %d bytes (%.2f MB, %.2f MB gzipped), total %d bytes\n", p, o, w, w / 1e6, g / 1e6, t }'

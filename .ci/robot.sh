#!/usr/bin/env bash
# Robot CI steps (issue 5), kept out of .ci/run until verified end to end.
set -euo pipefail
cd "$(dirname "$0")/.."
step() { printf '\n==> %s (%ss)\n' "$*" "$SECONDS"; }
# --- robot ---
# robot/tests/cyclone_interop.rs checks the node's wire format against an independent DDS
# (Eclipse Cyclone DDS from PyPI); it fails without it. The DDS tests are loopback-only by
# construction (127.0.0.1, private domains), so no network namespace is needed.
step "robot: python3 cyclonedds for the interop test"
if ! python3 -c "import cyclonedds" >/dev/null 2>&1; then
  # (Debian's own python3 refuses plain pip installs: PEP 668.)
  python3 -m pip install --quiet cyclonedds==11.0.1 \
    || python3 -m pip install --quiet --break-system-packages cyclonedds==11.0.1
fi
# --- end robot ---

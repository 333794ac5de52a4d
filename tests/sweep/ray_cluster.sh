#!/usr/bin/env bash
# A Ray cluster of a head (no CPU) and two worker nodes (one CPU each), all on 127.0.0.1, runs
# `scripts/ray-compare PLAN --address …`, then is stopped. tests/sweep.rs starts this inside a
# private network and PID namespace (`unshare -n -p -f --mount-proc`), so nothing can leave
# 127.0.0.1 and every Ray process ends with it. Token authentication on, with a token of its own.
# Usage: ray_cluster.sh VENV PLAN_DIR FITSLAM
set -euo pipefail
venv=$1 plan=$2 fitslam=$3
root=$(cd "$(dirname "$0")/../.." && pwd)
ip link set lo up
tmp=$(mktemp -d /tmp/fitslam-ray.XXXXXX)
trap '"$venv/bin/ray" stop --force >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' >"$tmp/auth_token"
export RAY_AUTH_MODE=token RAY_AUTH_TOKEN_PATH=$tmp/auth_token RAY_USAGE_STATS_ENABLED=0
address=127.0.0.1:6390
"$venv/bin/ray" start --head --node-ip-address=127.0.0.1 --port=6390 --num-cpus=0 --object-store-memory=100000000 \
  --include-dashboard=false --temp-dir="$tmp" >"$tmp/head.log" 2>&1 || { cat "$tmp/head.log"; exit 1; }
for worker in 1 2; do
  "$venv/bin/ray" start --address=$address --node-ip-address=127.0.0.1 --num-cpus=1 --object-store-memory=100000000 >"$tmp/worker$worker.log" 2>&1 ||
    { cat "$tmp/worker$worker.log"; exit 1; }
done
# Until the head sees both workers.
"$venv/bin/python" - "$address" <<'PY'
import sys, time, ray
ray.init(address=sys.argv[1], logging_level="ERROR", log_to_driver=False)
for _ in range(600):
    if sum(n["Alive"] and n["Resources"].get("CPU", 0) == 1 for n in ray.nodes()) == 2:
        break
    time.sleep(0.1)
else:
    sys.exit("the two Ray workers did not join")
print(f"ray cluster: {len(ray.nodes())} nodes", file=sys.stderr)
PY
FITSLAM_SWEEP_VENV=$venv "$root/scripts/ray-compare" "$plan" --address $address --fitslam "$fitslam"

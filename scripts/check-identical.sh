#!/usr/bin/env bash
# Runs two `fitslam` binaries on the same missions and checks that their reproducible outputs
# (metrics.csv, trajectory_est.tum, summary.json without its wall-time field) are byte-identical.
# For a refactoring that must not change behaviour.
#
# Usage: scripts/check-identical.sh BEFORE_BIN AFTER_BIN [OUT_DIR]
#   Env: WORLDS (default: every assets/worlds/*.toml), STRATEGIES (default "fit greedy random"),
#        SEEDS (default "1 2 3"), LOCALISATIONS (default "slam ground-truth"), JOBS (default 2),
#        REUSE_BEFORE=1 keeps OUT_DIR/before from an earlier run of the same BEFORE_BIN.
# Prints one line per mission that differs and a final count; exits 1 if any differs.
set -euo pipefail
cd "$(dirname "$0")/.."
before=$(realpath "$1")
after=$(realpath "$2")
out=${3:-target/check-identical}
worlds=${WORLDS:-$(ls assets/worlds/*.toml)}
strategies=${STRATEGIES:-fit greedy random}
seeds=${SEEDS:-1 2 3}
localisations=${LOCALISATIONS:-slam ground-truth}
jobs=${JOBS:-2}
reuse=${REUSE_BEFORE:-0}
if [[ $reuse == 1 && -d $out/before ]]; then rm -rf "$out/after"; else reuse=0; rm -rf "$out"; fi
mkdir -p "$out"

runs=()
for w in $worlds; do
  for s in $strategies; do
    for seed in $seeds; do
      for l in $localisations; do
        runs+=("$w $s $seed $l")
      done
    done
  done
done

run_one() {
  local bin=$1 tag=$2 w=$3 s=$4 seed=$5 l=$6
  local dir="$out/$tag/$(basename "$w" .toml)/$s-$seed-$l"
  mkdir -p "$dir"
  "$bin" explore --world "$w" --strategy "$s" --seed "$seed" --localisation "$l" --out "$dir" >"$dir.log" 2>&1 \
    || echo "FAILED $tag $w $s $seed $l (see $dir.log)"
}
export -f run_one
export out

if [[ $reuse == 0 ]]; then
  printf '%s\n' "${runs[@]}" | xargs -P "$jobs" -L 1 bash -c 'run_one "$0" before $1 $2 $3 $4' "$before"
fi
printf '%s\n' "${runs[@]}" | xargs -P "$jobs" -L 1 bash -c 'run_one "$0" after $1 $2 $3 $4' "$after"

differ=0
for r in "${runs[@]}"; do
  read -r w s seed l <<<"$r"
  rel="$(basename "$w" .toml)/$s-$seed-$l"
  for f in metrics.csv trajectory_est.tum summary.json; do
    a="$out/before/$rel/$f"
    b="$out/after/$rel/$f"
    if [[ ! -f $a || ! -f $b ]]; then
      echo "MISSING $rel/$f"
      differ=$((differ + 1))
      continue
    fi
    if [[ $f == summary.json ]]; then
      # total_plan_ms and wall_time_s are wall time, the fields that are not reproducible.
      if ! cmp -s <(grep -vE "total_plan_ms|wall_time_s" "$a") <(grep -vE "total_plan_ms|wall_time_s" "$b"); then
        echo "DIFFER $rel/$f"
        differ=$((differ + 1))
      fi
    elif ! cmp -s "$a" "$b"; then
      echo "DIFFER $rel/$f"
      differ=$((differ + 1))
    fi
  done
done
echo "${#runs[@]} missions, $differ files differ"
[[ $differ -eq 0 ]]

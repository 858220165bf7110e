#!/usr/bin/env bash
# The whole SLAM's timed runs (ci/gpu-slam.sh, as fast as possible, cuda by default) for several
# variants alternated run by run, so that a change is compared with its baseline on one machine in
# one call (docs/BENCHMARKS.md, "SLAM on the GPU machine"). A variant is NAME=SCRIPT[:ENV...]:
# SCRIPT is a gpu-slam.sh (this tree's, or a baseline tree's carried beside it), ENV settings
# (VAR=VALUE, separated by ':') apply to its runs. Each round runs every variant once (gpu-slam.sh
# with PORTA_SLAM_REPEATS=1, no deterministic, loop or camera-rate runs unless set); the summary,
# one line per run and the medians per variant, comes from bench/slam_variants.py, and everything
# is packed into OUT_DIR/variants.tgz (the device tool brings back few files).
#
#   usage: ci/gpu-slam-variants.sh OUT_DIR ROUNDS VARIANT...
#   e.g.   ci/gpu-carried.sh .deps OUT ci/gpu-slam-variants.sh   (with PORTA_SLAM_VARIANTS and
#          PORTA_SLAM_ROUNDS set, as gpu-carried.sh passes only OUT_DIR)
# Environment: PORTA_SLAM_VARIANTS (when no VARIANT is given; separated by spaces, or by ';' when
# a setting holds spaces, e.g. "a=ci/gpu-slam.sh; b=ci/gpu-slam.sh:PORTA_SLAM_RUN_ARGS=--x 1"),
# PORTA_SLAM_ROUNDS (default 3), and whatever gpu-slam.sh reads; PORTA_SLAM_WORK defaults to
# OUT_DIR/work (shared by the variants: the sequence is rendered once).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1
out="${1:?usage: ci/gpu-slam-variants.sh OUT_DIR [ROUNDS VARIANT...]}"
rounds="${2:-${PORTA_SLAM_ROUNDS:-3}}"
shift $(( $# >= 2 ? 2 : 1 ))
variants=("$@")
if [ ${#variants[@]} -eq 0 ]; then
  if [[ "${PORTA_SLAM_VARIANTS:-}" == *";"* ]]; then  # ';'-separated: settings may hold spaces
    IFS=';' read -r -a listed <<<"$PORTA_SLAM_VARIANTS"
    for v in "${listed[@]}"; do
      v="${v#"${v%%[![:space:]]*}"}" v="${v%"${v##*[![:space:]]}"}"
      [ -n "$v" ] && variants+=("$v")
    done
  else
    read -r -a variants <<<"${PORTA_SLAM_VARIANTS:-}"
  fi
fi
say() { echo "gpu-slam-variants.sh: $*"; }
if ! [[ "$rounds" =~ ^[1-9][0-9]?$ ]]; then
  say "ROUNDS must be a whole number from 1 to 99, got '$rounds'"
  exit 2
fi
if [ ${#variants[@]} -eq 0 ]; then
  say "no variants (give NAME=SCRIPT[:VAR=VALUE...] arguments or PORTA_SLAM_VARIANTS)"
  exit 2
fi
for v in "${variants[@]}"; do
  name="${v%%=*}" rest="${v#*=}"
  script="${rest%%:*}"
  if [ "$name" = "$v" ] || ! [[ "$name" =~ ^[A-Za-z0-9_.-]+$ ]] || [ ! -f "$script" ]; then
    say "bad variant '$v': expected NAME=SCRIPT[:VAR=VALUE...] with a plain NAME and an existing SCRIPT"
    exit 2
  fi
  if [ "$rest" != "$script" ]; then
    IFS=: read -r -a settings <<<"${rest#*:}"
    for setting in "${settings[@]}"; do
      if ! [[ "$setting" =~ ^[A-Za-z_][A-Za-z0-9_]*= ]]; then
        say "bad variant '$v': setting '$setting' is not VAR=VALUE"
        exit 2
      fi
    done
  fi
done
mkdir -p "$out" && out="$(cd "$out" && pwd)" || exit 1
export PORTA_SLAM_WORK="${PORTA_SLAM_WORK:-$out/work}" PORTA_SLAM_REPEATS=1
export PORTA_SLAM_DETERMINISTIC="${PORTA_SLAM_DETERMINISTIC:-0}" PORTA_SLAM_LOOP="${PORTA_SLAM_LOOP:-0}"
export PORTA_SLAM_RATE_FRAMES="${PORTA_SLAM_RATE_FRAMES:-0}" PORTA_SLAM_BA_BENCH="${PORTA_SLAM_BA_BENCH:-0}"
export PORTA_SLAM_BACKENDS="${PORTA_SLAM_BACKENDS:-cuda}"
status=0
for r in $(seq 1 "$rounds"); do
  for v in "${variants[@]}"; do
    name="${v%%=*}" rest="${v#*=}"
    script="${rest%%:*}"
    settings=()
    [ "$rest" != "$script" ] && IFS=: read -r -a settings <<<"${rest#*:}"
    say "round $r of $rounds: $name ($script ${settings[*]})"
    env "${settings[@]}" bash "$script" "$out/$name-$r" >"$out/$name-$r.txt" 2>&1 || { say "$name round $r FAILED"; status=1; }
  done
done
python3 bench/slam_variants.py "$out" | tee "$out/summary.md" || status=1
tar czf "$out.tgz" --exclude=work -C "$(dirname "$out")" "$(basename "$out")" && mv "$out.tgz" "$out/variants.tgz"
exit $status

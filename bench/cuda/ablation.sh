#!/usr/bin/env bash
# The CUDA backend's ablation and frame timing on a machine with an NVIDIA GPU (no OpenCV needed):
#   1. builds porta_cuda_ablation (Release; CUDA architecture of this GPU unless CMAKE_CUDA_ARCHITECTURES
#      or PORTA_CUDA_ARCH says otherwise);
#   2. runs it: the culling kernel alone per variant (mlpt_tewa, mlpt_block, log2_block) at 1242x375
#      and 640x480, 8 levels, cells 32 and 16 (CUDA events, median/p10/p90 over --reps launches),
#      and whole frames through porta::Frontend (stereo 1242x375 L8, mono 320x240 L1 detect only)
#      with graphs on/off x streams on/off; every variant and configuration is checked against cpu;
#   3. measures warp efficiency per culling variant with Nsight Compute: one untimed launch per
#      (size, cell, variant) (--profile-once), metrics below, clocks left as they are
#      (--clock-control none: this script never changes the card's settings).
#
#   usage: bench/cuda/ablation.sh [OUT_DIR] [BUILD_DIR]     (defaults: ablation-results, build-ablation)
# Environment: PORTA_ABLATION_ARGS (extra arguments of the timing run, e.g. "--reps 1000 --frames 2000"),
# PORTA_CUDA_ARCH (e.g. 90), PORTA_JOBS, PORTA_SKIP_NCU=1.
#
# Results in OUT_DIR: ablation.txt (tables), ablation.json, ncu_cull.csv (raw Nsight Compute rows),
# ncu_summary.md (per launch: warp instructions issued and relative to mlpt_tewa, threads active per
# issued instruction out of 32 = warp efficiency, branch uniformity, occupancy, duration),
# ncu_metrics.txt (which metrics this ncu knows).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.." || exit 1
out="${1:-ablation-results}"
build="${2:-build-ablation}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
jobs="${PORTA_JOBS:-$(nproc 2>/dev/null || echo 4)}"
if ! command -v nvcc >/dev/null 2>&1 && [ -x /usr/local/cuda/bin/nvcc ]; then export PATH="/usr/local/cuda/bin:$PATH"; fi

# ---- 1. Build ------------------------------------------------------------------------------------
arch="${PORTA_CUDA_ARCH:-}"
if [ -z "$arch" ] && command -v nvidia-smi >/dev/null 2>&1; then
  arch="$(nvidia-smi --query-gpu=compute_cap --format=csv,noheader 2>/dev/null | head -1 | tr -d ' .')"
fi
gen=(-G Ninja); command -v ninja >/dev/null 2>&1 || gen=(-G "Unix Makefiles")
cmake_args=(-S . -B "$build" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DPORTA_WITH_CUDA=ON -DPORTA_WITH_OPENCL=OFF
            -DPORTA_WITH_VULKAN=OFF -DPORTA_BUILD_APPS=OFF -DPORTA_BUILD_TESTS=OFF)
[ -n "$arch" ] && cmake_args+=("-DCMAKE_CUDA_ARCHITECTURES=$arch")
echo "ablation.sh: cmake ${cmake_args[*]}"
if ! { cmake "${cmake_args[@]}" && cmake --build "$build" --target porta_cuda_ablation -j "$jobs"; } >"$out/build.log" 2>&1; then
  echo "ablation.sh: BUILD FAILED"; tail -30 "$out/build.log"; exit 1
fi
tool="$build/backends/cuda/porta_cuda_ablation"

# ---- 2. Timing -----------------------------------------------------------------------------------
nvidia-smi -L 2>/dev/null | tee "$out/machine.txt"
# shellcheck disable=SC2206  # extra arguments are split on spaces on purpose
extra=(${PORTA_ABLATION_ARGS:-})
"$tool" --mode all --json "$out/ablation.json" "${extra[@]}" 2>&1 | tee "$out/ablation.txt"
status=${PIPESTATUS[0]}

# ---- 3. Warp efficiency (Nsight Compute) -----------------------------------------------------------
if [ "${PORTA_SKIP_NCU:-0}" != 1 ] && command -v ncu >/dev/null 2>&1; then
  # Nsight Compute 2025 lists smsp__thread_inst_executed_per_inst_executed as deprecated in favour of
  # smsp__average_...; each pair below is tried newest first.
  wanted=(
    smsp__average_thread_inst_executed_per_inst_executed.ratio          # active threads per warp instruction (/32)
    smsp__average_thread_inst_executed_pred_on_per_inst_executed.ratio  # ... not predicated off
    smsp__sass_average_branch_targets_threads_uniform.pct               # branch efficiency
    smsp__inst_executed.sum
    smsp__thread_inst_executed.sum
    sm__warps_active.avg.pct_of_peak_sustained_active           # achieved occupancy
    gpu__time_duration.sum
    launch__grid_size
    launch__block_size
  )
  ncu --query-metrics >"$out/ncu_metrics.txt" 2>&1
  old_name() { echo "${1/smsp__average_thread_inst/smsp__thread_inst}"; }  # the pre-2025 names
  known() { [ ! -s "$out/ncu_metrics.txt" ] || [[ "$1" == launch__* ]] || grep -q "^${1%%.*}[[:space:]]" "$out/ncu_metrics.txt"; }
  metrics=()
  for m in "${wanted[@]}"; do
    if known "$m"; then metrics+=("$m")
    elif known "$(old_name "$m")"; then metrics+=("$(old_name "$m")")
    else echo "ablation.sh: this ncu does not list ${m%%.*}; left out" | tee -a "$out/ncu_summary.md"; fi
  done
  list="$(IFS=,; echo "${metrics[*]}")"
  echo "ablation.sh: ncu --clock-control none --kernel-name regex:'cull_(cells|log2)_kernel' --metrics $list --csv --page raw $tool --mode cull --profile-once --no-cpu-check"
  ncu --clock-control none --kernel-name regex:'cull_(cells|log2)_kernel' --metrics "$list" --csv --page raw \
      "$tool" --mode cull --profile-once --no-cpu-check >"$out/ncu_cull.csv" 2>"$out/ncu_stderr.txt"
  echo "ncu exit status $?" >>"$out/ncu_stderr.txt"
  # The tool's own lines ("profile launch k: ...") name each launch, in the order ncu saw them.
  grep "^profile launch" "$out/ncu_cull.csv" >"$out/ncu_launches.txt"
  python3 - "$out/ncu_cull.csv" "$out/ncu_launches.txt" >>"$out/ncu_summary.md" <<'PY' || echo "ablation.sh: summary failed; see ncu_cull.csv"
import csv, sys
lines = [l for l in open(sys.argv[1]) if l.startswith('"')]
rows = list(csv.reader(lines))
names = [l.split(": ", 1)[1].strip() for l in open(sys.argv[2])]
if len(rows) < 3:
    print("no ncu rows (see ncu_stderr.txt)"); sys.exit(0)
head, data = rows[0], rows[2:]  # rows[1] holds the units
col = {h: i for i, h in enumerate(head)}
def get(r, m):
    i = col.get(m)
    return r[i] if i is not None and i < len(r) else ""
def first(r, *ms):
    for m in ms:
        v = get(r, m)
        if v: return v
    return ""
def num(v):
    try: return float(v.replace(",", ""))
    except ValueError: return None
# threads/instr is the lanes active per issued warp instruction (warp efficiency = /32); it does not
# see whole warps that only run overhead (idle threads of a one-cell block), so warp instructions
# issued per launch, relative to the first variant of the same case, are listed too.
print("| launch | grid | block | duration ns | warp instr | vs mlpt_tewa | thread instr | threads/instr | "
      "warp efficiency | pred-on threads/instr | branch uniformity % | occupancy % |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
base_inst = None
for k, r in enumerate(data):
    name = names[k] if k < len(names) else str(k)
    t = first(r, "smsp__average_thread_inst_executed_per_inst_executed.ratio",
              "smsp__thread_inst_executed_per_inst_executed.ratio")
    eff = "%.1f%%" % (100.0 * num(t) / 32.0) if num(t) is not None else ""
    inst = num(get(r, "smsp__inst_executed.sum"))
    if "mlpt_tewa" in name: base_inst = inst
    rel = "%.2fx" % (inst / base_inst) if inst and base_inst else ""
    print("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
        name, get(r, "launch__grid_size") or get(r, "Grid Size"), get(r, "launch__block_size") or get(r, "Block Size"),
        get(r, "gpu__time_duration.sum"), get(r, "smsp__inst_executed.sum"), rel, get(r, "smsp__thread_inst_executed.sum"),
        t, eff, first(r, "smsp__average_thread_inst_executed_pred_on_per_inst_executed.ratio",
                      "smsp__thread_inst_executed_pred_on_per_inst_executed.ratio"),
        get(r, "smsp__sass_average_branch_targets_threads_uniform.pct"),
        get(r, "sm__warps_active.avg.pct_of_peak_sustained_active")))
PY
  echo; echo "==== warp efficiency per culling variant (Nsight Compute) ===="; cat "$out/ncu_summary.md"
else
  echo "ablation.sh: ncu not run (PORTA_SKIP_NCU=1 or ncu not found)"
fi
echo "ablation.sh: results in $out"
exit "$status"

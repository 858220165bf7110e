#!/usr/bin/env bash
# Soak benchmark (not a test; docs/RELIABILITY.md, "Bounded memory"): the built-in street loop,
# which ends where it starts, played again and again as one KITTI sequence of FRAMES frames, run
# by `portaslam run` as fast as possible; prints the process's resident memory and the map's size
# every 500 frames (from summary.json) and the ratio RSS(last) / RSS(1000).
#   bench/soak/soak.sh [--frames N] [--size WxH] [--work DIR] [--portaslam PATH] [-- RUN OPTIONS...]
# Defaults: 10000 frames, 640x194 (the loop is tracked on every frame at that size), work folder
# soak-work, ./build/apps/portaslam. The images of one pass are rendered once and linked, not copied.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

frames=10000
size=640x194
work=soak-work
portaslam=./build/apps/portaslam
run_options=()
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    --portaslam) portaslam="$2"; shift 2 ;;
    --) shift; run_options=("$@"); break ;;
    *) echo "soak: unknown option '$1' (see the comment at the top of $0)" >&2; exit 2 ;;
  esac
done
case "$frames" in ''|*[!0-9]*) echo "soak: --frames expects a count, got '$frames'" >&2; exit 2 ;; esac
[ -x "$portaslam" ] || { echo "soak: $portaslam not found: build first (bash ci/build.sh)" >&2; exit 1; }

loop="$work/loop-$size"
if [ ! -f "$loop/times.txt" ]; then
  "$portaslam" render --path street-loop --size "$size" --out "$loop" --quiet
fi
pass=$(grep -c . "$loop/times.txt")
seq_dir="$work/repeated-$size-$frames"
rm -rf "$seq_dir"
mkdir -p "$seq_dir/image_0" "$seq_dir/image_1"
cp "$loop/calib.txt" "$seq_dir/"
loop_abs=$(cd "$loop" && pwd)
: > "$seq_dir/times.txt"
: > "$seq_dir/poses.txt"
for ((i = 0; i < frames; i++)); do
  k=$((i % pass))
  src=$(printf "%06d.png" "$k")
  dst=$(printf "%06d.png" "$i")
  ln -s "$loop_abs/image_0/$src" "$seq_dir/image_0/$dst"
  ln -s "$loop_abs/image_1/$src" "$seq_dir/image_1/$dst"
done
awk -v n="$frames" 'BEGIN { for (i = 0; i < n; i++) printf "%.6f\n", 0.1 * i }' > "$seq_dir/times.txt"
awk -v n="$frames" '{ line[NR - 1] = $0 } END { for (i = 0; i < n; i++) print line[i % NR] }' \
  "$loop/poses.txt" > "$seq_dir/poses.txt"

out="$work/run-$size-$frames"
echo "soak: $frames frames ($((frames / pass)) passes of the $pass-frame loop at $size) ..."
/usr/bin/time -v "$portaslam" run --dataset kitti "$seq_dir" --out "$out" --quiet "${run_options[@]}" \
  > "$out.log" 2> "$out.time" || { tail -20 "$out.log" "$out.time"; exit 1; }
grep -E "frames [0-9]+, tracked|ATE|loops" "$out.log" | head -5
echo "max RSS (time -v): $(grep -oE 'Maximum resident set size \(kbytes\): [0-9]+' "$out.time" | grep -oE '[0-9]+$') kB"
echo "frame  resident_MiB  keyframes  map_points"
grep -oE '\{"frame": [0-9]+, "resident_mib": [0-9.]+, "keyframes": [0-9]+, "map_points": [0-9]+\}' "$out/summary.json" |
  sed -E 's/[^0-9. ]+/ /g' | awk '{ printf "%5d  %12.1f  %9d  %10d\n", $1, $2, $3, $4; rss[$1] = $2; last = $1 }
    END { if (rss[1000] > 0) printf "RSS(%d) / RSS(1000) = %.2f\n", last, rss[last] / rss[1000] }'

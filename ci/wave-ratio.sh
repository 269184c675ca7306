#!/usr/bin/env bash
# wave-ratio.sh ROUNDS BIN...: issue 13's waveform cost on the wall, scene2 at ratio 10. For each
# round and binary, runs no waveform, --vcd, --wave .fst and --wave .fst --fst-pack lz4 in turn
# (alternated, so drift hits all alike), removing the last output and running `sync` before each
# run outside the timing (a run that overwrites a 500 MB VCD still being written back measures
# the disk). Reads each run's `host.simulation_seconds` and prints the medians and their ratios.
# RATIO (default 10) sets the Hi_Low_Ratio, MODES (default "off vcd fst lz4"; off is always run)
# the waveforms measured: `RATIO=1 MODES=fst ci/wave-ratio.sh 5 old new`.
set -euo pipefail
R=$1; shift
RATIO=${RATIO:-10}
read -r -a MS <<< "${MODES:-vcd fst lz4}"
MS=("${MS[@]/off/}")
cd "$(dirname "$0")/.."
D=$(mktemp -d); trap 'rm -rf "$D"' EXIT
for i in $(seq "$R"); do
  for b in "$@"; do
    n=$(basename "$b")
    for m in off ${MS[@]+"${MS[@]}"}; do
      rm -f "$D/x.vcd" "$D/x.fst" "$D/o.json"; sync
      case $m in
        off) a=() ;;
        vcd) a=(--vcd "$D/x.vcd") ;;
        fst) a=(--wave "$D/x.fst") ;;
        lz4) a=(--wave "$D/x.fst" --fst-pack lz4) ;;
      esac
      "$b" run --scene scenes/scene2.json --ratio "$RATIO" --json "$D/o.json" ${a[@]+"${a[@]}"} > /dev/null
      jq .host.simulation_seconds "$D/o.json" >> "$D/$n.$m"
    done
  done
done
med() { sort -g "$1" | awk '{a[NR]=$1} END {print a[int((NR + 1) / 2)]}'; }
for b in "$@"; do
  n=$(basename "$b")
  o=$(med "$D/$n.off")
  line="$n ($R rounds, ratio $RATIO) off ${o}s"
  for m in ${MS[@]+"${MS[@]}"}; do
    v=$(med "$D/$n.$m")
    line="$line  $m ${v}s ($(awk -v a="$v" -v b="$o" 'BEGIN {printf "%.2f", a / b}')x)"
  done
  echo "$line"
done

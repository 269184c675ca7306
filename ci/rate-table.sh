#!/usr/bin/env bash
# rate-table.sh ROUNDS BIN...: issue 13's simulated cycles per second, scene2 at Hi_Low_Ratio 1, 10
# and 30 on hw/configs/paper.toml with 1, 2, 4, 8 and 16 clusters (2 CTUs each, balancing on), no
# waveform. For each row, ROUNDS rounds run every binary in turn (alternated, so drift hits all
# alike); the table takes each binary's fastest `host.simulation_seconds` (the cycle model and its
# checks, not loading and partitioning), the cycles (every run of every binary must agree: a speed
# change keeps every statistic) and the peak RSS. Prints a Markdown table: per binary the seconds
# and M cycles/s, then the last binary's M cluster-cycles/s (cycles × clusters / second, the
# throughput per simulated cluster) and its speedup over the first. Needs jq.
set -euo pipefail
R=$1; shift
[ $# -ge 1 ] || { echo "usage: rate-table.sh ROUNDS BIN..." >&2; exit 2; }
cd "$(dirname "$0")/.."
D=$(mktemp -d); trap 'rm -rf "$D"' EXIT
names=(); for b in "$@"; do names+=("$(basename "$b")"); done
head="| ratio | clusters | cycles |"; rule="| --- | --- | --- |"
for n in "${names[@]}"; do head="$head s $n |"; rule="$rule --- |"; done
for n in "${names[@]}"; do head="$head M cycles/s $n |"; rule="$rule --- |"; done
echo "$head M cluster-cycles/s ${names[-1]} | speedup | peak RSS |"
echo "$rule --- | --- | --- |"
for c in 1 2 4 8 16; do
  sed "s/^clusters = 4 /clusters = $c /" hw/configs/paper.toml > "$D/c$c.toml"
  grep -q "^clusters = $c " "$D/c$c.toml" || { echo "paper.toml: no 'clusters = 4 ' line" >&2; exit 1; }
done
for ratio in 1 10 30; do
  for c in 1 2 4 8 16; do
    for i in $(seq "$R"); do
      for k in "${!names[@]}"; do
        "${@:k+1:1}" run --scene scenes/scene2.json --ratio "$ratio" --hw "$D/c$c.toml" \
          --json "$D/o.json" > /dev/null
        jq -r '[.stats.cycles, .host.simulation_seconds, .host.peak_rss_kib] | @tsv' "$D/o.json" \
          >> "$D/$k"
      done
    done
    cycles=$(cut -f1 "$D"/[0-9]* | sort -u)
    [ "$(echo "$cycles" | wc -l)" = 1 ] ||
      { echo "ratio $ratio, $c clusters: the runs simulated different cycles:" $cycles >&2; exit 1; }
    row="| $ratio | $c | $(echo "$cycles" | sed -e ':a' -e 's/\B[0-9]\{3\}\>/,&/' -e 'ta') |"
    best=(); for k in "${!names[@]}"; do best+=("$(cut -f2 "$D/$k" | sort -g | head -1)"); done
    for s in "${best[@]}"; do row="$row $(printf '%.3f' "$s") |"; done
    for s in "${best[@]}"; do row="$row $(awk -v n="$cycles" -v s="$s" 'BEGIN {printf "%.2f", n / s / 1e6}') |"; done
    last=${best[-1]}
    rss=$(cut -f3 "$D/$((${#names[@]} - 1))" | sort -g | tail -1)
    row="$row $(awk -v n="$cycles" -v c="$c" -v s="$last" 'BEGIN {printf "%.2f", n * c / s / 1e6}') |"
    row="$row $(awk -v a="${best[0]}" -v b="$last" 'BEGIN {printf "%.2f×", a / b}') | $((rss / 1024)) MiB |"
    echo "$row"
    rm -f "$D"/[0-9]*
  done
done

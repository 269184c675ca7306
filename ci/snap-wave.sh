#!/usr/bin/env bash
# snap-wave.sh BIN OUTDIR: the waveforms and run statistics a speed change must keep byte-identical.
# Writes five runs' full VCDs/FSTs, .gtkw files and run JSONs (host section dropped) into OUTDIR
# and their MD5s into OUTDIR.md5; compare two binaries' .md5 files with diff. FST bytes depend on
# the encoder's compression: compare FSTs through `fst2vcd` when the FST writer itself changed.
set -euo pipefail
BIN=$(readlink -f "$1"); OUT=$(readlink -f "$2")
cd "$(dirname "$0")/.."
rm -rf "$OUT"; mkdir -p "$OUT/cfg"
C="$OUT/cfg"
sed 's/^job_source = "ctu"/job_source = "bundle"/; s/^overlap_joins = false/overlap_joins = true/' hw/configs/paper.toml > "$C/bundle-overlap.toml"
sed 's/^overlap_joins = false/overlap_joins = true/' hw/configs/paper.toml > "$C/ctu-overlap.toml"
sed 's/^clusters = 4 /clusters = 16/' hw/configs/paper.toml > "$C/c16.toml"
"$BIN" run --scene scenes/scene2.json --ratio 1 --json "$OUT/r1.json" --vcd "$OUT/r1.vcd" > /dev/null 2>&1
"$BIN" run --scene scenes/scene2.json --ratio 1 --json "$OUT/r1f.json" --wave "$OUT/r1.fst" > /dev/null 2>&1
"$BIN" run --scene scenes/scene2.json --ratio 3 --hw "$C/bundle-overlap.toml" --json "$OUT/bo.json" --vcd "$OUT/bo.vcd" > /dev/null 2>&1
"$BIN" run --scene scenes/scene2.json --ratio 3 --hw "$C/ctu-overlap.toml" --json "$OUT/co.json" --vcd "$OUT/co.vcd" --vcd-scope 'machine.cluster_1.*' > /dev/null 2>&1
"$BIN" run --scene scenes/scene2.json --ratio 2 --hw "$C/c16.toml" --balance off --json "$OUT/c16.json" --wave "$OUT/c16.fst" --wave-window 1000:9000 > /dev/null 2>&1
"$BIN" run --scene scenes/cornell.json --hw hw/configs/small.toml --ratio 2 --json "$OUT/small.json" --vcd "$OUT/small.vcd" > /dev/null 2>&1
rm -rf "$C"
for j in "$OUT"/*.json; do jq 'del(.host)' "$j" > "$j.nohost"; rm "$j"; done
grep -rl "$OUT" "$OUT" 2>/dev/null | xargs -r sed -i "s#$OUT#OUT#g" || true
(cd "$OUT" && md5sum -- *) > "$OUT.md5"
echo "$OUT.md5"

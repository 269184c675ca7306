#!/usr/bin/env bash
# bench.sh [--quick] [--only PART]... [--list]: regenerates BENCHMARKS.md's table.
#
# Runs the criterion benches (benches/), the bench binary and the ratio scripts in ci/, reads
# their results (criterion's target/criterion/<group>/<bench>/new/estimates.json with jq; the
# scripts' and the CLI's own summary lines), computes each row's figure and rewrites the table
# between the `<!-- bench:begin -->` and `<!-- bench:end -->` markers of BENCHMARKS.md; the text
# outside the markers stays. The new file is built beside the old one and moved into place, so
# a failed run leaves the old table whole.
#
#   bash ci/bench.sh            # every part, full settings (≤ ~25 min on 2 cores)
#   bash ci/bench.sh --quick    # the smallest settings (a few minutes); keeps the rows of the
#                               # slow parts: synth (minutes of Yosys), estimator (deterministic)
#   bash ci/bench.sh --only waves --only levels   # rerun these parts' rows, keep the others
#   bash ci/bench.sh --list     # the parts
#
# A part whose tool is absent (Verilator, Yosys, valgrind, embreex) writes "not measured: …"
# in its rows; a part that fails writes "failed" and its log's path, and the others go on.
# Logs: $CARGO_TARGET_DIR/bench-logs (default target/). The wall seconds of the parts are
# printed to stderr, not written to the table.
set -euo pipefail
cd "$(dirname "$0")/.."

PARTS=(machine waves rates instr levels radiosity explore reference fixed tracer embree scale cosim synth estimator)
# Slow parts: --quick keeps their rows as they are unless --only names them.
SLOW=(synth estimator)
QUICK=0; ONLY=()
while [ $# -gt 0 ]; do
  case $1 in
    --quick) QUICK=1 ;;
    --only) [ $# -ge 2 ] || { echo "bench.sh: --only needs a part" >&2; exit 2; }
            ONLY+=("$2"); shift ;;
    --list) printf '%s\n' "${PARTS[@]}"; exit 0 ;;
    -h|--help) sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench.sh: unknown argument $1 (--quick, --only PART, --list)" >&2; exit 2 ;;
  esac
  shift
done
for p in ${ONLY[@]+"${ONLY[@]}"}; do
  [[ " ${PARTS[*]} " == *" $p "* ]] || { echo "bench.sh: no part '$p' (--list)" >&2; exit 2; }
done
RUN=()
if [ ${#ONLY[@]} -gt 0 ]; then RUN=("${ONLY[@]}")
else
  for p in "${PARTS[@]}"; do
    if [ "$QUICK" = 1 ] && [[ " ${SLOW[*]} " == *" $p "* ]]; then continue; fi
    RUN+=("$p")
  done
fi

FILE=BENCHMARKS.md
BEGIN='<!-- bench:begin -->'; END='<!-- bench:end -->'
if ! grep -qx "$BEGIN" "$FILE" || ! grep -qx "$END" "$FILE"; then
  echo "bench.sh: $FILE lacks the $BEGIN / $END lines" >&2; exit 1
fi
TARGET=${CARGO_TARGET_DIR:-target}
BIN=$TARGET/release/shellsim
EX=$TARGET/release/examples
CRIT=$TARGET/criterion
LOGS=$TARGET/bench-logs
mkdir -p "$LOGS"
W=$(mktemp -d "${TMPDIR:-/tmp}/bench.XXXXXX"); trap 'rm -rf "$W"' EXIT
TODAY=$(date -u +%F)

# The settings of each mode.
if [ $QUICK = 1 ]; then
  CRIT_ARGS=(--warm-up-time 1 --measurement-time 2 --sample-size 10)
  WAVE_ROUNDS=1; RATE_ROUNDS=1; INSTR_RATIO=1; EMBREE_ROUNDS=1; TRACER_REPS=1
  SCALE_RAYS=100000; SCALE_ROWS=2000; COSIM_VECTORS=100000
else
  CRIT_ARGS=()
  WAVE_ROUNDS=9; RATE_ROUNDS=3; INSTR_RATIO=10; EMBREE_ROUNDS=3; TRACER_REPS=5
  SCALE_RAYS=1000000; SCALE_ROWS=all; COSIM_VECTORS=1000000
fi
# Criterion's options as the command column shows them: after a filter (CAF), alone (CA).
CAF=${CRIT_ARGS[*]+" ${CRIT_ARGS[*]}"}; CA=${CRIT_ARGS[*]+" -- ${CRIT_ARGS[*]}"}
if [ $QUICK = 1 ]; then TODAY="$TODAY, --quick"; fi

# row PART MEASURE COMMAND FIGURE VALUE TARGET: one table row into $W/PART.rows. VALUE is the
# number the target compares (empty: no comparison); TARGET is "≤ 3×", "≥ 30×", "≤ 60 s",
# "≥ 1.0×" or "—".
row() {
  local part=$1 measure=$2 cmd=$3 fig=$4 v=$5 target=$6 met="—"
  if [ -n "$v" ] && [ "$target" != "—" ]; then
    local op=${target%% *} t; t=$(echo "${target#* }" | tr -dc '0-9.')
    met=$(awk -v v="$v" -v t="$t" -v op="$op" 'BEGIN {
      ok = (op == "≤") ? v <= t : v >= t; print ok ? "yes" : "**no**" }')
  fi
  # shellcheck disable=SC2016 # the backquotes are Markdown's
  printf '| `%s` | %s | `%s` | %s | %s | %s | %s |\n' \
    "$part" "$measure" "$cmd" "$fig" "$target" "$met" "$TODAY" >> "$W/$part.rows"
}
# na PART MEASURE COMMAND TARGET WHY: a row that could not be measured here.
na() { row "$1" "$2" "$3" "not measured: $5" "" "$4"; }
# crit GROUP BENCH: criterion's median, in ns.
crit() { jq '.median.point_estimate' "$CRIT/$1/$2/new/estimates.json"; }
# Arithmetic and formats; thou puts thousands separators in an integer.
thou() { sed -e ':a' -e 's/\B[0-9]\{3\}\>/,&/' -e 'ta'; }
calc() { awk "BEGIN {printf \"$1\", $2}"; }
ms() { calc '%.1f' "$1 / 1e6"; }

part_machine() {
  rm -rf "$CRIT/cycle_vs_untimed" "$CRIT/machine_scene2"
  cargo bench --bench machine -- \
    'cycle_vs_untimed/(cycle_model|untimed_same_jobs|untimed_issued_jobs)$|machine_scene2/cycle_model' \
    ${CRIT_ARGS[@]+"${CRIT_ARGS[@]}"}
  local c s i r1 vcd fst r
  c=$(crit cycle_vs_untimed cycle_model); s=$(crit cycle_vs_untimed untimed_same_jobs)
  i=$(crit cycle_vs_untimed untimed_issued_jobs)
  r=$(calc '%.2f' "$c / $s")
  row machine "Cycle model / untimed model on as many (ray, patch) jobs; scene2, paper.toml, ratio 10" \
    "cargo bench --bench machine -- cycle_vs_untimed$CAF" "$r× ($(ms "$c") / $(ms "$s") ms)" "$r" "≤ 3×"
  r=$(calc '%.2f' "$c / $i")
  row machine "Cycle model / untimed model on the very jobs the machine issued" \
    "cargo bench --bench machine -- cycle_vs_untimed$CAF" "$r× ($(ms "$c") / $(ms "$i") ms)" "$r" "≤ 3×"
  r1=$(crit machine_scene2 cycle_model); vcd=$(crit machine_scene2 cycle_model_with_vcd)
  fst=$(crit machine_scene2 cycle_model_with_fst)
  r=$(calc '%.2f' "$vcd / $r1")
  row machine "VCD on / off, scene2 ratio 1 (39 MB VCD, a fresh file each run)" \
    "cargo bench --bench machine -- machine_scene2/cycle_model$CAF" "$r× ($(ms "$vcd") / $(ms "$r1") ms)" "$r" "≤ 2×"
  r=$(calc '%.2f' "$fst / $r1")
  row machine "FST on / off, scene2 ratio 1" \
    "cargo bench --bench machine -- machine_scene2/cycle_model$CAF" "$r× ($(ms "$fst") / $(ms "$r1") ms)" "$r" "≤ 2×"
}

part_waves() {
  local out; out=$(bash ci/wave-ratio.sh "$WAVE_ROUNDS" "$BIN"); echo "$out"
  med() { echo "$out" | grep -o " $1 [0-9.]*s ([0-9.]*x)" | head -1; }
  local off; off=$(echo "$out" | grep -o 'off [0-9.]*s' | head -1 | tr -dc '0-9.')
  off=$(calc '%.3f' "$off")
  local cmd="bash ci/wave-ratio.sh $WAVE_ROUNDS target/release/shellsim"
  for m in vcd fst lz4; do
    local f v s; f=$(med "$m"); v=$(echo "$f" | grep -o '([0-9.]*x)' | tr -dc '0-9.')
    s=$(echo "$f" | awk '{printf "%.3fs", $2}')
    case $m in
      vcd) row waves "VCD on / off, scene2 ratio 10 (500 MB VCD), medians of simulation seconds" \
             "$cmd" "$v× ($s / ${off}s)" "$v" "≤ 2×" ;;
      fst) row waves "FST (zlib) on / off, scene2 ratio 10" "$cmd" "$v× ($s / ${off}s)" "$v" "≤ 2×" ;;
      lz4) row waves "FST \`--fst-pack lz4\` on / off, scene2 ratio 10" "$cmd" "$v× ($s / ${off}s)" "" "—" ;;
    esac
  done
  # The sizes: one VCD and one FST of the same run.
  "$BIN" run --scene scenes/scene2.json --ratio 10 --json "$W/o.json" --vcd "$W/x.vcd" > /dev/null
  local vb fb; vb=$(stat -c %s "$W/x.vcd"); rm -f "$W/x.vcd"
  "$BIN" run --scene scenes/scene2.json --ratio 10 --json "$W/o.json" --wave "$W/x.fst" > /dev/null
  fb=$(stat -c %s "$W/x.fst"); rm -f "$W/x.fst"
  local r; r=$(calc '%.1f' "$vb / $fb")
  row waves "FST size against the VCD of the same run, scene2 ratio 10" \
    "shellsim run --scene scenes/scene2.json --ratio 10 --vcd x.vcd (then --wave x.fst)" \
    "$r× smaller ($(calc '%.1f' "$fb / 1e6") / $(calc '%.1f' "$vb / 1e6") MB)" "$r" "≥ 10×"
}

part_rates() {
  bash ci/rate-table.sh "$RATE_ROUNDS" "$BIN" | tee "$W/rates.md"
  # | ratio | clusters | cycles | s | M cycles/s | M cluster-cycles/s | speedup | peak RSS |
  local cmd="bash ci/rate-table.sh $RATE_ROUNDS target/release/shellsim" p cc rss
  p=$(awk -F' *[|] *' '$2 == 10 && $3 == 4 {print $6}' "$W/rates.md")
  row rates "Simulated cycles per second, the paper machine (4 clusters × 2 CTUs), scene2 ratio 10" \
    "$cmd" "$p M cycles/s" "" "—"
  cc=$(awk -F' *[|] *' '$2 ~ /^[0-9]+$/ {print $7}' "$W/rates.md" | sort -g | sed -n '1p;$p' | paste -sd/ | sed 's#/# – #')
  row rates "Simulator throughput per simulated cluster over ratio 1/10/30 × 1–16 clusters" \
    "$cmd" "$cc M cluster-cycles/s" "" "—"
  rss=$(for q in 1 10 30; do awk -F' *[|] *' -v q=$q '$2 == q {print $9}' "$W/rates.md" | sort -g | tail -1; done | paste -sd/ | sed 's#/# / #g')
  row rates "Peak RSS of \`run\`, scene2 at ratio 1 / 10 / 30 (969 / 9,690 / 29,070 rays)" \
    "$cmd" "$rss" "" "—"
}

part_instr() {
  local m="Instructions of \`Machine::run\` (simulation thread), VCD / no waveform, scene2 ratio $INSTR_RATIO"
  local cmd="bash ci/thread-instr.sh target/release/shellsim --ratio $INSTR_RATIO [--vcd x.vcd]"
  command -v valgrind > /dev/null || { na instr "$m" "$cmd" "—" "valgrind not installed"; return; }
  local a b
  local oa ob
  oa=$(bash ci/thread-instr.sh "$BIN" --ratio "$INSTR_RATIO"); echo "$oa"
  ob=$(bash ci/thread-instr.sh "$BIN" --ratio "$INSTR_RATIO" --vcd "$W/x.vcd"); echo "$ob"
  a=$(echo "$oa" | grep -o 'Machine::run [0-9]*' | awk '{print $2}')
  b=$(echo "$ob" | grep -o 'Machine::run [0-9]*' | awk '{print $2}')
  rm -f "$W/x.vcd"
  row instr "$m" "$cmd" "$(calc '%.2f' "$b / $a")× ($(calc '%.0f' "$b / 1e6") / $(calc '%.0f' "$a / 1e6") M)" "" "—"
}

part_levels() {
  local out s; out=$("$BIN" experiment levels --scene scenes/scene2.json --out "$W/levels"); echo "$out"
  s=$(echo "$out" | grep '^mean |error|')
  # mean |error| 0.6%, max 2.8%; wall: cycle 5.47s, queue timing 0.95s (5.8× faster), with the
  # untimed results 1.21s (4.5×); the network alone 0.038s (144×: …)
  local cyc q qx net nx mean max
  cyc=$(echo "$s" | grep -o 'cycle [0-9.]*s' | tr -dc '0-9.')
  q=$(echo "$s" | grep -o 'queue timing [0-9.]*s' | tr -dc '0-9.')
  qx=$(echo "$s" | grep -o '([0-9.]*× faster)' | tr -dc '0-9.')
  net=$(echo "$s" | grep -o 'network alone [0-9.]*s' | tr -dc '0-9.')
  nx=$(echo "$s" | grep -o '[0-9.]*×:' | tr -dc '0-9.')
  mean=$(echo "$s" | grep -o 'mean |error| [0-9.]*%' | grep -o '[0-9.]*%')
  max=$(echo "$s" | grep -o 'max [0-9.]*%' | grep -o '[0-9.]*%')
  local cmd="shellsim experiment levels --scene scenes/scene2.json --out DIR"
  row levels "Queue level against cycle level, the network on a walk the machines share (11 machines, scene2)" \
    "$cmd" "$nx× (${net}s / ${cyc}s)" "$nx" "≥ 30×"
  row levels "Queue level against cycle level, walk and network (a lone run)" \
    "$cmd" "$qx× (${q}s / ${cyc}s)" "" "—"
  row levels "Queue level's cycles against the cycle level's, mean / max \|error\|" \
    "$cmd" "$mean / $max" "" "—"
}

part_radiosity() {
  local out; out=$(cargo bench --bench radiosity -- scene2); echo "$out"
  local f x m c
  f=$(echo "$out" | awk '$1 == "scene2" && $2 == "float" {print $4}')
  x=$(echo "$out" | awk '$1 == "scene2" && $2 == "fixed" {print $4}')
  m=$(echo "$out" | awk '$1 == "scene2" && $2 == "machine" {print $4}')
  c=$(echo "$out" | awk '$1 == "scene2" && $2 == "machine" {print $5}')
  local cmd="cargo bench --bench radiosity -- scene2"
  row radiosity "Whole form-factor matrix of scene2 on the machine (808 rows × 969 rays, paper.toml, 2 threads), wall" \
    "$cmd" "$m s ($(echo "$c" | thou) cycles)" "$m" "≤ 60 s"
  row radiosity "The same matrix on the float / fixed-point models, wall" "$cmd" "$f s / $x s" "" "—"
}

part_explore() {
  rm -rf "$CRIT/explore_point_scene2_ratio1"
  cargo bench --bench explore -- ${CRIT_ARGS[@]+"${CRIT_ARGS[@]}"}
  local g=explore_point_scene2_ratio1 f m q
  f=$(crit $g fixed); m=$(crit $g machine); q=$(crit $g machine-queue)
  ph() { calc '%.0f' "3600e9 / $1" | thou; }
  local cmd="cargo bench --bench explore$CA"
  row explore "Design points per hour per core, one \`explore\` point on scene2 ratio 1: fixed / machine / machine at the queue level" \
    "$cmd" "$(ph "$f") / $(ph "$m") / $(ph "$q")" "" "—"
  row explore "A machine point at the cycle level / at the queue level" "$cmd" \
    "$(calc '%.2f' "$m / $q")× ($(ms "$m") / $(ms "$q") ms)" "" "—"
}

part_reference() {
  rm -rf "$CRIT/reference_scene2"
  cargo bench --bench reference -- ${CRIT_ARGS[@]+"${CRIT_ARGS[@]}"}
  local g=reference_scene2 d p b n
  d=$(crit $g grid_dda); p=$(crit $g grid_dda_packet); b=$(crit $g brute_force)
  n=$(jq '.throughput.Elements' "$CRIT/$g/grid_dda/new/benchmark.json")
  local cmd="cargo bench --bench reference$CA"
  row reference "Float reference tracer, grid + 3D-DDA, one thread (scene2, 48,450 rays, cell 0.05)" \
    "$cmd" "$(calc '%.2f' "$n / $d * 1e3") M rays/s" "" "—"
  row reference "Its packet path / one-ray path; brute force / grid" "$cmd" \
    "$(calc '%.2f' "$p / $d")× / $(calc '%.1f' "$b / $d")×" "" "—"
}

part_fixed() {
  rm -rf "$CRIT/ray_patch_tests_scene2"
  cargo bench --bench fixed -- ${CRIT_ARGS[@]+"${CRIT_ARGS[@]}"}
  local g=ray_patch_tests_scene2 f x n
  f=$(crit $g float_reference); x=$(crit $g fixed_model)
  n=$(jq '.throughput.Elements' "$CRIT/$g/fixed_model/new/benchmark.json")
  row fixed "Fixed-point datapath / float test, the same ray–patch tests (scene2, brute force, F = 12)" \
    "cargo bench --bench fixed$CA" \
    "$(calc '%.2f' "$x / $f")× ($(calc '%.0f' "$n / $x * 1e3") / $(calc '%.0f' "$n / $f * 1e3") M tests/s)" "" "—"
}

part_tracer() {
  local m="Float tracer, packet path, one thread: Cornell room, 21,175 patches (sized grid, 48,450 rays)"
  local j; j=$("$EX/tracer_speed" cornell-55 --reps "$TRACER_REPS"); echo "$j"
  row tracer "$m" "target/release/examples/tracer_speed cornell-55 --reps $TRACER_REPS" \
    "$(echo "$j" | jq -r '[.rays / .packet_s, .rays / .one_s, .rays / .dda_only_s] | @tsv' |
      awk '{printf "%.2f M rays/s (one-ray %.2f, bare walk %.2f)", $1 / 1e6, $2 / 1e6, $3 / 1e6}')" "" "—"
}

part_embree() {
  local venv=${VENV:-/tmp/embree-venv}
  local cmd="ROUNDS=$EMBREE_ROUNDS bash ci/embree-ratio.sh"
  local names=("Cornell box, 18 patches" "Cornell room, 1,183 patches" "Cornell room, 21,175 patches")
  local keys=(cornell corpus-subdivided-cornell-13 corpus-subdivided-cornell-55)
  if ! "$venv/bin/python" -c "import embreex, numpy" 2> /dev/null; then
    for s in "${names[@]}"; do
      na embree "Float tracer (packet path) / Embree 4, one thread, same rays: $s" "$cmd" "≥ 1.0×" \
        "embreex not installed in $venv (\`bash ci/embree-ratio.sh\` installs it from PyPI)"
    done
    return
  fi
  ROUNDS=$EMBREE_ROUNDS VENV=$venv bash ci/embree-ratio.sh | tee "$W/embree.md"
  # | scene | patches (triangles) | rays | one-ray | packet | bare walk | Embree | packet / Embree | …
  local k; for k in 0 1 2; do
    local r p e
    r=$(awk -F' *[|] *' -v s="${keys[k]}" '$2 == s {print $9}' "$W/embree.md" | tr -dc '0-9.')
    p=$(awk -F' *[|] *' -v s="${keys[k]}" '$2 == s {print $6}' "$W/embree.md" | tr -dc '0-9.')
    e=$(awk -F' *[|] *' -v s="${keys[k]}" '$2 == s {print $8}' "$W/embree.md" | tr -dc '0-9.')
    [ -n "$r" ] || { echo "bench.sh: no row for ${keys[k]} in embree-ratio.sh's table" >&2; return 1; }
    row embree "Float tracer (packet path) / Embree 4, one thread, same rays: ${names[k]}" "$cmd" \
      "$r× ($p / $e M rays/s)" "$r" "≥ 1.0×"
  done
}

part_scale() {
  local d=$TARGET/bench-scenes; mkdir -p "$d"
  local k; for k in 12 27 53 120; do
    [ -f "$d/cornell-$k.json" ] ||
      "$BIN" scene gen corpus-subdivided-cornell --n "$k" -o "$d/cornell-$k.json" > /dev/null
  done
  local tests=() np=()
  for k in 12 27 120; do
    np+=("$(jq '.patches | length' "$d/cornell-$k.json" | sed -e ':a' -e 's/\B[0-9]\{3\}\>/,&/' -e 'ta')")
    tests+=("$("$BIN" reference --scene "$d/cornell-$k.json" --source 0 --rays "$SCALE_RAYS" \
      --directions random | grep -o '[0-9.]* patch tests per ray' | cut -d' ' -f1)")
  done
  local r; r=$(calc '%.2f' "${tests[2]} / ${tests[1]}")
  row scale "Patch tests per ray, grid sized to the scene: ${np[2]} against ${np[1]} patches (${np[0]} / ${np[1]} / ${np[2]}: ${tests[0]} / ${tests[1]} / ${tests[2]})" \
    "shellsim reference --scene cornell-K.json --source 0 --rays $SCALE_RAYS --directions random (K = 12, 27, 120)" \
    "$r×" "$r" "≤ 2×"
  # Float matrix CPU seconds at 1,008 and 19,663 patches: N^k.
  local cpu=() n=() rss=""
  for k in 12 53; do
    local s=$d/cornell-$k.json np rows
    np=$(jq '.patches | length' "$s"); n+=("$np")
    rows=$np; [ "$SCALE_ROWS" != all ] && [ "$np" -gt "$SCALE_ROWS" ] && rows=$SCALE_ROWS
    /usr/bin/time -o "$W/time" -f '%U %S %M' "$BIN" matrix --scene "$s" --model float \
      --sources "0..$rows" --out "$W/m.mtx" > /dev/null
    read -r u sy m < "$W/time"
    cpu+=("$(calc '%.4f' "($u + $sy) * $np / $rows")"); rss=$m
    rm -f "$W/m.mtx"
  done
  local x; x=$(calc '%.2f' "log(${cpu[1]} / ${cpu[0]}) / log(${n[1]} / ${n[0]})")
  local how="all rows"; [ "$SCALE_ROWS" != all ] && how="the first $SCALE_ROWS rows, scaled"
  row scale "Float matrix CPU ∝ N^k, sized grid, 1,008 → 19,663 patches ($how: $(calc '%.1f' "${cpu[0]}") → $(calc '%.1f' "${cpu[1]}") s)" \
    "shellsim matrix --scene cornell-K.json --model float --sources 0..ROWS --out m.mtx (K = 12, 53)" \
    "k = $x" "$x" "≤ 1.2"
  row scale "Peak RSS, float matrix at 19,663 patches ($how)" \
    "/usr/bin/time -f %M shellsim matrix --scene cornell-53.json --model float --out m.mtx" \
    "$((rss / 1024)) MiB" "" "—"
}

part_cosim() {
  local c=$TARGET/bench-rtl-cache
  local m1="Co-simulation, ICU at full rate / under back-pressure / DDA step, every stage register compared, F = 12"
  local cmd1="shellsim cosim --frac-bits 12 --vectors $COSIM_VECTORS"
  if command -v verilator > /dev/null; then
    local out; out=$(SHELLSIM_RTL_CACHE=$c "$BIN" cosim --frac-bits 12 --vectors "$COSIM_VECTORS"); echo "$out"
    local a b e
    a=$(echo "$out" | grep 'icu at full rate:' | grep -o '[0-9.]* M vectors/s' | cut -d' ' -f1)
    b=$(echo "$out" | grep 'icu back-pressure:' | grep -o '[0-9.]* M vectors/s' | cut -d' ' -f1)
    e=$(echo "$out" | grep 'dda:' | grep -o '[0-9.]* M vectors/s' | cut -d' ' -f1)
    row cosim "$m1" "$cmd1" "$a / $b / $e M vectors/s" "" "—"
  else
    na cosim "$m1" "$cmd1" "—" "verilator not installed"
  fi
}

part_synth() {
  local m2="Yosys synthesis of the ICU at F = 12, generic + ECP5, uncached (wall)"
  local cmd2="SHELLSIM_RTL_CACHE=\$(mktemp -d) shellsim rtl cost --frac-bits 12"
  if command -v yosys > /dev/null; then
    local t0 t1; t0=$(date +%s.%N)
    SHELLSIM_RTL_CACHE=$W/rtl "$BIN" rtl cost --frac-bits 12
    t1=$(date +%s.%N)
    row synth "$m2" "$cmd2" "$(calc '%.0f' "$t1 - $t0") s" "" "—"
  else
    na synth "$m2" "$cmd2" "—" "yosys not installed"
  fi
}

part_estimator() {
  "$EX/estimator_error" | tee "$W/est.csv"
  # case,directions,rays,seeds,rms,max_abs,binomial,rms_over_binomial,rms_times_n075
  # shellcheck disable=SC2016 # awk's fields
  local at='$3 == 1000000'
  local rnd mal rng
  span() { sort -g | sed -n '1p;$p' | paste -sd' ' | awk '{printf "%.2f–%.2f", $1, $2}'; }
  rnd=$(awk -F, "$at"' && $2 == "Random" {print $8}' "$W/est.csv" | span)
  mal=$(awk -F, "$at"' && $2 == "Malley" && $1 ~ /^point/ {print $9}' "$W/est.csv" | span)
  rng=$(awk -F, "$at"' && $2 == "Rings" && $1 ~ /^area/ {print $8}' "$W/est.csv" | span)
  row estimator "Form-factor error against the analytic value, unit cube, N = 10⁶: random directions RMS / binomial σ; Malley from a point RMS·N^¾; rings from an area RMS / binomial σ" \
    "cargo run --release --example estimator_error" "$rnd; $mal; $rng" "" "—"
}

# Build first (not a part: its time is printed apart).
declare -A SECS
t0=$(date +%s)
{
  cargo build --release --bin shellsim --example tracer_speed --example estimator_error
  cargo bench --no-run
} > "$LOGS/build.log" 2>&1 || { tail -30 "$LOGS/build.log" >&2; exit 1; }
SECS[build]=$(( $(date +%s) - t0 ))

for p in "${RUN[@]}"; do
  echo "bench.sh: $p …" >&2
  t0=$(date +%s)
  set +e
  ( set -euo pipefail; "part_$p" ) > "$LOGS/$p.log" 2>&1
  rc=$?
  set -e
  SECS[$p]=$(( $(date +%s) - t0 ))
  if [ $rc != 0 ]; then
    echo "bench.sh: part $p failed (exit $rc), log $LOGS/$p.log:" >&2; tail -5 "$LOGS/$p.log" >&2
    rm -f "$W/$p.rows"
    row "$p" "(every row of this part)" "bash ci/bench.sh --only $p" "failed: see $LOGS/$p.log" "" "—"
  fi
done

# The table: the rows of the parts run now, the old rows of the others, in PARTS order.
{
  echo "| part | measure | command | now | target | met | date |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  old=$(sed -n "/^$BEGIN\$/,/^$END\$/p" "$FILE")
  for p in "${PARTS[@]}"; do
    if [ -f "$W/$p.rows" ]; then cat "$W/$p.rows"
    else echo "$old" | grep -F "| \`$p\` |" || true
    fi
  done
} > "$W/table.md"
new=$(mktemp "$FILE.XXXXXX")
{
  sed -n "1,/^$BEGIN\$/p" "$FILE"
  cat "$W/table.md"
  sed -n "/^$END\$/,\$p" "$FILE"
} > "$new"
chmod 644 "$new"
mv "$new" "$FILE"

{
  echo "bench.sh: wall seconds per part ($([ $QUICK = 1 ] && echo quick || echo full) mode):"
  total=0
  for p in build "${RUN[@]}"; do printf '  %-10s %5d s\n' "$p" "${SECS[$p]}"; total=$((total + SECS[$p])); done
  printf '  %-10s %5d s\n' total "$total"
} >&2

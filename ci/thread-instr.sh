#!/usr/bin/env bash
# thread-instr.sh BIN [RUN ARGS...]: instructions per thread of one `BIN run` under callgrind
# (valgrind --separate-threads=yes), with the inclusive count of `Machine::run` on the
# simulation thread (an inlined callee's inclusive count, such as the probe's, can differ
# between two runs of the same binary as callgrind attributes tail calls; threads' totals
# and `Machine::run` do not). Instruction counts do not see kernel time or the
# two cores' contention, but they are stable from run to run where wall times on these
# machines move by 15 % or more: compare them across changes and sessions (BENCHMARKS.md, row `instr`).
# Default run: scene2 at Hi_Low_Ratio 10 with a VCD. Needs valgrind (callgrind_annotate).
# Example: bash ci/thread-instr.sh target/release/shellsim --ratio 10 --wave /tmp/x.fst
set -euo pipefail
BIN=$(readlink -f "$1"); shift
cd "$(dirname "$0")/.."
SCENE=$(readlink -f scenes/scene2.json)
[ $# -gt 0 ] || set -- --ratio 10 --vcd "${TMPDIR:-/tmp}/thread-instr.vcd"
DIR=$(mktemp -d "${TMPDIR:-/tmp}/thread-instr.XXXXXX")
trap 'rm -rf "$DIR"' EXIT
if ! (cd "$DIR" && valgrind --tool=callgrind --separate-threads=yes \
    "$BIN" run --scene "$SCENE" --json "$DIR/run.json" "$@" > /dev/null 2> "$DIR/valgrind.log"); then
    tail -20 "$DIR/valgrind.log" >&2
    exit 1
fi
# (awk reads to the end: callgrind_annotate cut off by a closed pipe fails the pipeline)
total() {
    callgrind_annotate --show-percs=no "$1" 2>/dev/null |
        awk '/PROGRAM TOTALS/ && !n {gsub(",", "", $1); n = $1} END {print n}'
}
incl() {
    callgrind_annotate --show-percs=no --inclusive=yes "$1" 2>/dev/null |
        awk -v pat="$2" '$0 ~ pat && $1 ~ /^[0-9,]+$/ && !n {gsub(",", "", $1); n = $1} END {print n}'
}
printf '%-8s %15s  %s\n' thread instructions 'of which'
for f in "$DIR"/callgrind.out.*-*; do
    n=$(total "$f"); [ "${n:-0}" -gt 1000000 ] || continue
    # (`Machine::run` is `run_reporting` with no report since the progress line)
    run=$(incl "$f" 'machine::Machine::run(_reporting)? \\[')
    extra=${run:+Machine::run $run}
    printf '%-8s %15s  %s\n' "${f##*.out.*-}" "$n" "$extra"
done

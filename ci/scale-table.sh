#!/usr/bin/env bash
# Issue 31's scale table: the Cornell room subdivided to 100–100,000 patches
# (`shellsim scene gen corpus-subdivided-cornell --n K`, K = 4, 12, 27, 53, 120), each
# command timed (CPU seconds = user + system, peak RSS) on the paper's grid (`--cell 0.05`,
# the scene's extent / 20, the only grid before issue 31) and on the grid sized to the
# scene (the default now). Large matrices are timed on a contiguous block of rows and
# scaled to all rows (the `rows` column says how many ran).
#
#   cargo build --release && bash ci/scale-table.sh > docs/scale/scale.csv
#   python3 ci/scale-table.py docs/scale/scale.csv > docs/scale/scale.md
#
# BIN (default target/release/shellsim); OUT (default out/scale) holds the scenes and outputs.
set -euo pipefail
bin=${BIN:-target/release/shellsim}
out=${OUT:-out/scale}
mkdir -p "$out"
echo "patches,command,grid,rows,cpu_s,peak_rss_kb,tests_per_ray,cells_per_ray"
for k in 4 12 27 53 120; do
  scene="$out/cornell-$k.json"
  [ -f "$scene" ] || "$bin" scene gen corpus-subdivided-cornell --n "$k" -o "$scene" >/dev/null
  n=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))['patches']))" "$scene")
  for grid in paper sized; do
    cell=(); [ "$grid" = paper ] && cell=(--cell 0.05)
    run() { # command rows args...
      local cmd=$1 rows=$2; shift 2
      if ! /usr/bin/time -o "$out/time" -f "%U %S %M" "$bin" "$@" >"$out/last.out" 2>"$out/last.err"; then
        echo "scale-table: $bin $* failed:" >&2; cat "$out/last.err" >&2; exit 1
      fi
      read -r u s m <"$out/time"
      local tests="" cells=""
      if [ "$cmd" = reference ]; then
        tests=$(grep -o '[0-9.]* patch tests per ray' "$out/last.out" | cut -d' ' -f1)
        cells=$(grep -o '[0-9.]* cells and' "$out/last.out" | cut -d' ' -f1)
      fi
      echo "$n,$cmd,$grid,$rows,$(python3 -c "print(round($u+$s,2))"),$m,$tests,$cells"
    }
    run reference 1 reference --scene "$scene" --source 0 --rays 1000000 --directions random "${cell[@]}"
    # Rows: every row up to 20k patches for float and fixed; a block for the rest.
    full=$n; [ "$n" -gt 20000 ] && full=10000
    run "matrix float" "$full" matrix --scene "$scene" --model float --sources "0..$full" --out "$out/m.mtx" "${cell[@]}"
    run "matrix fixed" "$full" matrix --scene "$scene" --model fixed --sources "0..$full" --out "$out/m.mtx" "${cell[@]}"
    mrows=$n; [ "$n" -gt 1100 ] && mrows=250
    [ "$n" -le 20000 ] && run "matrix machine" "$mrows" matrix --scene "$scene" --model machine --sources "0..$mrows" --out "$out/m.mtx" "${cell[@]}"
    [ "$n" -le 20000 ] && run radiosity "$n" radiosity --scene "$scene" --model float --out "$out/rad" "${cell[@]}"
    rm -f "$out/m.mtx"
  done
done

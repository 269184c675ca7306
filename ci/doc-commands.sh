#!/usr/bin/env bash
# Every `shellsim …` command in the fenced code blocks of README.md and docs/manual/*.md
# names a subcommand that exists and only flags that subcommand accepts; the files its
# --scene, --space, --hw and --matrix name (when they are repository paths) exist; every
# relative link of those files points to a file that exists.
#
#   bash ci/doc-commands.sh [SHELLSIM_BINARY]     (default target/release/shellsim)
#
# For each command line (continuation lines joined; `cargo run --release [-q] -- ARGS`
# counts as `shellsim ARGS`) it walks the subcommand path through `shellsim … --help`'s
# "Commands:" lists, then checks every `--flag` and `-x` of the line against that
# subcommand's --help text (aliases appear there as `[alias: --x]`). Exit 1 naming the
# file, the line and the flag or subcommand on the first kind of mismatch (all are listed).
set -euo pipefail
cd "$(dirname "$0")/.."
bin="${1:-target/release/shellsim}"
if [ ! -x "$bin" ]; then
  cargo build --release -q
fi
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"

declare -A helps
help_of() { # the --help text of a subcommand path ("" = the top level)
  local key=":$1"
  if [ -z "${helps[$key]+x}" ]; then
    # shellcheck disable=SC2086
    helps[$key]="$("$bin" $1 --help 2>&1 || true)"
  fi
  printf '%s' "${helps[$key]}"
}
commands_of() { # the subcommands a help text lists
  awk '/^Commands:/{f=1;next} /^[^ ]/{f=0} f && /^  [a-z]/{print $1}' <<<"$1"
}

fail=0
checked=0
links=0
files=(README.md docs/manual/*.md)
while IFS=$'\t' read -r file line cmd; do
  checked=$((checked + 1))
  read -ra tok <<<"$cmd"
  # the subcommand path
  path=""
  i=1
  while [ $i -lt ${#tok[@]} ]; do
    t="${tok[$i]}"
    [[ "$t" == -* ]] && break
    subs="$(commands_of "$(help_of "$path")")"
    [ -z "$subs" ] && break
    if grep -qxF -- "$t" <<<"$subs"; then
      path="${path:+$path }$t"
      i=$((i + 1))
    else
      # a positional argument is fine only where the usage takes one besides <COMMAND>
      if ! grep -E '^ *(Usage:|  ) *[^ ]+.*<[A-Z_]+>' <<<"$(help_of "$path")" | grep -qv '<COMMAND>'; then
        echo "$file:$line: \`shellsim${path:+ $path}\` has no subcommand '$t': $cmd" >&2
        fail=1
        path="-"
      fi
      break
    fi
  done
  [ "$path" = "-" ] && continue
  help="$(help_of "$path")"
  if ! grep -q '^Usage:' <<<"$help"; then
    echo "$file:$line: \`shellsim${path:+ $path} --help\` fails: $cmd" >&2
    fail=1
    continue
  fi
  # the flags, and the input files they name
  prev=""
  for t in "${tok[@]:1}"; do
    flag=""
    if [[ "$t" =~ ^(--[a-z][a-z0-9-]*)(=.*)?$ ]]; then
      flag="${BASH_REMATCH[1]}"
    elif [[ "$t" =~ ^-[a-zA-Z]$ ]]; then
      flag="$t"
    fi
    if [ -n "$flag" ] && ! grep -qE -- "(^|[^a-z0-9-])${flag}([^a-z0-9-]|\$)" <<<"$help"; then
      echo "$file:$line: \`shellsim${path:+ $path}\` has no flag $flag: $cmd" >&2
      fail=1
    fi
    case "$prev" in
      --scene | --space | --hw | --matrix)
        if [[ "$t" == */* && "$t" != /* && "$t" != *[A-Z]* && "$t" != out/* && ! -e "$t" ]]; then
          echo "$file:$line: $prev $t: no such file in the repository: $cmd" >&2
          fail=1
        fi
        ;;
    esac
    prev="$t"
  done
done < <(
  awk '
    FNR == 1 { fence = 0; cont = "" }
    /^[ \t]*```/ { fence = !fence; cont = ""; next }
    !fence { next }
    {
      s = $0
      if (cont == "") start = FNR
      # a trailing backslash continues the command on the next line
      if (s ~ /\\[ \t]*$/) { sub(/\\[ \t]*$/, "", s); cont = cont s " "; next }
      s = cont s; cont = ""
      sub(/[ \t]+#.*$/, "", s)                     # a comment after the command
      sub(/^cargo run --release( -q)? -- /, "shellsim ", s)
      n = index(s, "shellsim ")
      if (s ~ /^[ \t]*#/ || n == 0) next
      pre = substr(s, 1, n - 1)
      # `shellsim` as the command (at the start, after VAR=… or a job runner), not in a path
      if (pre != "" && pre !~ /[ \t]$/) next
      print FILENAME "\t" start "\t" substr(s, n)
    }' "${files[@]}"
)
# every relative link of these files points to a file that exists
for f in "${files[@]}"; do
  dir="$(dirname "$f")"
  while IFS=$'\t' read -r line target; do
    target="${target%%#*}"
    [ -z "$target" ] && continue
    links=$((links + 1))
    if [ ! -e "$dir/$target" ]; then
      echo "$f:$line: the link ($target) points to nothing" >&2
      fail=1
    fi
  done < <(awk '
    /^[ \t]*```/ { fence = !fence; next }
    fence { next }
    {
      s = $0
      while (match(s, /\]\([^)[:space:]]+\)/)) {
        t = substr(s, RSTART + 2, RLENGTH - 3)
        if (t !~ /^[a-z]+:/) print FNR "\t" t
        s = substr(s, RSTART + RLENGTH)
      }
    }' "$f")
done
if [ "$checked" -eq 0 ]; then
  echo "doc-commands: no shellsim command found in ${files[*]}" >&2
  exit 1
fi
if [ "$fail" -ne 0 ]; then
  exit 1
fi
echo "doc-commands: $checked shellsim commands in ${#files[@]} files: every subcommand and flag exists; all $links relative links resolve"

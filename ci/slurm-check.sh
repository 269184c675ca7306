#!/usr/bin/env bash
# CI: a real one-node Slurm cluster on this host. Installs Debian's slurm-wlm and munge if
# missing, starts munged, slurmctld and slurmd from a private configuration under a temporary
# directory, submits the `shellsim explore slurm` job array and its afterok merge job, and
# checks the merged result is byte-identical to a local unsharded `shellsim explore run`.
# It stops exactly the daemons it started (by pid) and removes its temporary directory.
#
#   ci/slurm-check.sh           the sweep check (needs target/release/shellsim)
#   ci/slurm-check.sh --smoke   only the cluster: a 3-task array job plus an afterok job
#   ci/slurm-check.sh --study FILE
#                               a study on the cluster: the array job FILE (an .sbatch run
#                               from the repository) and, afterok, `bash FILE merge`
#                               (e.g. ci/corpus-study.sbatch; raise SLURM_CHECK_TIMEOUT)
#
# Environment: CARGO_TARGET_DIR (where the release binary is), SLURM_CHECK_TIMEOUT (seconds
# to wait for the jobs, default 300), SLURM_CHECK_PORT (slurmctld's port, default 16817;
# slurmd takes the next one), SLURM_CHECK_KEEP=1 (keep the temporary directory).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
mode=sweep
case "${1:-}" in
  "") ;;
  --smoke) mode=smoke ;;
  --study)
    mode=study
    study=${2:?usage: $0 --study FILE}
    [ -f "$study" ] || { echo "slurm-check: $study: no such file" >&2; exit 2; }
    ;;
  *) echo "usage: $0 [--smoke | --study FILE]" >&2; exit 2 ;;
esac
# The daemons run as root (SlurmUser=root): when not root, run the whole script under sudo.
if [ "$(id -u)" -ne 0 ]; then
  exec sudo --preserve-env=CARGO_TARGET_DIR,SLURM_CHECK_TIMEOUT,SLURM_CHECK_PORT,SLURM_CHECK_KEEP,TMPDIR \
    bash "$repo/ci/slurm-check.sh" "$@"
fi
# Slurm's input variables from the calling environment (say, a CI job that is itself a
# Slurm job) would shard the local run or redirect sbatch: drop them.
for v in $(compgen -e | grep -E '^(SLURM_|SBATCH_|SQUEUE_|SINFO_)' | grep -v '^SLURM_CHECK_' || true); do
  unset "$v"
done
start=$(date +%s)
timeout_s=${SLURM_CHECK_TIMEOUT:-300}
port=${SLURM_CHECK_PORT:-16817}

say() { echo "slurm-check: $*"; }

# 1. Install what is missing.
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
  || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
  say "installing slurm-wlm and munge"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi
installed=$(date +%s)

bin="${CARGO_TARGET_DIR:-$repo/target}/release/shellsim"
case "$bin" in /*) ;; *) bin="$repo/$bin" ;; esac
if [ "$mode" = sweep ] && [ ! -x "$bin" ]; then
  echo "slurm-check: $bin does not exist: build it first (cargo build --release)" >&2
  exit 1
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/slurm-check.XXXXXX")
chmod 755 "$tmp"
pids=()
cleanup() {
  local rc=$?
  set +e
  if [ "${#pids[@]}" -gt 0 ] && command -v squeue >/dev/null && [ -n "${SLURM_CONF:-}" ]; then
    # Our private cluster holds only our jobs: cancel whatever is left before the daemons go.
    local left
    mapfile -t left < <(timeout 5 squeue -h -o %A 2>/dev/null | sort -u)
    [ "${#left[@]}" -gt 0 ] && timeout 5 scancel "${left[@]}" 2>/dev/null && sleep 1
  fi
  # In reverse order (slurmd, slurmctld, munged), each given 5 s before it is killed.
  local i pid
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    pid=${pids[$i]}
    kill "$pid" 2>/dev/null
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
  done
  if [ "${SLURM_CHECK_KEEP:-0}" = 1 ]; then say "kept $tmp"; else rm -rf "$tmp"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# The tail of each daemon's log (or of its stderr, when it died before opening its log).
logs() {
  local d f
  for d in munged slurmctld slurmd; do
    f="$tmp/log/$d.log"
    [ -s "$f" ] || f="$tmp/log/$d.out"
    [ -s "$f" ] || continue
    echo "---- $d: ${f#"$tmp"/} (last 30 lines)"
    tail -n 30 "$f"
  done
  # The jobs' own output (sbatch --output files) under the sweep or smoke directory.
  find "$tmp/sweep" "$tmp/smoke" -name '*.out' -size +0 2>/dev/null | sort | while read -r f; do
    echo "---- job output: ${f#"$tmp"/} (last 15 lines)"
    tail -n 15 "$f"
  done
}
fail() {
  echo "slurm-check: FAILED: $*" >&2
  logs >&2
  exit 1
}

# 2. Munge with a private key, socket and log; Slurm with a private configuration.
mkdir -p "$tmp"/munge "$tmp"/log "$tmp"/state "$tmp"/spool "$tmp"/run
mungekey --create --keyfile="$tmp/munge/munge.key" 2>"$tmp/log/mungekey.log" \
  || dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 600 "$tmp/munge/munge.key"
socket="$tmp/munge/munge.socket"
munged --force --foreground --socket="$socket" --key-file="$tmp/munge/munge.key" \
  --pid-file="$tmp/munge/munged.pid" --seed-file="$tmp/munge/munged.seed" \
  >"$tmp/log/munged.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || fail "munged did not create its socket $socket"
kill -0 "${pids[0]}" 2>/dev/null || fail "munged exited"
echo test | munge --socket="$socket" | unmunge --socket="$socket" >/dev/null \
  || fail "munge cannot encode and decode a credential through $socket"

# `slurmd -C` prints this host's node line (and an UpTime line that is not configuration).
node=$(slurmd -C | grep '^NodeName=') || fail "slurmd -C printed no NodeName line"
host=${node%% *}
host=${host#NodeName=}
export SLURM_CONF="$tmp/slurm.conf"
cat >"$SLURM_CONF" <<EOF
# One-node cluster for ci/slurm-check.sh: no systemd, no cgroups, daemons as root.
ClusterName=shellsimci
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
MpiDefault=none
SwitchType=switch/none
ProctrackType=proctrack/pgid
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
SchedulerParameters=batch_sched_delay=0
MailProg=/bin/true
ReturnToService=2
MinJobAge=600
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool/slurmd-%n
SlurmctldPidFile=$tmp/run/slurmctld.pid
SlurmdPidFile=$tmp/run/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld -D -c -f "$SLURM_CONF" >"$tmp/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N "$host" >"$tmp/log/slurmd.out" 2>&1 &
pids+=($!)

# 3. Wait for the node to be idle.
up=""
for _ in $(seq 60); do
  for i in 1 2; do kill -0 "${pids[$i]}" 2>/dev/null || fail "$([ "$i" = 1 ] && echo slurmctld || echo slurmd) exited"; done
  state=$(sinfo -h -n "$host" -o %T 2>/dev/null || true)
  [ "$state" = idle ] && { up=1; break; }
  sleep 0.5
done
[ -n "$up" ] || fail "node $host not idle after 30 s (sinfo says: '${state:-nothing}')"
ready=$(date +%s)
say "cluster up in $((ready - installed)) s: $(sinfo -h -o '%P %D %T %C')"

# Wait until no job of our cluster is pending or running; fail on any job that did not complete.
wait_jobs() {
  local deadline=$(($(date +%s) + timeout_s)) list bad node_state
  while :; do
    list=$(squeue -h -r -t all -o '%i %T %r') || fail "squeue failed"
    bad=$(echo "$list" | awk '$2 !~ /^(PENDING|CONFIGURING|RUNNING|COMPLETING|COMPLETED)$/ || $3 ~ /DependencyNeverSatisfied/')
    [ -z "$bad" ] || fail "a job did not complete:"$'\n'"$list"
    # A job that slurmd cannot launch ends COMPLETED and drains the node: catch that here.
    node_state=$(sinfo -h -n "$host" -o %T) || fail "sinfo failed"
    case "$node_state" in
      idle | mixed | allocated | completing) ;;
      *) fail "node $host is $node_state ($(sinfo -h -R -o %E)); jobs:"$'\n'"$list" ;;
    esac
    echo "$list" | awk '$2 != "COMPLETED"' | grep -q . || break
    [ "$(date +%s)" -lt "$deadline" ] || fail "jobs not done after $timeout_s s:"$'\n'"$list"
    sleep 1
  done
  [ -n "$list" ] || fail "no job was submitted"
  echo "$list" | awk '{ print "  " $0 }'
}

if [ "$mode" = smoke ]; then
  # 4a. A 3-task array job writing one file per task, and an afterok job joining them.
  mkdir -p "$tmp/smoke"
  cd "$tmp/smoke"
  cat >array.sbatch <<'EOF'
#!/bin/bash
#SBATCH --array=0-2 --output=task-%a.out
echo "task $SLURM_ARRAY_TASK_ID of $SLURM_ARRAY_TASK_COUNT" >"part-$SLURM_ARRAY_TASK_ID"
EOF
  cat >join.sbatch <<'EOF'
#!/bin/bash
#SBATCH --output=join.out
cat part-0 part-1 part-2 >joined
EOF
  array=$(sbatch --parsable array.sbatch) || fail "sbatch of the array job failed"
  sbatch --parsable --dependency="afterok:$array" join.sbatch >/dev/null || fail "sbatch of the join job failed"
  wait_jobs
  printf 'task %d of 3\n' 0 1 2 | cmp - joined || fail "the join job's output is wrong"
  say "smoke passed: array job $array and its afterok job, $(($(date +%s) - start)) s in all"
  exit 0
fi

if [ "$mode" = study ]; then
  # 4b. A study's array job from the repository, then its merge as an afterok job.
  array=$(sbatch --parsable --chdir="$repo" "$study") || fail "sbatch of $study failed"
  sbatch --parsable --chdir="$repo" --dependency="afterok:$array" --output="$tmp/log/merge.out" \
    --wrap "bash $study merge" >/dev/null || fail "sbatch of the merge job failed"
  wait_jobs
  cat "$tmp/log/merge.out"
  say "study $study done: array job $array and its merge, $(($(date +%s) - start)) s in all"
  exit 0
fi

# 4. The sweep on Slurm, then the same sweep locally, compared byte for byte.
space="$repo/docs/explore/ci.toml"
"$bin" explore slurm --space "$space" --tasks 3 --out "$tmp/sweep" --bin "$bin" \
  || fail "shellsim explore slurm failed"
(cd "$tmp/sweep" && bash "$tmp/sweep/submit.sh") || fail "submit.sh failed"
wait_jobs
swept=$(date +%s)
"$bin" explore run --space "$space" --out "$tmp/local" >"$tmp/log/local.out" 2>&1 \
  || fail "the local explore run failed: $(tail -n 20 "$tmp/log/local.out")"
for f in points.csv points.json front.csv; do
  [ -f "$tmp/sweep/merged/$f" ] || fail "the merge job wrote no merged/$f"
  cmp "$tmp/sweep/merged/$f" "$tmp/local/$f" || fail "merged/$f differs from the unsharded run"
done
end=$(date +%s)
say "passed: merged shards identical to the unsharded run (points.csv, points.json, front.csv)"
say "time: $((end - start)) s in all, $((end - installed)) s after installation" \
  "(cluster $((ready - installed)) s, Slurm sweep $((swept - ready)) s, local run $((end - swept)) s)"

#!/bin/bash
# guest_test.sh OUT -- runs inside deb_qemu.sh's guest (systemd, the .deb installed), as a oneshot
# unit after indurop-agent.service; writes its findings to OUT (the second serial port):
#   RESULT key=value ...   what was found or measured (times in ms, from this guest's clock)
#   FAIL what              a check that did not hold
#   LOG ...                journal lines, for the record
#   RESULT done            the last line
# The checks: both units active; the default set stored and activated on first boot; irpd's user,
# capabilities and SCHED_FIFO threads; irpd killed (SIGKILL) -> restarted by systemd, running the
# active set again; irpd stopped (SIGSTOP) -> killed by the watchdog ("Watchdog timeout" in the
# journal) and restarted; the agent answering with irpd's status after each; a managed restart
# through the agent (same main pid, no systemd restart, the user and capabilities kept).
exec >"${1:-/dev/stdout}" 2>&1
# The agent serves HTTPS on 8443 with the certificate the package made (docs/administration.md).
api=https://127.0.0.1:8443/api/v1
data=/var/lib/indurop
ca=(--cacert "$data/tls/cert.pem")
now_ms() { date +%s%3N; }
fail() { echo "FAIL $*"; }
# wait_until SECONDS COMMAND...: runs COMMAND every 20 ms until it succeeds; 1 when it never did.
wait_until() {
  local end=$(( $(date +%s) + $1 )); shift
  until "$@" >/dev/null 2>&1; do [ "$(date +%s)" -lt $end ] || return 1; sleep 0.02; done
}
main_pid() { systemctl show -p MainPID --value irpd.service; }
active_set() { readlink "$data/active" | sed -n 's#^sets/\([0-9a-f]*\)/files$#\1#p'; }
# api_get SECONDS PATH [CURL OPTIONS...]: the agent's answer to GET $api/PATH as the admin.
api_get() { local limit=$1 path=$2; shift 2; curl -s -m "$limit" "${ca[@]}" "$@" -H "Authorization: Bearer $(cat $data/admin-token)" "$api/$path"; }
# irpd_set: the set id in the agent's GET /status (2 s limit); each answer is logged to $probes
# (time ms, HTTP status or 000 for none, seconds taken, set id) for the failure report.
probes=/tmp/guest-status-probes
irpd_set() {
  local out status set
  out=$(api_get 2 status -w '\n%{http_code} %{time_total}')
  status=${out##*$'\n'}
  # the top level's set_id: after a crash, status.last_crash has one too (the crashed run's)
  set=$(printf '%s' "${out%$'\n'*}" | python3 -S -c 'import json, sys; print(json.load(sys.stdin).get("set_id") or "")' 2>/dev/null)
  echo "$(now_ms) $status ${set:--}" >> $probes
  [ "${status%% *}" = 200 ] && [ -n "$set" ] && echo "$set"
}
# probe_report T0: the probes since T0 (ms), runs of the same answer collapsed: "from+ms to+ms
# count status set max-seconds".
probe_report() {
  awk -v t0="$1" '$1 >= t0 { key = $2 " " $4
    if (key != last) { if (n) print "LOG probes +" a - t0 " +" b - t0 " " n " " last " max " m; a = $1; n = 0; m = 0; last = key }
    b = $1; n++; if ($3 > m) m = $3 }
    END { if (n) print "LOG probes +" a - t0 " +" b - t0 " " n " " last " max " m }' $probes
}
irpd_back() {   # a new main pid, the unit active (READY=1 received)
  local pid; pid=$(main_pid)
  [ "$pid" != "$1" ] && [ "$pid" != 0 ] && [ "$(systemctl show -p ActiveState --value irpd.service)" = active ]
}
runs_active_set() { [ -n "$(active_set)" ] && [ "$(irpd_set)" = "$(active_set)" ]; }

wait_until 180 curl -sf -m 2 "${ca[@]}" "$api/health" || fail "the agent did not answer $api/health within 180 s of its start"
wait_until 90 test -e "$data/active.json" || fail "the default set was not activated (no $data/active.json)"
wait_until 30 runs_active_set || fail "irpd does not run the active set"
echo "RESULT irpd=$(systemctl is-active irpd.service) agent=$(systemctl is-active indurop-agent.service) enabled=$(systemctl is-enabled irpd.service),$(systemctl is-enabled indurop-agent.service)"
echo "RESULT active_set=$(active_set) irpd_set=$(irpd_set) default=$(grep -o '"action": *"[a-z]*"' $data/active.json | head -1)"
pid=$(main_pid)
echo "RESULT irpd_uid=$(awk '/^Uid:/ {print $2}' /proc/$pid/status) irpd_gid=$(awk '/^Gid:/ {print $2}' /proc/$pid/status) indurop_uid=$(id -u indurop) cap_eff=$(awk '/^CapEff:/ {print $2}' /proc/$pid/status)"
[ "$(awk '/^Uid:/ {print $2}' /proc/$pid/status)" = "$(id -u indurop)" ] || fail "irpd did not switch to the user indurop"
[ "$(awk '/^CapEff:/ {print $2}' /proc/$pid/status)" = 0000000000804000 ] || fail "irpd's capabilities are not CAP_SYS_NICE and CAP_IPC_LOCK alone"
echo "RESULT irpd_fifo_threads=$(ps -L -o cls= -p "$pid" | grep -c FF) socket=$(stat -c '%U:%G:%a' /run/indurop/irpd.sock) agent_user=$(ps -o user= -p "$(systemctl show -p MainPID --value indurop-agent.service)")"
echo "RESULT cpus irpd=$(taskset -pc "$pid" | sed 's/.*: //') agent=$(taskset -pc "$(systemctl show -p MainPID --value indurop-agent.service)" | sed 's/.*: //')"

# SIGKILL: systemd restarts irpd (Restart=on-failure, RestartSec), irpd-start runs the active set.
pid=$(main_pid); t0=$(now_ms)
kill -KILL "$pid"
if wait_until 60 irpd_back "$pid"; then
  t1=$(now_ms)
  wait_until 30 runs_active_set || fail "after SIGKILL irpd does not run the active set"
  t2=$(now_ms)
  echo "RESULT sigkill_restart_ms=$((t1 - t0)) sigkill_active_set_via_agent_ms=$((t2 - t0)) set=$(irpd_set)"
else
  fail "irpd was not restarted within 60 s of SIGKILL"
fi

# SIGSTOP: the RT loop makes no progress, no WATCHDOG=1; systemd kills it after WatchdogSec.
sleep 3
pid=$(main_pid); t0=$(now_ms); since=$(date +%s)
kill -STOP "$pid"
if wait_until 60 irpd_back "$pid"; then
  t1=$(now_ms)
  if ! wait_until 90 runs_active_set; then
    fail "after the watchdog irpd does not run the active set"
    # the agent's side of it: its events (restores, irpd lost and connected) and audit, for the record
    api_get 10 "events?since=0&agent_since=0&limit=60" | sed 's/^/LOG events /'
    tail -n 20 "$data/audit.jsonl" | sed 's/^/LOG audit /'
    ps -eo pid,pcpu,cls,rtprio,nlwp,etimes,comm --sort=-pcpu | head -12 | sed 's/^/LOG ps /'
  fi
  t2=$(now_ms)
  probe_report "$t0"
  line=$(journalctl -u irpd.service -o short-unix --since "@$since" --no-pager | grep -m1 "Watchdog timeout")
  [ -n "$line" ] || fail "no 'Watchdog timeout' journal line"
  wd=$(echo "$line" | awk '{split($1, t, "."); print t[1] substr(t[2] "000", 1, 3)}')   # ms, no float
  echo "RESULT sigstop_watchdog_detect_ms=$((wd - t0)) sigstop_restart_ms=$((t1 - t0)) sigstop_active_set_via_agent_ms=$((t2 - t0)) set=$(irpd_set)"
  # irpd's crash record names systemd's watchdog (SIGABRT from pid 1), not a crash of its own,
  # and blames no module: no dispatcher was stalled, the whole process was stopped
  cause=$(api_get 10 status |
    python3 -S -c 'import json, sys; c = json.load(sys.stdin).get("last_crash") or {}; print(c.get("cause"), c.get("sender_pid"), c.get("module"))')
  echo "RESULT sigstop_last_crash_cause_sender_module=${cause// /,}"
  [ "$cause" = "watchdog 1 None" ] || fail "irpd's last crash does not name systemd's watchdog alone: $cause"
else
  fail "irpd was not restarted within 60 s of SIGSTOP (watchdog)"
fi
# A managed restart through the agent (activate with mode restart): irpd executes itself again under
# systemd, the same main pid, no restart counted by systemd, still the user indurop with its two
# capabilities (ambient across the exec), and the downtime reported.
pid=$(main_pid); restarts=$(systemctl show -p NRestarts --value irpd.service)
answer=$(curl -s -m 60 "${ca[@]}" -X POST -H "Authorization: Bearer $(cat $data/admin-token)" -H 'Content-Type: application/json' \
  -d '{"mode": "restart"}' "$api/sets/$(active_set)/activate")
downtime=$(printf '%s' "$answer" | python3 -S -c 'import json, sys; print(json.load(sys.stdin).get("downtime_ns"))' 2>/dev/null)
wait_until 30 runs_active_set || fail "irpd does not run the active set after a managed restart"
echo "RESULT managed_restart_downtime_ns=$downtime pid_same=$([ "$(main_pid)" = "$pid" ] && echo yes || echo no) nrestarts_same=$([ "$(systemctl show -p NRestarts --value irpd.service)" = "$restarts" ] && echo yes || echo no) cap_eff=$(awk '/^CapEff:/ {print $2}' /proc/$pid/status) state=$(systemctl is-active irpd.service)"
[ "$(main_pid)" = "$pid" ] || fail "a managed restart changed irpd's main pid ($pid -> $(main_pid)): $answer"
[ "$(systemctl show -p NRestarts --value irpd.service)" = "$restarts" ] || fail "systemd counted the managed restart as a restart"
[ "$(awk '/^CapEff:/ {print $2}' /proc/$pid/status)" = 0000000000804000 ] || fail "after a managed restart irpd's capabilities are not CAP_SYS_NICE and CAP_IPC_LOCK"
[ "$(awk '/^Uid:/ {print $2}' /proc/$pid/status)" = "$(id -u indurop)" ] || fail "after a managed restart irpd is not the user indurop"
case "$downtime" in ''|None|0) fail "the managed restart reported no downtime: $answer" ;; esac
echo "RESULT nrestarts=$(systemctl show -p NRestarts --value irpd.service) agent_pid_unchanged_state=$(systemctl is-active indurop-agent.service)"
journalctl -u irpd.service -u indurop-agent.service --no-pager -o short-monotonic | tail -40 | sed 's/^/LOG /'
echo "RESULT done"

#!/usr/bin/env bash
# demo.sh -- installs what is missing, builds, and starts the default demo: irpd running the
# set activated last through the agent, or the PLC + robot cell (the paper's §4, its drives
# simulated on Modbus TCP by indurop-drivesim) with its PLC program in Structured Text
# (config/sets/plc-robot-st) the first time, with its control
# socket, indurop-agent on http://127.0.0.1:8080/api/v1 beside it, the DDS bridge on loopback
# (docs/dds.md) and the OPC UA server on opc.tcp://127.0.0.1:4840/ (docs/opcua.md).  Ctrl-C stops them.  Extra arguments
# go to irpd, e.g. `bash packaging/demo.sh --duration 10 --stats-json /tmp/stats.json` (the
# agent stops when irpd does).  INDUROP_PORT and INDUROP_DATA change the port and data folder;
# INDUROP_SET=<name> starts build/sets/<name> instead, e.g. INDUROP_SET=plc-robot for the cell
# with its PLC program in C++ (config/sets/plc-robot), and makes it the agent's active set
# (packaging/demo-set.sh: uploaded once it is up, an ST set's .st sources with it).
# Both programs' output goes to the terminal and, each line stamped with its UTC time, to
# <data>/logs/irpd.log and agent.log, which the web UI's System page reads.  The agent is started
# again when it exits asking for it (exit 75: a restart from the System page, a restore).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
# The Python venv (pip: mostly the disk and pip's cache) is made beside the build.
venv_path=$(mktemp)
bash "$root/packaging/venv.sh" >"$venv_path" &
venv_job=$!
bash "$root/packaging/build.sh"
wait $venv_job || { echo "demo: the Python venv was not made (packaging/venv.sh)" >&2; exit 1; }
venv=$(cat "$venv_path")
rm -f "$venv_path"

data=${INDUROP_DATA:-$root/build/demo-data}
port=${INDUROP_PORT:-8080}
url=http://127.0.0.1:$port
mkdir -p "$data"
sock="$data/irpd.sock"

# The set: with INDUROP_SET=<name>, build/sets/<name>; else the set activated last through the agent
# (its set store keeps a link to it), else the PLC + robot cell of the paper's §4 in ST, whose drives are
# simulated on Modbus TCP (127.0.0.1:15020) by indurop-drivesim, a non-real process module of the
# set that irpd starts and stops.  A set of the build becomes the store's active set below.
config=$(bash "$root/packaging/demo-set.sh" pick "$data" "$root/build/sets") || exit 2
# The logs: each line to the terminal, and stamped to its file (bash's printf keeps it one process).
logs="$data/logs"
mkdir -p "$logs"
for f in irpd agent; do  # one older generation is kept
  if [ -f "$logs/$f.log" ] && [ "$(stat -c %s "$logs/$f.log")" -gt $((16 << 20)) ]; then mv "$logs/$f.log" "$logs/$f.log.1"; fi
done
stamp() {
  local line
  export TZ=UTC  # (this runs in its own subshell)
  while IFS= read -r line || [ -n "$line" ]; do
    printf '%s\n' "$line"
    printf '%(%Y-%m-%dT%H:%M:%S)TZ %s\n' -1 "$line" >>"$1"
  done
}
# Ctrl-C or SIGTERM stops what was started so far, also while the demo is still starting.
pids=()
stop() { kill -TERM "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap 'stop; exit 130' INT
trap 'stop; exit 143' TERM
# irpd keeps its state (RETAIN values, crash records) in $data/state (demo-irpd.sh)
bash "$root/packaging/demo-irpd.sh" "$data" "$root/build/bin/irpd" --config "$config" --control-socket "$sock" "$@" \
  > >(stamp "$logs/irpd.log") 2>&1 &
irpd_pid=$!
pids+=($irpd_pid)
for _ in $(seq 100); do [ -S "$sock" ] && break; kill -0 $irpd_pid 2>/dev/null || break; sleep 0.05; done
# The agent, like irpd's own non-RT threads, stays off the dispatcher's CPU (irpd's default: the
# last one) when there is another.
off_rt=()
n=$(nproc)
[ "$n" -gt 1 ] && off_rt=(taskset -c "0-$((n - 2))")
# The agent, started again whenever it exits with 75 (a restart asked from the System page).
(cd "$root/agent" && INDUROP_SUPERVISOR=demo exec bash "$root/packaging/respawn.sh" "${off_rt[@]}" \
    "$venv/bin/python" -m indurop_agent --host 127.0.0.1 --port "$port" --data-dir "$data" --irpd-socket "$sock" \
    --irpd-log "$logs/irpd.log" --agent-log "$logs/agent.log" --line-file "$data/line.json") > >(stamp "$logs/agent.log") 2>&1 &
agent_pid=$!
pids+=($agent_pid)
# The DDS bridge (docs/dds.md): ROS 2's /joint_states and /diagnostics on Cyclone DDS, loopback
# only, domain INDUROP_DDS_DOMAIN (default 0); it announces this controller on the line as
# INDUROP_NAME (default: the host's name) and writes the line's view the agent serves (the Line page).
(cd "$root/agent" && exec "${off_rt[@]}" "$venv/bin/python" -m indurop_agent.dds --irpd-socket "$sock" \
    --domain-id "${INDUROP_DDS_DOMAIN:-0}" --interface lo --name "${INDUROP_NAME:-$(hostname -s)}" \
    --agent-url "$url/" --line-file "$data/line.json") > >(stamp "$logs/dds-bridge.log") 2>&1 &
bridge_pid=$!
pids+=($bridge_pid)
# The OPC UA server (docs/opcua.md): opc.tcp://127.0.0.1:INDUROP_OPCUA_PORT (default 4840), the web
# UI's users and roles, Basic256Sha256 and Aes128_Sha256_RsaOaep; its certificate and PKI folders in
# <data>/opcua/.
opcua_port=${INDUROP_OPCUA_PORT:-4840}
(cd "$root/agent" && exec "${off_rt[@]}" "$venv/bin/python" -m indurop_agent.opcua --irpd-socket "$sock" \
    --data-dir "$data" --host 127.0.0.1 --port "$opcua_port" --agent-url "$url/") > >(stamp "$logs/opcua.log") 2>&1 &
opcua_pid=$!
pids+=($opcua_pid)
for _ in $(seq 200); do curl -sf "$url/api/v1/health" >/dev/null && break; kill -0 $agent_pid 2>/dev/null || break; sleep 0.1; done
# A set of the build becomes the set store's active set (its files, history, rollback; the UI's
# edits, of an ST program too, are versions of it): uploaded and activated, a hot reload (the first
# time the cell's; then the one INDUROP_SET names, unless the store's active set is that build of it).
case $config in
"$root/build/sets/"*) bash "$root/packaging/demo-set.sh" store "$data" "$(dirname "$config")" "$url" "$venv/bin/irpctl" || true ;;
esac
# No default password: the first admin sets theirs with the admin token the agent's first start wrote.
if curl -sf "$url/api/v1/session" | grep -q '"first_run":true'; then
  echo "demo: no user yet: set the first admin's password in the web UI ($url/ asks for the admin token in"
  echo "demo:   $data/admin-token), or on this shell (it asks the password twice):"
  echo "demo:   INDUROP_URL=$url INDUROP_TOKEN_FILE=$data/admin-token $venv/bin/irpctl user add admin --role admin"
fi
echo "demo: the web UI: $url/  (sign in with a user name and password; docs/administration.md)"
echo "demo: start the cell from the UI's Variables page (PLC_ROBOT.PLC_IN.Enable = 1, then PLC_ROBOT.I0 = 1) or: irpctl write PLC_ROBOT.PLC_IN.Enable 1; irpctl write PLC_ROBOT.I0 1 (docs/plc-robot-cell.md)"
echo "demo: irpd (pid $irpd_pid) on $config; agent (pid $agent_pid) on $url/api/v1/docs"
echo "demo: DDS bridge (pid $bridge_pid): rt/joint_states and rt/diagnostics on domain ${INDUROP_DDS_DOMAIN:-0}, loopback; the line on the web UI's Line page and irpctl line (docs/dds.md)"
echo "demo: OPC UA server (pid $opcua_pid): opc.tcp://127.0.0.1:$opcua_port/ -- sign in with a web UI user (Basic256Sha256 or Aes128_Sha256_RsaOaep, Sign or SignAndEncrypt); a client's certificate is refused until an admin trusts it: the web UI's OPC UA page, or irpctl opcua certs / irpctl opcua trust SHA1 (docs/opcua.md)"
echo "demo: the admin token is in $data/admin-token"
echo "demo: the logs are in $logs (irpd.log, agent.log, dds-bridge.log, opcua.log; the web UI's System page shows the first two)"

# Whichever ends first (irpd after --duration, or the agent) ends the demo.
wait -n $irpd_pid $agent_pid || true
stop

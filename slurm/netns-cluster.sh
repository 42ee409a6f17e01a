# shellcheck shell=bash
# A K-node Slurm cluster on this one machine, sourced by slurm/local-cluster for --nodes K (K >= 2).
# Each node nodeK is a network namespace hpcgi-nodeK with its own hostname (a UTS namespace), joined by a veth pair
# to the bridge hpcgi-br0 in this machine's namespace, address 10.250.77.K; it runs its own `slurmd -N nodeK`.
# One slurmctld (this machine's namespace, the "head" at 10.250.77.254, port 6917) serves them all; munge is this
# machine's (its socket is a file, which every namespace sees). Everything lives in $NS_DIR (slurm.conf, state,
# spools, logs, pid files), apart from the namespaces, links and /etc/netns/hpcgi-node*/hosts (ip netns exec mounts
# it over /etc/hosts inside the node). Clients use SLURM_CONF=$NS_DIR/slurm.conf, so a single-node cluster
# (/etc/slurm/slurm.conf, port 6817) can run beside it. stop removes all of it, and start calls stop on any failure.
NS_DIR=/run/hpcgi-cluster
NS_CONF=$NS_DIR/slurm.conf
NS_NET=10.250.77
NS_BR=hpcgi-br0

ns_nodes() { cat "$NS_DIR/nodes" 2>/dev/null || ip netns list 2>/dev/null | sed -n 's/^hpcgi-node\([0-9]*\).*/\1/p'; }

ns_refuse() { echo "local-cluster: $*" >&2; exit 2; }

ns_check() {  # ns_check K: refuses in one line where the cluster cannot work
  local k=$1
  [[ $k =~ ^[1-9][0-9]?$ ]] && [ "$k" -le 32 ] || ns_refuse "--nodes takes 1..32, got '$k'"
  [ "$(id -u)" -eq 0 ] || ns_refuse "a $k-node cluster needs root (network namespaces)"
  command -v ip >/dev/null || ns_refuse "a $k-node cluster needs 'ip' (iproute2)"
  command -v unshare >/dev/null || ns_refuse "a $k-node cluster needs 'unshare' (util-linux)"
  command -v slurmd >/dev/null && command -v slurmctld >/dev/null ||
    ns_refuse "slurmctld/slurmd are not installed (make deps)"
  unshare --net --uts true 2>/dev/null ||
    ns_refuse "network and UTS namespaces are not allowed here (unshare --net --uts fails)"
  [ ! -e "$NS_DIR" ] ||
    ns_refuse "a cluster is already up ($NS_DIR exists): slurm/local-cluster --nodes $(ns_nodes | wc -l) stop"
}

ns_write_conf() {  # ns_write_conf K
  local k=$1 cpus mem i nodes
  cpus=$(nproc)
  mem=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2 / k ))  # MiB: the nodes share this machine
  nodes="node[1-$k]"
  mkdir -p "$NS_DIR/state" "$NS_DIR/log"
  cat > "$NS_CONF" <<CONF
# written by slurm/local-cluster --nodes $k: $k namespaced nodes on one machine
ClusterName=hpcgi-local$k
SlurmctldHost=hpcgi-head($NS_NET.254)
SlurmctldPort=6917
SlurmdPort=6918
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SlurmdTimeout=5
MessageTimeout=5
StateSaveLocation=$NS_DIR/state
SlurmdSpoolDir=$NS_DIR/%n/spool
SlurmctldLogFile=$NS_DIR/log/slurmctld.log
SlurmdLogFile=$NS_DIR/log/slurmd-%n.log
SlurmctldPidFile=$NS_DIR/slurmctld.pid
SlurmdPidFile=$NS_DIR/%n/slurmd.pid
MaxArraySize=10001
NodeName=DEFAULT CPUs=$cpus RealMemory=$mem State=UNKNOWN
CONF
  for ((i = 1; i <= k; i++)); do
    echo "NodeName=node$i NodeAddr=$NS_NET.$i NodeHostname=node$i" >> "$NS_CONF"
  done
  echo "PartitionName=local Nodes=$nodes Default=YES MaxTime=INFINITE State=UP" >> "$NS_CONF"
  # srun --mpi=pmix: Slurm's PMIx server makes its clients' folder under this base, named by job and step only, so
  # the nodes (which share /tmp) must not share it: each node mounts its own nodeI/tmp here (ns_start).
  mkdir -p "$NS_DIR/tmp"
  echo "PMIxCliTmpDirBase=$NS_DIR/tmp" > "$NS_DIR/mpi.conf"
}

ns_net() {  # ns_net K: the bridge, one namespace and veth pair per node, /etc/netns/hpcgi-nodeI/hosts
  local k=$1 i hosts
  ip link add "$NS_BR" type bridge
  ip addr add "$NS_NET.254/24" dev "$NS_BR"
  ip link set "$NS_BR" up
  hosts="127.0.0.1 localhost"$'\n'"$NS_NET.254 hpcgi-head"
  for ((i = 1; i <= k; i++)); do hosts+=$'\n'"$NS_NET.$i node$i"; done
  for ((i = 1; i <= k; i++)); do
    ip netns add "hpcgi-node$i"
    ip link add "hpcgi-v$i" type veth peer name eth0 netns "hpcgi-node$i"
    ip link set "hpcgi-v$i" master "$NS_BR" up
    ip -n "hpcgi-node$i" addr add "$NS_NET.$i/24" dev eth0
    ip -n "hpcgi-node$i" link set lo up
    ip -n "hpcgi-node$i" link set eth0 up
    mkdir -p "/etc/netns/hpcgi-node$i" "$NS_DIR/node$i/spool"
    printf '%s\n' "$hosts" > "/etc/netns/hpcgi-node$i/hosts"
  done
}

ns_start() {  # ns_start K
  local k=$1 i idle
  ns_check "$k"
  mkdir -p "$NS_DIR"
  trap 'ns_fail' EXIT
  trap 'exit 130' INT TERM HUP  # interrupted: the EXIT trap takes it all down
  seq "$k" > "$NS_DIR/nodes"
  ns_write_conf "$k"
  ns_net "$k"
  if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then start_munge; touch "$NS_DIR/munged.ours"; fi
  # The controller: this machine's network, its own hostname (Slurm starts only on the host SlurmctldHost names).
  unshare --uts sh -c "hostname hpcgi-head && exec /usr/sbin/slurmctld -f '$NS_CONF'"
  # A node: its network namespace, its own hostname and a private mount namespace in which its /etc/hosts is
  # /etc/netns/hpcgi-nodeI/hosts and $NS_DIR/tmp is its own nodeI/tmp (nsenter, not ip netns exec, which would
  # mount a /sys without the cgroups slurmd reads). The mounts go when the node's last process does.
  for ((i = 1; i <= k; i++)); do
    mkdir -p "$NS_DIR/node$i/tmp"
    nsenter --net="/run/netns/hpcgi-node$i" unshare --uts --mount --propagation private sh -c \
      "mount --bind /etc/netns/hpcgi-node$i/hosts /etc/hosts && mount --bind '$NS_DIR/node$i/tmp' '$NS_DIR/tmp' &&
       hostname node$i && exec /usr/sbin/slurmd -f '$NS_CONF' -N node$i"
  done
  for _ in $(seq 150); do
    idle=$(SLURM_CONF=$NS_CONF sinfo -h -N -o '%N %t' 2>/dev/null | awk '$2 == "idle"' | wc -l)
    [ "$idle" -eq "$k" ] && break
    sleep 0.2
  done
  [ "${idle:-0}" -eq "$k" ] || { echo "local-cluster: only ${idle:-0} of $k nodes became idle" >&2; exit 1; }
  trap - EXIT INT TERM HUP
  echo "local-cluster: $k nodes idle (node1..node$k at $NS_NET.1-$k, controller hpcgi-head at $NS_NET.254:6917)"
  echo "local-cluster: use it with: export SLURM_CONF=$NS_CONF"
}

ns_fail() {  # the EXIT trap of start: on failure, the logs' last lines, then everything taken down
  local s=$?
  [ $s -eq 0 ] && return
  tail -n 3 "$NS_DIR"/log/*.log >&2 2>/dev/null || true
  ns_stop >/dev/null 2>&1 || true
  exit $s
}

ns_kill() {  # ns_kill PID...: TERM, then KILL what is left after 3 s
  [ $# -gt 0 ] || return 0
  local p alive
  kill "$@" 2>/dev/null || true
  for _ in $(seq 30); do
    alive=()
    for p in "$@"; do kill -0 "$p" 2>/dev/null && alive+=("$p"); done
    [ ${#alive[@]} -eq 0 ] && return 0
    sleep 0.1
  done
  kill -9 "${alive[@]}" 2>/dev/null || true
}

ns_stop() {
  local i pids=()
  for i in $(ns_nodes); do  # every process inside a node: its slurmd, job steps, MPI ranks
    # shellcheck disable=SC2207
    pids+=($(ip netns pids "hpcgi-node$i" 2>/dev/null || true))
  done
  [ -f "$NS_DIR/slurmctld.pid" ] && pids+=("$(cat "$NS_DIR/slurmctld.pid")")
  if [ -f "$NS_DIR/munged.ours" ] && [ -f /run/munge/munged.pid ]; then pids+=("$(cat /run/munge/munged.pid)"); fi
  ns_kill ${pids[@]+"${pids[@]}"}  # all at once: each daemon takes its time to shut down
  for i in $(ns_nodes); do
    ip netns del "hpcgi-node$i" 2>/dev/null || true  # its end of the veth pair goes with it, and so the pair
    ip link del "hpcgi-v$i" 2>/dev/null || true
    rm -rf "/etc/netns/hpcgi-node$i"
  done
  ip link del "$NS_BR" 2>/dev/null || true
  rmdir /etc/netns 2>/dev/null || true
  rm -rf "$NS_DIR"
  echo "local-cluster: stopped"
}

ns_leftovers() {  # prints what a stopped cluster would have left behind (nothing when clean)
  ip netns list 2>/dev/null | grep '^hpcgi-' || true
  ip -o link show 2>/dev/null | grep -o 'hpcgi-[a-z0-9]*' || true
  grep 'hpcgi-' /proc/mounts || true
  ps -eo pid=,args= | grep -F "$NS_CONF" | grep -v grep || true
  [ ! -e "$NS_DIR" ] || echo "$NS_DIR"
  ls -d /etc/netns/hpcgi-* 2>/dev/null || true
}

#!/usr/bin/env bash
# A real single-node SLURM cluster with accounting on this machine (Debian 12, root, no systemd):
#   munged -> mariadbd -> slurmdbd -> (sacctmgr: cluster, account, user) -> slurmctld -> slurmd
#
#   cluster.sh up       install the Debian packages if missing, write the configs, start the
#                       daemons, wait until the node is idle and sacct answers   (idempotent)
#   cluster.sh down     cancel jobs, stop every daemon this script starts (by pid), remove
#                       slurm.conf (see cmd_down), keep the accounting data
#   cluster.sh status   what runs; sinfo; sacct; exit 0 only when the cluster is usable
#   cluster.sh purge    down, then remove the accounting database, the spool/state folders and
#                       the generated configs (packages stay installed)
#
# Environment (all optional; not SLURM_* names, which srun/sacct read themselves):
#   CORTEX_SLURM_CLUSTER (cortex)  CORTEX_SLURM_PARTITION (main)  CORTEX_SLURM_ACCOUNT (cortex)
#   CORTEX_SLURM_USERS   (root, and $SUDO_USER when set: the users added to the account)
#   CORTEX_SLURM_TIMEOUT (120: seconds each wait may take)
#
# Packages (Debian 12, --no-install-recommends): munge mariadb-server slurmdbd slurmctld slurmd
# slurm-client (Slurm 22.05.8, MariaDB 10.11, munge 0.5.15; 26 packages with dependencies).
# Files: /etc/slurm/{slurm.conf,slurmdbd.conf,.dbpass}, /etc/mysql/mariadb.conf.d/60-slurmdbd.cnf,
# /var/spool/slurm{ctld,d}, /run/{slurm,munge,mysqld}, logs in /var/log/{slurm,munge,mysql} and
# /var/log/cluster-sh-*.log. Daemons are started directly (no systemd), tracked by pid file.
set -euo pipefail

CLUSTER=${CORTEX_SLURM_CLUSTER:-cortex}
PARTITION=${CORTEX_SLURM_PARTITION:-main}
ACCOUNT=${CORTEX_SLURM_ACCOUNT:-cortex}
USERS=${CORTEX_SLURM_USERS:-root${SUDO_USER:+ $SUDO_USER}}
TIMEOUT=${CORTEX_SLURM_TIMEOUT:-120}
# mariadb-server pulls the client; slurm-client holds sinfo/sbatch/sacct/sacctmgr
PACKAGES=(munge mariadb-server slurmdbd slurmctld slurmd slurm-client)

ETC=/etc/slurm
LOG=/var/log/slurm
CTLD_SPOOL=/var/spool/slurmctld
SLURMD_SPOOL=/var/spool/slurmd
RUN=/run/slurm
MUNGE_PID=/run/munge/munged.pid
MYSQL_PID=/run/mysqld/mysqld.pid
MYSQL_SOCK=/run/mysqld/mysqld.sock
DBD_PID=$RUN/slurmdbd.pid
CTLD_PID=$RUN/slurmctld.pid
SLURMD_PID=$RUN/slurmd.pid
DB_NAME=slurm_acct_db
DB_USER=slurm
DB_PASS_FILE=$ETC/.dbpass        # generated once, root/slurm only

say() { printf '[cluster] %s\n' "$*"; }
die() { printf '[cluster] ERROR: %s\n' "$*" >&2; exit 1; }

# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------

# pid from a pid file when that process is alive and is the named program
pid_of() {   # pidfile comm
    local f=$1 comm=$2 pid
    [[ -r $f ]] || return 1
    pid=$(tr -dc '0-9' <"$f")
    [[ -n $pid ]] || return 1
    [[ -r /proc/$pid/comm ]] || return 1
    [[ $(cat "/proc/$pid/comm") == "$comm"* ]] || return 1
    alive "$pid" || return 1
    echo "$pid"
}

running() { pid_of "$@" >/dev/null 2>&1; }

# a process that exited but is not reaped yet (a zombie) counts as gone
alive() {
    local stat
    stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
    stat=${stat##*) }
    [[ ${stat:0:1} != Z ]]
}

wait_for() {   # description command...  (polls every 0.5 s up to $TIMEOUT)
    local what=$1 t0=$SECONDS
    shift
    until "$@" >/dev/null 2>&1; do
        ((SECONDS - t0 < TIMEOUT)) || return 1
        sleep 0.5
    done
    say "  $what ($((SECONDS - t0)) s)"
}

stop_pid() {   # name pidfile comm
    local name=$1 f=$2 comm=$3 pid _ t0
    t0=$EPOCHREALTIME
    if pid=$(pid_of "$f" "$comm"); then
        kill -TERM "$pid" 2>/dev/null || true
        for _ in $(seq 1 150); do
            alive "$pid" || break
            sleep 0.2
        done
        if alive "$pid"; then
            say "  $name ($pid) did not stop in 30 s: SIGKILL"
            kill -KILL "$pid" 2>/dev/null || true
            sleep 0.5
        fi
        say "  stopped $name ($pid, $(awk -v a="$t0" -v b="$EPOCHREALTIME" 'BEGIN{printf "%.1f", b-a}') s)"
    else
        say "  $name not running"
    fi
    rm -f "$f"
}

need_root() { [[ $(id -u) == 0 ]] || die "run as root (installs packages, writes /etc/slurm, starts daemons)"; }

# ---------------------------------------------------------------------------------------------
# up
# ---------------------------------------------------------------------------------------------

install_packages() {
    local missing=() p
    for p in "${PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
    done
    if ((${#missing[@]} == 0)); then
        say "packages present: ${PACKAGES[*]}"
        return
    fi
    command -v apt-get >/dev/null || die "apt-get not found: install ${missing[*]} by hand"
    say "installing Debian packages: ${missing[*]}"
    # no service may start from a maintainer script (there is no init system to own it)
    local policy_created=0
    if [[ ! -e /usr/sbin/policy-rc.d ]]; then
        printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d
        chmod +x /usr/sbin/policy-rc.d
        policy_created=1
    fi
    local rc=0 apt_log=/var/log/cluster-sh-apt.log
    : >"$apt_log"
    # package lists: fetched when absent; fetched again when an install from old lists fails
    if ! apt-cache show slurmctld >/dev/null 2>&1; then
        apt-get update -q >>"$apt_log" 2>&1 || rc=$?
    fi
    if ((rc == 0)); then
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" >>"$apt_log" 2>&1 \
            || { apt-get update -q >>"$apt_log" 2>&1 \
                 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" >>"$apt_log" 2>&1; } \
            || rc=$?
    fi
    ((policy_created)) && rm -f /usr/sbin/policy-rc.d
    ((rc == 0)) || die "apt-get failed (rc $rc), see $apt_log"
    say "  installed: $(dpkg-query -W -f='${Package} ${Version}, ' "${PACKAGES[@]}")"
}

write_if_changed() {   # path mode owner  (content on stdin); prints "changed" when it did
    local path=$1 mode=$2 owner=$3 tmp
    tmp=$(mktemp)
    cat >"$tmp"
    if [[ -f $path ]] && cmp -s "$tmp" "$path"; then
        rm -f "$tmp"
        chmod "$mode" "$path"; chown "$owner" "$path"
        return 0
    fi
    install -m "$mode" -o "${owner%%:*}" -g "${owner##*:}" "$tmp" "$path"
    rm -f "$tmp"
    echo changed
}

SLURM_CONF_CHANGED=""
write_configs() {
    id slurm >/dev/null 2>&1 || die "user slurm missing (the slurm packages create it)"
    install -d -m 755 "$ETC"
    install -d -m 755 -o slurm -g slurm "$LOG" "$RUN"
    install -d -m 700 -o slurm -g slurm "$CTLD_SPOOL"
    install -d -m 755 "$SLURMD_SPOOL"

    local host node_line
    host=$(hostname -s)
    getent hosts "$host" >/dev/null || die "hostname $host does not resolve (add it to /etc/hosts)"
    # the node as slurmd sees it: CPUs, sockets/cores/threads, RealMemory
    node_line=$(slurmd -C | head -n1)
    [[ $node_line == NodeName=* ]] || die "slurmd -C gave no node line: $node_line"

    [[ -s $DB_PASS_FILE ]] || (umask 077; head -c 18 /dev/urandom | base64 | tr -dc 'A-Za-z0-9' >"$DB_PASS_FILE")
    chown slurm:slurm "$DB_PASS_FILE"; chmod 600 "$DB_PASS_FILE"

    SLURM_CONF_CHANGED=$(write_if_changed "$ETC/slurm.conf" 644 root:root <<EOF
# Written by cluster.sh: one node (this host), one partition, accounting through slurmdbd.
ClusterName=$CLUSTER
SlurmctldHost=$host
SlurmUser=slurm
SlurmdUser=root
AuthType=auth/munge
CryptoType=crypto/munge
MpiDefault=none
MailProg=/bin/true
# no cgroups needed (containers/VMs without a delegated cgroup tree)
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/linux
# sample each job's memory/CPU every 5 s (sacct MaxRSS; short jobs get at least one sample)
JobAcctGatherFrequency=5
SwitchType=switch/none
# CPUs and memory are consumable: a job's --mem above RealMemory is refused at submission
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
ReturnToService=2
# finished jobs leave squeue after 5 min; sacct keeps them
MinJobAge=300
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=localhost
AccountingStorageEnforce=associations
StateSaveLocation=$CTLD_SPOOL
SlurmdSpoolDir=$SLURMD_SPOOL
SlurmctldPidFile=$CTLD_PID
SlurmdPidFile=$SLURMD_PID
SlurmctldLogFile=$LOG/slurmctld.log
SlurmdLogFile=$LOG/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
$node_line State=UNKNOWN
PartitionName=$PARTITION Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
    )
    write_if_changed "$ETC/slurmdbd.conf" 600 slurm:slurm >/dev/null <<EOF
# Written by cluster.sh: slurmdbd on MariaDB (local socket).
AuthType=auth/munge
DbdHost=localhost
SlurmUser=slurm
PidFile=$DBD_PID
LogFile=$LOG/slurmdbd.log
DebugLevel=info
StorageType=accounting_storage/mysql
StorageHost=localhost
StorageLoc=$DB_NAME
StorageUser=$DB_USER
StoragePass=$(cat "$DB_PASS_FILE")
EOF
    # slurmdbd warns unless InnoDB waits long enough for its schema updates
    write_if_changed /etc/mysql/mariadb.conf.d/60-slurmdbd.cnf 644 root:root >/dev/null <<'EOF'
# Written by cluster.sh for slurmdbd
[mysqld]
innodb_lock_wait_timeout=900
innodb_buffer_pool_size=1024M
# slurmdbd talks to it over the local socket only
skip-networking
EOF
}

start_munge() {
    if running $MUNGE_PID munged; then say "munged running"; return; fi
    if [[ ! -s /etc/munge/munge.key ]]; then
        say "creating /etc/munge/munge.key"
        mungekey --create --keyfile=/etc/munge/munge.key 2>/dev/null \
            || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
        chown munge:munge /etc/munge/munge.key; chmod 400 /etc/munge/munge.key
    fi
    install -d -m 755 -o munge -g munge /run/munge
    rm -f /run/munge/munge.socket.2 /run/munge/munge.socket.2.lock "$MUNGE_PID"
    say "starting munged"
    runuser -u munge -- /usr/sbin/munged --pid-file=$MUNGE_PID || die "munged did not start (see /var/log/munge/munged.log)"
    wait_for "munge answers" bash -c 'munge -n | unmunge' || die "munged does not answer (see /var/log/munge/munged.log)"
}

mysql_root() { mariadb --protocol=socket -S "$MYSQL_SOCK" -u root "$@"; }

start_mariadb() {
    if running $MYSQL_PID mariadbd || running $MYSQL_PID mysqld; then
        say "mariadbd running"
    else
        if [[ ! -d /var/lib/mysql/mysql ]]; then
            say "initialising /var/lib/mysql"
            mariadb-install-db --user=mysql --datadir=/var/lib/mysql >/var/log/cluster-sh-mariadb-install.log 2>&1 \
                || die "mariadb-install-db failed, see /var/log/cluster-sh-mariadb-install.log"
        fi
        install -d -m 755 -o mysql -g mysql /run/mysqld
        install -d -m 750 -o mysql -g adm /var/log/mysql
        say "starting mariadbd"
        # own session, output to a log; pid and socket as in Debian's defaults
        setsid -f /usr/sbin/mariadbd --user=mysql --pid-file=$MYSQL_PID --socket=$MYSQL_SOCK \
            >>/var/log/mysql/cluster-sh-mariadbd.log 2>&1 </dev/null || die "mariadbd did not start"
        wait_for "mariadb answers" mysql_root -e 'select 1' || die "mariadbd does not answer (see /var/log/mysql/cluster-sh-mariadbd.log)"
    fi
    local pass
    pass=$(cat "$DB_PASS_FILE")
    mysql_root <<EOF || die "could not create the database $DB_NAME / user $DB_USER"
CREATE DATABASE IF NOT EXISTS $DB_NAME;
CREATE USER IF NOT EXISTS '$DB_USER'@'localhost' IDENTIFIED BY '$pass';
ALTER USER '$DB_USER'@'localhost' IDENTIFIED BY '$pass';
GRANT ALL ON $DB_NAME.* TO '$DB_USER'@'localhost';
FLUSH PRIVILEGES;
EOF
}

start_slurmdbd() {
    if running $DBD_PID slurmdbd; then say "slurmdbd running"; else
        say "starting slurmdbd"
        /usr/sbin/slurmdbd || die "slurmdbd did not start (see $LOG/slurmdbd.log)"
    fi
    wait_for "slurmdbd answers (sacctmgr)" sacctmgr -n show cluster \
        || die "slurmdbd does not answer (see $LOG/slurmdbd.log)"
}

# sacctmgr objects: cluster, account, users (non-interactive, only what is missing)
accounting_objects() {
    local out u
    out=$(sacctmgr -nP show cluster "$CLUSTER" format=cluster) || die "sacctmgr show cluster failed"
    if [[ -z $out ]]; then
        sacctmgr -i add cluster "$CLUSTER" >/dev/null || die "sacctmgr add cluster $CLUSTER failed"
        say "  added cluster $CLUSTER"
    fi
    out=$(sacctmgr -nP show account "$ACCOUNT" format=account) || die "sacctmgr show account failed"
    if [[ -z $out ]]; then
        sacctmgr -i add account "$ACCOUNT" cluster="$CLUSTER" Description="cortex-ti jobs" Organization=cortex >/dev/null \
            || die "sacctmgr add account $ACCOUNT failed"
        say "  added account $ACCOUNT"
    fi
    for u in $USERS; do
        out=$(sacctmgr -nP show assoc cluster="$CLUSTER" account="$ACCOUNT" user="$u" format=user) || die "sacctmgr show assoc failed"
        if [[ -z $out ]]; then
            sacctmgr -i add user "$u" account="$ACCOUNT" cluster="$CLUSTER" DefaultAccount="$ACCOUNT" >/dev/null \
                || die "sacctmgr add user $u failed"
            say "  added user $u to account $ACCOUNT"
        fi
    done
}

node_idle() { [[ $(sinfo -h -N -o '%t' 2>/dev/null | head -n1) =~ ^(idle|mix|alloc)$ ]]; }

start_slurmctld() {
    if running $CTLD_PID slurmctld; then
        say "slurmctld running"
        [[ -z $SLURM_CONF_CHANGED ]] || { say "  slurm.conf changed: scontrol reconfigure"; scontrol reconfigure; }
    else
        say "starting slurmctld"
        runuser -u slurm -- /usr/sbin/slurmctld || die "slurmctld did not start (see $LOG/slurmctld.log)"
    fi
    wait_for "slurmctld answers" scontrol ping || die "slurmctld does not answer (see $LOG/slurmctld.log)"
}

start_slurmd() {
    if running $SLURMD_PID slurmd; then say "slurmd running"; else
        say "starting slurmd"
        /usr/sbin/slurmd || die "slurmd did not start (see $LOG/slurmd.log)"
    fi
    if ! wait_for "node idle" node_idle; then
        # a node left DOWN/DRAIN by an earlier unclean stop
        scontrol update nodename="$(hostname -s)" state=resume 2>/dev/null || true
        wait_for "node idle after resume" node_idle || { sinfo -N -l >&2 || true; die "the node is not idle (see $LOG/slurmd.log)"; }
    fi
}

cmd_up() {
    need_root
    local t0=$SECONDS
    install_packages
    write_configs
    start_munge
    start_mariadb
    start_slurmdbd
    accounting_objects
    start_slurmctld
    start_slurmd
    wait_for "sacct answers" sacct -n -X -S now-1minute || die "sacct does not answer"
    say "up in $((SECONDS - t0)) s: cluster $CLUSTER, partition $PARTITION, account $ACCOUNT"
    sinfo
}

# ---------------------------------------------------------------------------------------------
# down / purge / status
# ---------------------------------------------------------------------------------------------

cmd_down() {
    need_root
    if running $CTLD_PID slurmctld && command -v squeue >/dev/null; then
        local jobs
        jobs=$(squeue -h -o %i 2>/dev/null || true)
        if [[ -n $jobs ]]; then
            say "cancelling jobs: ${jobs//$'\n'/ }"
            # shellcheck disable=SC2086
            scancel $jobs || true
            local _
            for _ in $(seq 1 30); do [[ -z $(squeue -h -t R,CG -o %i 2>/dev/null) ]] && break; sleep 1; done
        fi
    fi
    say "stopping daemons"
    stop_pid slurmd "$SLURMD_PID" slurmd
    stop_pid slurmctld "$CTLD_PID" slurmctld
    stop_pid slurmdbd "$DBD_PID" slurmdbd
    if pid_of $MYSQL_PID mariadbd >/dev/null 2>&1 || pid_of $MYSQL_PID mysqld >/dev/null 2>&1; then
        mysql_root -e 'SHUTDOWN' 2>/dev/null || true
    fi
    stop_pid mariadbd "$MYSQL_PID" mariadbd
    stop_pid munged "$MUNGE_PID" munged
    # With a slurm.conf but no slurmctld, every Slurm client command waits ~10 s for the
    # controller, and so does every `snakemake` start (importing snakemake-executor-plugin-slurm
    # runs `scontrol show config`): without it they fail at once. `up` writes it again.
    if [[ -f $ETC/slurm.conf ]]; then
        rm -f "$ETC/slurm.conf"
        say "removed $ETC/slurm.conf (up writes it again)"
    fi
    say "down"
}

cmd_purge() {
    cmd_down
    if [[ -d /var/lib/mysql/mysql ]] && command -v mariadbd >/dev/null; then
        # drop database and user through the server (InnoDB keeps a dictionary: no rm -rf)
        say "dropping database $DB_NAME and user $DB_USER"
        install -d -m 755 -o mysql -g mysql /run/mysqld
        setsid -f /usr/sbin/mariadbd --user=mysql --pid-file=$MYSQL_PID --socket=$MYSQL_SOCK \
            >>/var/log/mysql/cluster-sh-mariadbd.log 2>&1 </dev/null
        wait_for "mariadb answers" mysql_root -e 'select 1' || die "mariadbd does not answer"
        mysql_root -e "DROP DATABASE IF EXISTS $DB_NAME; DROP USER IF EXISTS '$DB_USER'@'localhost';" \
            || die "could not drop $DB_NAME"
        mysql_root -e 'SHUTDOWN' 2>/dev/null || true
        stop_pid mariadbd "$MYSQL_PID" mariadbd
    fi
    say "removing spool/state folders and the generated configs"
    rm -rf "$CTLD_SPOOL" "$SLURMD_SPOOL" "$RUN"
    rm -f "$ETC/slurm.conf" "$ETC/slurmdbd.conf" "$DB_PASS_FILE" /etc/mysql/mariadb.conf.d/60-slurmdbd.cnf
    say "purged (packages stay installed)"
}

cmd_status() {
    local ok=0 d pid
    for d in "munged:$MUNGE_PID" "mariadbd:$MYSQL_PID" "slurmdbd:$DBD_PID" "slurmctld:$CTLD_PID" "slurmd:$SLURMD_PID"; do
        if pid=$(pid_of "${d#*:}" "${d%%:*}" 2>/dev/null); then
            say "${d%%:*}: running (pid $pid)"
        else
            say "${d%%:*}: not running"; ok=1
        fi
    done
    if ((ok == 0)); then
        sinfo || ok=1
        node_idle || { say "node not idle/usable"; ok=1; }
        sacct -n -X -S now-1day -o JobID,JobName%30,State,ExitCode | tail -n 5 || ok=1
    fi
    return $ok
}

case ${1:-} in
    up) cmd_up ;;
    down) cmd_down ;;
    status) cmd_status ;;
    purge) cmd_purge ;;
    *) echo "usage: $0 up|down|status|purge" >&2; exit 2 ;;
esac

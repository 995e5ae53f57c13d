"""A single-node SLURM cluster on this machine, for the profile test and for trying the profile by hand.

    python tests/slurm_cluster.py up /tmp/rgns-slurm      # start munged, slurmctld, slurmd; wait for idle
    python tests/slurm_cluster.py down /tmp/rgns-slurm    # stop them

Needs root and Debian's packages (``apt-get install slurmctld slurmd slurm-client munge``). No
systemd: the daemons are started by hand, with process tracking by /proc (proctrack/linuxproc).
``/etc/slurm/slurm.conf`` must point at the generated file, because the executor plugin's inner
``srun`` ignores ``SLURM_CONF``; an existing file there that is not ours is never replaced.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

PROGRAMS = ("slurmctld", "slurmd", "munged", "sinfo", "squeue", "sbatch")  # daemons and the clients used
SYSTEM_CONF = Path("/etc/slurm/slurm.conf")
MUNGE_KEY = Path("/etc/munge/munge.key")
PARTITION = "debug"

CONF = """\
ClusterName=rgnstest
SlurmctldHost={host}(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation={base}/state
SlurmdSpoolDir={base}/spool
SlurmctldPidFile={base}/run/slurmctld.pid
SlurmdPidFile={base}/run/slurmd.pid
SlurmctldLogFile={base}/log/slurmctld.log
SlurmdLogFile={base}/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/affinity
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
MinJobAge=600
MpiDefault=none
MailProg=/bin/true
NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory={memory_mb} State=UNKNOWN
PartitionName={partition} Nodes={host} Default=YES MaxTime=INFINITE State=UP
"""


def missing() -> list[str]:
    """The SLURM and munge programs not on PATH (or the reason this cannot run)."""
    absent = [name for name in PROGRAMS if shutil.which(name) is None]
    if os.geteuid() != 0:
        absent.append("root (the daemons run as root)")
    return absent


def _node() -> dict:
    """This machine's CPUs and memory as slurmd sees them (``slurmd -C``)."""
    fields = dict(
        item.split("=", 1)
        for item in subprocess.run(["slurmd", "-C"], capture_output=True, text=True, check=True).stdout.split()
        if "=" in item
    )
    return {"cpus": int(fields["CPUs"]), "memory_mb": int(fields["RealMemory"]) - 1000}


def up(base: Path, timeout_s: float = 60.0) -> None:
    """Write slurm.conf under ``base``, start munged, slurmctld and slurmd, wait until the node is idle."""
    base = base.resolve()
    for sub in ("state", "spool", "log", "run"):
        (base / sub).mkdir(parents=True, exist_ok=True)
    conf = base / "slurm.conf"
    if SYSTEM_CONF.exists() and not SYSTEM_CONF.is_symlink():
        raise RuntimeError(f"{SYSTEM_CONF} exists and is not a link: a real cluster's config is not replaced")
    _stop_running()
    conf.write_text(CONF.format(host=socket.gethostname().split(".")[0], base=base, partition=PARTITION, **_node()))
    SYSTEM_CONF.parent.mkdir(parents=True, exist_ok=True)
    SYSTEM_CONF.unlink(missing_ok=True)
    SYSTEM_CONF.symlink_to(conf)
    Path("/run/munge").mkdir(exist_ok=True)
    shutil.chown("/run/munge", "munge", "munge")
    if not MUNGE_KEY.exists():
        subprocess.run(["mungekey", "--create"], check=True)
        shutil.chown(MUNGE_KEY, "munge", "munge")
    if subprocess.run(["pgrep", "-x", "munged"], capture_output=True).returncode != 0:
        subprocess.run(["runuser", "-u", "munge", "--", "munged"], check=True)
    subprocess.run(["slurmctld"], check=True)
    subprocess.run(["slurmd"], check=True)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        state = subprocess.run(["sinfo", "-h", "-o", "%t"], capture_output=True, text=True).stdout.strip()
        if state == "idle":
            return
        time.sleep(0.5)
    raise RuntimeError(
        f"the SLURM node did not come up idle in {timeout_s:g} s (sinfo says {state!r}); see {base / 'log'}"
    )


def _running() -> bool:
    return any(
        subprocess.run(["pgrep", "-x", name], capture_output=True).returncode == 0 for name in ("slurmctld", "slurmd")
    )


def _stop_running(timeout_s: float = 30.0) -> None:
    """Shut down daemons left by an earlier ``up`` (ours: /etc/slurm/slurm.conf is our link), so
    the new cluster does not find its ports taken and quietly serve the old one."""
    if not _running():
        return
    subprocess.run(["scontrol", "shutdown"], capture_output=True)
    deadline = time.monotonic() + timeout_s
    while _running():
        if time.monotonic() > deadline:
            raise RuntimeError("slurmctld/slurmd from an earlier start did not stop; stop them by hand")
        time.sleep(0.5)


def down(base: Path) -> None:
    """Stop slurmd and slurmctld by their PID files (munged is left for the next start) and take back the link
    to this cluster's config: left behind, every later ``scontrol`` (the SLURM executor plugin calls it when
    any snakemake starts) waits 9 s for the stopped controller."""
    conf = base.resolve() / "slurm.conf"
    if SYSTEM_CONF.is_symlink() and SYSTEM_CONF.resolve() == conf:
        SYSTEM_CONF.unlink()
    for name in ("slurmd", "slurmctld"):
        pid_file = base.resolve() / "run" / f"{name}.pid"
        if pid_file.exists():
            try:
                os.kill(int(pid_file.read_text()), signal.SIGTERM)
            except (ProcessLookupError, ValueError):
                pass
            pid_file.unlink(missing_ok=True)


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("up", "down"):
        sys.exit(__doc__)
    if sys.argv[1] == "up" and missing():
        sys.exit(f"missing: {', '.join(missing())}")
    (up if sys.argv[1] == "up" else down)(Path(sys.argv[2]))

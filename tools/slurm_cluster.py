"""A one-node Slurm cluster of its own, for the farm tests: munged with its own key and
socket, slurmctld and slurmd with a generated slurm.conf, their state and logs all in one
temporary folder; everything is stopped and the folder removed when the `with` block ends,
whatever happens in it. Needs root and Debian's slurm-wlm and munge (build.sh PACKAGES).

    with SlurmCluster() as cluster:
        env = cluster.env   # SLURM_CONF for sbatch, squeue, scancel, sinfo
"""

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _die_with_parent():
    """In the daemon's process before it starts: SIGTERM when the test's Blender ends, even
    killed (a test timeout), so that no daemon outlives it."""
    import ctypes
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


class SlurmCluster:
    def __init__(self, start_timeout=60.0):
        self.start_timeout = start_timeout
        self.procs = []

    def __enter__(self):
        missing = [p for p in ("munged", "mungekey", "slurmctld", "slurmd", "sbatch", "sinfo")
                   if shutil.which(p) is None and not os.path.exists(f"/usr/sbin/{p}")]
        if missing:
            raise RuntimeError(f"Slurm is not installed ({', '.join(missing)} missing): run "
                               "./build.sh deps (Debian packages slurm-wlm and munge)")
        if os.geteuid() != 0:
            raise RuntimeError("the one-node Slurm cluster of the tests needs root")
        # inside the test's own temporary folder when there is one (run.py removes it even
        # after a killed test)
        self.root = tempfile.mkdtemp(prefix="tussock-slurm-", dir=os.environ.get("TSK_TEST_TMP"))
        try:
            self._start()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def path(self, *names):
        return os.path.join(self.root, *names)

    def _daemon(self, name, cmd):
        log = open(self.path(f"{name}.stdout"), "w")
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=self.env,
                                start_new_session=True, preexec_fn=_die_with_parent)
        log.close()
        self.procs.append((name, proc))
        return proc

    def _start(self):
        for d in ("munge", "state", "spool", "log"):
            os.makedirs(self.path(d), mode=0o755 if d == "munge" else 0o700)
        sock = self.path("munge", "munge.socket")
        key = self.path("munge", "munge.key")
        subprocess.run(["/usr/sbin/mungekey", "--create", f"--keyfile={key}"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
        self.env = dict(os.environ, SLURM_CONF=self.path("slurm.conf"))
        self._daemon("munged", ["/usr/sbin/munged", "--foreground", "--force",
                                f"--socket={sock}", f"--key-file={key}",
                                f"--pid-file={self.path('munge', 'munged.pid')}",
                                f"--log-file={self.path('log', 'munged.log')}",
                                f"--seed-file={self.path('munge', 'munged.seed')}"])
        self.host = host = socket.gethostname().split(".")[0]
        cpus = os.cpu_count() or 1
        conf = f"""ClusterName=tussock
SlurmctldHost={host}
SlurmctldPort={_free_port()}
SlurmdPort={_free_port()}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={sock}
SlurmUser=root
SlurmdUser=root
StateSaveLocation={self.path('state')}
SlurmdSpoolDir={self.path('spool')}
SlurmctldPidFile={self.path('slurmctld.pid')}
SlurmdPidFile={self.path('slurmd.pid')}
SlurmctldLogFile={self.path('log', 'slurmctld.log')}
SlurmdLogFile={self.path('log', 'slurmd.log')}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
KillWait=5
NodeName={host} CPUs={cpus} RealMemory=1024 State=UNKNOWN
PartitionName=main Nodes={host} Default=YES MaxTime=INFINITE State=UP
"""
        with open(self.path("slurm.conf"), "w") as f:
            f.write(conf)
        self._wait(lambda: os.path.exists(sock), "munged did not start")
        conf = self.path("slurm.conf")
        self._daemon("slurmctld", ["/usr/sbin/slurmctld", "-D", "-i", "-f", conf])
        self._daemon("slurmd", ["/usr/sbin/slurmd", "-D", "-f", self.path("slurm.conf")])
        self._wait(self._idle, "the node did not become idle")

    def drain(self, on=True):
        """Stops (on) or lets again (off) the node start jobs; queued jobs wait meanwhile.
        A test that cancels a job before it runs drains first: else a short task may end
        between the submission and the scancel."""
        state = ["State=DRAIN", "Reason=tussock-test"] if on else ["State=RESUME"]
        subprocess.run(["scontrol", "update", f"NodeName={self.host}", *state], env=self.env,
                       check=True, stdout=subprocess.DEVNULL)

    def _idle(self):
        out = subprocess.run(["sinfo", "-h", "-N", "-o", "%t"], env=self.env, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL).stdout
        return out.strip() == "idle"

    def _wait(self, ready, what):
        deadline = time.time() + self.start_timeout
        while time.time() < deadline:
            for name, proc in self.procs:
                if proc.poll() is not None:
                    raise RuntimeError(f"Slurm test cluster: {name} exited with "
                                       f"{proc.returncode}:\n{self.logs()}")
            if ready():
                return
            time.sleep(0.25)
        raise RuntimeError(f"Slurm test cluster: {what} within {self.start_timeout:.0f} s:\n"
                           f"{self.logs()}")

    def logs(self):
        out = []
        for name in sorted(os.listdir(self.path("log"))) + \
                [n for n in os.listdir(self.root) if n.endswith(".stdout")]:
            p = self.path("log", name) if not name.endswith(".stdout") else self.path(name)
            with open(p, errors="replace") as f:
                out.append(f"--- {name}\n" + "".join(f.readlines()[-15:]))
        return "\n".join(out)

    def __exit__(self, *exc):
        # the jobs first (a failed test may leave some running: their Blenders would outlive
        # slurmd), then our own daemons, by their process ids, munged last
        if any(name == "slurmctld" and p.poll() is None for name, p in self.procs):
            jobs = subprocess.run(["squeue", "-h", "-o", "%A"], env=self.env, text=True,
                                  stdout=subprocess.PIPE, stderr=subprocess.DEVNULL).stdout.split()
            if jobs:
                subprocess.run(["scancel", *sorted(set(jobs))], env=self.env,
                               stderr=subprocess.DEVNULL)
                deadline = time.time() + 20
                while time.time() < deadline and subprocess.run(
                        ["squeue", "-h", "-o", "%A"], env=self.env, text=True,
                        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL).stdout.strip():
                    time.sleep(0.25)
        for name, proc in reversed(self.procs):
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
        self.procs = []
        shutil.rmtree(self.root, ignore_errors=True)


if __name__ == "__main__":  # a manual check: start, show the node, stop
    with SlurmCluster() as c:
        print(subprocess.run(["sinfo"], env=c.env, text=True, stdout=subprocess.PIPE).stdout)
        out = subprocess.run(["sbatch", "--parsable", "--wrap", "hostname", "-o",
                              c.path("out.txt")], env=c.env, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT).stdout
        print("sbatch:", out)
        time.sleep(3)
        print(open(c.path("out.txt")).read() if os.path.exists(c.path("out.txt")) else c.logs())

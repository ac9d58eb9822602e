//! A throwaway single-node Slurm cluster for the end-to-end tests: its own
//! munged, slurmctld and slurmd, configured in a temporary directory, on
//! 127.0.0.1 and free high ports. Dropping the [`Cluster`] cancels its jobs
//! and stops exactly the daemons it started (by their pid files).
//!
//! Needs Debian's `slurm-wlm` and `munge` packages and root (slurmd runs the
//! jobs); [`Cluster::start`] says why when it cannot run here.

#![allow(dead_code, reason = "each test file uses part of these helpers")]

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// A running cluster; stopped when dropped.
pub struct Cluster {
    /// The temporary directory holding conf, key, state, spool, logs, pid files.
    pub dir: PathBuf,
    /// `slurm.conf`, exported to the commands as `SLURM_CONF`.
    pub conf: PathBuf,
    started: Vec<(&'static str, PathBuf)>,
}

/// Why the cluster cannot run on this machine (the caller skips or fails).
pub struct Unavailable(pub String);

fn have(cmd: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|d| d.join(cmd).is_file())
            || ["/usr/sbin", "/sbin"]
                .iter()
                .any(|d| Path::new(d).join(cmd).is_file())
    })
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("no free port on 127.0.0.1")
}

fn sbin(cmd: &str) -> PathBuf {
    for d in ["/usr/sbin", "/sbin"] {
        let p = Path::new(d).join(cmd);
        if p.is_file() {
            return p;
        }
    }
    PathBuf::from(cmd)
}

/// The short host name (what slurmd and slurmctld compare their names with).
fn hostname() -> String {
    let o = Command::new("hostname")
        .output()
        .expect("cannot run hostname");
    let name = String::from_utf8(o.stdout).unwrap();
    name.trim()
        .split('.')
        .next()
        .unwrap_or_default()
        .to_string()
}

fn read_pid(p: &Path) -> Option<i32> {
    std::fs::read_to_string(p).ok()?.trim().parse().ok()
}

fn alive(pid: i32) -> bool {
    // SAFETY: kill with signal 0 only checks that the process exists.
    unsafe { libc::kill(pid, 0) == 0 }
}

fn tail(p: &Path) -> String {
    let t = std::fs::read_to_string(p).unwrap_or_default();
    let lines: Vec<&str> = t.lines().collect();
    lines[lines.len().saturating_sub(15)..].join("\n")
}

impl Cluster {
    /// Starts munged, slurmctld and slurmd, and waits until the node is idle.
    /// `Err` when Slurm or munge is not installed or this is not root; panics
    /// (with the daemons' logs) when they are there but do not come up.
    pub fn start(name: &str) -> Result<Cluster, Unavailable> {
        let missing: Vec<&str> = [
            "slurmctld",
            "slurmd",
            "munged",
            "mungekey",
            "sbatch",
            "squeue",
            "scancel",
            "sinfo",
        ]
        .into_iter()
        .filter(|c| !have(c))
        .collect();
        if !missing.is_empty() {
            return Err(Unavailable(format!(
                "Slurm/munge not installed (missing {}; Debian: apt-get install slurm-wlm munge)",
                missing.join(", ")
            )));
        }
        // SAFETY: geteuid has no preconditions.
        if unsafe { libc::geteuid() } != 0 {
            return Err(Unavailable(
                "starting slurmd (which runs the jobs) needs root".into(),
            ));
        }
        // Short path: the munge socket's path must fit in sun_path.
        let dir = PathBuf::from(format!("/tmp/rwg-slurm-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for d in ["state", "spool", "log"] {
            std::fs::create_dir_all(dir.join(d)).unwrap();
        }
        let mut c = Cluster {
            conf: dir.join("slurm.conf"),
            dir: dir.clone(),
            started: vec![],
        };
        let key = dir.join("munge.key");
        let o = Command::new(sbin("mungekey"))
            .args(["-c", "-k"])
            .arg(&key)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "mungekey: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let sock = dir.join("munge.sock");
        let o = Command::new(sbin("munged"))
            .arg("--force")
            .arg(format!("--socket={}", sock.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!(
                "--log-file={}",
                dir.join("log/munged.log").display()
            ))
            .arg(format!("--pid-file={}", dir.join("munged.pid").display()))
            .arg(format!("--seed-file={}", dir.join("munged.seed").display()))
            .output()
            .unwrap();
        c.started.push(("munged", dir.join("munged.pid")));
        assert!(
            o.status.success(),
            "munged: {}\n{}",
            String::from_utf8_lossy(&o.stderr),
            tail(&dir.join("log/munged.log"))
        );
        let host = hostname();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let (ctld_port, d_port) = (free_port(), free_port());
        let d = dir.display();
        // NoInAddrAny and NoCtldInAddrAny: slurmd and slurmctld listen on
        // 127.0.0.1 (their NodeAddr and SlurmctldHost address), not on every
        // interface of the machine.
        let conf = format!(
            "ClusterName=rwgtest\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             SlurmctldPort={ctld_port}\n\
             SlurmdPort={d_port}\n\
             SlurmUser=root\n\
             AuthType=auth/munge\n\
             AuthInfo=socket={sock}\n\
             CryptoType=crypto/munge\n\
             MpiDefault=none\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core\n\
             SchedulerType=sched/backfill\n\
             AccountingStorageType=accounting_storage/none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             JobCompType=jobcomp/none\n\
             StateSaveLocation={d}/state\n\
             SlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\n\
             SlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/log/slurmctld.log\n\
             SlurmdLogFile={d}/log/slurmd.log\n\
             ReturnToService=2\n\
             CommunicationParameters=NoInAddrAny,NoCtldInAddrAny\n\
             MinJobAge=600\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
             PartitionName=rwgtest Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
            sock = sock.display(),
        );
        std::fs::write(&c.conf, conf).unwrap();
        for (daemon, pid) in [("slurmctld", "slurmctld.pid"), ("slurmd", "slurmd.pid")] {
            let mut cmd = Command::new(sbin(daemon));
            cmd.arg("-f").arg(&c.conf);
            if daemon == "slurmd" {
                cmd.args(["-N", &host]);
            }
            let o = cmd.env("SLURM_CONF", &c.conf).output().unwrap();
            c.started.push((daemon, dir.join(pid)));
            assert!(
                o.status.success(),
                "{daemon}: {}\n{}",
                String::from_utf8_lossy(&o.stderr),
                tail(&dir.join(format!("log/{daemon}.log")))
            );
        }
        let t0 = Instant::now();
        loop {
            let o = c.cmd("sinfo").args(["-h", "-o", "%T"]).output().unwrap();
            let state = String::from_utf8_lossy(&o.stdout).trim().to_string();
            if state == "idle" {
                break;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(60),
                "the node is not idle after 60 s (sinfo: {state:?} {})\nslurmctld:\n{}\nslurmd:\n{}",
                String::from_utf8_lossy(&o.stderr),
                tail(&dir.join("log/slurmctld.log")),
                tail(&dir.join("log/slurmd.log"))
            );
            std::thread::sleep(Duration::from_millis(200));
        }
        Ok(c)
    }

    /// A Slurm command (`sbatch`, `squeue`, ...) talking to this cluster.
    pub fn cmd(&self, prog: &str) -> Command {
        let mut c = Command::new(prog);
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// Runs a Slurm command; returns its output.
    pub fn run(&self, prog: &str, args: &[&str]) -> Output {
        self.cmd(prog).args(args).output().unwrap()
    }

    /// The state of every job or array task of `job` (`squeue -t all`):
    /// `(id, state, reason)`.
    pub fn jobs(&self, job: &str) -> Vec<(String, String, String)> {
        let o = self.run("squeue", &["-h", "-t", "all", "-o", "%i|%T|%r", "-j", job]);
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| {
                let mut it = l.split('|');
                Some((
                    it.next()?.to_string(),
                    it.next()?.to_string(),
                    it.next().unwrap_or("").to_string(),
                ))
            })
            .collect()
    }

    /// Waits until job `job` (every task of it) has left the running and
    /// pending states; returns the final states. Panics after `timeout`.
    pub fn wait_done(&self, job: &str, timeout: Duration) -> Vec<(String, String, String)> {
        let t0 = Instant::now();
        loop {
            let jobs = self.jobs(job);
            let active = [
                "PENDING",
                "RUNNING",
                "CONFIGURING",
                "COMPLETING",
                "REQUEUED",
            ];
            if !jobs.is_empty() && jobs.iter().all(|(_, s, _)| !active.contains(&s.as_str())) {
                return jobs;
            }
            assert!(
                t0.elapsed() < timeout,
                "job {job} not done after {timeout:?}: {jobs:?}\nslurmctld:\n{}",
                tail(&self.dir.join("log/slurmctld.log"))
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The tail of a daemon's log, for failure messages.
    pub fn log(&self, daemon: &str) -> String {
        tail(&self.dir.join(format!("log/{daemon}.log")))
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Cancel this cluster's jobs first, so no job step outlives slurmd.
        if self.started.iter().any(|(d, _)| *d == "slurmctld") {
            let _ = self.cmd("scancel").args(["--user", "root"]).output();
            let t0 = Instant::now();
            while t0.elapsed() < Duration::from_secs(10) {
                let o = self.cmd("squeue").args(["-h", "-o", "%i"]).output();
                if o.map_or(true, |o| o.stdout.is_empty()) {
                    break;
                }
                std::thread::sleep(Duration::from_millis(200));
            }
        }
        // Then the daemons, newest first, each by the pid its own file names.
        for (daemon, pid_file) in self.started.iter().rev() {
            let Some(pid) = read_pid(pid_file) else {
                eprintln!("note: {daemon} left no pid file {}", pid_file.display());
                continue;
            };
            // SAFETY: signalling a pid this cluster's daemon wrote.
            unsafe { libc::kill(pid, libc::SIGTERM) };
            let t0 = Instant::now();
            while alive(pid) && t0.elapsed() < Duration::from_secs(10) {
                std::thread::sleep(Duration::from_millis(100));
            }
            if alive(pid) {
                // SAFETY: as above.
                unsafe { libc::kill(pid, libc::SIGKILL) };
            }
        }
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

use super::*;
use std::time::{Duration, Instant};

fn alive(pid: i32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .map(|s| {
            !matches!(
                s[s.rfind(')').unwrap() + 2..].chars().next(),
                Some('Z' | 'X')
            )
        })
        .unwrap_or(false)
}

/// A daemon (setsid and a double fork: re-parented to rwg, in a session of
/// its own) started by a command with the next worker's mark; its pid and
/// the mark.
fn daemon(tag: &str) -> (i32, String) {
    let mut c = std::process::Command::new("sh");
    c.arg("-c")
        .arg("setsid sh -c 'sleep 600 > /dev/null 2>&1 & echo $!' < /dev/null");
    let mark = enlist(&mut c);
    let out = c.output().unwrap();
    let pid: i32 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();
    assert!(alive(pid), "{tag}: the daemon is not running");
    (pid, mark)
}

fn kill(pid: i32) {
    // SAFETY: killing the test's own stray.
    unsafe {
        libc::kill(pid, libc::SIGKILL);
        libc::waitpid(pid, std::ptr::null_mut(), 0);
    }
}

/// A worker's daemon ends with the worker; another worker's does not, even
/// one whose mark starts with the first one's (worker 1 and worker 10).
#[test]
fn a_workers_daemon_ends_with_it_and_no_other() {
    let mut started = vec![daemon("mine")];
    if started[0].1.ends_with(":0") {
        // worker 0: no other worker's number starts with its own
        kill(started[0].0);
        started[0] = daemon("mine");
    }
    // enough workers that one's number starts with the first one's
    let longer = format!("{}0", started[0].1);
    while started.last().unwrap().1 != longer {
        started.push(daemon("other"));
    }
    let (mine, mark) = started[0].clone();
    sweep(&mark);
    let t0 = Instant::now();
    while alive(mine) && t0.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(!alive(mine), "the worker's daemon outlived it");
    for (other, m) in &started[1..] {
        assert!(
            alive(*other),
            "worker {m}'s daemon was killed with {mark}'s"
        );
        kill(*other);
    }
}

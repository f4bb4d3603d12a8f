//! The line protocol between the coordinator and its child processes.
//!
//! A child prints `ready` once its endpoints exist, then reads one command per line on stdin and answers each
//! with one line on stdout (`error <why>` when a command fails). Logs go to stderr. The coordinator side is
//! [`Child`].

use std::{path::Path, process::Stdio, time::Duration};

use anyhow::{anyhow, bail, Context as _, Result};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader, Lines};

/// Commands arriving on this process's stdin.
pub struct Commands(Lines<BufReader<tokio::io::Stdin>>);

impl Commands {
    /// Starts reading stdin.
    pub fn new() -> Commands {
        Commands(BufReader::new(tokio::io::stdin()).lines())
    }

    /// The next command split into words; `None` at end of input or on `quit`.
    pub async fn next(&mut self) -> Option<Vec<String>> {
        loop {
            let line = self.0.next_line().await.ok()??;
            let words: Vec<String> = line.split_whitespace().map(str::to_owned).collect();
            match words.first().map(String::as_str) {
                None => continue,
                Some("quit") => return None,
                Some(_) => return Some(words),
            }
        }
    }
}

/// Answers the coordinator (one line).
pub fn reply(line: impl std::fmt::Display) {
    println!("{line}");
}

/// A child process of the coordinator, driven through its stdin and stdout.
pub struct Child {
    what: String,
    child: tokio::process::Child,
    stdin: tokio::process::ChildStdin,
    lines: Lines<BufReader<tokio::process::ChildStdout>>,
}

impl Child {
    /// Starts `program args...` with `ROS_DOMAIN_ID=domain` and waits up to `timeout` for its `ready` line.
    pub async fn start(
        program: &Path,
        args: &[&str],
        domain: u16,
        envs: &[(&str, &str)],
        timeout: Duration,
    ) -> Result<Child> {
        let what = format!(
            "{} {}",
            program.file_name().unwrap_or_default().to_string_lossy(),
            args.join(" ")
        );
        let mut cmd = tokio::process::Command::new(program);
        cmd.args(args)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .kill_on_drop(true);
        for (k, v) in envs {
            cmd.env(k, v);
        }
        let mut child = cmd.spawn().with_context(|| format!("starting `{what}`"))?;
        let stdin = child.stdin.take().expect("piped stdin");
        let lines = BufReader::new(child.stdout.take().expect("piped stdout")).lines();
        let mut c = Child {
            what,
            child,
            stdin,
            lines,
        };
        let first = c.line(timeout).await?;
        if first != "ready" {
            bail!("`{}` said {first:?} instead of `ready`", c.what);
        }
        Ok(c)
    }

    /// The process id (to read its CPU time).
    pub fn pid(&self) -> u32 {
        self.child.id().unwrap_or(0)
    }

    async fn line(&mut self, timeout: Duration) -> Result<String> {
        match tokio::time::timeout(timeout, self.lines.next_line()).await {
            Err(_) => bail!("`{}` did not answer within {timeout:?}", self.what),
            Ok(Err(e)) => Err(anyhow!("reading from `{}`: {e}", self.what)),
            Ok(Ok(None)) => {
                let status = self.child.wait().await.ok();
                bail!("`{}` exited ({status:?}); its stderr is above", self.what)
            }
            Ok(Ok(Some(l))) => Ok(l),
        }
    }

    /// Sends one command without waiting for its answer (read it with [`Child::answer`]).
    pub async fn send(&mut self, command: &str) -> Result<()> {
        self.stdin
            .write_all(format!("{command}\n").as_bytes())
            .await
            .with_context(|| format!("sending `{command}` to `{}`", self.what))?;
        self.stdin.flush().await?;
        Ok(())
    }

    /// The answer to the command sent last; an `error ...` answer becomes an error.
    pub async fn answer(&mut self, timeout: Duration) -> Result<String> {
        let answer = self.line(timeout).await?;
        if let Some(why) = answer.strip_prefix("error ") {
            bail!("`{}` failed: {why}", self.what);
        }
        Ok(answer)
    }

    /// Sends one command and returns the answer; an `error ...` answer becomes an error.
    pub async fn ask(&mut self, command: &str, timeout: Duration) -> Result<String> {
        self.send(command).await?;
        self.answer(timeout)
            .await
            .with_context(|| format!("answering `{command}`"))
    }

    /// Sends `command` and parses the answer as JSON.
    pub async fn ask_json(
        &mut self,
        command: &str,
        timeout: Duration,
    ) -> Result<serde_json::Value> {
        let a = self.ask(command, timeout).await?;
        serde_json::from_str(&a)
            .with_context(|| format!("`{}` answered `{command}` with {a:?}", self.what))
    }

    /// Kills the child with SIGKILL (no goodbye on the wire) and reaps it.
    pub async fn kill(mut self) {
        let _ = self.child.kill().await;
    }

    /// Sends SIGTERM, as a service manager stops a program, and waits up to `timeout`: how long it took to
    /// exit and its exit code (killed, and an error, past `timeout`).
    pub async fn terminate(mut self, timeout: Duration) -> Result<(Duration, Option<i32>)> {
        let pid = self.pid();
        let t = std::time::Instant::now();
        // SAFETY: kill(2) on our own child's pid; it has not been reaped (we hold it)
        if pid == 0 || unsafe { libc::kill(pid as i32, libc::SIGTERM) } != 0 {
            bail!("could not send SIGTERM to `{}`", self.what);
        }
        match tokio::time::timeout(timeout, self.child.wait()).await {
            Ok(status) => Ok((t.elapsed(), status?.code())),
            Err(_) => {
                let _ = self.child.kill().await;
                bail!("`{}` did not exit within {timeout:?} of SIGTERM", self.what)
            }
        }
    }

    /// Asks the child to quit and waits for it (killed after 5 s).
    pub async fn quit(mut self) {
        let _ = self.stdin.write_all(b"quit\n").await;
        if tokio::time::timeout(Duration::from_secs(5), self.child.wait())
            .await
            .is_err()
        {
            let _ = self.child.kill().await;
        }
    }
}

/// CPU time (user + system) a process has used, from `/proc/<pid>/stat`.
pub fn cpu_time(pid: u32) -> Result<Duration> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .with_context(|| format!("reading /proc/{pid}/stat"))?;
    // fields after the `(comm)`, which may contain spaces
    let rest = stat
        .rsplit_once(')')
        .map(|(_, r)| r)
        .ok_or_else(|| anyhow!("unexpected /proc/{pid}/stat"))?;
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 after `(comm)`
    let ticks: u64 = f[11].parse::<u64>()? + f[12].parse::<u64>()?;
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as u64;
    Ok(Duration::from_nanos(ticks * 1_000_000_000 / hz))
}

/// What the scheduler saw of a process, summed over its threads (`/proc/<pid>/task/*/schedstat`): time on a
/// core, time runnable but waiting for one, and how many times a thread was put on a core (a thread woken, or
/// given the core back after a preemption). Threads that ended before the read are not counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sched {
    /// Nanoseconds on a core.
    pub run_ns: u64,
    /// Nanoseconds runnable, waiting for a core.
    pub wait_ns: u64,
    /// Times a thread was put on a core.
    pub slices: u64,
}

impl Sched {
    /// What happened between `before` and `self`.
    pub fn since(self, before: Sched) -> Sched {
        Sched {
            run_ns: self.run_ns.saturating_sub(before.run_ns),
            wait_ns: self.wait_ns.saturating_sub(before.wait_ns),
            slices: self.slices.saturating_sub(before.slices),
        }
    }
}

impl std::ops::Add for Sched {
    type Output = Sched;
    fn add(self, o: Sched) -> Sched {
        Sched {
            run_ns: self.run_ns + o.run_ns,
            wait_ns: self.wait_ns + o.wait_ns,
            slices: self.slices + o.slices,
        }
    }
}

/// The scheduler's figures of process `pid` now by thread name (`/proc/<pid>/task/*/comm`), threads of one
/// name summed (a runtime's workers).
pub fn sched_by_thread(pid: u32) -> Result<std::collections::BTreeMap<String, Sched>> {
    let dir = format!("/proc/{pid}/task");
    let mut by = std::collections::BTreeMap::new();
    for t in std::fs::read_dir(&dir).with_context(|| format!("reading {dir}"))? {
        let path = t?.path();
        // a thread that ends between the listing and the read is left out
        let (Ok(line), Ok(name)) = (
            std::fs::read_to_string(path.join("schedstat")),
            std::fs::read_to_string(path.join("comm")),
        ) else {
            continue;
        };
        let f: Vec<u64> = line
            .split_whitespace()
            .map(str::parse)
            .collect::<std::result::Result<_, _>>()
            .with_context(|| format!("unexpected schedstat {line:?} in {dir}"))?;
        let [run_ns, wait_ns, slices] = f[..] else {
            bail!("unexpected schedstat {line:?} in {dir}");
        };
        let s: &mut Sched = by.entry(name.trim().to_owned()).or_default();
        *s = *s
            + Sched {
                run_ns,
                wait_ns,
                slices,
            };
    }
    Ok(by)
}

/// UDP datagrams sent and received so far in this process's network namespace (`/proc/self/net/snmp`'s
/// `OutDatagrams` and `InDatagrams`): under `tests/isolated.sh` only the benchmark's processes send any, so the
/// difference over a run is what the run's processes sent. `None` where the counters cannot be read.
pub fn udp_datagrams() -> Option<(u64, u64)> {
    let snmp = std::fs::read_to_string("/proc/self/net/snmp").ok()?;
    udp_datagrams_of(&snmp)
}

fn udp_datagrams_of(snmp: &str) -> Option<(u64, u64)> {
    let mut udp = snmp.lines().filter(|l| l.starts_with("Udp:"));
    let (names, values) = (udp.next()?, udp.next()?);
    let field = |want: &str| {
        let i = names.split_whitespace().position(|n| n == want)?;
        values.split_whitespace().nth(i)?.parse::<u64>().ok()
    };
    Some((field("OutDatagrams")?, field("InDatagrams")?))
}

/// This process's resident memory in bytes, from `/proc/self/status`.
pub fn rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .unwrap_or(0)
        * 1024
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn udp_datagrams_are_read_from_the_udp_lines_not_udplite() {
        let snmp = "Ip: Forwarding DefaultTTL\nIp: 1 64\n\
                    Udp: InDatagrams NoPorts InErrors OutDatagrams RcvbufErrors\n\
                    Udp: 120 3 0 77 0\n\
                    UdpLite: InDatagrams NoPorts InErrors OutDatagrams RcvbufErrors\n\
                    UdpLite: 9 9 9 9 9\n";
        assert_eq!(udp_datagrams_of(snmp), Some((77, 120)));
        assert_eq!(udp_datagrams_of("Ip: 1\n"), None);
    }

    #[test]
    fn sched_counts_this_process_working_and_a_thread_woken() {
        let pid = std::process::id();
        let sched = |pid| {
            sched_by_thread(pid)
                .unwrap()
                .into_values()
                .fold(Sched::default(), |a, b| a + b)
        };
        // this thread's CPU clock (the kernel's per-thread accounting, not schedstat) says when it has worked
        // 30 ms: a wall-clock loop works less on a loaded machine (other tests beside it)
        let thread_cpu = || {
            let mut ts = libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            };
            // SAFETY: `ts` is a valid timespec to write into.
            assert_eq!(
                unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) },
                0
            );
            Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
        };
        let before = sched(pid);
        let worked = thread_cpu();
        while thread_cpu() - worked < Duration::from_millis(30) {}
        // this thread sleeps and is woken ten times: ten more times on a core at least
        for _ in 0..10 {
            std::thread::sleep(Duration::from_millis(1));
        }
        let d = sched(pid).since(before);
        assert!(d.run_ns >= 20_000_000, "{d:?}");
        assert!(d.slices >= 10, "{d:?}");
    }

    #[test]
    fn cpu_time_grows_when_this_process_works() {
        let pid = std::process::id();
        let before = cpu_time(pid).unwrap();
        let t = std::time::Instant::now();
        let mut x = 0u64;
        while t.elapsed() < Duration::from_millis(100) {
            x = x.wrapping_mul(31).wrapping_add(7);
        }
        std::hint::black_box(x);
        assert!(cpu_time(pid).unwrap() > before);
        assert!(rss_bytes() > 0);
    }
}

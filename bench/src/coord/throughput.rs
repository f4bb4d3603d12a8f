//! Throughput scenarios: signals per second through a connection, stepped up until one is lost.

use super::*;

impl Bench {
    fn push_throughput(
        &mut self,
        key: &str,
        label: &str,
        n: usize,
        r: (f64, f64, Vec<Step>),
        connect_ms: Option<(f64, f64)>,
    ) {
        self.results.throughput.push(Throughput {
            key: key.into(),
            label: label.into(),
            connections: n,
            max_lossless: r.0,
            relay_cpu: r.1,
            connect_ms: connect_ms.map(|c| c.0),
            connect_fresh_ms: connect_ms.map(|c| c.1),
            steps: r.2,
        });
    }

    /// `connect-many` of `n` from `mgr`: the time it says (ms).
    async fn connect_many(mgr: &mut Child, n: usize) -> Result<f64> {
        let armed = mgr
            .ask(
                &format!("connect-many /bench/src /bench/sink {n}"),
                Duration::from_secs(300),
            )
            .await?;
        armed
            .strip_prefix("armed ")
            .and_then(|ms| ms.trim().parse::<f64>().ok())
            .ok_or_else(|| anyhow!("connect-many said {armed:?}"))
    }

    /// Waits (at most 30 s) until the processes `pids` together use under 5% of a core over half a second:
    /// their discovery of each other (and of a manager that left) is over.
    async fn settled(pids: &[u32]) -> Result<()> {
        let window = Duration::from_millis(500);
        let deadline = Instant::now() + Duration::from_secs(30);
        let used = || -> Result<Duration> { pids.iter().map(|p| cpu_time(*p)).sum() };
        loop {
            let before = used()?;
            tokio::time::sleep(window).await;
            if (used()? - before).as_secs_f64() < 0.05 * window.as_secs_f64()
                || Instant::now() > deadline
            {
                return Ok(());
            }
        }
    }

    /// The most signals per second forwarded with no loss.
    pub(super) async fn throughput(&mut self) -> Result<()> {
        // raw one hop
        let d = self.domain();
        let mut sink = self
            .child(d, &["sinks", "--prefix", "/bench/sink", "--count", "1"])
            .await?;
        let mut src = self
            .child(d, &["raw-source", "--topic", "/bench/sink_0/start"])
            .await?;
        src.ask("wait", START).await?;
        let r = self.ladder(&mut src, &mut sink, None).await?;
        self.push_throughput("raw_1hop", "raw ros2-client, 1 hop", 1, r, None);
        src.quit().await;
        sink.quit().await;
        // raw two hops
        let d = self.domain();
        let mut sink = self
            .child(d, &["sinks", "--prefix", "/bench/sink", "--count", "1"])
            .await?;
        let fwd = self
            .child(
                d,
                &[
                    "raw-forward",
                    "--from",
                    "/bench/src_0/triggered",
                    "--to",
                    "/bench/sink_0/start",
                ],
            )
            .await?;
        let mut src = self
            .child(d, &["raw-source", "--topic", "/bench/src_0/triggered"])
            .await?;
        src.ask("wait", START).await?;
        tokio::time::sleep(Duration::from_millis(300)).await;
        let pid = fwd.pid();
        let r = self.ladder(&mut src, &mut sink, Some(pid)).await?;
        self.push_throughput(
            "raw_2hop",
            "raw ros2-client, 2 hops (forwarding node)",
            1,
            r,
            None,
        );
        for c in [src, fwd, sink] {
            c.quit().await;
        }
        // through a radar_ros manager in its own process, with N live connections
        for n in self.plan.fanouts.clone() {
            let d = self.domain();
            let ns = n.to_string();
            let mut sink = self
                .child(d, &["sinks", "--prefix", "/bench/sink", "--count", &ns])
                .await?;
            let mut src = self
                .child(d, &["sources", "--prefix", "/bench/src", "--count", &ns])
                .await?;
            // a program started with the components' processes (they still discover each other), then one
            // connecting to them once they run settled, as a program does to a robot's running components
            let mut first = self.child(d, &["manager"]).await?;
            let fresh = Self::connect_many(&mut first, n).await?;
            first.quit().await;
            Self::settled(&[sink.pid(), src.pid()]).await?;
            let mut mgr = self.child(d, &["manager"]).await?;
            let connect = Self::connect_many(&mut mgr, n).await?;
            eprintln!(
                "radar_bench: {n} connections armed in {connect} ms ({fresh} ms with the components just started)"
            );
            src.ask("wait", Duration::from_secs(60)).await?;
            tokio::time::sleep(Duration::from_millis(300)).await;
            let pid = mgr.pid();
            let r = self.ladder(&mut src, &mut sink, Some(pid)).await?;
            self.push_throughput(
                &format!("radar_{n}"),
                &format!("radar_ros manager process, {n} live connection(s), load spread over all"),
                n,
                r,
                Some((connect, fresh)),
            );
            for c in [mgr, src, sink] {
                c.quit().await;
            }
        }
        Ok(())
    }

    /// Steps through the offered rates until a step loses signals.
    async fn ladder(
        &self,
        src: &mut Child,
        sink: &mut Child,
        relay: Option<u32>,
    ) -> Result<(f64, f64, Vec<Step>)> {
        let mut steps = Vec::new();
        let (mut best, mut best_cpu) = (0.0, 0.0);
        let count = |s: String| s.parse::<u64>().map_err(|_| anyhow!("bad count {s:?}"));
        for &rate in &self.plan.rates {
            let base = count(sink.ask("count", START).await?)?;
            let cpu0 = relay.map(cpu_time).transpose()?.unwrap_or_default();
            let t = Instant::now();
            let sent = count(
                src.ask(
                    &format!("rate {rate} {}", self.plan.window_ms),
                    Duration::from_millis(self.plan.window_ms) + START,
                )
                .await?,
            )?;
            // wait until everything arrived, or nothing more arrives for 500 ms
            let (mut last, mut since) = (u64::MAX, Instant::now());
            let mut got;
            loop {
                got = count(sink.ask("count", START).await?)? - base;
                if got >= sent || since.elapsed() > Duration::from_millis(500) {
                    break;
                }
                if got != last {
                    last = got;
                    since = Instant::now();
                }
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
            let wall = t.elapsed().as_secs_f64();
            let cpu = match relay {
                Some(pid) => (cpu_time(pid)? - cpu0).as_secs_f64() / wall,
                None => 0.0,
            };
            steps.push(Step {
                rate,
                sent,
                received: got,
                relay_cpu: cpu,
            });
            if got < sent {
                break;
            }
            (best, best_cpu) = (rate, cpu);
        }
        Ok((best, best_cpu, steps))
    }
}

//! The table, the JSON and the CDF plots of a run.

use std::{fmt::Write as _, path::Path};

use anyhow::{Context as _, Result};
use plotters::prelude::*;

use crate::{coord::Results, stats::cdf};

fn ratio(x: f64, base: Option<f64>) -> String {
    match base {
        Some(b) if b > 0.0 => format!("{:.2}x", x / b),
        _ => "-".into(),
    }
}

/// The results as Markdown tables (what `docs/benchmarks.md` shows).
pub fn table(r: &Results) -> String {
    let mut s = String::new();
    let hop = latency_table(&mut s, &r.latency);
    if !r.breakdown.is_empty() {
        breakdown_table(&mut s, &r.breakdown);
    }
    ms_table(
        &mut s,
        "Connections (milliseconds; ratio = p50 / raw 1-hop p50)",
        &r.setup,
        hop,
    );
    throughput_table(&mut s, &r.throughput);
    if !r.scale.is_empty() {
        scale_curve_table(&mut s, &r.scale);
    }
    if let Some(sc) = r.scale.last() {
        scale_table(&mut s, sc);
    }
    if !r.state_memory.is_empty() {
        memory_table(&mut s, &r.state_memory);
    }
    if !r.kill.is_empty() {
        ms_table(
            &mut s,
            "A deliberative program killed (SIGKILL; milliseconds)",
            &r.kill,
            None,
        );
    }
    if !r.codec.is_empty() {
        codec_table(&mut s, &r.codec);
    }
    for v in &r.view {
        view_table(&mut s, v);
    }
    if !r.errors.is_empty() {
        let _ = writeln!(s, "\n### Failed\n");
        for e in &r.errors {
            let _ = writeln!(s, "- {e}");
        }
    }
    s
}

/// The latency table; returns the raw 1-hop p50 that ratios are taken against.
fn latency_table(s: &mut String, latency: &[crate::coord::Latency]) -> Option<f64> {
    let p50_of = |key: &str| {
        latency
            .iter()
            .find(|l| l.key == key)
            .map(|l| l.summary.p50_us)
    };
    let (hop, floor) = (p50_of("raw_1hop"), p50_of("udp_floor"));
    let _ = writeln!(
        s,
        "### Latency (microseconds; ratio = p50 / raw 1-hop p50; x wire = p50 / UDP loopback p50)\n"
    );
    let _ = writeln!(
        s,
        "| path | n | p50 | p90 | p99 | max | ratio | x wire | missing | note |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for l in latency {
        let m = &l.summary;
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {:.0} | {:.0} | {:.0} | {} | {} | {} | {} |",
            l.label,
            m.n,
            m.p50_us,
            m.p90_us,
            m.p99_us,
            m.max_us,
            ratio(m.p50_us, hop),
            ratio(m.p50_us, floor),
            l.missing,
            l.note
        );
    }
    hop
}

/// One hop cut into stages (RustDDS's latency probe): a row per stage, p50 and p90 per path.
fn breakdown_table(s: &mut String, paths: &[serde_json::Value]) {
    let _ = writeln!(
        s,
        "\n### One hop by stage (microseconds, p50 / p90 of each stage; RustDDS probe on)\n"
    );
    let mut head = String::from("| stage |");
    let mut rule = String::from("|---|");
    for p in paths {
        let _ = write!(head, " {} |", p["label"].as_str().unwrap_or("?"));
        rule.push_str("---:|");
    }
    let _ = writeln!(s, "{head}\n{rule}");
    let cell = |v: &serde_json::Value| match (v["p50_us"].as_f64(), v["p90_us"].as_f64()) {
        (Some(a), Some(b)) => format!("{a:.1} / {b:.1}"),
        _ => "-".into(),
    };
    for (i, (name, _, _)) in crate::coord::SEGMENTS.iter().enumerate() {
        let mut row = format!("| {name} |");
        for p in paths {
            let _ = write!(row, " {} |", cell(&p["segments"][i]["summary"]));
        }
        let _ = writeln!(s, "{row}");
    }
    let mut row = String::from("| **whole hop** (samples joined) |");
    for p in paths {
        let _ = write!(row, " {} ({}) |", cell(&p["total"]), p["joined"]);
    }
    let _ = writeln!(s, "{row}");
}

/// The throughput table, ratios against the raw 1-hop row.
fn throughput_table(s: &mut String, throughput: &[crate::coord::Throughput]) {
    let base = throughput
        .iter()
        .find(|t| t.key == "raw_1hop")
        .map(|t| t.max_lossless);
    let _ = writeln!(
        s,
        "\n### Throughput (signals per second with none lost; ratio = / raw 1-hop)\n"
    );
    let _ = writeln!(
        s,
        "| path | connections | max lossless | ratio | relay CPU at that rate | first lossy step | connect all (by name, from the manager's process; the components settled) | the same, the components just started |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---|---:|---:|");
    let ms = |v: Option<f64>| v.map_or_else(|| "-".into(), |ms| format!("{ms:.0} ms"));
    for t in throughput {
        let lossy = t
            .steps
            .iter()
            .find(|st| st.received < st.sent)
            .map(|st| format!("{:.0}/s: {} of {} arrived", st.rate, st.received, st.sent))
            .unwrap_or_else(|| "none (highest step passed)".into());
        let cpu = if t.key == "raw_1hop" {
            "-".into()
        } else {
            format!("{:.0}% of a core", t.relay_cpu * 100.0)
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {} | {} | {} | {} | {} |",
            t.label,
            t.connections,
            t.max_lossless,
            ratio(t.max_lossless, base),
            cpu,
            lossy,
            ms(t.connect_ms),
            ms(t.connect_fresh_ms),
        );
    }
}

/// The largest scale step in detail.
fn scale_table(s: &mut String, sc: &serde_json::Value) {
    let f = |k: &str| sc[k].as_f64().unwrap_or(f64::NAN);
    let _ = writeln!(
        s,
        "\n### Scale: {} events, {} responses, {} connections in one process\n",
        sc["events"], sc["responses"], sc["connections"]
    );
    let _ = writeln!(s, "| measure | value |");
    let _ = writeln!(s, "|---|---:|");
    let rows = [
        ("spawn all components", format!("{:.0} ms", f("spawn_ms"))),
        (
            "memory per component (RSS)",
            format!("{:.1} KiB", f("bytes_per_component") / 1024.0),
        ),
        (
            "file descriptors: participant / with components (limit)",
            format!(
                "{} / {} ({})",
                sc["fds_participant"], sc["fds_components"], sc["fd_limit"]
            ),
        ),
        (
            "create all connections (to armed)",
            format!("{:.0} ms", f("connect_ms")),
        ),
        (
            "memory per connection (RSS)",
            format!("{:.2} KiB", f("bytes_per_connection") / 1024.0),
        ),
        (
            "events active while connected",
            format!("{}", sc["active_while_connected"]),
        ),
        ("drop all guards", format!("{:.1} ms", f("drop_ms"))),
        (
            "drop -> every event inactive",
            format!("{:.0} ms", f("all_inactive_ms")),
        ),
        (
            "events still active after teardown",
            format!("{}", sc["still_active_after_teardown"]),
        ),
        (
            "idle CPU, participant only",
            format!("{:.2}% of a core", f("cpu_idle_empty") * 100.0),
        ),
        (
            "idle CPU, components, no listeners",
            format!("{:.2}% of a core", f("cpu_idle_components") * 100.0),
        ),
        (
            "idle CPU, all connected, no signals",
            format!("{:.2}% of a core", f("cpu_idle_connected") * 100.0),
        ),
        (
            "SIGTERM -> exited (exit code)",
            format!("{:.0} ms ({})", f("sigterm_ms"), sc["sigterm_code"]),
        ),
        (
            "RSS: participant / + components / + connections",
            format!(
                "{:.1} / {:.1} / {:.1} MiB",
                f("rss_empty_bytes") / 1048576.0,
                f("rss_components_bytes") / 1048576.0,
                f("rss_connected_bytes") / 1048576.0
            ),
        ),
    ];
    for (k, v) in rows {
        let _ = writeln!(s, "| {k} | {v} |");
    }
}

/// Memory over long runs.
fn memory_table(s: &mut String, runs: &[serde_json::Value]) {
    let _ = writeln!(
        s,
        "\n### Memory over a long run (RSS; nobody subscribed to the latched topic)\n"
    );
    let _ = writeln!(
        s,
        "| run | writes | RSS at start | after 10% | at the end | end - 10% | time |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
    for m in runs {
        let rss: Vec<(u64, u64)> = serde_json::from_value(m["rss"].clone()).unwrap_or_default();
        let at = |i: usize| {
            rss.get(i)
                .map(|x| x.1 as f64 / 1048576.0)
                .unwrap_or(f64::NAN)
        };
        let (first, tenth, last) = (at(0), at(1), at(rss.len().saturating_sub(1)));
        let _ = writeln!(
            s,
            "| {} | {} | {first:.1} MiB | {tenth:.1} MiB | {last:.1} MiB | {:+.0} KiB | {:.1} s |",
            m["label"].as_str().unwrap_or("?"),
            rss.last().map(|x| x.0).unwrap_or(0),
            (last - tenth) * 1024.0,
            m["secs"].as_f64().unwrap_or(f64::NAN)
        );
    }
}

/// `radar view` with many components: the first picture, the updates a page gets, a browser's memory.
fn view_table(s: &mut String, v: &serde_json::Value) {
    let f = |x: &serde_json::Value| x.as_f64().unwrap_or(f64::NAN);
    let _ = writeln!(
        s,
        "\n### radar view, {} components ({} events, {} responses)\n",
        v["components"], v["events"], v["responses"]
    );
    let _ = writeln!(s, "| what | value |\n|---|---:|");
    let _ = writeln!(
        s,
        "| view started -> a page holds every component with its state | {:.2} s |",
        f(&v["first_picture_s"])
    );
    let _ = writeln!(
        s,
        "| a page joining later: its snapshot | {:.1} ms, {:.0} KiB |",
        f(&v["snapshot_ms"]),
        f(&v["snapshot_kib"])
    );
    let _ = writeln!(
        s,
        "| the watched process told to stop (SIGTERM) -> exited, the view attached (exit code) | {:.0} ms ({}) |",
        f(&v["sigterm_ms"]),
        v["sigterm_code"]
    );
    if let Some(b) = v["browser"].as_object() {
        let _ = writeln!(
            s,
            "| chromium: page opened -> every component drawn | {:.2} s |",
            f(&b["first_picture_s"])
        );
        let samples = b["samples"].as_array().cloned().unwrap_or_default();
        let mib = |x: &serde_json::Value| f(&x["heap"]) / 1048576.0;
        if let (Some(first), Some(last)) = (samples.first(), samples.last()) {
            let _ = writeln!(
                s,
                "| chromium JS heap (performance.memory): first / after {:.0} s of updates | {:.1} / {:.1} MiB ({} DOM elements) |",
                f(&last["t"]),
                mib(first),
                mib(last),
                last["dom"]
            );
        }
    }
    let _ = writeln!(
        s,
        "\n| starts/s | messages/s to a page | KiB/s | component updates/s | timeline lines/s | dropped/s | view CPU |"
    );
    let _ = writeln!(s, "|---:|---:|---:|---:|---:|---:|---:|");
    for st in v["steps"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "| {:.0} | {:.1} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0}% |",
            f(&st["starts_per_s"]),
            f(&st["messages_per_s"]),
            f(&st["kib_per_s"]),
            f(&st["component_updates_per_s"]),
            f(&st["lines_per_s"]),
            f(&st["dropped_per_s"]),
            f(&st["view_cpu"]) * 100.0
        );
    }
}

/// A table of durations in milliseconds, one row per distribution.
fn ms_table(s: &mut String, title: &str, rows: &[crate::coord::Latency], base_us: Option<f64>) {
    let _ = writeln!(s, "\n### {title}\n");
    let _ = writeln!(s, "| step | n | p50 | p90 | max | ratio |");
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
    for l in rows {
        let m = &l.summary;
        let _ = writeln!(
            s,
            "| {} | {} | {:.3} | {:.3} | {:.3} | {} |",
            l.label,
            m.n,
            m.p50_us / 1000.0,
            m.p90_us / 1000.0,
            m.max_us / 1000.0,
            ratio(m.p50_us, base_us)
        );
    }
}

/// Encoding and decoding one payload (nanoseconds per message); ratio: p50 against the hand-written struct's
/// row of the same message and direction.
fn codec_table(s: &mut String, rows: &[crate::coord::Latency]) {
    let _ = writeln!(
        s,
        "\n### Payload encoding, in one process (nanoseconds per message; ratio = p50 / the hand-written struct's)\n"
    );
    let _ = writeln!(s, "| payload: operation | n | p50 | p90 | max | ratio |");
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
    for l in rows {
        let m = &l.summary;
        // codec_<msg>_<encode|decode>_<hand|generated|runtime>
        let base_key = match l.key.rsplit_once('_') {
            Some((stem, _)) => format!("{stem}_hand"),
            None => l.key.clone(),
        };
        let base = rows
            .iter()
            .find(|b| b.key == base_key)
            .map(|b| b.summary.p50_us);
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {:.0} | {:.0} | {} |",
            l.label,
            m.n,
            m.p50_us * 1000.0,
            m.p90_us * 1000.0,
            m.max_us * 1000.0,
            ratio(m.p50_us, base)
        );
    }
}

/// One row per step of the scale curve.
fn scale_curve_table(s: &mut String, steps: &[serde_json::Value]) {
    let _ = writeln!(
        s,
        "\n### Scale curve: components in one process (half events, half responses; each event in two \
         connections)\n"
    );
    let _ = writeln!(
        s,
        "| components | spawn | per component | per event, first / last tenth | per response, first / last tenth | RSS per event | RSS per response | fds (participant) | idle CPU per 1,000 components | idle CPU, connected, per 1,000 | the same once discovery settled (measured from, after the last connection) | connect all | drop -> all inactive | SIGTERM -> exited |"
    );
    let _ = writeln!(
        s,
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for sc in steps {
        let f = |k: &str| sc[k].as_f64().unwrap_or(f64::NAN);
        let n = f("events") + f("responses");
        let per_k = |k: &str| f(k) * 100.0 * 1000.0 / n;
        let _ = writeln!(
            s,
            "| {n} | {:.0} ms | {:.2} ms | {:.2} / {:.2} ms | {:.2} / {:.2} ms | {:.1} KiB | {:.1} KiB | {} ({}) | {:.2}% of a core | {:.2}% | {:.2}% ({:.1} s) | {:.0} ms ({} connections) | {:.0} ms | {:.0} ms ({}) |",
            f("spawn_ms"),
            f("spawn_ms") / n,
            f("spawn_event_first_tenth_ms"),
            f("spawn_event_last_tenth_ms"),
            f("spawn_response_first_tenth_ms"),
            f("spawn_response_last_tenth_ms"),
            f("bytes_per_event") / 1024.0,
            f("bytes_per_response") / 1024.0,
            sc["fds_components"],
            sc["fds_participant"],
            per_k("cpu_idle_components"),
            per_k("cpu_idle_connected"),
            per_k("cpu_idle_connected_settled"),
            f("settle_ms") / 1000.0,
            f("connect_ms"),
            sc["connections"],
            f("all_inactive_ms"),
            f("sigterm_ms"),
            sc["sigterm_code"],
        );
    }
}

/// One chart of the scale curve: title, unit, and its series (label, points).
type Panel<'a> = (&'a str, &'a str, Vec<(&'a str, Vec<(f64, f64)>)>);

/// The scale curve: memory, descriptors, spawn time and idle CPU against the number of components.
fn scale_svg(path: &Path, steps: &[serde_json::Value]) -> Result<()> {
    let pts = |y: &dyn Fn(&serde_json::Value, f64) -> f64| -> Vec<(f64, f64)> {
        steps
            .iter()
            .map(|sc| {
                let n =
                    sc["events"].as_f64().unwrap_or(0.0) + sc["responses"].as_f64().unwrap_or(0.0);
                (n, y(sc, n))
            })
            .filter(|(n, y)| *n > 0.0 && y.is_finite())
            .collect()
    };
    let get = |sc: &serde_json::Value, k: &str| sc[k].as_f64().unwrap_or(f64::NAN);
    let panels: [Panel; 4] = [
        (
            "memory per component",
            "KiB (RSS)",
            vec![
                ("event", pts(&|sc, _| get(sc, "bytes_per_event") / 1024.0)),
                (
                    "response",
                    pts(&|sc, _| get(sc, "bytes_per_response") / 1024.0),
                ),
            ],
        ),
        (
            "spawn time per component",
            "ms",
            vec![("spawn", pts(&|sc, n| get(sc, "spawn_ms") / n))],
        ),
        (
            "idle CPU per 1,000 components",
            "% of a core",
            vec![
                (
                    "unconnected",
                    pts(&|sc, n| get(sc, "cpu_idle_components") * 1e5 / n),
                ),
                (
                    "connected",
                    pts(&|sc, n| get(sc, "cpu_idle_connected") * 1e5 / n),
                ),
            ],
        ),
        (
            "open file descriptors",
            "count",
            vec![("with components", pts(&|sc, _| get(sc, "fds_components")))],
        ),
    ];
    let root = SVGBackend::new(path, (1000, 700)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        "Scale: components in one process (x: components, log scale)",
        ("sans-serif", 20),
    )?;
    let (xlo, xhi) = steps
        .iter()
        .map(|sc| sc["events"].as_f64().unwrap_or(1.0) + sc["responses"].as_f64().unwrap_or(1.0))
        .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let (xlo, xhi) = if xlo > xhi {
        (1.0, 10.0)
    } else {
        (xlo * 0.7, xhi * 1.4)
    };
    for (area, (title, unit, series)) in root.split_evenly((2, 2)).iter().zip(panels) {
        let ymax = series
            .iter()
            .flat_map(|(_, p)| p.iter().map(|(_, y)| *y))
            .fold(0.0f64, f64::max)
            .max(1e-3)
            * 1.25;
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d((xlo..xhi).log_scale(), 0.0..ymax)?;
        chart.configure_mesh().y_desc(unit).draw()?;
        for (i, (label, p)) in series.into_iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(p.clone(), color.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
            chart.draw_series(
                p.into_iter()
                    .map(|(x, y)| Circle::new((x, y), 3, color.filled())),
            )?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Draws the CDFs of `series` (label, samples in ns) on a log-scale time axis.
fn cdf_svg(path: &Path, title: &str, series: &[(&str, &[u64])], unit_ms: bool) -> Result<()> {
    let scale = if unit_ms { 1000.0 } else { 1.0 };
    let lines: Vec<(&str, Vec<(f64, f64)>)> = series
        .iter()
        .filter(|(_, s)| !s.is_empty())
        .map(|(l, s)| {
            (
                *l,
                cdf(s, 400)
                    .into_iter()
                    .map(|(x, y)| ((x / scale).max(1e-3), y))
                    .collect(),
            )
        })
        .collect();
    let (lo, hi) = lines
        .iter()
        .flat_map(|(_, p)| p.iter().map(|(x, _)| *x))
        .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let (lo, hi) = if lo > hi {
        (1.0, 10.0)
    } else {
        (lo * 0.8, hi * 1.25)
    };
    let root = SVGBackend::new(path, (900, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(52)
        .build_cartesian_2d((lo..hi).log_scale(), 0.0..1.0)?;
    chart
        .configure_mesh()
        .x_desc(if unit_ms {
            "milliseconds (log scale)"
        } else {
            "microseconds (log scale)"
        })
        .y_desc("fraction of signals at or below")
        .draw()?;
    for (i, (label, pts)) in lines.into_iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Writes `results.json`, `table.md`, `latency_cdf.svg`, `setup_cdf.svg` and `scale_curve.svg` into `dir`.
pub fn write(r: &Results, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    std::fs::write(dir.join("results.json"), serde_json::to_string_pretty(r)?)?;
    std::fs::write(dir.join("table.md"), table(r))?;
    let lat: Vec<(&str, &[u64])> = r
        .latency
        .iter()
        .map(|l| (l.key.as_str(), l.samples.as_slice()))
        .collect();
    cdf_svg(
        &dir.join("latency_cdf.svg"),
        "Signal latency across processes (CDF)",
        &lat,
        false,
    )?;
    let setup: Vec<(&str, &[u64])> = r
        .setup
        .iter()
        .map(|l| (l.key.as_str(), l.samples.as_slice()))
        .collect();
    cdf_svg(
        &dir.join("setup_cdf.svg"),
        "Connection setup and teardown (CDF)",
        &setup,
        true,
    )?;
    if !r.scale.is_empty() {
        scale_svg(&dir.join("scale_curve.svg"), &r.scale)?;
    }
    Ok(())
}

//! `radar graph`: the components and live connections of every program as a picture (like rtstodot, live).

use std::time::Duration;

use radar_ros::{msg::ConnectionList, Radar};

use crate::{
    common::{discover, latest, state_of, with_status, Fallible, Out, Stop},
    picture,
};

/// `radar graph`: draws the graph once, or with `watch` every second.
pub(crate) async fn draw(
    radar: &Radar,
    out: &Out,
    discovery: Duration,
    output: Option<std::path::PathBuf>,
    watch: bool,
    duration: Option<f64>,
) -> Fallible<()> {
    let svg = match output
        .as_ref()
        .and_then(|p| p.extension())
        .and_then(|e| e.to_str())
    {
        Some("svg") => true,
        Some("dot") | Some("gv") => false,
        None if output.is_none() => false,
        _ => return Err("the output file ends in .svg or .dot".into()),
    };
    // with --watch: redraw until Ctrl-C or SIGTERM
    let mut stop = match watch {
        true => Some(Stop::catch()?),
        false => None,
    };
    with_status("discovering", discover(radar, discovery)).await;
    let end = tokio::time::Instant::now()
        + duration
            .map(Duration::from_secs_f64)
            .unwrap_or(Duration::from_secs(u64::MAX / 4));
    loop {
        let p = gather(radar).await;
        let text = if svg { p.svg() } else { p.dot() };
        match &output {
            Some(path) => std::fs::write(path, &text)
                .map_err(|e| crate::Error::io(format!("write {}", path.display()), e))?,
            None if !out.json => print!("{text}"),
            None => {}
        }
        if out.json {
            println!("{}", serde_json::to_string(&p)?);
        } else if let Some(path) = &output {
            if !watch {
                println!(
                    "{}: {} components, {} connections",
                    path.display(),
                    p.nodes.len(),
                    p.edges.len()
                );
            }
        }
        let Some(stop) = stop.as_mut().filter(|_| tokio::time::Instant::now() < end) else {
            return Ok(());
        };
        tokio::select! {
            _ = tokio::time::sleep_until(end.min(tokio::time::Instant::now() + Duration::from_secs(1))) => {}
            _ = stop.requested() => return Ok(()),
        }
    }
}

/// Every component with its state, and every program's connections.
async fn gather(radar: &Radar) -> picture::Picture {
    let components = radar.components();
    let states = futures::future::join_all(
        components
            .iter()
            .map(|c| state_of(radar, c, Duration::from_secs(3))),
    )
    .await;
    let mut p = picture::Picture::default();
    for (c, s) in components.iter().zip(states) {
        p.nodes.push(picture::Node {
            name: c.name().fully_qualified(),
            kind: c.kind().into(),
            active: s.as_ref().and_then(|s| s["active"].as_bool()),
            state: s
                .as_ref()
                .and_then(|s| s["state_label"].as_str().map(str::to_owned)),
        });
    }
    let lists =
        futures::future::join_all(radar.introspect().connection_topics().into_iter().map(
            |t| async move { latest::<ConnectionList>(radar, &t, Duration::from_secs(3)).await },
        ))
        .await;
    for list in lists.into_iter().flatten() {
        for k in list.connections {
            let (source, signal) = picture::split(&k.source);
            let (target, slot) = picture::split(&k.target);
            p.edges.push(picture::Edge {
                id: k.id,
                program: list.manager.clone(),
                kind: k.kind_label.clone(),
                source,
                signal,
                target,
                slot,
                until: (!k.until.is_empty()).then(|| picture::split(&k.until).0),
                state: k.state_label.clone(),
            });
        }
    }
    // a manager node and its program node show the same connections: keep one of each
    p.edges.sort_by(|a, b| {
        (a.id, &a.source, &a.target, &a.program).cmp(&(b.id, &b.source, &b.target, &b.program))
    });
    p.edges.dedup_by(|a, b| {
        (a.id, &a.source, &a.target, &a.kind) == (b.id, &b.source, &b.target, &b.kind)
    });
    p.complete();
    p
}

//! The web side of `radar view`: the page (HTML, script and style built into the binary: no CDN, nothing
//! from the internet), and `/ws`, the WebSocket each page reads the hub's messages from and asks on.
//!
//! What a page may ask, one JSON object per text message:
//! - `{"op":"params","component":NAME}`: the component's parameters, answered `{"type":"params",..}`;
//! - `{"op":"act","slot":"start"|"interrupt"|"exit","component":NAME,"payload":YAML}`: what `radar act`
//!   sends, answered `{"type":"acted",..}`; refused (`{"type":"error",..}`) unless `--allow-act`.
//!
//! A WebSocket is only accepted from a page this server served (its `Origin` is this host), so that another
//! web site open in the same browser cannot drive the robot through it.

use std::{collections::HashMap, sync::Arc, time::Duration};

use axum::{
    extract::{
        ws::{Message, WebSocket, WebSocketUpgrade},
        State,
    },
    http::{header, HeaderMap, StatusCode},
    response::{IntoResponse, Response},
    routing::get,
    Router,
};
use futures::{SinkExt, StreamExt};
use radar_ros::{topics::RawPublisher, Radar};
use serde_json::{json, Value};
use tokio::sync::mpsc;

use super::hub::{Ask, PAGE_BACKLOG};
use crate::codec;

const PAGE: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/view.js");
const STYLE: &str = include_str!("page/view.css");
const ICON: &str = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 16 16\"><circle cx=\"8\" cy=\"8\" \
                    r=\"6\" fill=\"none\" stroke=\"#0969da\" stroke-width=\"2\"/><circle cx=\"8\" cy=\"8\" r=\"2\" \
                    fill=\"#0969da\"/></svg>";

/// Only what this server serves: the page loads nothing from anywhere else.
const POLICY: &str =
    "default-src 'self'; connect-src 'self'; img-src 'self' data:; object-src 'none'; \
                      base-uri 'none'; frame-ancestors 'none'";

/// How long acting waits for a response and for its slot's subscriber.
const ACT_TIMEOUT: Duration = Duration::from_secs(3);

/// What the routes share.
pub(crate) struct Shared {
    pub(crate) radar: Radar,
    pub(crate) asks: mpsc::UnboundedSender<Ask>,
    pub(crate) allow_act: bool,
    /// Slot publishers made by acting, by topic (kept: a new one each time would wait for matching again).
    publishers: tokio::sync::Mutex<HashMap<String, RawPublisher>>,
}

impl Shared {
    pub(crate) fn new(radar: Radar, asks: mpsc::UnboundedSender<Ask>, allow_act: bool) -> Shared {
        Shared {
            radar,
            asks,
            allow_act,
            publishers: Default::default(),
        }
    }
}

/// The routes.
pub(crate) fn app(shared: Arc<Shared>) -> Router {
    let file = |body: &'static str, kind: &'static str| {
        get(move || async move {
            (
                [
                    (header::CONTENT_TYPE, kind),
                    (header::CONTENT_SECURITY_POLICY, POLICY),
                    (header::CACHE_CONTROL, "no-cache"),
                ],
                body,
            )
        })
    };
    Router::new()
        .route("/", file(PAGE, "text/html; charset=utf-8"))
        .route("/view.js", file(SCRIPT, "text/javascript; charset=utf-8"))
        .route("/view.css", file(STYLE, "text/css; charset=utf-8"))
        .route("/favicon.svg", file(ICON, "image/svg+xml"))
        .route("/favicon.ico", file(ICON, "image/svg+xml"))
        .route("/ws", get(upgrade))
        .with_state(shared)
}

/// `GET /ws`: a page's WebSocket, if it comes from a page this server served.
async fn upgrade(
    ws: WebSocketUpgrade,
    headers: HeaderMap,
    State(shared): State<Arc<Shared>>,
) -> Response {
    if let Err(why) = same_origin(&headers) {
        return (StatusCode::FORBIDDEN, why).into_response();
    }
    ws.on_upgrade(move |socket| session(socket, shared))
}

/// Accepts a request with no `Origin` (not from a browser: scripts, tests) or one whose `Origin` is the host it
/// was sent to (the page this server served).
fn same_origin(headers: &HeaderMap) -> Result<(), String> {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return Ok(());
    };
    let origin = origin.to_str().unwrap_or_default();
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or_default();
    match origin.strip_prefix("http://") {
        Some(o) if !host.is_empty() && o == host => Ok(()),
        _ => Err(format!(
            "radar view takes WebSockets only from its own page (Origin {origin} is not http://{host})"
        )),
    }
}

/// One page: the hub's messages out, its asks in, until either side ends. A page too far behind is closed
/// (it reconnects and takes a new snapshot).
async fn session(socket: WebSocket, shared: Arc<Shared>) {
    let (to_page, mut from_hub) = mpsc::channel(PAGE_BACKLOG);
    if shared.asks.send(Ask::Join(to_page)).is_err() {
        return;
    }
    let (mut sink, mut stream) = socket.split();
    // answers to the page's asks, which may take a while (acting waits for a subscriber): out of the loop
    let (answers, mut answered) = mpsc::unbounded_channel::<Value>();
    loop {
        let text: String = tokio::select! {
            m = from_hub.recv() => match m {
                Some(text) => text.as_ref().to_owned(),
                None => {
                    let _ = sink.send(Message::Close(Some(axum::extract::ws::CloseFrame {
                        code: 1013,
                        reason: "this page fell behind: reconnect for a new snapshot".into(),
                    }))).await;
                    return;
                }
            },
            a = answered.recv() => match a {
                Some(a) => a.to_string(),
                None => return,
            },
            m = stream.next() => match m {
                Some(Ok(Message::Text(t))) => {
                    let (shared, answers) = (shared.clone(), answers.clone());
                    let ask = t.as_str().to_owned();
                    tokio::spawn(async move {
                        let _ = answers.send(answer(&shared, &ask).await);
                    });
                    continue;
                }
                Some(Ok(Message::Close(_))) | None | Some(Err(_)) => return,
                Some(Ok(_)) => continue,
            },
        };
        if sink.send(Message::Text(text.into())).await.is_err() {
            return;
        }
    }
}

/// The answer to one ask of a page.
async fn answer(shared: &Shared, ask: &str) -> Value {
    let ask: Value = match serde_json::from_str(ask) {
        Ok(v) => v,
        Err(e) => return error(format!("not JSON: {e}")),
    };
    let component = ask["component"].as_str().unwrap_or_default();
    match ask["op"].as_str() {
        Some("params") => params(shared, component).await,
        Some("act") => match act(shared, &ask, component).await {
            Ok(v) => v,
            Err(e) => error(e.report().to_string()),
        },
        _ => error(format!(
            "unknown op {}: params or act",
            ask["op"].as_str().unwrap_or("(none)")
        )),
    }
}

fn error(message: String) -> Value {
    json!({ "type": "error", "message": message })
}

/// `{"op":"params"}`: the component's parameters, `null` if it serves none.
async fn params(shared: &Shared, component: &str) -> Value {
    let radar = &shared.radar;
    let params = match radar.introspect().serves_parameters(component) {
        false => Value::Null,
        true => match radar
            .parameters_of(component)
            .timeout(Duration::from_secs(3))
            .await
        {
            Ok(ps) => ps
                .iter()
                .map(|(n, v)| (n.clone(), crate::verbs::cat::param_json(v)))
                .collect::<serde_json::Map<_, _>>()
                .into(),
            Err(e) => return error(format!("parameters of {component}: {}", e.report())),
        },
    };
    json!({ "type": "params", "component": component, "params": params })
}

/// `{"op":"act"}`: publishes into a response's slot, as `radar act` does (the signal that follows is on the
/// timeline).
async fn act(shared: &Shared, ask: &Value, component: &str) -> crate::common::Fallible<Value> {
    if !shared.allow_act {
        return Err("acting from the page is off: start radar view with --allow-act".into());
    }
    let slot = ask["slot"].as_str().unwrap_or_default();
    let payload = ask["payload"].as_str().unwrap_or_default();
    let r = shared
        .radar
        .response(component)
        .timeout(ACT_TIMEOUT)
        .await?;
    let slot_ref = match slot {
        "start" => r.start_slot(),
        "interrupt" => r.interrupt_slot(),
        "exit" => r.exit_slot(),
        other => return Err(format!("no slot {other:?}: start, interrupt or exit").into()),
    };
    if slot != "start" && !payload.trim().is_empty() {
        return Err(format!("only start takes a payload; {slot} does not").into());
    }
    let raw = codec::encode(slot_ref.ros_type(), payload)?;
    let mut publishers = shared.publishers.lock().await;
    let publisher = match publishers.entry(slot_ref.topic().to_owned()) {
        std::collections::hash_map::Entry::Occupied(p) => p.into_mut(),
        std::collections::hash_map::Entry::Vacant(v) => v.insert(
            shared
                .radar
                .raw_publisher(slot_ref.topic(), slot_ref.ros_type())?,
        ),
    };
    publisher
        .wait_for_subscribers(1)
        .timeout(ACT_TIMEOUT)
        .await?;
    publisher.publish(raw)?;
    Ok(json!({ "type": "acted", "component": r.name().fully_qualified(), "slot": slot }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(origin: Option<&str>, host: &str) -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert(header::HOST, host.parse().unwrap());
        if let Some(o) = origin {
            h.insert(header::ORIGIN, o.parse().unwrap());
        }
        h
    }

    #[test]
    fn websockets_are_taken_from_the_served_page_and_from_scripts_only() {
        assert!(same_origin(&headers(Some("http://127.0.0.1:8780"), "127.0.0.1:8780")).is_ok());
        assert!(same_origin(&headers(None, "127.0.0.1:8780")).is_ok());
        let other = same_origin(&headers(Some("https://evil.example"), "127.0.0.1:8780"));
        assert!(other.unwrap_err().contains("only from its own page"));
        assert!(same_origin(&headers(Some("http://127.0.0.1:9999"), "127.0.0.1:8780")).is_err());
        assert!(same_origin(&headers(Some("null"), "127.0.0.1:8780")).is_err());
    }
}

//! `radar view --foxglove PORT` (the `foxglove` cargo feature): the view's live data through the Foxglove SDK's
//! WebSocket server, so that Foxglove and Lichtblick show RADAR next to everything else. It reads the hub as a
//! page does (a snapshot, then changes) and gives:
//! - a channel per component state, `<component>/state` (JSON, with a JSON Schema named after its ROS type,
//!   `radar_msgs/msg/EventState` or `radar_msgs/msg/ResponseState`), logged at each change;
//! - a channel per signal, `<component>/<signal>` (JSON: the payload decoded, schema named after its ROS type),
//!   logged at the time it was sent;
//! - the connection graph (the SDK's `ConnectionGraph` capability): each component publishes its signals and
//!   subscribes its slots; each program's manager subscribes a connection's source (and `until`) and publishes
//!   into its target.

use std::{collections::BTreeMap, net::IpAddr, sync::Arc};

use foxglove::{
    websocket::{Capability, ConnectionGraph},
    ChannelBuilder, Context, PartialMetadata, RawChannel, Schema, WebSocketServer,
};
use serde_json::{json, Value};
use tokio::sync::mpsc;

use super::hub::{Ask, PAGE_BACKLOG};
use crate::common::Fallible;

/// The Foxglove side: its server, its channels by topic, what the graph is drawn from.
struct Bridge {
    ctx: Arc<Context>,
    server: foxglove::WebSocketServerHandle,
    channels: BTreeMap<String, Arc<RawChannel>>,
    components: BTreeMap<String, Value>,
    managers: BTreeMap<String, Value>,
}

/// Starts the Foxglove server on `bind:port` and feeds it from the hub until the hub ends; returns the port.
pub(crate) async fn start(
    bind: IpAddr,
    port: u16,
    asks: mpsc::UnboundedSender<Ask>,
) -> Fallible<(u16, tokio::task::JoinHandle<()>)> {
    let ctx = Context::new();
    let server = WebSocketServer::new()
        .name("radar view")
        .bind(bind.to_string(), port)
        .capabilities([Capability::ConnectionGraph])
        .context(&ctx)
        .start()
        .await
        .map_err(|e| {
            crate::Error::other(
                format!("cannot start the Foxglove server on {bind}:{port}"),
                e,
            )
        })?;
    let port = server.port();
    let mut bridge = Bridge {
        ctx,
        server,
        channels: BTreeMap::new(),
        components: BTreeMap::new(),
        managers: BTreeMap::new(),
    };
    let task = tokio::spawn(async move {
        // as a page: joined again if the hub dropped it for falling behind
        loop {
            let (tx, mut rx) = mpsc::channel(PAGE_BACKLOG);
            if asks.send(Ask::Join(tx)).is_err() {
                break;
            }
            while let Some(text) = rx.recv().await {
                if let Ok(m) = serde_json::from_str::<Value>(&text) {
                    bridge.take(&m);
                }
            }
            if asks.is_closed() {
                break;
            }
        }
        let _ = bridge.server.stop();
    });
    Ok((port, task))
}

impl Bridge {
    /// One message of the hub.
    fn take(&mut self, m: &Value) {
        if m["type"] == "snapshot" {
            self.components.clear();
            self.managers.clear();
        }
        for c in m["components"].as_array().into_iter().flatten() {
            let name = c["name"].as_str().unwrap_or_default().to_owned();
            self.state(&name, c);
            self.components.insert(name, c.clone());
        }
        for g in m["gone"].as_array().into_iter().flatten() {
            self.components.remove(g.as_str().unwrap_or_default());
        }
        if let Some(ms) = m["managers"].as_object() {
            for (k, v) in ms {
                self.managers.insert(k.clone(), v.clone());
            }
        }
        for g in m["managers_gone"].as_array().into_iter().flatten() {
            self.managers.remove(g.as_str().unwrap_or_default());
        }
        for line in m["timeline"].as_array().into_iter().flatten() {
            self.signal(line);
        }
        let _ = self.server.publish_connection_graph(self.graph());
    }

    /// Logs a component's state on `<component>/state`.
    fn state(&mut self, name: &str, c: &Value) {
        if c["state"].is_null() {
            return;
        }
        let ros_type = match c["kind"].as_str() {
            Some("event") => "radar_msgs/msg/EventState",
            _ => "radar_msgs/msg/ResponseState",
        };
        let stamp = &c["state"]["stamp"];
        let t = stamp["sec"].as_i64().unwrap_or(0) * 1_000_000_000
            + stamp["nanosec"].as_i64().unwrap_or(0);
        self.log(&format!("{name}/state"), ros_type, &c["state"], t);
    }

    /// Logs a timeline line (a signal) on `<component>/<signal>`.
    fn signal(&mut self, line: &Value) {
        let (component, signal) = (
            line["component"].as_str().unwrap_or_default(),
            line["signal"].as_str().unwrap_or_default(),
        );
        let ros_type = self
            .components
            .get(component)
            .and_then(|c| c["topics"][signal]["type"].as_str().map(str::to_owned));
        let ros_type = ros_type.unwrap_or_else(|| "radar/Signal".into());
        let t = line["t"].as_i64().unwrap_or(0);
        self.log(
            &format!("{component}/{signal}"),
            &ros_type,
            &line["payload"],
            t,
        );
    }

    /// Logs `value` as JSON on `topic` (made on first use, its schema inferred from this first value).
    fn log(&mut self, topic: &str, ros_type: &str, value: &Value, t: i64) {
        if !self.channels.contains_key(topic) {
            let schema = serde_json::to_vec(&json_schema(value)).unwrap_or_default();
            match ChannelBuilder::new(topic)
                .message_encoding("json")
                .schema(Schema::new(ros_type, "jsonschema", schema))
                .context(&self.ctx)
                .build_raw()
            {
                Ok(c) => {
                    self.channels.insert(topic.to_owned(), c);
                }
                Err(e) => {
                    tracing::warn!("radar view: no Foxglove channel {topic}: {e}");
                    return;
                }
            }
        }
        let body = serde_json::to_vec(value).unwrap_or_default();
        let meta = PartialMetadata {
            log_time: (t > 0).then_some(t as u64),
        };
        self.channels[topic].log_with_meta(&body, meta);
    }

    /// Who publishes and subscribes what, from the components' topics and the managers' connections.
    fn graph(&self) -> ConnectionGraph {
        let mut published: BTreeMap<String, Vec<String>> = BTreeMap::new();
        let mut subscribed: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for (name, c) in &self.components {
            for (label, t) in c["topics"].as_object().into_iter().flatten() {
                let topic = t["topic"].as_str().unwrap_or_default().to_owned();
                let side = match label.as_str() {
                    "start" | "interrupt" | "exit" => &mut subscribed,
                    _ => &mut published,
                };
                side.entry(topic).or_default().push(name.clone());
            }
        }
        for (manager, list) in &self.managers {
            for k in list.as_array().into_iter().flatten() {
                for from in ["source", "until"] {
                    if let Some(t) = k[from].as_str().filter(|t| !t.is_empty()) {
                        subscribed
                            .entry(t.into())
                            .or_default()
                            .push(manager.clone());
                    }
                }
                if let Some(t) = k["target"].as_str().filter(|t| t.starts_with('/')) {
                    published.entry(t.into()).or_default().push(manager.clone());
                }
            }
        }
        let mut g = ConnectionGraph::new();
        for (t, ids) in published {
            g.set_published_topic(t, ids);
        }
        for (t, ids) in subscribed {
            g.set_subscribed_topic(t, ids);
        }
        g
    }
}

/// A JSON Schema of the shape of `v` (what Foxglove's panels offer as fields).
fn json_schema(v: &Value) -> Value {
    match v {
        Value::Null => json!({}),
        Value::Bool(_) => json!({ "type": "boolean" }),
        Value::Number(n) if n.is_f64() => json!({ "type": "number" }),
        Value::Number(_) => json!({ "type": "integer" }),
        Value::String(_) => json!({ "type": "string" }),
        Value::Array(a) => {
            json!({ "type": "array", "items": a.first().map(json_schema).unwrap_or(json!({})) })
        }
        Value::Object(o) => json!({
            "type": "object",
            "properties": o.iter().map(|(k, x)| (k.clone(), json_schema(x))).collect::<serde_json::Map<_, _>>(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_values_schema_names_every_field_with_its_type() {
        let s = json_schema(
            &json!({ "data": 3, "x": 1.5, "ok": true, "s": "a", "v": [1], "in": { "y": "b" } }),
        );
        assert_eq!(s["type"], "object");
        assert_eq!(s["properties"]["data"]["type"], "integer");
        assert_eq!(s["properties"]["x"]["type"], "number");
        assert_eq!(s["properties"]["ok"]["type"], "boolean");
        assert_eq!(s["properties"]["v"]["items"]["type"], "integer");
        assert_eq!(s["properties"]["in"]["properties"]["y"]["type"], "string");
    }
}

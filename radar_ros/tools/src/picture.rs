//! `radar graph`: the components and the live connections of every program as a picture, in SVG (drawn
//! here, no Graphviz needed) or as Graphviz DOT text.

use std::collections::HashMap;

use serde::Serialize;

/// A box's width and height in the SVG, the space between rows, the first row's top.
const W: f64 = 270.0;
const H: f64 = 52.0;
const GAP: f64 = 78.0;
const TOP: f64 = 60.0;

/// A component (or a plain topic a connection touches) in the picture.
#[derive(Clone, Debug, Serialize)]
pub struct Node {
    /// Fully qualified name.
    pub name: String,
    /// `event`, `response` or `topic`.
    pub kind: String,
    /// For events: checking now (someone listens).
    pub active: Option<bool>,
    /// For responses: the state label (`idle`, `running`, ...).
    pub state: Option<String>,
}

/// A live connection.
#[derive(Clone, Debug, Serialize)]
pub struct Edge {
    /// Its id within its program or manager.
    pub id: u64,
    /// The program or manager node that holds it.
    pub program: String,
    /// `once` or `whenever`.
    pub kind: String,
    /// The source component and its signal.
    pub source: String,
    /// `triggered`, `started`, `interrupted`, `exited`, ...
    pub signal: String,
    /// The target component and its slot.
    pub target: String,
    /// `start`, `interrupt`, `exit`, ...
    pub slot: String,
    /// The component whose signal interrupts the started run, if any.
    pub until: Option<String>,
    /// `armed`, `waiting for source`, ...
    pub state: String,
}

/// Everything drawn.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Picture {
    /// Components, events first.
    pub nodes: Vec<Node>,
    /// Connections.
    pub edges: Vec<Edge>,
}

/// `/a/b/triggered` -> (`/a/b`, `triggered`).
pub fn split(topic: &str) -> (String, String) {
    match topic.rsplit_once('/') {
        Some((c, e)) if !c.is_empty() => (c.to_owned(), e.to_owned()),
        _ => (topic.to_owned(), String::new()),
    }
}

impl Picture {
    /// Adds a `topic` node for every edge end that is not a known component.
    pub fn complete(&mut self) {
        let mut missing = Vec::new();
        for e in &self.edges {
            for n in [Some(&e.source), Some(&e.target), e.until.as_ref()]
                .into_iter()
                .flatten()
            {
                if !self.nodes.iter().any(|x| &x.name == n) && !missing.contains(n) {
                    missing.push(n.clone());
                }
            }
        }
        for name in missing {
            self.nodes.push(Node {
                name,
                kind: "topic".into(),
                active: None,
                state: None,
            });
        }
        self.nodes.sort_by_key(|n| {
            (
                match n.kind.as_str() {
                    "event" => 0,
                    "topic" => 1,
                    _ => 2,
                },
                n.name.clone(),
            )
        });
    }

    /// Graphviz DOT text.
    pub fn dot(&self) -> String {
        let mut s = String::from("digraph radar {\n  rankdir=LR;\n  node [shape=box, style=\"rounded,filled\", fontname=\"sans-serif\"];\n");
        for n in &self.nodes {
            let (fill, label) = node_look(n);
            s.push_str(&format!(
                "  \"{}\" [label=\"{}\\n{}\", fillcolor=\"{}\"];\n",
                n.name, n.name, label, fill
            ));
        }
        for e in &self.edges {
            let style = if e.kind == "once" { "dashed" } else { "solid" };
            s.push_str(&format!(
                "  \"{}\" -> \"{}\" [label=\"{} {} -> {} #{}\", style={}];\n",
                e.source, e.target, e.kind, e.signal, e.slot, e.id, style
            ));
            if let Some(u) = &e.until {
                s.push_str(&format!(
                    "  \"{}\" -> \"{}\" [label=\"until (#{})\", style=dotted, color=\"#d1242f\"];\n",
                    u, e.target, e.id
                ));
            }
        }
        s.push_str("}\n");
        s
    }

    /// An SVG picture: events on the left, responses on the right, one arrow per connection (whenever solid,
    /// once dashed, until dotted red), active events and running responses filled.
    pub fn svg(&self) -> String {
        let (left_x, right_x) = (30.0, 470.0);
        let mut pos = HashMap::new();
        let (mut left, mut right) = (0.0, 0.0);
        for n in &self.nodes {
            let (x, row) = if n.kind == "response" {
                (right_x, &mut right)
            } else {
                (left_x, &mut left)
            };
            pos.insert(n.name.clone(), (x, TOP + *row * GAP));
            *row += 1.0;
        }
        let rows = f64::max(left, right).max(1.0);
        let width = right_x + W + 130.0;
        let height = TOP + rows * GAP + 70.0;
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
             viewBox=\"0 0 {width} {height}\" font-family=\"sans-serif\" font-size=\"13\">\n\
             <defs><marker id=\"arrow\" viewBox=\"0 0 10 10\" refX=\"10\" refY=\"5\" markerWidth=\"7\" \
             markerHeight=\"7\" orient=\"auto-start-reverse\"><path d=\"M 0 0 L 10 5 L 0 10 z\" \
             fill=\"context-stroke\"/></marker></defs>\n\
             <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
             <text x=\"{left_x}\" y=\"30\" font-size=\"15\" font-weight=\"bold\">events</text>\n\
             <text x=\"{right_x}\" y=\"30\" font-size=\"15\" font-weight=\"bold\">responses</text>\n"
        );
        for (k, e) in self.edges.iter().enumerate() {
            let (colour, dash) = if e.kind == "once" {
                ("#8250df", "7 4")
            } else {
                ("#0969da", "none")
            };
            let label = format!("#{} {} {} -> {}", e.id, e.kind, e.signal, e.slot);
            arrow(
                &mut s,
                &pos,
                &e.source,
                &e.target,
                (colour, dash),
                &label,
                k % 3,
            );
            if let Some(u) = &e.until {
                arrow(
                    &mut s,
                    &pos,
                    u,
                    &e.target,
                    ("#d1242f", "2 3"),
                    &format!("#{} until", e.id),
                    k % 3,
                );
            }
        }
        for n in &self.nodes {
            let (x, y) = pos[&n.name];
            let (fill, label) = node_look(n);
            s.push_str(&format!(
                "<g class=\"{}\"><rect x=\"{x}\" y=\"{y}\" width=\"{W}\" height=\"{H}\" rx=\"8\" fill=\"{fill}\" \
                 stroke=\"#57606a\"/>\n<text x=\"{}\" y=\"{}\" font-weight=\"bold\">{}</text>\n\
                 <text x=\"{}\" y=\"{}\" fill=\"#57606a\" font-size=\"11\">{}</text></g>\n",
                n.kind,
                x + 10.0,
                y + 21.0,
                xml(&n.name),
                x + 10.0,
                y + 39.0,
                xml(&label)
            ));
        }
        s.push_str(&legend(height - 30.0));
        s.push_str("</svg>\n");
        s
    }
}

/// An arrow from `from` to `to` (by their places in `pos`), in the colour and dash pattern of `look`, with
/// its label; `k` spreads the labels of several arrows between the same pair.
fn arrow(
    s: &mut String,
    pos: &HashMap<String, (f64, f64)>,
    from: &str,
    to: &str,
    look: (&str, &str),
    label: &str,
    k: usize,
) {
    let (colour, dash) = look;
    let (Some(&(x1, y1)), Some(&(x2, y2))) = (pos.get(from), pos.get(to)) else {
        return;
    };
    // labels of several arrows between the same pair are spread along the curve
    let shift = k as f64 * 14.0;
    let (path, lx, ly) = if (x1 - x2).abs() < 1.0 {
        // same column: an arc on the right
        let (sx, sy, ey) = (x1 + W, y1 + H / 2.0, y2 + H / 2.0);
        let bulge = sx + 90.0 + shift;
        (
            format!("M {sx} {sy} C {bulge} {sy}, {bulge} {ey}, {sx} {ey}"),
            bulge - 20.0,
            (sy + ey) / 2.0,
        )
    } else {
        let (sx, sy, ex, ey) = (x1 + W, y1 + H / 2.0, x2, y2 + H / 2.0);
        let mx = (sx + ex) / 2.0;
        (
            format!("M {sx} {sy} C {mx} {sy}, {mx} {ey}, {ex} {ey}"),
            mx - 60.0,
            (sy + ey) / 2.0 - 6.0 + shift,
        )
    };
    s.push_str(&format!(
            "<path class=\"connection\" d=\"{path}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"2\" \
             stroke-dasharray=\"{dash}\" marker-end=\"url(#arrow)\"/>\n\
             <text x=\"{lx}\" y=\"{ly}\" fill=\"{colour}\" font-size=\"11\">{}</text>\n",
            xml(label)
        ));
}

/// The key to the line styles, at height `ly`.
fn legend(ly: f64) -> String {
    format!(
        "<g font-size=\"11\"><line x1=\"30\" y1=\"{ly}\" x2=\"70\" y2=\"{ly}\" stroke=\"#0969da\" stroke-width=\"2\"/>\
         <text x=\"76\" y=\"{}\">whenever</text>\
         <line x1=\"150\" y1=\"{ly}\" x2=\"190\" y2=\"{ly}\" stroke=\"#8250df\" stroke-width=\"2\" stroke-dasharray=\"7 4\"/>\
         <text x=\"196\" y=\"{}\">once</text>\
         <line x1=\"250\" y1=\"{ly}\" x2=\"290\" y2=\"{ly}\" stroke=\"#d1242f\" stroke-width=\"2\" stroke-dasharray=\"2 3\"/>\
         <text x=\"296\" y=\"{}\">until</text>\
         <rect x=\"350\" y=\"{}\" width=\"14\" height=\"10\" fill=\"#dafbe1\" stroke=\"#57606a\"/>\
         <text x=\"370\" y=\"{}\">active event / running response</text></g>\n",
        ly + 4.0,
        ly + 4.0,
        ly + 4.0,
        ly - 5.0,
        ly + 4.0
    )
}

fn node_look(n: &Node) -> (&'static str, String) {
    match n.kind.as_str() {
        "event" => match n.active {
            Some(true) => ("#dafbe1", "event, active".into()),
            Some(false) => ("#f6f8fa", "event, inactive".into()),
            None => ("#f6f8fa", "event".into()),
        },
        "response" => {
            let st = n.state.clone().unwrap_or_else(|| "?".into());
            let fill = if st == "idle" || st == "?" {
                "#f6f8fa"
            } else {
                "#dafbe1"
            };
            (fill, format!("response, {st}"))
        }
        _ => ("#fff8c5", "topic".into()),
    }
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picture() -> Picture {
        let mut p = Picture {
            nodes: vec![
                Node {
                    name: "/resp".into(),
                    kind: "response".into(),
                    active: None,
                    state: Some("running".into()),
                },
                Node {
                    name: "/ev".into(),
                    kind: "event".into(),
                    active: Some(true),
                    state: None,
                },
            ],
            edges: vec![Edge {
                id: 1,
                program: "/main_program".into(),
                kind: "once".into(),
                source: "/ev".into(),
                signal: "triggered".into(),
                target: "/resp".into(),
                slot: "start".into(),
                until: Some("/stop".into()),
                state: "armed".into(),
            }],
        };
        p.complete();
        p
    }

    #[test]
    fn every_node_and_connection_is_drawn() {
        let p = picture();
        assert_eq!(
            p.nodes.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(),
            ["/ev", "/stop", "/resp"],
            "events first, unknown ends as topics"
        );
        let svg = p.svg();
        for n in [
            "/ev",
            "/stop",
            "/resp",
            "#1 once triggered -&gt; start",
            "#1 until",
        ] {
            assert!(svg.contains(n), "{n} missing");
        }
        assert_eq!(svg.matches("class=\"connection\"").count(), 2);
        assert!(svg.contains("stroke-dasharray=\"7 4\""), "once is dashed");
        let dot = p.dot();
        assert!(dot.contains("\"/ev\" -> \"/resp\"") && dot.contains("style=dashed"));
        assert!(dot.contains("\"/stop\" -> \"/resp\" [label=\"until (#1)\""));
    }
}

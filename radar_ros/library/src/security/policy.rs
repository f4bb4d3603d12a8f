//! Access-control policies in sros2's format (version 0.2.0), read as `ros2 security create_permission` reads
//! them, into the [`Grant`] of each enclave.
//!
//! ```xml
//! <policy version="0.2.0">
//!   <enclaves>
//!     <enclave path="/planner">
//!       <profiles>
//!         <profile ns="/" node="planner">
//!           <topics publish="DENY"><topic>/dock/exit</topic></topics>
//!           <topics publish="ALLOW"><topic>/dock/start</topic><topic>/dock/interrupt</topic></topics>
//!           <topics subscribe="ALLOW"><topic>/dock/exited</topic><topic>~/state</topic></topics>
//!           <services request="ALLOW"><service>/radar_manager/connect</service></services>
//!           <actions call="ALLOW"><action>fibonacci</action></actions>
//!         </profile>
//!       </profiles>
//!     </enclave>
//!   </enclaves>
//! </policy>
//! ```
//!
//! As sros2 translates them: a name is absolute (`/dock/start`), private (`~/state`: the profile's node's
//! namespace and name before it) or relative to the profile's namespace; topics become `rt<name>`; a service
//! `request`ed is `rq<name>Request` published and `rr<name>Reply` subscribed (`reply` the other way round); an
//! action `call`ed publishes its three request topics and subscribes its replies, feedback and status
//! (`execute` the other way round). `DENY` entries go to a deny rule checked before the allow rule, and what
//! neither names is denied. Every enclave may also publish and subscribe `ros_discovery_info` (the graph's node
//! names, which every ROS 2 program writes). DDS topic expressions work in names (`*`, `?`, `[...]`):
//! `<topic>*</topic>` in namespace `/` is `rt/*`, every topic. `xi:include` elements (sros2's shared
//! profiles, `common/node.xml`) are read from their `href`, relative to the including file, and their root's
//! children put in their place.

use std::path::{Path, PathBuf};

use super::keystore::Grant;
use crate::error::{Error, Result};

fn bad(file: &Path, reason: impl std::fmt::Display) -> Error {
    Error::Config {
        setting: "policy",
        value: file.display().to_string(),
        reason: reason.to_string(),
    }
}

/// `ros2 security create_permission KEYSTORE ENCLAVE POLICY`: the enclave's permissions made again from what
/// the policy file grants `enclave`, signed by the keystore's CA. The enclave must exist
/// ([`super::keystore::create_enclave`]). The permissions document's path.
pub fn create_permission(keystore: &Path, enclave: &str, policy: &Path) -> Result<PathBuf> {
    let grants = grants_from_file(policy)?;
    let Some((_, grant)) = grants.iter().find(|(e, _)| e == enclave) else {
        let have: Vec<&str> = grants.iter().map(|(e, _)| e.as_str()).collect();
        return Err(Error::Config {
            setting: "policy",
            value: policy.display().to_string(),
            reason: format!("it has no enclave {enclave}; it has: {}", have.join(", ")),
        });
    };
    super::keystore::write_permission(keystore, enclave, grant)
}

/// The enclaves a policy file names, each with what it grants (in the file's order).
pub fn grants_from_file(file: &Path) -> Result<Vec<(String, Grant)>> {
    let text =
        std::fs::read_to_string(file).map_err(|e| bad(file, format!("cannot read it: {e}")))?;
    grants_from_xml(&text, file)
}

/// [`grants_from_file`] of a policy's text; `file` names it in errors and is where `xi:include`s are found
/// from.
pub fn grants_from_xml(text: &str, file: &Path) -> Result<Vec<(String, Grant)>> {
    let mut rules: Vec<(String, Rules)> = Vec::new();
    walk(text, file, |enclave, profile| {
        if rules.last().is_none_or(|(e, _)| e != enclave) {
            rules.push((enclave.to_owned(), Rules::default()));
        }
        let Some((ns, node, entries)) = profile else {
            return Ok(());
        };
        let r = &mut rules.last_mut().expect("pushed above").1;
        entries.iter().try_for_each(|k| r.add(k, ns, node, file))
    })?;
    Ok(rules.into_iter().map(|(e, r)| (e, r.grant())).collect())
}

/// Reads a policy's enclaves and profiles in the file's order: `visit(enclave, None)` for each enclave, then
/// `visit(enclave, Some((ns, node, elements)))` for each of its profiles, `xi:include`s resolved.
fn walk(
    text: &str,
    file: &Path,
    mut visit: impl FnMut(&str, Option<(&str, &str, Vec<Entry>)>) -> Result<()>,
) -> Result<()> {
    let doc = roxmltree::Document::parse(text).map_err(|e| bad(file, format!("not XML: {e}")))?;
    let root = doc.root_element();
    if root.tag_name().name() != "policy" {
        return Err(bad(
            file,
            format!(
                "the root element is <{}>, not <policy version=\"0.2.0\">",
                root.tag_name().name()
            ),
        ));
    }
    let enclaves = child(root, "enclaves")
        .ok_or_else(|| bad(file, "no <enclaves> in <policy> (sros2's format 0.2.0)"))?;
    let mut any = false;
    for enclave in elements(enclaves).filter(|e| e.tag_name().name() == "enclave") {
        any = true;
        let path = enclave
            .attribute("path")
            .ok_or_else(|| bad(file, "an <enclave> without path=\"/...\""))?;
        if !path.starts_with('/') {
            return Err(bad(
                file,
                format!("enclave path {path:?} is not absolute (like /robot/planner)"),
            ));
        }
        visit(path, None)?;
        for profiles in elements(enclave).filter(|e| e.tag_name().name() == "profiles") {
            for profile in elements(profiles).filter(|e| e.tag_name().name() == "profile") {
                let ns = profile.attribute("ns").unwrap_or("/");
                let node = profile.attribute("node").ok_or_else(|| {
                    bad(file, format!("a <profile> of {path} without node=\"...\""))
                })?;
                let mut kids = Vec::new();
                expand(profile, file, &mut kids, 0)?;
                visit(path, Some((ns, node, kids)))?;
            }
        }
    }
    if !any {
        return Err(bad(file, "no <enclave path=\"...\"> in <enclaves>"));
    }
    Ok(())
}

/// `radar security generate_policy`: the policy of the nodes on the graph (`nodes`, from
/// [`crate::radar::introspect::Introspect::nodes`]), one profile per node under its enclave, every topic it publishes
/// or subscribes and every service it serves or calls allowed, by absolute name; nodes whose names begin with
/// `_` are left out (hidden, as sros2 leaves them out). When the policy file exists already (`existing`: its
/// text and path) its rules are kept and the graph's added to them, as `ros2 security generate_policy` amends
/// a policy; its `xi:include`s are written in place. What it returns is the new file's text.
pub fn generate(
    existing: Option<(&str, &Path)>,
    nodes: &[crate::graph::GraphNode],
) -> Result<String> {
    use super::model::{Kind, Policy, Rule};
    let mut policy = Policy::default();
    if let Some((text, file)) = existing {
        walk(text, file, |enclave, profile| {
            let Some((ns, node, entries)) = profile else {
                return Ok(());
            };
            let rules = policy.profile(enclave, ns, node);
            for e in entries {
                let kind = Kind::of_tag(&e.tag).ok_or_else(|| {
                    bad(
                        file,
                        format!(
                            "<{}> in the profile of {node}: expected <topics>, <services> or <actions>",
                            e.tag
                        ),
                    )
                })?;
                for (access, qualifier) in e.attrs {
                    rules
                        .entry(Rule {
                            kind,
                            access,
                            qualifier,
                        })
                        .or_default()
                        .extend(e.names.iter().cloned());
                }
            }
            Ok(())
        })?;
    }
    for n in nodes.iter().filter(|n| !n.name.starts_with('_')) {
        let ns = if n.namespace.is_empty() {
            "/"
        } else {
            &n.namespace
        };
        let profile = policy.profile(&n.enclave, ns, &n.name);
        for (kind, access, names) in [
            (Kind::Topics, "publish", &n.publishes),
            (Kind::Topics, "subscribe", &n.subscribes),
            (Kind::Services, "reply", &n.serves),
            (Kind::Services, "request", &n.calls),
        ] {
            if !names.is_empty() {
                profile
                    .entry(Rule::allow(kind, access))
                    .or_default()
                    .extend(names.iter().cloned());
            }
        }
    }
    Ok(policy.to_xml("the nodes on the ROS graph (radar security generate_policy)"))
}

fn elements<'a>(n: roxmltree::Node<'a, 'a>) -> impl Iterator<Item = roxmltree::Node<'a, 'a>> {
    n.children().filter(|c| c.is_element())
}

fn child<'a>(n: roxmltree::Node<'a, 'a>, name: &str) -> Option<roxmltree::Node<'a, 'a>> {
    elements(n).find(|c| c.tag_name().name() == name)
}

/// One element of a profile, with its included content resolved: (tag, attributes, names).
struct Entry {
    tag: String,
    attrs: Vec<(String, String)>,
    names: Vec<String>,
}

/// The profile's child elements, with `xi:include`s replaced by the children of the included file's root.
fn expand(
    parent: roxmltree::Node<'_, '_>,
    file: &Path,
    out: &mut Vec<Entry>,
    depth: u32,
) -> Result<()> {
    for c in elements(parent) {
        if c.tag_name().name() == "include" {
            if depth > 8 {
                return Err(bad(file, "xi:include nested more than 8 deep"));
            }
            let href = c
                .attribute("href")
                .ok_or_else(|| bad(file, "an xi:include without href"))?;
            let inc: PathBuf = file.parent().unwrap_or(Path::new(".")).join(href);
            let text = std::fs::read_to_string(&inc)
                .map_err(|e| bad(file, format!("xi:include {}: {e}", inc.display())))?;
            let doc = roxmltree::Document::parse(&text)
                .map_err(|e| bad(&inc, format!("not XML: {e}")))?;
            expand(doc.root_element(), &inc, out, depth + 1)?;
            continue;
        }
        out.push(Entry {
            tag: c.tag_name().name().to_owned(),
            attrs: c
                .attributes()
                .map(|a| (a.name().to_owned(), a.value().to_owned()))
                .collect(),
            names: elements(c)
                .map(|n| n.text().unwrap_or("").trim().to_owned())
                .collect(),
        });
    }
    Ok(())
}

/// sros2's name resolution: absolute, private (`~`), or relative to the profile's namespace.
fn resolve(name: &str, ns: &str, node: &str) -> String {
    let ns = if ns.ends_with('/') {
        ns.to_owned()
    } else {
        format!("{ns}/")
    };
    if name.starts_with('/') {
        name.to_owned()
    } else if let Some(rest) = name.strip_prefix('~') {
        format!("{ns}{node}{rest}")
    } else {
        format!("{ns}{name}")
    }
}

#[derive(Default)]
struct Rules {
    /// (publish, subscribe) for ALLOW and for DENY
    allow: (Vec<String>, Vec<String>),
    deny: (Vec<String>, Vec<String>),
}

impl Rules {
    fn add(&mut self, e: &Entry, ns: &str, node: &str, file: &Path) -> Result<()> {
        let kinds: &[&str] = match e.tag.as_str() {
            "topics" => &["publish", "subscribe"],
            "services" => &["request", "reply"],
            "actions" => &["call", "execute"],
            other => {
                return Err(bad(
                    file,
                    format!("<{other}> in a profile of node {node}: expected <topics>, <services> or <actions>"),
                ))
            }
        };
        for (k, v) in &e.attrs {
            if !kinds.contains(&k.as_str()) {
                return Err(bad(
                    file,
                    format!(
                        "<{} {k}=...>: a <{}> takes {}",
                        e.tag,
                        e.tag,
                        kinds.join(" or ")
                    ),
                ));
            }
            let (publish, subscribe) = match v.as_str() {
                "ALLOW" => (&mut self.allow.0, &mut self.allow.1),
                "DENY" => (&mut self.deny.0, &mut self.deny.1),
                other => {
                    return Err(bad(
                        file,
                        format!("<{} {k}=\"{other}\">: ALLOW or DENY", e.tag),
                    ))
                }
            };
            for name in &e.names {
                let n = resolve(name, ns, node);
                let (out, into): (Vec<String>, Vec<String>) = match k.as_str() {
                    "publish" => (vec![format!("rt{n}")], vec![]),
                    "subscribe" => (vec![], vec![format!("rt{n}")]),
                    "request" => (vec![format!("rq{n}Request")], vec![format!("rr{n}Reply")]),
                    "reply" => (vec![format!("rr{n}Reply")], vec![format!("rq{n}Request")]),
                    "call" | "execute" => {
                        let rq: Vec<String> = ["cancel_goal", "get_result", "send_goal"]
                            .iter()
                            .map(|s| format!("rq{n}/_action/{s}Request"))
                            .collect();
                        let mut rr: Vec<String> = ["cancel_goal", "get_result", "send_goal"]
                            .iter()
                            .map(|s| format!("rr{n}/_action/{s}Reply"))
                            .collect();
                        rr.push(format!("rt{n}/_action/feedback"));
                        rr.push(format!("rt{n}/_action/status"));
                        if k == "call" {
                            (rq, rr)
                        } else {
                            (rr, rq)
                        }
                    }
                    _ => unreachable!("checked above"),
                };
                publish.extend(out);
                subscribe.extend(into);
            }
        }
        Ok(())
    }

    fn grant(self) -> Grant {
        let tidy = |mut v: Vec<String>| {
            v.sort();
            v.dedup();
            v
        };
        let (mut publish, mut subscribe) = self.allow;
        publish.push("ros_discovery_info".into());
        subscribe.push("ros_discovery_info".into());
        Grant {
            publish: tidy(publish),
            subscribe: tidy(subscribe),
            deny_publish: tidy(self.deny.0),
            deny_subscribe: tidy(self.deny.1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `generate_policy` as sros2 amends a file: the file's rules stay (a DENY, relative names, an included
    /// profile written in place), the graph's nodes are added under their enclaves, hidden nodes are not, and
    /// what comes out reads back as the grants both say.
    #[test]
    fn a_generated_policy_keeps_the_files_rules_and_adds_the_graphs() {
        use crate::graph::GraphNode;
        let dir = std::env::temp_dir().join(format!("radar_generate_test_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("common.xml"),
            r#"<profile><topics subscribe="ALLOW"><topic>/clock</topic></topics></profile>"#,
        )
        .unwrap();
        let file = dir.join("policy.xml");
        let existing = r#"<policy version="0.2.0" xmlns:xi="http://www.w3.org/2001/XInclude"><enclaves>
            <enclave path="/planner"><profiles><profile ns="/robot" node="planner">
              <xi:include href="common.xml" xpointer="xpointer(/profile/*)"/>
              <topics publish="DENY"><topic>dock/exit</topic></topics>
            </profile></profiles></enclave></enclaves></policy>"#;
        let set = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
        let nodes = [
            GraphNode {
                namespace: "/robot".into(),
                name: "planner".into(),
                enclave: "/planner".into(),
                publishes: set(&["/robot/dock/start"]),
                calls: set(&["/radar_manager/connect"]),
                ..Default::default()
            },
            GraphNode {
                namespace: "/".into(),
                name: "dock".into(),
                enclave: "/robot".into(),
                subscribes: set(&["/robot/dock/start"]),
                serves: set(&["/dock/get_parameters"]),
                ..Default::default()
            },
            GraphNode {
                namespace: "/".into(),
                name: "_hidden".into(),
                enclave: "/robot".into(),
                publishes: set(&["/secret"]),
                ..Default::default()
            },
        ];
        let xml = generate(Some((existing, &file)), &nodes).unwrap();
        assert!(
            !xml.contains("/secret") && !xml.contains("_hidden"),
            "{xml}"
        );
        assert!(
            xml.contains("<topic>dock/exit</topic>"),
            "names kept as written: {xml}"
        );
        let g = grants_from_xml(&xml, &file).unwrap();
        let grant = |e: &str| &g.iter().find(|(n, _)| n == e).unwrap().1;
        let p = grant("/planner");
        assert_eq!(p.deny_publish, ["rt/robot/dock/exit"]);
        assert!(p.publish.contains(&"rt/robot/dock/start".to_owned()));
        assert!(p
            .publish
            .contains(&"rq/radar_manager/connectRequest".to_owned()));
        assert!(
            p.subscribe.contains(&"rt/clock".to_owned()),
            "the include, in place"
        );
        let r = grant("/robot");
        assert!(r.subscribe.contains(&"rt/robot/dock/start".to_owned()));
        assert!(r
            .publish
            .contains(&"rr/dock/get_parametersReply".to_owned()));
        assert!(!r.publish.contains(&"rt/robot/dock/start".to_owned()));
        // generating again from its own output changes nothing
        assert_eq!(generate(Some((&xml, &file)), &nodes).unwrap(), xml);
        assert!(generate(Some(("<nope/>", &file)), &nodes).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// sros2's translation: absolute, private and relative names; topics, services and actions both ways;
    /// DENY before ALLOW; includes resolved from the including file's directory.
    #[test]
    fn a_policy_is_translated_as_sros2_translates_it() {
        let dir = std::env::temp_dir().join(format!("radar_policy_test_{}", std::process::id()));
        std::fs::create_dir_all(dir.join("common")).unwrap();
        std::fs::write(
            dir.join("common/node.xml"),
            r#"<profile xmlns:xi="http://www.w3.org/2001/XInclude">
                 <topics publish="ALLOW"><topic>/rosout</topic></topics>
                 <services reply="ALLOW"><service>~/get_parameters</service></services>
               </profile>"#,
        )
        .unwrap();
        let policy = dir.join("policy.xml");
        std::fs::write(
            &policy,
            r#"<?xml version="1.0"?>
<policy version="0.2.0" xmlns:xi="http://www.w3.org/2001/XInclude">
  <enclaves>
    <enclave path="/robot/planner">
      <profiles>
        <profile ns="/robot" node="planner">
          <xi:include href="common/node.xml" xpointer="xpointer(/profile/*)"/>
          <topics publish="DENY"><topic>dock/exit</topic></topics>
          <topics publish="ALLOW" subscribe="ALLOW"><topic>dock/start</topic></topics>
          <topics subscribe="ALLOW"><topic>/dock/exited</topic><topic>~/state</topic></topics>
          <services request="ALLOW"><service>/radar_manager/connect</service></services>
          <actions call="ALLOW"><action>fibonacci</action></actions>
        </profile>
      </profiles>
    </enclave>
    <enclave path="/robot/dock">
      <profiles>
        <profile ns="/" node="dock">
          <actions execute="ALLOW"><action>fibonacci</action></actions>
        </profile>
      </profiles>
    </enclave>
  </enclaves>
</policy>"#,
        )
        .unwrap();
        let g = grants_from_file(&policy).unwrap();
        assert_eq!(g[0].0, "/robot/planner");
        let p = &g[0].1;
        assert_eq!(p.deny_publish, ["rt/robot/dock/exit"]);
        assert!(p.deny_subscribe.is_empty());
        for t in [
            "rt/rosout",
            "rr/robot/planner/get_parametersReply",
            "rt/robot/dock/start",
            "rq/radar_manager/connectRequest",
            "rq/robot/fibonacci/_action/send_goalRequest",
            "ros_discovery_info",
        ] {
            assert!(p.publish.contains(&t.to_owned()), "{t} in {:?}", p.publish);
        }
        for t in [
            "rq/robot/planner/get_parametersRequest",
            "rt/robot/dock/start",
            "rt/dock/exited",
            "rt/robot/planner/state",
            "rr/radar_manager/connectReply",
            "rt/robot/fibonacci/_action/feedback",
        ] {
            assert!(
                p.subscribe.contains(&t.to_owned()),
                "{t} in {:?}",
                p.subscribe
            );
        }
        let d = &g[1].1;
        assert!(d
            .publish
            .contains(&"rr/fibonacci/_action/send_goalReply".to_owned()));
        assert!(d
            .subscribe
            .contains(&"rq/fibonacci/_action/get_resultRequest".to_owned()));

        // the permissions document: deny rule first, then allow, then DENY
        let xml = crate::security::keystore::permissions_xml("/robot/planner", p);
        let (deny, allow) = (
            xml.find("<deny_rule>").unwrap(),
            xml.find("<allow_rule>").unwrap(),
        );
        assert!(deny < allow && allow < xml.find("<default>DENY").unwrap());

        // bad input says what is wrong
        std::fs::write(
            &policy,
            "<policy version=\"0.2.0\"><enclaves><enclave path=\"robot\"/></enclaves></policy>",
        )
        .unwrap();
        let e = grants_from_file(&policy).unwrap_err().to_string();
        assert!(e.contains("not absolute"), "{e}");
        std::fs::write(
            &policy,
            r#"<policy version="0.2.0"><enclaves><enclave path="/r"><profiles><profile node="n">
               <topics publish="MAYBE"><topic>x</topic></topics></profile></profiles></enclave></enclaves></policy>"#,
        )
        .unwrap();
        let e = grants_from_file(&policy).unwrap_err().to_string();
        assert!(e.contains("ALLOW or DENY"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

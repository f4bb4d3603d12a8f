//! An access-control policy as sros2's format 0.2.0 lays it out (enclaves, each node's profile, its rules),
//! built in memory and written as XML: what [`crate::Radar::policy`] and `radar security generate_policy`
//! write.

use std::collections::{BTreeMap, BTreeSet};

/// The element a rule is: `<topics>`, `<services>` or `<actions>` (written in that order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Kind {
    Topics,
    Services,
    Actions,
}

impl Kind {
    fn tags(self) -> (&'static str, &'static str) {
        match self {
            Kind::Topics => ("topics", "topic"),
            Kind::Services => ("services", "service"),
            Kind::Actions => ("actions", "action"),
        }
    }

    /// The kind of a rule element's tag.
    #[cfg_attr(not(feature = "security"), allow(dead_code))]
    pub(crate) fn of_tag(tag: &str) -> Option<Kind> {
        match tag {
            "topics" => Some(Kind::Topics),
            "services" => Some(Kind::Services),
            "actions" => Some(Kind::Actions),
            _ => None,
        }
    }
}

/// One rule of a profile: `<topics publish="ALLOW">`.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct Rule {
    pub(crate) kind: Kind,
    /// `publish`, `subscribe`, `reply`, `request`, `call` or `execute`.
    pub(crate) access: String,
    /// `ALLOW` or `DENY`.
    pub(crate) qualifier: String,
}

impl Rule {
    pub(crate) fn allow(kind: Kind, access: &str) -> Rule {
        Rule {
            kind,
            access: access.to_owned(),
            qualifier: "ALLOW".to_owned(),
        }
    }
}

/// A profile's rules, each with the names it covers.
pub(crate) type Profile = BTreeMap<Rule, BTreeSet<String>>;

/// Each enclave's profiles, by (namespace, node), each profile's rules with the names they cover.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Policy {
    pub(crate) enclaves: BTreeMap<String, BTreeMap<(String, String), Profile>>,
}

impl Policy {
    /// Adds `name` under `rule` to the profile of node `ns`/`node` in `enclave` (made if missing).
    pub(crate) fn add(&mut self, enclave: &str, ns: &str, node: &str, rule: Rule, name: &str) {
        self.profile(enclave, ns, node)
            .entry(rule)
            .or_default()
            .insert(name.to_owned());
    }

    /// The profile of node `ns`/`node` in `enclave`, made (empty) if missing.
    pub(crate) fn profile(&mut self, enclave: &str, ns: &str, node: &str) -> &mut Profile {
        self.enclaves
            .entry(enclave.to_owned())
            .or_default()
            .entry((ns.to_owned(), node.to_owned()))
            .or_default()
    }

    /// The policy as XML, with `comment` at its top.
    pub(crate) fn to_xml(&self, comment: &str) -> String {
        let mut out = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- {} -->\n<policy version=\"0.2.0\">\n  <enclaves>\n",
            comment.replace("--", "- -")
        );
        for (enclave, profiles) in &self.enclaves {
            out += &format!(
                "    <enclave path=\"{}\">\n      <profiles>\n",
                escape(enclave)
            );
            for ((ns, node), rules) in profiles {
                out += &format!(
                    "        <profile ns=\"{}\" node=\"{}\">\n",
                    escape(ns),
                    escape(node)
                );
                for (rule, names) in rules.iter().filter(|(_, n)| !n.is_empty()) {
                    let (tag, item) = rule.kind.tags();
                    out += &format!(
                        "          <{tag} {}=\"{}\">\n",
                        rule.access,
                        escape(&rule.qualifier)
                    );
                    for n in names {
                        out += &format!("            <{item}>{}</{item}>\n", escape(n));
                    }
                    out += &format!("          </{tag}>\n");
                }
                out += "        </profile>\n";
            }
            out += "      </profiles>\n    </enclave>\n";
        }
        out += "  </enclaves>\n</policy>\n";
        out
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_policy_is_written_enclave_by_enclave_profile_by_profile_topics_first() {
        let mut p = Policy::default();
        p.add(
            "/robot",
            "/",
            "dock",
            Rule::allow(Kind::Services, "reply"),
            "/dock/get_parameters",
        );
        p.add(
            "/robot",
            "/",
            "dock",
            Rule::allow(Kind::Topics, "subscribe"),
            "/dock/start",
        );
        p.add(
            "/robot",
            "/",
            "dock",
            Rule::allow(Kind::Topics, "publish"),
            "/dock/exited",
        );
        p.add(
            "/robot",
            "/",
            "dock",
            Rule::allow(Kind::Topics, "publish"),
            "/dock/a&b",
        );
        p.profile("/planner", "/robot", "planner");
        let xml = p.to_xml("made -- by a test");
        assert_eq!(
            xml,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- made - - by a test -->\n<policy version=\"0.2.0\">\n  <enclaves>\n\
             \x20   <enclave path=\"/planner\">\n      <profiles>\n        <profile ns=\"/robot\" node=\"planner\">\n        </profile>\n      </profiles>\n    </enclave>\n\
             \x20   <enclave path=\"/robot\">\n      <profiles>\n        <profile ns=\"/\" node=\"dock\">\n\
             \x20         <topics publish=\"ALLOW\">\n            <topic>/dock/a&amp;b</topic>\n            <topic>/dock/exited</topic>\n          </topics>\n\
             \x20         <topics subscribe=\"ALLOW\">\n            <topic>/dock/start</topic>\n          </topics>\n\
             \x20         <services reply=\"ALLOW\">\n            <service>/dock/get_parameters</service>\n          </services>\n\
             \x20       </profile>\n      </profiles>\n    </enclave>\n  </enclaves>\n</policy>\n"
        );
    }
}

//! ROS name rules for RADAR components, checked before anything is created.
//!
//! A component name is a node name, optionally with a namespace: `count_up`, `robot1/count_up` (relative to
//! the [`Radar`](crate::Radar) namespace) or `/robot1/count_up` (absolute). Each `/`-separated token follows
//! the rules of `rmw_validate_namespace` / `rmw_validate_node_name`: ASCII letters, digits and `_`, not starting
//! with a digit, not empty. Topics of a component are `<namespace>/<name>/<signal>`.

use crate::{endpoint::Endpoint, error::Error};

/// A validated, fully qualified component name (namespace + base name).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ComponentName {
    namespace: String,
    base: String,
}

const MAX_NODE_NAME: usize = 255;

fn check_token(full: &str, token: &str) -> Result<(), Error> {
    let bad = |reason: String| Error::InvalidName {
        name: full.to_owned(),
        reason,
    };
    if token.is_empty() {
        return Err(bad(
            "it has an empty segment (a leading, trailing or doubled '/'); write e.g. \"robot1/count_up\"".into(),
        ));
    }
    if let Some(c) = token
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        return Err(bad(format!(
            "'{c}' is not allowed; use ASCII letters, digits and '_' (e.g. \"{}\")",
            suggest(token)
        )));
    }
    if token.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(bad(format!(
            "segment \"{token}\" starts with a digit; ROS names must start with a letter or '_' (e.g. \"_{token}\")"
        )));
    }
    Ok(())
}

fn suggest(token: &str) -> String {
    let s: String = token
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.starts_with(|c: char| c.is_ascii_digit()) {
        format!("_{s}")
    } else {
        s
    }
}

/// Checks a namespace such as `/` or `/robot1/arm`.
pub(crate) fn validate_namespace(ns: &str) -> Result<String, Error> {
    if ns == "/" || ns.is_empty() {
        return Ok("/".to_owned());
    }
    let trimmed = ns.strip_prefix('/').unwrap_or(ns);
    for token in trimmed.split('/') {
        check_token(ns, token)?;
    }
    Ok(format!("/{trimmed}"))
}

impl ComponentName {
    /// Resolves `name` against the default namespace `default_ns` and checks every rule.
    ///
    /// ```
    /// use radar_ros::graph::ComponentName;
    /// let n = ComponentName::resolve("arm/grasp", "/robot").unwrap();
    /// assert_eq!(n.fully_qualified(), "/robot/arm/grasp");
    /// assert_eq!((n.namespace(), n.base()), ("/robot/arm", "grasp"));
    /// assert_eq!(n.topic("start"), "/robot/arm/grasp/start");
    /// assert!(ComponentName::resolve("bad name", "/").is_err());
    /// ```
    pub fn resolve(name: &str, default_ns: &str) -> Result<ComponentName, Error> {
        if name.is_empty() {
            return Err(Error::InvalidName {
                name: String::new(),
                reason: "the name is empty; give the node a name such as \"count_up\"".into(),
            });
        }
        if name.starts_with('~') {
            return Err(Error::InvalidName {
                name: name.to_owned(),
                reason: "'~' (private namespace) has no meaning for a component; use a relative or absolute name"
                    .into(),
            });
        }
        let absolute = name.starts_with('/');
        let body = if absolute { &name[1..] } else { name };
        let tokens: Vec<&str> = body.split('/').collect();
        for t in &tokens {
            check_token(name, t)?;
        }
        let (base, rel_ns) = tokens
            .split_last()
            .expect("split yields at least one token");
        if base.len() > MAX_NODE_NAME {
            return Err(Error::InvalidName {
                name: name.to_owned(),
                reason: format!("node names are at most {MAX_NODE_NAME} characters"),
            });
        }
        let mut namespace = if absolute {
            String::new()
        } else {
            let ns = validate_namespace(default_ns)?;
            if ns == "/" {
                String::new()
            } else {
                ns
            }
        };
        for t in rel_ns {
            namespace.push('/');
            namespace.push_str(t);
        }
        if namespace.is_empty() {
            namespace.push('/');
        }
        Ok(ComponentName {
            namespace,
            base: (*base).to_owned(),
        })
    }

    /// The namespace, `/` or `/a/b`.
    pub fn namespace(&self) -> &str {
        &self.namespace
    }

    /// The node's base name.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// `/a/b/name`.
    pub fn fully_qualified(&self) -> String {
        if self.namespace == "/" {
            format!("/{}", self.base)
        } else {
            format!("{}/{}", self.namespace, self.base)
        }
    }

    /// The absolute topic of one of this component's endpoints, e.g. `/a/b/name/triggered`.
    pub fn topic(&self, endpoint: &str) -> String {
        format!("{}/{}", self.fully_qualified(), endpoint)
    }

    /// The absolute topic of one of this component's RADAR endpoints.
    ///
    /// ```
    /// use radar_ros::{graph::ComponentName, graph::Endpoint};
    /// let n = ComponentName::resolve("dock", "/robot").unwrap();
    /// assert_eq!(n.endpoint(Endpoint::Exited), "/robot/dock/exited");
    /// ```
    pub fn endpoint(&self, e: Endpoint) -> String {
        self.topic(e.name())
    }
}

impl std::fmt::Display for ComponentName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.fully_qualified())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_names_resolve_in_the_default_namespace() {
        let n = ComponentName::resolve("count_up", "/").unwrap();
        assert_eq!(n.fully_qualified(), "/count_up");
        assert_eq!(n.namespace(), "/");
        let n = ComponentName::resolve("arm/count_up", "/robot1").unwrap();
        assert_eq!(n.fully_qualified(), "/robot1/arm/count_up");
        assert_eq!(n.namespace(), "/robot1/arm");
        assert_eq!(n.topic("start"), "/robot1/arm/count_up/start");
    }

    #[test]
    fn absolute_names_ignore_the_default_namespace() {
        let n = ComponentName::resolve("/x/count_up", "/robot1").unwrap();
        assert_eq!(n.fully_qualified(), "/x/count_up");
    }

    #[test]
    fn invalid_names_are_rejected_with_a_hint() {
        for (bad, needle) in [
            ("count-up", "'-' is not allowed"),
            ("1count", "starts with a digit"),
            ("a//b", "empty segment"),
            ("a/", "empty segment"),
            ("", "empty"),
            ("~/x", "private namespace"),
            ("sp ace", "' ' is not allowed"),
        ] {
            let e = ComponentName::resolve(bad, "/").unwrap_err().to_string();
            assert!(e.contains(needle), "{bad:?}: {e}");
            assert!(e.contains("invalid ROS name"), "{e}");
        }
        let e = ComponentName::resolve("x", "/bad-ns")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad-ns"), "{e}");
    }
}

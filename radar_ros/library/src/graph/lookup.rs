//! Finding RADAR components by name through ROS graph discovery, instead of a naming service.
//!
//! `radar.response("count_up")` resolves the name like any ROS name (relative names in the Radar's namespace,
//! absolute names as given) and waits (default [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change) until the graph
//! shows a response there: a subscription on `<name>/start` and a publisher on `<name>/exited`.
//! `radar.event("start_event")` waits for a publisher on `<name>/triggered`. The types come from discovery, so
//! the returned reference works in connections exactly like a local handle, whichever process or host the
//! component runs in.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! let bumper = radar.event("/robot/bumper").await?;
//! let dock = radar.response("/robot/dock").await?;
//! let _c = radar.whenever(&bumper).start(&dock).await?;
//! # Ok(()) }
//! ```

use std::collections::BTreeSet;

use crate::{
    error::{Error, Result},
    wire::dds_names::ros_type as ros_type_of_dds,
    wire::names::ComponentName,
    wire::refs::{EventRef, ResponseRef},
};

pub(crate) enum Found {
    Event(String),
    Response(String, String),
}

/// A RADAR component seen on the ROS graph (from [`Radar::components`](crate::Radar::components)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Component {
    /// An event: a publisher on `<name>/triggered`.
    Event(EventRef),
    /// A response: a subscription on `<name>/start` and a publisher on `<name>/exited`.
    Response(ResponseRef),
}

impl Component {
    /// Its name.
    pub fn name(&self) -> &ComponentName {
        match self {
            Component::Event(e) => e.name(),
            Component::Response(r) => r.name(),
        }
    }

    /// `"event"` or `"response"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Component::Event(_) => "event",
            Component::Response(_) => "response",
        }
    }
}

/// The DDS types of the writers (`true`) or readers on a ROS topic.
pub(crate) type TypesOn<'a> = &'a dyn Fn(bool, &str) -> BTreeSet<String>;

/// What the graph shows at `name` now: `Ok(None)` if nothing (yet).
pub(crate) fn inspect(types_on: TypesOn<'_>, name: &ComponentName) -> Result<Option<Found>> {
    let types = |writer: bool, endpoint: &str| -> BTreeSet<String> {
        types_on(writer, &name.topic(endpoint))
            .iter()
            .map(|ty| ros_type_of_dds(ty))
            .collect()
    };
    let one = |set: BTreeSet<String>, endpoint: &str| -> Result<Option<String>> {
        match set.len() {
            0 => Ok(None),
            1 => Ok(set.into_iter().next()),
            _ => Err(Error::Ambiguous {
                topic: name.topic(endpoint),
                types: set.into_iter().collect(),
            }),
        }
    };
    if let Some(p) = one(types(true, "triggered"), "triggered")? {
        return Ok(Some(Found::Event(p)));
    }
    let start = one(types(false, "start"), "start")?;
    let exited = one(types(true, "exited"), "exited")?;
    match (start, exited) {
        (Some(s), Some(o)) => Ok(Some(Found::Response(s, o))),
        _ => Ok(None),
    }
}

/// [`TypesOn`] for a list of endpoints, indexed once (a listing asks it several topics per component: a scan of
/// the list each time made listing 2,000 components cost O(components x endpoints), most of `radar view`'s CPU).
pub(crate) fn in_list(
    endpoints: &[(bool, String, String)],
) -> impl Fn(bool, &str) -> BTreeSet<String> + '_ {
    let mut index: std::collections::HashMap<(bool, &str), BTreeSet<String>> =
        std::collections::HashMap::new();
    for (w, t, ty) in endpoints {
        index
            .entry((*w, t.as_str()))
            .or_default()
            .insert(ty.clone());
    }
    move |writer, topic| index.get(&(writer, topic)).cloned().unwrap_or_default()
}

/// The RADAR components the graph shows, closest to `wanted` first.
pub(crate) fn candidates(endpoints: &[(bool, String, String)], wanted: &str) -> Vec<String> {
    let mut names = BTreeSet::new();
    for (w, t, _) in endpoints {
        match (w, crate::endpoint::Endpoint::of_topic(t)) {
            (true, Some((n, crate::endpoint::Endpoint::Triggered))) => {
                names.insert(format!("{n} (event)"))
            }
            (false, Some((n, crate::endpoint::Endpoint::Start))) => {
                names.insert(format!("{n} (response)"))
            }
            _ => false,
        };
    }
    let mut v: Vec<String> = names.into_iter().collect();
    v.sort_by_key(|c| distance(c.split(' ').next().unwrap_or(c), wanted));
    v
}

/// Levenshtein distance, for suggestions.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eps() -> Vec<(bool, String, String)> {
        let e = "std_msgs::msg::dds_::Empty_".to_owned();
        let s = "std_msgs::msg::dds_::String_".to_owned();
        vec![
            (true, "/start_event/triggered".into(), e.clone()),
            (false, "/count_up/start".into(), s.clone()),
            (true, "/count_up/exited".into(), e.clone()),
            (false, "/count_down/start".into(), e.clone()),
            (true, "/count_down/exited".into(), e.clone()),
            (true, "/twice/triggered".into(), e),
            (true, "/twice/triggered".into(), s),
        ]
    }

    fn n(s: &str) -> ComponentName {
        ComponentName::resolve(s, "/").unwrap()
    }

    #[test]
    fn components_are_recognised_by_their_topics_and_types() {
        match inspect(&in_list(&eps()), &n("count_up")).unwrap() {
            Some(Found::Response(s, o)) => assert_eq!(
                (s.as_str(), o.as_str()),
                ("std_msgs/msg/String", "std_msgs/msg/Empty")
            ),
            _ => panic!("count_up is a response"),
        }
        assert!(
            matches!(inspect(&in_list(&eps()), &n("start_event")).unwrap(), Some(Found::Event(t)) if t == "std_msgs/msg/Empty")
        );
        assert!(inspect(&in_list(&eps()), &n("nothing")).unwrap().is_none());
        let e = inspect(&in_list(&eps()), &n("twice"))
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("/twice/triggered") && e.contains("std_msgs/msg/String"),
            "{e}"
        );
    }

    #[test]
    fn suggestions_come_closest_first() {
        let c = candidates(&eps(), "/count_upp");
        assert_eq!(c[0], "/count_up (response)");
        assert_eq!(c[1], "/count_down (response)");
        assert!(c.contains(&"/start_event (event)".to_owned()));
    }
}

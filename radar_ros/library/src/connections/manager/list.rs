//! The manager's connections as `radar_msgs/msg/Connection` (its `connections` topic and `list` service).

use radar_semantics::connection::Kind;

use super::{outlet::Outlet, Manager, Target};

impl Manager {
    /// Every live connection, as `radar_msgs/msg/Connection`.
    pub(crate) fn list(&self) -> Vec<crate::wire::msg::Connection> {
        use crate::wire::msg::Connection as C;
        let st = self.state();
        st.table
            .list()
            .into_iter()
            .map(|c| {
                let hops = {
                    let source_local = self.local
                        && self
                            .participant
                            .taps()
                            .find(&c.source.topic, &c.source.ros_type)
                            .is_some_and(|t| t.has_emitters());
                    let target_local = match &c.target {
                        Target::Anon(_) => true,
                        Target::Slot(k) => st.outlets.get(k).is_some_and(Outlet::local),
                    };
                    u8::from(!source_local) + u8::from(!target_local)
                };
                C {
                    id: c.id,
                    kind: match c.kind {
                        Kind::Once => C::ONCE,
                        Kind::Whenever => C::WHENEVER,
                    },
                    kind_label: match c.kind {
                        Kind::Once => "once".into(),
                        Kind::Whenever => "whenever".into(),
                    },
                    source_type: c.source.ros_type.clone(),
                    depth: c.source.depth.min(u32::MAX as usize) as u32,
                    source: c.source.topic,
                    target: match c.target {
                        Target::Slot(t) => t.topic,
                        Target::Anon(_) => "(anonymous)".into(),
                    },
                    until: c.until.map(|u| u.topic).unwrap_or_default(),
                    owner: st
                        .records
                        .get(&c.id)
                        .map(|r| r.owner.clone())
                        .unwrap_or_default(),
                    delivered: c.delivered,
                    state: C::state_of(c.link),
                    state_label: c.link.label().into(),
                    departure: st
                        .records
                        .get(&c.id)
                        .and_then(|r| {
                            r.suspended
                                .clone()
                                .or_else(|| r.departure.as_ref().map(|d| d.to_string()))
                        })
                        .unwrap_or_default(),
                    hops,
                    panics: st.records.get(&c.id).map_or(0, |r| r.faults.count()),
                    panic: st
                        .records
                        .get(&c.id)
                        .map(|r| r.faults.last())
                        .unwrap_or_default(),
                    since: crate::wire::msg::Time::from_nanos(c.armed_at),
                    statement: format!("{:032x}", st.table.statement(c.id)),
                }
            })
            .collect()
    }
}

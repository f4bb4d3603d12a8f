//! A component's parameters on ROS: the six `rcl_interfaces` parameter services on its node, answered from the
//! [`Store`](super::Store), and `/parameter_events`.

use std::sync::Arc;

use futures::StreamExt;
use ros2_client::{
    parameters::raw,
    rcl_interfaces::{
        DescribeParametersRequest, DescribeParametersResponse, GetParameterTypesRequest,
        GetParameterTypesResponse, GetParametersRequest, GetParametersResponse,
        ListParametersRequest, ListParametersResponse, ListParametersResult,
        SetParametersAtomicallyResponse, SetParametersRequest, SetParametersResponse,
    },
    ParameterValue,
};

use super::{store::Range, Params};
use crate::{
    error::Result,
    graph::Graph,
    node::endpoints::{publisher, reply, Watched},
    node::participant::Participant,
    node::services::service_server_of,
};

/// The writer of `/parameter_events` of one node (rclcpp's QoS: reliable, volatile, keep-last 1000).
pub(crate) struct Events(Watched<crate::node::transport::Publisher<raw::ParameterEvent>>);

impl Events {
    pub(crate) fn create(
        graph: &Graph,
        node: &mut crate::node::transport::RosNode,
    ) -> Result<Events> {
        let ty = crate::wire::raw::parse_type_name("rcl_interfaces/msg/ParameterEvent")?;
        Ok(Events(publisher(
            graph,
            node,
            "/parameter_events",
            &ty,
            &crate::wire::qos::signal_qos_depth(1000),
        )?))
    }

    /// Publishes what was declared (`new`) or changed.
    pub(crate) fn publish(
        &self,
        node: &str,
        new: Vec<(String, ParameterValue)>,
        changed: Vec<(String, ParameterValue)>,
    ) {
        let wire = |ps: Vec<(String, ParameterValue)>| {
            ps.into_iter()
                .map(|(name, value)| raw::Parameter {
                    name,
                    value: value.into(),
                })
                .collect()
        };
        let event = raw::ParameterEvent {
            stamp: ros2_client::builtin_interfaces::Time::now(),
            node: node.to_owned(),
            new_parameters: wire(new),
            changed_parameters: wire(changed),
            deleted_parameters: Vec::new(),
        };
        if let Err(e) = self.0.publish(event) {
            tracing::warn!(%node, error = ?e, "could not publish on /parameter_events");
        }
    }
}

/// Keeps a component's parameter services up; dropping it takes them down.
pub(crate) struct Serving(tokio::task::JoinHandle<()>);

impl Drop for Serving {
    fn drop(&mut self) {
        self.0.abort();
    }
}

type Srv<Q, A> = Arc<crate::node::transport::Server<Q, A>>;

struct Servers {
    get: Srv<GetParametersRequest, GetParametersResponse>,
    types: Srv<GetParameterTypesRequest, GetParameterTypesResponse>,
    set: Srv<SetParametersRequest, SetParametersResponse>,
    set_atomically: Srv<SetParametersRequest, SetParametersAtomicallyResponse>,
    list: Srv<ListParametersRequest, ListParametersResponse>,
    describe: Srv<DescribeParametersRequest, DescribeParametersResponse>,
}

/// Serves `params` on `node`: `<node>/get_parameters`, `get_parameter_types`, `set_parameters`,
/// `set_parameters_atomically`, `list_parameters`, `describe_parameters`.
pub(crate) fn serve(
    participant: &Participant,
    node: &mut crate::node::transport::RosNode,
    params: &Params,
) -> Result<Serving> {
    let fq = params.node().to_owned();
    let s = Servers {
        get: Arc::new(service_server_of(
            node,
            &fq,
            "get_parameters",
            "rcl_interfaces",
            "GetParameters",
        )?),
        types: Arc::new(service_server_of(
            node,
            &fq,
            "get_parameter_types",
            "rcl_interfaces",
            "GetParameterTypes",
        )?),
        set: Arc::new(service_server_of(
            node,
            &fq,
            "set_parameters",
            "rcl_interfaces",
            "SetParameters",
        )?),
        set_atomically: Arc::new(service_server_of(
            node,
            &fq,
            "set_parameters_atomically",
            "rcl_interfaces",
            "SetParametersAtomically",
        )?),
        list: Arc::new(service_server_of(
            node,
            &fq,
            "list_parameters",
            "rcl_interfaces",
            "ListParameters",
        )?),
        describe: Arc::new(service_server_of(
            node,
            &fq,
            "describe_parameters",
            "rcl_interfaces",
            "DescribeParameters",
        )?),
    };
    let graph = participant.graph().clone();
    let params = params.clone();
    Ok(Serving(tokio::spawn(async move {
        run(s, params, graph, fq).await;
    })))
}

async fn run(s: Servers, params: Params, graph: Graph, fq: String) {
    let mut get = Box::pin(s.get.receive_request_stream());
    let mut types = Box::pin(s.types.receive_request_stream());
    let mut set = Box::pin(s.set.receive_request_stream());
    let mut set_atomically = Box::pin(s.set_atomically.receive_request_stream());
    let mut list = Box::pin(s.list.receive_request_stream());
    let mut describe = Box::pin(s.describe.receive_request_stream());
    let bad = |service: &str, e: &dyn std::fmt::Display| {
        let ty = format!("rcl_interfaces/srv/{service}_Request");
        graph
            .malformed()
            .note(&format!("{fq}/{service}"), &ty, None, e);
    };
    loop {
        tokio::select! {
            Some(r) = get.next() => match r {
                Ok((id, req)) => {
                    let values = values_of(&params, &req.names).collect();
                    reply(&s.get, &graph, &fq, "get_parameters", id, GetParametersResponse { values });
                }
                Err(e) => bad("get_parameters", &e),
            },
            Some(r) = types.next() => match r {
                Ok((id, req)) => {
                    let values = values_of(&params, &req.names).map(|v| v.ptype).collect();
                    reply(&s.types, &graph, &fq, "get_parameter_types", id, GetParameterTypesResponse { values });
                }
                Err(e) => bad("get_parameter_types", &e),
            },
            Some(r) = set.next() => match r {
                Ok((id, req)) => {
                    let results = req
                        .parameter
                        .into_iter()
                        .map(|p| result(params.set(&p.name, ParameterValue::from(p.value))))
                        .collect();
                    reply(&s.set, &graph, &fq, "set_parameters", id, SetParametersResponse { results });
                }
                Err(e) => bad("set_parameters", &e),
            },
            Some(r) = set_atomically.next() => match r {
                Ok((id, req)) => {
                    let all = req
                        .parameter
                        .into_iter()
                        .map(|p| (p.name, ParameterValue::from(p.value)))
                        .collect();
                    let result = result(params.set_all(all));
                    reply(&s.set_atomically, &graph, &fq, "set_parameters_atomically", id,
                        SetParametersAtomicallyResponse { result });
                }
                Err(e) => bad("set_parameters_atomically", &e),
            },
            Some(r) = list.next() => match r {
                Ok((id, req)) => {
                    let (names, prefixes) = params.inner.store.lock().unwrap().list(&req.prefixes, req.depth);
                    reply(&s.list, &graph, &fq, "list_parameters", id,
                        ListParametersResponse { result: ListParametersResult { names, prefixes } });
                }
                Err(e) => bad("list_parameters", &e),
            },
            Some(r) = describe.next() => match r {
                Ok((id, req)) => {
                    let values = req.names.iter().map(|n| descriptor(&params, n)).collect();
                    reply(&s.describe, &graph, &fq, "describe_parameters", id,
                        DescribeParametersResponse { values });
                }
                Err(e) => bad("describe_parameters", &e),
            },
            else => break,
        }
    }
}

/// The values of the parameters `names`, as the services send them (not set: `NOT_SET`).
fn values_of<'a>(
    params: &'a Params,
    names: &'a [String],
) -> impl Iterator<Item = raw::ParameterValue> + 'a {
    names
        .iter()
        .map(|n| params.get(n).unwrap_or(ParameterValue::NotSet).into())
}

fn result(r: Result<()>) -> raw::SetParametersResult {
    match r {
        Ok(()) => raw::SetParametersResult {
            successful: true,
            reason: String::new(),
        },
        Err(crate::Error::Config { reason, .. }) => raw::SetParametersResult {
            successful: false,
            reason,
        },
        Err(e) => raw::SetParametersResult {
            successful: false,
            reason: e.to_string(),
        },
    }
}

/// What `ros2 param describe` shows of `name` (an undeclared name: type NOT_SET, as rclcpp answers).
fn descriptor(params: &Params, name: &str) -> raw::ParameterDescriptor {
    let store = params.inner.store.lock().unwrap();
    let Some(d) = store.decl(name) else {
        return raw::ParameterDescriptor {
            name: name.to_owned(),
            r#type: 0,
            description: String::new(),
            additional_constraints: String::new(),
            read_only: false,
            dynamic_typing: false,
            floating_point_range: Vec::new(),
            integer_range: Vec::new(),
        };
    };
    let (floating_point_range, integer_range) = match d.range {
        Range::Any => (Vec::new(), Vec::new()),
        Range::Integer { from, to, step } => (
            Vec::new(),
            vec![raw::IntegerRange {
                from_value: from,
                to_value: to,
                step: step.max(0) as u64 as i64,
            }],
        ),
        Range::Float { from, to, step } => (
            vec![raw::FloatingPointRange {
                from_value: from,
                to_value: to,
                step,
            }],
            Vec::new(),
        ),
    };
    raw::ParameterDescriptor {
        name: name.to_owned(),
        r#type: raw::ParameterValue::from(d.default.clone()).ptype,
        description: d.description.clone(),
        additional_constraints: d.constraints.clone(),
        read_only: d.read_only,
        dynamic_typing: false,
        floating_point_range,
        integer_range,
    }
}

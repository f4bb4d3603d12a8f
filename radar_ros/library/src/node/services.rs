//! The ROS 2 services of components, programs and managers (radar_msgs' `connect`, `disconnect`, `list`;
//! rcl_interfaces' parameter services): one way to make their servers and clients, with the names and QoS rmw
//! gives them.

use ros2_client::{dds::Node, Name};

use crate::error::{Error, Result};

/// The ROS name of the service `<fq>/<service>` (a manager's `connect`, a node's `get_parameters`, ...), checked.
fn service_name(fq: &str, service: &str) -> Result<Name> {
    Name::new(fq, service).map_err(|e| Error::InvalidName {
        name: format!("{fq}/{service}"),
        reason: format!("{e}"),
    })
}

/// The server of the radar_msgs service `<fq>/<service>` of type `radar_msgs/srv/<ty>` on `node`: the one way
/// radar_ros makes one (enhanced mapping as rmw does, the signal QoS both ways).
pub(crate) fn service_server<Req, Resp>(
    node: &mut Node,
    fq: &str,
    service: &str,
    ty: &str,
) -> Result<ros2_client::dds::Server<Req, Resp>>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + Clone + 'static,
{
    service_server_of(node, fq, service, "radar_msgs", ty)
}

/// [`service_server`] for a service of another package (`rcl_interfaces/srv/GetParameters`, ...).
pub(crate) fn service_server_of<Req, Resp>(
    node: &mut Node,
    fq: &str,
    service: &str,
    package: &str,
    ty: &str,
) -> Result<ros2_client::dds::Server<Req, Resp>>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + Clone + 'static,
{
    let at = ServiceAt {
        fq,
        service,
        package,
        ty,
    };
    at.make(
        node,
        crate::node::declared::Access::Reply,
        |node, name, t, q| {
            node.create_server::<Req, Resp>(
                ros2_client::dds::ServiceMapping::Enhanced,
                name,
                t,
                q.clone(),
                q,
            )
        },
    )
}

/// Where a service endpoint goes: service `<fq>/<service>` of type `<package>/srv/<ty>`.
struct ServiceAt<'a> {
    fq: &'a str,
    service: &'a str,
    package: &'a str,
    ty: &'a str,
}

impl ServiceAt<'_> {
    /// Makes a server or a client (`make(node, name, type, qos)`) as rmw does (enhanced mapping, the signal QoS
    /// both ways), recording the access (`Reply`: a server, `Request`: a client) a security policy must grant.
    fn make<T, E: std::error::Error + Send + Sync + 'static>(
        &self,
        node: &mut Node,
        access: crate::node::declared::Access,
        make: impl FnOnce(
            &mut Node,
            &Name,
            &ros2_client::ServiceTypeName,
            ros2_client::QosProfile,
        ) -> std::result::Result<T, E>,
    ) -> Result<T> {
        let path = format!("{}/{}", self.fq.trim_end_matches('/'), self.service);
        crate::node::declared::record_node(node, access, &path);
        let name = service_name(self.fq, self.service)?;
        let what = match access {
            crate::node::declared::Access::Reply => format!("service {}/{}", self.fq, self.service),
            _ => format!("a client of {}/{}", self.fq, self.service),
        };
        make(
            node,
            &name,
            &ros2_client::ServiceTypeName::new(self.package, self.ty),
            crate::wire::qos::signal_qos(),
        )
        .map_err(|e| Error::transport(what, e))
    }
}

/// A client of the radar_msgs service `<fq>/<service>` of type `radar_msgs/srv/<ty>` on `node`, made as
/// [`service_server`] makes the server.
pub(crate) fn service_client<Req, Resp>(
    node: &mut Node,
    fq: &str,
    service: &str,
    ty: &str,
) -> Result<ros2_client::dds::Client<Req, Resp>>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + Clone + 'static,
{
    service_client_of(node, fq, service, "radar_msgs", ty)
}

/// [`service_client`] for a service of another package.
pub(crate) fn service_client_of<Req, Resp>(
    node: &mut Node,
    fq: &str,
    service: &str,
    package: &str,
    ty: &str,
) -> Result<ros2_client::dds::Client<Req, Resp>>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + Clone + 'static,
{
    let at = ServiceAt {
        fq,
        service,
        package,
        ty,
    };
    at.make(
        node,
        crate::node::declared::Access::Request,
        |node, name, t, q| {
            node.create_client::<Req, Resp>(
                ros2_client::dds::ServiceMapping::Enhanced,
                name,
                t,
                q.clone(),
                q,
            )
        },
    )
}

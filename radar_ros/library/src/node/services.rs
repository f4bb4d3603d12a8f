//! The ROS 2 services of components, programs and managers (radar_msgs' `connect`, `disconnect`, `list`;
//! rcl_interfaces' parameter services): one way to make their servers and clients, with the names and QoS rmw
//! gives them.

use ros2_client::Name;

use crate::{
    error::{Error, Result},
    node::transport::{Client, RosNode as Node, Server},
};

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
) -> Result<Server<Req, Resp>>
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
) -> Result<Server<Req, Resp>>
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
            .map(Server::Dds)
            .map_err(|e| Box::new(e) as BoxError)
        },
        #[cfg(feature = "zenoh")]
        |node, name, t| {
            node.create_server::<Req, Resp>(name, t)
                .map(Server::Zenoh)
                .map_err(|e| Box::new(e) as BoxError)
        },
    )
}

/// Why a server or client could not be made, whichever transport.
type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// Where a service endpoint goes: service `<fq>/<service>` of type `<package>/srv/<ty>`.
struct ServiceAt<'a> {
    fq: &'a str,
    service: &'a str,
    package: &'a str,
    ty: &'a str,
}

impl ServiceAt<'_> {
    /// Makes a server or a client as rmw does: over DDS `dds(node, name, type, qos)` (enhanced mapping, the
    /// signal QoS both ways), over Zenoh `zenoh(node, name, type)` (a queryable, or queries, as rmw_zenoh's);
    /// recording the access (`Reply`: a server, `Request`: a client) a security policy must grant.
    fn make<T>(
        &self,
        node: &mut Node,
        access: crate::node::declared::Access,
        dds: impl FnOnce(
            &mut ros2_client::dds::Node,
            &Name,
            &ros2_client::ServiceTypeName,
            ros2_client::QosProfile,
        ) -> std::result::Result<T, BoxError>,
        #[cfg(feature = "zenoh")] zenoh: impl FnOnce(
            &ros2_client::zenoh::Node,
            &Name,
            &ros2_client::ServiceTypeName,
        ) -> std::result::Result<T, BoxError>,
    ) -> Result<T> {
        let path = format!("{}/{}", self.fq.trim_end_matches('/'), self.service);
        crate::node::declared::record_node(node, access, &path);
        let name = service_name(self.fq, self.service)?;
        let what = match access {
            crate::node::declared::Access::Reply => format!("service {}/{}", self.fq, self.service),
            _ => format!("a client of {}/{}", self.fq, self.service),
        };
        let ty = ros2_client::ServiceTypeName::new(self.package, self.ty);
        match node {
            Node::Dds(node) => dds(node, &name, &ty, crate::wire::qos::signal_qos()),
            #[cfg(feature = "zenoh")]
            Node::Zenoh(node) => {
                // the service's own hash (request, response and event as one, as rosidl hashes it) in its key
                // and tokens: an rmw_zenoh peer matches only on it (the backend knows rcl_interfaces' and a
                // few others; radar_ros ships radar_msgs', std_srvs', ...)
                let as_ros = format!("{}/srv/{}", self.package, self.ty);
                if let Some(hash) = crate::wire::msg::type_hash_of(&as_ros) {
                    let dds = format!("{}::srv::dds_::{}_", self.package, self.ty);
                    ros2_client::zenoh::register_type_hash(&dds, hash)
                        .map_err(|e| Error::transport(what.clone(), crate::error::Text(e)))?;
                }
                zenoh(&node.node, &name, &ty)
            }
        }
        .map_err(|e| Error::transport(what, crate::error::Text(e.to_string())))
    }
}

/// A client of the radar_msgs service `<fq>/<service>` of type `radar_msgs/srv/<ty>` on `node`, made as
/// [`service_server`] makes the server.
pub(crate) fn service_client<Req, Resp>(
    node: &mut Node,
    fq: &str,
    service: &str,
    ty: &str,
) -> Result<Client<Req, Resp>>
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
) -> Result<Client<Req, Resp>>
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
            .map(Client::Dds)
            .map_err(|e| Box::new(e) as BoxError)
        },
        #[cfg(feature = "zenoh")]
        |node, name, t| {
            node.create_client::<Req, Resp>(name, t)
                .map(Client::Zenoh)
                .map_err(|e| Box::new(e) as BoxError)
        },
    )
}

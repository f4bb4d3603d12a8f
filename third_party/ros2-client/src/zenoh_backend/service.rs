//! Zenoh services: `Client` and `Server` over queryable/get.
//!
//! Mirrors `rmw_zenoh` (see `docs/zenoh_study/research/rmw_zenoh.md` §5 and
//! `docs/decisions/0006-services-over-queryable-get.md`):
//!
//! * A **server** declares a `complete` queryable on the service key and, for
//!   each incoming query, reads the request (CDR payload) and its attachment
//!   `(seq, ts, client_gid)`. It stores the pending [`zenoh::query::Query`]
//!   keyed by `(client_gid, seq)` and, when the response is ready, `reply`s
//!   with the CDR response plus an attachment echoing the client's seq + gid.
//! * A **client** issues a `get` on the service key (wildcard type-hash,
//!   liberal receive) carrying the request payload + attachment, and decodes
//!   the first OK reply.

use std::{
  collections::HashMap,
  marker::PhantomData,
  sync::{
    Mutex,
    atomic::{AtomicI64, Ordering},
  },
  time::{SystemTime, UNIX_EPOCH},
};

use serde::{Serialize, de::DeserializeOwned};
use zenoh::{
  Session, Wait,
  liveliness::LivelinessToken,
  query::{ConsolidationMode, Query, QueryTarget, Queryable},
};

use super::{attachment::AttachmentData, cdr, quiet_fifo::QuietFifo};
use crate::{
  error::{ServiceError, ServiceResult},
  gid::Gid,
  request_id::RmwRequestId,
};

fn now_nanos() -> i64 {
  SystemTime::now()
    .duration_since(UNIX_EPOCH)
    .map(|d| d.as_nanos() as i64)
    .unwrap_or(0)
}

fn gid_key(gid: [u8; 16]) -> u128 {
  u128::from_le_bytes(gid)
}

/// A ROS 2 service client over Zenoh.
pub struct Client<Req, Resp> {
  session: Session,
  /// The `get` selector (concrete service key).
  selector: String,
  seq: AtomicI64,
  client_gid: [u8; 16],
  /// Optional `get` timeout override (actions' `get_result` uses a long one).
  timeout: Option<std::time::Duration>,
  _liveliness_token: Option<LivelinessToken>,
  phantom: PhantomData<fn(Req) -> Resp>,
}

impl<Req: Serialize, Resp: DeserializeOwned> Client<Req, Resp> {
  pub(crate) fn new_with_timeout(
    session: Session,
    selector: String,
    client_gid: [u8; 16],
    liveliness_token: Option<LivelinessToken>,
    timeout: Option<std::time::Duration>,
  ) -> Self {
    Self {
      session,
      selector,
      seq: AtomicI64::new(0),
      client_gid,
      timeout,
      _liveliness_token: liveliness_token,
      phantom: PhantomData,
    }
  }

  fn request_bytes(&self, req: &Req) -> ServiceResult<(Vec<u8>, zenoh::bytes::ZBytes)> {
    let payload = cdr::to_cdr(req)?;
    let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
    let attachment = AttachmentData {
      sequence_number: seq,
      source_timestamp: now_nanos(),
      source_gid: self.client_gid,
    }
    .to_zbytes();
    Ok((payload, attachment))
  }

  fn decode_reply(reply: &zenoh::query::Reply) -> Option<ServiceResult<Resp>> {
    let sample = reply.result().ok()?;
    let bytes = sample.payload().to_bytes();
    Some(cdr::from_cdr::<Resp>(&bytes).map_err(Into::into))
  }

  /// Call the service and wait (blocking) for the first reply.
  pub fn call(&self, req: Req) -> ServiceResult<Resp> {
    let (payload, attachment) = self.request_bytes(&req)?;
    let mut builder = self
      .session
      .get(&self.selector)
      .payload(payload)
      .attachment(attachment)
      .target(QueryTarget::AllComplete)
      .consolidation(ConsolidationMode::None);
    if let Some(t) = self.timeout {
      builder = builder.timeout(t);
    }
    let replies = builder.with(QuietFifo).wait()?;
    while let Ok(reply) = replies.recv_blocking() {
      if let Some(res) = Self::decode_reply(&reply) {
        return res;
      }
    }
    Err(ServiceError::NoReply)
  }

  /// Call the service and await the first reply.
  pub async fn async_call(&self, req: Req) -> ServiceResult<Resp> {
    let (payload, attachment) = self.request_bytes(&req)?;
    let mut builder = self
      .session
      .get(&self.selector)
      .payload(payload)
      .attachment(attachment)
      .target(QueryTarget::AllComplete)
      .consolidation(ConsolidationMode::None);
    if let Some(t) = self.timeout {
      builder = builder.timeout(t);
    }
    // returns at the first answer; what comes after it (another server's answer, the query's timeout) is
    // dropped quietly (patch 22)
    let replies = builder.with(QuietFifo).await?;
    while let Ok(reply) = replies.recv().await {
      if let Some(res) = Self::decode_reply(&reply) {
        return res;
      }
    }
    Err(ServiceError::NoReply)
  }
}

/// A ROS 2 service server over Zenoh.
pub struct Server<Req, Resp> {
  /// Its queries, through a [`QuietFifo`] (patch 22): those that come after the server is dropped are
  /// dropped without an error line.
  queryable: Queryable<async_channel::Receiver<Query>>,
  pending: Mutex<HashMap<(u128, i64), Query>>,
  _liveliness_token: Option<LivelinessToken>,
  phantom: PhantomData<fn(Req) -> Resp>,
}

impl<Req: DeserializeOwned, Resp: Serialize> Server<Req, Resp> {
  pub(crate) fn new(
    queryable: Queryable<async_channel::Receiver<Query>>,
    liveliness_token: Option<LivelinessToken>,
  ) -> Self {
    Self {
      queryable,
      pending: Mutex::new(HashMap::new()),
      _liveliness_token: liveliness_token,
      phantom: PhantomData,
    }
  }

  fn accept(&self, query: Query) -> ServiceResult<(RmwRequestId, Req)> {
    let payload = query.payload().ok_or(ServiceError::Malformed)?;
    let req = cdr::from_cdr::<Req>(&payload.to_bytes())?;
    let attachment = query.attachment().ok_or(ServiceError::Malformed)?;
    let a = AttachmentData::from_zbytes(attachment).map_err(|_| ServiceError::Malformed)?;
    let id = RmwRequestId {
      writer_gid: Gid::from(a.source_gid),
      sequence_number: a.sequence_number,
    };
    self
      .pending
      .lock()
      .unwrap()
      .insert((gid_key(a.source_gid), a.sequence_number), query);
    Ok((id, req))
  }

  /// Take the next pending request if one is immediately available.
  pub fn try_receive_request(&self) -> ServiceResult<Option<(RmwRequestId, Req)>> {
    match self.queryable.try_recv() {
      Ok(query) => self.accept(query).map(Some),
      Err(_) => Ok(None),
    }
  }

  /// Await the next request.
  pub async fn async_receive_request(&self) -> ServiceResult<(RmwRequestId, Req)> {
    let query = self
      .queryable
      .recv()
      .await
      .map_err(|_| ServiceError::NoReply)?;
    self.accept(query)
  }

  /// Send the response for a previously received request.
  pub fn send_response(&self, id: RmwRequestId, resp: Resp) -> ServiceResult<()> {
    let query = self
      .pending
      .lock()
      .unwrap()
      .remove(&(gid_key(id.writer_gid.to_bytes16()), id.sequence_number))
      .ok_or(ServiceError::UnknownRequest)?;
    let payload = cdr::to_cdr(&resp)?;
    // Echo the request's seq + client gid; fresh reply timestamp.
    let attachment = AttachmentData {
      sequence_number: id.sequence_number,
      source_timestamp: now_nanos(),
      source_gid: id.writer_gid.to_bytes16(),
    }
    .to_zbytes();
    query
      .reply(query.key_expr().clone(), payload)
      .attachment(attachment)
      .wait()?;
    Ok(())
  }
}

// ---------------------------------------------------------------------------

#[cfg(test)]
mod tests {
  use std::{
    sync::{
      Arc,
      atomic::{AtomicBool, Ordering},
    },
    time::{Duration, Instant},
  };

  use serde::{Deserialize, Serialize};
  use zenoh::Config;

  use super::{Client, Server};
  use crate::{
    Name, NodeName, NodeOptions, ServiceTypeName,
    zenoh_backend::context::{Context, ContextOptions},
  };

  #[derive(Serialize, Deserialize)]
  struct AddTwoIntsRequest {
    a: i64,
    b: i64,
  }
  #[derive(Serialize, Deserialize)]
  struct AddTwoIntsResponse {
    sum: i64,
  }

  fn make_config(listen_port: u16, connect_port: Option<u16>) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"peer\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
      .unwrap();
    c.insert_json5(
      "listen/endpoints",
      &format!("[\"tcp/127.0.0.1:{listen_port}\"]"),
    )
    .unwrap();
    if let Some(p) = connect_port {
      c.insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{p}\"]"))
        .unwrap();
    }
    c
  }

  #[test]
  fn add_two_ints_roundtrip() {
    let srv_port = 17519;
    let cli_port = 17520;
    let srv_ctx =
      Context::with_options(ContextOptions::new().zenoh_config(make_config(srv_port, None)))
        .unwrap();
    let cli_ctx = Context::with_options(
      ContextOptions::new().zenoh_config(make_config(cli_port, Some(srv_port))),
    )
    .unwrap();

    let srv_node = srv_ctx
      .new_node(
        NodeName::new("/", "add_server").unwrap(),
        NodeOptions::new(),
      )
      .unwrap();
    let cli_node = cli_ctx
      .new_node(
        NodeName::new("/", "add_client").unwrap(),
        NodeOptions::new(),
      )
      .unwrap();
    let stype = ServiceTypeName::new("example_interfaces", "AddTwoInts");
    let name = Name::new("/", "add_two_ints").unwrap();

    let server: Server<AddTwoIntsRequest, AddTwoIntsResponse> =
      srv_node.create_server(&name, &stype).unwrap();
    let client: Client<AddTwoIntsRequest, AddTwoIntsResponse> =
      cli_node.create_client(&name, &stype).unwrap();

    // Run the server in a background thread: answer requests with a + b.
    let stop = Arc::new(AtomicBool::new(false));
    let stop_srv = stop.clone();
    let server_thread = std::thread::spawn(move || {
      let deadline = Instant::now() + Duration::from_secs(25);
      while !stop_srv.load(Ordering::Relaxed) && Instant::now() < deadline {
        if let Ok(Some((id, req))) = server.try_receive_request() {
          let _ = server.send_response(id, AddTwoIntsResponse { sum: req.a + req.b });
        }
        std::thread::sleep(Duration::from_millis(20));
      }
    });

    // Retry the call until the peers connect and the queryable is discovered.
    let deadline = Instant::now() + Duration::from_secs(25);
    let mut sum = None;
    while Instant::now() < deadline {
      if let Ok(resp) = client.call(AddTwoIntsRequest { a: 2, b: 40 }) {
        sum = Some(resp.sum);
        break;
      }
      std::thread::sleep(Duration::from_millis(200));
    }

    stop.store(true, Ordering::Relaxed);
    let _ = server_thread.join();

    assert_eq!(sum, Some(42));
  }

  /// A server that answers only the probe (`a == 0`, to know the peers met) and holds every other request
  /// unanswered until the test ends.
  fn answer_probes_only(server: Server<AddTwoIntsRequest, AddTwoIntsResponse>) {
    std::thread::spawn(move || {
      futures::executor::block_on(async {
        let mut held = Vec::new();
        while let Ok((id, req)) = server.async_receive_request().await {
          if req.a == 0 {
            let _ = server.send_response(id, AddTwoIntsResponse { sum: req.b });
          } else {
            held.push(id);
          }
        }
      })
    });
  }

  /// Calls the probe until a server answers it.
  fn until_answered(client: &Client<AddTwoIntsRequest, AddTwoIntsResponse>) {
    let deadline = Instant::now() + Duration::from_secs(20);
    while client.call(AddTwoIntsRequest { a: 0, b: 1 }).is_err() {
      assert!(Instant::now() < deadline, "no server answered in 20 s");
      std::thread::sleep(Duration::from_millis(50));
    }
  }

  fn nodes(
    srv_port: u16,
    cli_port: u16,
    name: &str,
  ) -> (Context, Context, crate::zenoh_backend::node::Node, crate::zenoh_backend::node::Node) {
    let srv_ctx =
      Context::with_options(ContextOptions::new().zenoh_config(make_config(srv_port, None))).unwrap();
    let mut cli_config = make_config(cli_port, Some(srv_port));
    // a query unanswered is given up by Zenoh after this long (its default is 10 s)
    cli_config.insert_json5("queries_default_timeout", "300").unwrap();
    let cli_ctx = Context::with_options(ContextOptions::new().zenoh_config(cli_config)).unwrap();
    let srv_node = srv_ctx
      .new_node(NodeName::new("/", &format!("{name}_server")).unwrap(), NodeOptions::new())
      .unwrap();
    let cli_node = cli_ctx
      .new_node(NodeName::new("/", &format!("{name}_client")).unwrap(), NodeOptions::new())
      .unwrap();
    (srv_ctx, cli_ctx, srv_node, cli_node)
  }

  /// radar_ros patch 22: a caller that stops waiting for an answer (its future dropped: a timeout of its
  /// own, a cancel, a program stopping) logs no error when Zenoh later gives the query up. Zenoh's FIFO
  /// handler logged `sending on a closed channel` at ERROR when its timeout reply found the receiver gone.
  #[test]
  fn a_call_given_up_logs_no_error_when_its_query_times_out() {
    crate::zenoh_backend::logged_errors::install();
    let (_s, _c, srv_node, cli_node) = nodes(17551, 17552, "given_up");
    let stype = ServiceTypeName::new("example_interfaces", "AddTwoInts");
    let name = Name::new("/", "given_up").unwrap();
    answer_probes_only(srv_node.create_server(&name, &stype).unwrap());
    let client: Client<AddTwoIntsRequest, AddTwoIntsResponse> =
      cli_node.create_client(&name, &stype).unwrap();
    until_answered(&client);

    let before = crate::zenoh_backend::logged_errors::handler_errors();
    futures::executor::block_on(async {
      let call = futures::FutureExt::fuse(Box::pin(client.async_call(AddTwoIntsRequest { a: 1, b: 1 })));
      let (tx, rx) = futures::channel::oneshot::channel::<()>();
      std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(50));
        let _ = tx.send(());
      });
      let mut gave_up = futures::FutureExt::fuse(rx);
      futures::pin_mut!(call);
      futures::select! {
        r = call => panic!("the held request was answered: {:?}", r.is_ok()),
        _ = gave_up => {}
      }
    });
    // past the query's timeout (300 ms)
    std::thread::sleep(Duration::from_millis(800));
    let after = crate::zenoh_backend::logged_errors::handler_errors();
    assert_eq!(after, before, "an ERROR line after the caller gave up");
  }

  /// radar_ros patch 22: two servers of one service (ROS 2 allows it; a respawned server beside the old
  /// one's last moments); the call returns the first answer, and the second, coming later, is dropped
  /// quietly. Zenoh's FIFO handler logged it at ERROR (`sending on a closed channel`).
  #[test]
  fn a_second_answer_after_the_first_logs_no_error() {
    crate::zenoh_backend::logged_errors::install();
    let (_s, _c, srv_node, cli_node) = nodes(17553, 17554, "two_servers");
    let stype = ServiceTypeName::new("example_interfaces", "AddTwoInts");
    let name = Name::new("/", "two_servers").unwrap();
    let quick: Server<AddTwoIntsRequest, AddTwoIntsResponse> =
      srv_node.create_server(&name, &stype).unwrap();
    let slow: Server<AddTwoIntsRequest, AddTwoIntsResponse> =
      srv_node.create_server(&name, &stype).unwrap();
    let answer = |server: Server<AddTwoIntsRequest, AddTwoIntsResponse>, after: Duration| {
      std::thread::spawn(move || {
        futures::executor::block_on(async {
          while let Ok((id, req)) = server.async_receive_request().await {
            if req.a != 0 {
              std::thread::sleep(after);
            }
            let _ = server.send_response(id, AddTwoIntsResponse { sum: req.a + req.b });
          }
        })
      })
    };
    answer(quick, Duration::ZERO);
    answer(slow, Duration::from_millis(100));
    let client: Client<AddTwoIntsRequest, AddTwoIntsResponse> =
      cli_node.create_client(&name, &stype).unwrap();
    until_answered(&client);

    let before = crate::zenoh_backend::logged_errors::handler_errors();
    let sum = futures::executor::block_on(client.async_call(AddTwoIntsRequest { a: 2, b: 40 }));
    assert_eq!(sum.unwrap().sum, 42);
    let sum = client.call(AddTwoIntsRequest { a: 1, b: 2 });
    assert_eq!(sum.unwrap().sum, 3);
    // past the slow server's answers
    std::thread::sleep(Duration::from_millis(400));
    let after = crate::zenoh_backend::logged_errors::handler_errors();
    assert_eq!(after, before, "an ERROR line for an answer after the first");
  }

  /// radar_ros patch 22: a server dropped with queries still coming (its channel full: a server that fell
  /// behind, or stopped reading at a program's stop) logs no error; Zenoh's FIFO handler logged `sending on
  /// a closed channel` at ERROR for each query it was handed after the drop.
  #[test]
  fn a_server_dropped_while_queries_arrive_logs_no_error() {
    crate::zenoh_backend::logged_errors::install();
    let (_s, _c, srv_node, cli_node) = nodes(17557, 17558, "flooded");
    let stype = ServiceTypeName::new("example_interfaces", "AddTwoInts");
    let name = Name::new("/", "flooded").unwrap();
    let server: Server<AddTwoIntsRequest, AddTwoIntsResponse> =
      srv_node.create_server(&name, &stype).unwrap();
    let client: Client<AddTwoIntsRequest, AddTwoIntsResponse> =
      cli_node.create_client(&name, &stype).unwrap();
    // the probe, answered by hand (the server is dropped below, so it is read here, not by a thread)
    std::thread::scope(|s| {
      let probe = s.spawn(|| until_answered(&client));
      while !probe.is_finished() {
        if let Ok(Some((id, _))) = server.try_receive_request() {
          let _ = server.send_response(id, AddTwoIntsResponse { sum: 1 });
        }
        std::thread::sleep(Duration::from_millis(5));
      }
    });

    let before = crate::zenoh_backend::logged_errors::handler_errors();
    std::thread::scope(|s| {
      // more queries than the server's channel holds, none read
      s.spawn(|| {
        let calls = (0..400).map(|a| client.async_call(AddTwoIntsRequest { a: a + 1, b: 0 }));
        futures::executor::block_on(futures::future::join_all(calls));
      });
      std::thread::sleep(Duration::from_millis(150));
      drop(server);
    });
    std::thread::sleep(Duration::from_millis(200));
    let after = crate::zenoh_backend::logged_errors::handler_errors();
    assert_eq!(after, before, "ERROR lines from a server dropped while queries arrived");
  }
}

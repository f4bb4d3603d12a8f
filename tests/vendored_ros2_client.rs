//! The vendored ros2-client (`third_party/ros2-client`, see its `RADAR_PATCHES.md`): each radar_ros patch,
//! over real DDS between two participants.

use std::time::Duration;

use radar_test_util::{init_logs, require_isolation, DISCOVERY};
// the DDS backend's entities by their module path: this build has the Zenoh backend beside it
// (tests/Cargo.toml), so ros2-client does not re-export either backend's at its root
use ros2_client::{
    dds::{
        rustdds::{self, SampleIdentity, SequenceNumber, Timestamp, GUID},
        Context, ContextOptions, Node, Publisher, Subscription,
    },
    MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};

const DOMAIN: u16 = 3;

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct Int32 {
    data: i32,
}

fn node(ctx: &Context, name: &str) -> Node {
    let mut node = ctx
        .new_node(
            NodeName::new("/", name).unwrap(),
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .unwrap();
    tokio::spawn(node.spinner().unwrap().spin());
    node
}

fn qos() -> QosProfile {
    radar_ros::qos::signal_qos()
}

/// A publisher in one participant and a subscription in another, matched both ways.
async fn pair(
    topic: &str,
) -> (
    (Context, Node, Publisher<Int32>),
    (Context, Node, Subscription<Int32>),
) {
    init_logs();
    require_isolation();
    let ctx = |_| Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let (a, b) = (ctx(0), ctx(1));
    let (mut na, mut nb) = (node(&a, "writer_side"), node(&b, "reader_side"));
    let ty = MessageTypeName::new("std_msgs", "Int32");
    let name = Name::new("/", topic).unwrap();
    let ta = na.create_topic(&name, ty.clone(), &qos()).unwrap();
    let tb = nb.create_topic(&name, ty, &qos()).unwrap();
    let p = na.create_publisher::<Int32>(&ta, Some(qos())).unwrap();
    let s = nb.create_subscription::<Int32>(&tb, Some(qos())).unwrap();
    tokio::time::timeout(DISCOVERY, p.wait_for_subscription(&na))
        .await
        .expect("the subscription matched");
    tokio::time::timeout(DISCOVERY, s.wait_for_publisher(&nb))
        .await
        .expect("the publisher matched");
    // the reader side matched: the writer's first heartbeat may still be on its way; a fresh sample is
    // delivered either way (RustDDS patch 2)
    ((a, na, p), (b, nb, s))
}

#[tokio::test(flavor = "multi_thread")]
async fn publish_with_options_carries_the_source_time_and_the_related_identity() {
    let ((_a, _na, p), (_b, _nb, s)) = pair("patch1").await;
    let related = SampleIdentity {
        writer_guid: GUID::from_bytes([7; 16]),
        sequence_number: SequenceNumber::from(42_i64),
    };
    let at: Timestamp = ros2_client::ROSTime::from_nanos(1_700_000_000_123_456_789).into();
    let written = p
        .publish_with_options(
            Int32 { data: 7 },
            rustdds::WriteOptionsBuilder::new()
                .source_timestamp(at)
                .related_sample_identity(related)
                .build(),
        )
        .map_err(|e| e.forget_data())
        .expect("written");
    assert_eq!(
        written.writer_guid,
        p.guid(),
        "the identity of the sample written"
    );
    let (m, info) = tokio::time::timeout(DISCOVERY, s.async_take())
        .await
        .expect("delivered")
        .expect("decoded");
    assert_eq!(m.data, 7);
    let got = info.source_timestamp().expect("a source time");
    assert!(
        (got.to_nanos() - 1_700_000_000_123_456_789).abs() <= 1,
        "the source time given, not the time of writing: {got:?}"
    );
    let rel = info.related_request_id().expect("a related identity");
    assert_eq!(SampleIdentity::from(rel), related);
    // a plain publish carries none
    p.publish(Int32 { data: 8 })
        .map_err(|e| e.forget_data())
        .unwrap();
    let (_, info) = tokio::time::timeout(DISCOVERY, s.async_take())
        .await
        .unwrap()
        .unwrap();
    assert!(info.related_request_id().is_none());
}

#[tokio::test(flavor = "multi_thread")]
async fn wait_for_acknowledgments_returns_once_the_reader_has_everything() {
    let ((_a, _na, p), (_b, _nb, s)) = pair("patch2").await;
    for i in 0..20 {
        p.publish(Int32 { data: i })
            .map_err(|e| e.forget_data())
            .unwrap();
    }
    let acked = tokio::task::spawn_blocking(move || {
        let r = p.wait_for_acknowledgments(Duration::from_secs(10));
        (r, p)
    })
    .await
    .unwrap();
    assert_eq!(acked.0.ok(), Some(true), "acknowledged within the limit");
    // everything acknowledged is in the reader's cache now
    for i in 0..20 {
        let (m, _) = s.take().unwrap().expect("already there");
        assert_eq!(m.data, i);
    }
}

/// Patch 3: a node that creates 60 endpoints back to back sends its participant's `ros_discovery_info` a few
/// times, not once per endpoint, and the last one lists every endpoint.
#[tokio::test(flavor = "multi_thread")]
async fn many_endpoints_at_once_send_ros_discovery_info_a_few_times_not_once_each() {
    init_logs();
    require_isolation();
    let other = rustdds::DomainParticipant::new(DOMAIN).unwrap();
    let mut reader = discovery_info_reader(&other);
    let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let me = ros2_client::Gid::from(rustdds::RTPSEntity::guid(&ctx.domain_participant()));
    let mut n = node(&ctx, "many_endpoints");
    let mine = |reader: &mut DiscoveryInfoReader| discovery_info_of(reader, me);
    // the node is known: its first update has arrived
    let t0 = std::time::Instant::now();
    while mine(&mut reader).is_empty() {
        assert!(
            t0.elapsed() < DISCOVERY,
            "no ros_discovery_info from the node"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let ty = MessageTypeName::new("std_msgs", "Int32");
    let mut publishers = Vec::new();
    let burst = std::time::Instant::now();
    for i in 0..60 {
        let t = n
            .create_topic(
                &Name::new("/", &format!("p3_{i}")).unwrap(),
                ty.clone(),
                &qos(),
            )
            .unwrap();
        publishers.push(n.create_publisher::<Int32>(&t, Some(qos())).unwrap());
    }
    let took = burst.elapsed();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let updates = mine(&mut reader);
    println!(
        "{} ros_discovery_info updates for 60 endpoints made in {took:?}",
        updates.len()
    );
    // at most one per 50 ms while they were made, and one after (before: one per endpoint)
    let bound = (took.as_millis() / 50) as usize + 3;
    assert!(
        !updates.is_empty() && updates.len() <= bound.min(20),
        "{} updates for 60 endpoints made in {took:?}",
        updates.len()
    );
    let last = updates.last().unwrap();
    let listed = last
        .nodes()
        .iter()
        .find(|ni| ni.name() == "many_endpoints")
        .map(|ni| ni.writers().len())
        .unwrap_or(0);
    assert!(listed >= 60, "the last update lists every writer: {listed}");
}

type DiscoveryInfoReader =
    rustdds::no_key::DataReaderCdr<ros2_client::entities_info::ParticipantEntitiesInfo>;

/// A reader of every `ros_discovery_info` sample (reliable, keep all) in `other`.
fn discovery_info_reader(other: &rustdds::DomainParticipant) -> DiscoveryInfoReader {
    use ros2_client::builtin_topics::ros_discovery;
    let all = rustdds::QosPolicyBuilder::new()
        .reliability(rustdds::policy::Reliability::Reliable {
            max_blocking_time: rustdds::Duration::ZERO,
        })
        .history(rustdds::policy::History::KeepAll)
        .durability(rustdds::policy::Durability::Volatile)
        .build();
    let topic = other
        .create_topic(
            ros_discovery::TOPIC_NAME.to_string(),
            ros_discovery::TYPE_NAME.to_string(),
            &all,
            rustdds::TopicKind::NoKey,
        )
        .unwrap();
    other
        .create_subscriber(&all)
        .unwrap()
        .create_datareader_no_key_cdr(&topic, Some(all.clone()))
        .unwrap()
}

/// The `ros_discovery_info` samples of participant `gid` that `reader` has, oldest first.
fn discovery_info_of(
    reader: &mut DiscoveryInfoReader,
    gid: ros2_client::Gid,
) -> Vec<ros2_client::entities_info::ParticipantEntitiesInfo> {
    let mut v = Vec::new();
    while let Ok(Some(s)) = reader.take_next_sample() {
        if s.value().gid() == gid {
            v.push(s.value().clone());
        }
    }
    v
}

/// `count` publishers and as many subscriptions made back to back by `n` on topics `{prefix}_{i}`, and the GIDs
/// of all of them.
#[allow(clippy::type_complexity)]
fn pubs_and_subs(
    n: &mut Node,
    prefix: &str,
    count: usize,
) -> (
    Vec<Publisher<Int32>>,
    Vec<Subscription<Int32>>,
    std::collections::HashSet<ros2_client::Gid>,
) {
    let ty = MessageTypeName::new("std_msgs", "Int32");
    let (mut publishers, mut subscriptions) = (Vec::new(), Vec::new());
    for i in 0..count {
        let t = n
            .create_topic(
                &Name::new("/", &format!("{prefix}_{i}")).unwrap(),
                ty.clone(),
                &qos(),
            )
            .unwrap();
        publishers.push(n.create_publisher::<Int32>(&t, Some(qos())).unwrap());
        subscriptions.push(n.create_subscription::<Int32>(&t, Some(qos())).unwrap());
    }
    let gids = publishers
        .iter()
        .map(|p| p.guid().into())
        .chain(subscriptions.iter().map(|s| s.guid().into()))
        .collect();
    (publishers, subscriptions, gids)
}

/// Patch 8: a node's `ros_discovery_info` entry is made when it is sent, not at every endpoint the node
/// creates (each made it again in O(N): O(N^2) for a node of N endpoints, half of a manager's main thread when
/// it made 1,000 connections). 400 endpoints made back to back make a few entries (the count of entries made in
/// this process; other tests running beside this one add theirs), not 400; the entry sent last lists them all,
/// the node's parameter events and rosout writers first, as the node always listed them.
#[tokio::test(flavor = "multi_thread")]
async fn a_node_entry_is_made_when_sent_not_at_every_endpoint() {
    use ros2_client::entities_info::entries_made;
    init_logs();
    require_isolation();
    let other = rustdds::DomainParticipant::new(DOMAIN).unwrap();
    let mut reader = discovery_info_reader(&other);
    let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let me = ros2_client::Gid::from(rustdds::RTPSEntity::guid(&ctx.domain_participant()));
    let mut n = ctx
        .new_node(
            NodeName::new("/", "entry_when_sent").unwrap(),
            NodeOptions::new()
                .enable_rosout(true)
                .start_parameter_services(false),
        )
        .unwrap();
    let before = entries_made();
    let (_publishers, _subscriptions, mine) = pubs_and_subs(&mut n, "p8", 200);
    let made = entries_made() - before;
    assert!(made < 100, "{made} node entries made for 400 endpoints");
    let t0 = std::time::Instant::now();
    let entry = loop {
        let last = discovery_info_of(&mut reader, me).pop().and_then(|info| {
            info.nodes()
                .iter()
                .find(|ni| ni.name() == "entry_when_sent")
                .cloned()
        });
        // the entry sent once all 400 are made (one sent while they were being made lists some)
        if let Some(e) = last.filter(|e| e.readers().len() == 200 && e.writers().len() == 203) {
            break e;
        }
        assert!(
            t0.elapsed() < DISCOVERY,
            "no entry listing all 400 endpoints"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    };
    let listed: std::collections::HashSet<ros2_client::Gid> = entry
        .readers()
        .iter()
        .chain(entry.writers())
        .copied()
        .collect();
    assert!(mine.is_subset(&listed), "every endpoint listed");
    // parameter events and rosout first (neither is one of the 400), the ros_discovery_info writer last
    let w = entry.writers();
    assert_eq!(w.len(), 200 + 3, "the node's writers: {}", w.len());
    assert!(!mine.contains(&w[0]) && !mine.contains(&w[1]) && !mine.contains(&w[202]));
    assert_eq!(
        entry.readers().len(),
        200,
        "rosout is not read by this node"
    );
}

/// Patch 9: a publisher or subscription dropped is taken off its node's `ros_discovery_info` entry, and the
/// list is sent again (it only grew: a node that makes and drops endpoints, as a RADAR manager does with each
/// scope's connections, announced every GID it ever had). Five rounds of 40 endpoints made and dropped: the
/// entry sent after each drop lists none of them and no more than the node had before.
#[tokio::test(flavor = "multi_thread")]
async fn dropped_endpoints_leave_their_nodes_entry() {
    init_logs();
    require_isolation();
    let other = rustdds::DomainParticipant::new(DOMAIN).unwrap();
    let mut reader = discovery_info_reader(&other);
    let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let me = ros2_client::Gid::from(rustdds::RTPSEntity::guid(&ctx.domain_participant()));
    let mut n = node(&ctx, "drops_endpoints");
    // the node's entry as last sent, once it satisfies `done`
    let mut last = None;
    let mut entry_when = |done: &dyn Fn(&ros2_client::entities_info::NodeEntitiesInfo) -> bool| {
        let t0 = std::time::Instant::now();
        loop {
            for info in discovery_info_of(&mut reader, me) {
                last = info
                    .nodes()
                    .iter()
                    .find(|ni| ni.name() == "drops_endpoints")
                    .cloned();
            }
            match &last {
                Some(e) if done(e) => return e.clone(),
                _ => {}
            }
            assert!(t0.elapsed() < DISCOVERY, "last entry sent: {last:?}");
            std::thread::sleep(Duration::from_millis(10));
        }
    };
    let count =
        |e: &ros2_client::entities_info::NodeEntitiesInfo| e.readers().len() + e.writers().len();
    let base = count(&entry_when(&|_| true));
    for round in 0..5 {
        let (publishers, subscriptions, made) = pubs_and_subs(&mut n, &format!("p9_{round}"), 20);
        let listed = |e: &ros2_client::entities_info::NodeEntitiesInfo| {
            e.readers()
                .iter()
                .chain(e.writers())
                .filter(|g| made.contains(*g))
                .count()
        };
        entry_when(&|e| listed(e) == 40);
        drop(publishers);
        drop(subscriptions);
        let after = entry_when(&|e| listed(e) == 0);
        assert_eq!(
            count(&after),
            base,
            "round {round}: the node's own endpoints only"
        );
    }
}

/// Patch 4: dropping a publisher waits until its subscription has acknowledged what it sent: right after the
/// drop, everything is in the subscription's cache.
#[tokio::test(flavor = "multi_thread")]
async fn a_dropped_publisher_leaves_nothing_unacknowledged() {
    let ((_a, _na, p), (_b, _nb, s)) = pair("patch4").await;
    for i in 0..50 {
        p.publish(Int32 { data: i })
            .map_err(|e| e.forget_data())
            .unwrap();
    }
    tokio::task::spawn_blocking(move || drop(p)).await.unwrap();
    let mut got = 0;
    while let Ok(Some(_)) = s.take() {
        got += 1;
    }
    assert_eq!(got, 50, "all there the moment the drop returned");
}

/// The threads of this process that belong to a DDS participant or its context: RustDDS's event loop and
/// discovery, ros2-client's `ros_discovery_info` thread (their names as `/proc` shows them: 15 bytes).
fn participant_threads() -> Vec<String> {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return vec!["(no /proc/self/task)".into()];
    };
    tasks
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("comm")).ok())
        .map(|n| n.trim().to_owned())
        .filter(|n| n.starts_with("RustDDS") || n.starts_with("ros2-discovery"))
        .collect()
}

/// Patch 6: the last handle of a context takes its participant down before it returns, also while the
/// context's `ros_discovery_info` thread holds the context to broadcast: no thread of it is left. Before, the
/// participant's drop (its goodbye to the graph) then ran later in that thread, and a process ending right after
/// left without it (its peers saw it go only when its lease ran out). The thread is made to hold the context
/// 300 ms after each broadcast (`RADAR_TEST_HOLD_BROADCAST_MS`), and the handle dropped in that window. Runs in
/// a child process of its own, so that no other test's participant is counted.
#[test]
fn the_last_context_handle_takes_the_participant_down_before_it_returns() {
    const CHILD: &str = "RADAR_TEST_LAST_HANDLE_CHILD";
    let name = "the_last_context_handle_takes_the_participant_down_before_it_returns";
    if std::env::var_os(CHILD).is_none() {
        require_isolation();
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .args(["--exact", name, "--nocapture", "--test-threads", "1"])
            .env(CHILD, "1")
            .env("RADAR_TEST_HOLD_BROADCAST_MS", "300")
            .output()
            .expect("run this test in a child process");
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(
            out.status.success() && stdout.contains(&format!("{name} ... ok")),
            "the child failed:\n{stdout}\n{stderr}"
        );
        return;
    }
    assert!(participant_threads().is_empty(), "none before");
    for round in 0..3 {
        let ctx = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
        // the node's creation is broadcast at once: the thread holds the context from then on for 300 ms
        let n = ctx
            .new_node(
                NodeName::new("/", &format!("last_handle_{round}")).unwrap(),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .unwrap();
        std::thread::sleep(Duration::from_millis(50));
        assert!(!participant_threads().is_empty(), "round {round}: running");
        let t = std::time::Instant::now();
        drop(n);
        drop(ctx);
        let left = participant_threads();
        assert!(
            left.is_empty(),
            "round {round}: still running {:?} after the last handle went: {left:?}",
            t.elapsed()
        );
    }
}

/// Patch 7: a node's `ros_discovery_info` entry made in one pass lists the same readers and writers, each once and
/// in the same order, as adding them one by one (which searched the list at every add: O(N^3) for a node of N
/// endpoints, seen as 31 s for `radar view` of 2,000 components).
#[test]
fn a_node_info_lists_each_entity_once_in_order_as_add_did() {
    use ros2_client::{entities_info::NodeEntitiesInfo, Gid};
    let gid = |k: u8| {
        let mut bytes = [0u8; 16];
        bytes[11] = k;
        Gid::from(bytes)
    };
    let readers: Vec<Gid> = [3, 1, 3, 2, 1].map(gid).to_vec();
    let writers: Vec<Gid> = [9, 9, 7].map(gid).to_vec();
    let name = NodeName::new("/", "n").unwrap();
    let mut one_by_one = NodeEntitiesInfo::new(name.clone());
    for r in &readers {
        one_by_one.add_reader(*r);
    }
    for w in &writers {
        one_by_one.add_writer(*w);
    }
    let at_once = NodeEntitiesInfo::with_entities(name, readers, writers);
    assert_eq!(at_once.readers(), one_by_one.readers());
    assert_eq!(at_once.writers(), one_by_one.writers());
    assert_eq!(at_once.readers(), [3, 1, 2].map(gid));
    assert_eq!(at_once.writers(), [9, 7].map(gid));
}

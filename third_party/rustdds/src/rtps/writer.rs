use std::{
  cell::RefCell,
  cmp::{max, min},
  collections::{BTreeMap, BTreeSet},
  ops::Bound::Included,
  rc::Rc,
  sync::mpsc::TrySendError,
};

#[allow(unused_imports)]
use log::{debug, error, info, trace, warn};
use speedy::Endianness;
use mio1::Token;

use crate::{
  rtps::type_hash::TypeHashRefusals,
  dds::{
    qos::{
      policy,
      policy::{History, Reliability},
      HasQoSPolicy, QosPolicies,
    },
    statusevents::{
      CountWithChange, DataWriterStatus, DomainParticipantStatusEvent, StatusChannelSender,
    },
  },
  messages::submessages::submessages::AckSubmessage,
  network::{udp_sender::UDPSender, util::IfAddr},
  polling::SharedTimer,
  rtps::{
    constant::{
      DEFAULT_WRITER_MAX_SAMPLES, FALLBACK_MAX_AGGREGATED_DATAGRAM_SIZE, FRAGMENT_SIZE,
      HEARTBEAT_PERIOD_FAST, HEARTBEAT_PERIOD_SLOW, HEARTBEAT_SUBMESSAGE_SERIALIZED_SIZE,
      NACK_RESPONSE_DELAY, NACK_SUPPRESSION_DURATION, REPAIR_BATCH_MAX_BYTES,
      REPAIR_BATCH_MAX_BYTES_SAME_HOST,
      REPAIR_INTERVAL_DEFAULT, REPAIR_INTERVAL_MAX, REPAIR_INTERVAL_MIN,
    },
    outbound::{SocketId, TrafficClass},
    rtps_reader_proxy::RtpsReaderProxy,
    timed_event::DpTimerEvent,
    transmit::{DefaultRouteSelector, InterfaceObservations, RouteKey},
    writer_send_buffer::{InlinePlan, WriterSendBuffer},
    Message, MessageBuilder,
  },
  structure::{
    cache_change::CacheChange,
    duration::Duration,
    entity::RTPSEntity,
    guid::{EntityId, GuidPrefix, GUID},
    locator::Locator,
    sequence_number::{FragmentNumber, SequenceNumber},
    time::Timestamp,
  },
};
#[cfg(feature = "security")]
use crate::{
  rtps::Submessage,
  security::{
    security_plugins::{SecurityPlugins, SecurityPluginsHandle},
    SecurityResult,
  },
};
#[cfg(not(feature = "security"))]
use crate::no_security::SecurityPluginsHandle;

#[derive(PartialEq, Eq, Clone, Copy)]
pub enum DeliveryMode {
  Unicast,
  Multicast,
}

/// nonblocking-transmit: how far into the current push-mode sample we have
/// transmitted. Lets a large (fragmented) sample resume from the exact point
/// where the socket last returned WouldBlock, instead of restarting.
/// (see src/rtps/nonblocking_transmit_design.md)
#[derive(PartialEq, Eq, Clone, Copy, Debug)]
pub(crate) enum SampleCursor {
  /// Nothing of this sample has been transmitted yet (fresh DATA, or the first
  /// DATAFRAG together with any leading GAP).
  Fresh,
  /// Resume DATAFRAG transmission starting at this fragment number, then the
  /// trailing HEARTBEAT.
  Frag(FragmentNumber),
  /// All fragments sent; only the trailing HEARTBEAT of a fragmented sample
  /// remains.
  Heartbeat,
}

/// Item 1 (DATA aggregation): outcome of attempting to coalesce one or more
/// consecutive unfragmented multicast-to-all samples into a single datagram.
pub(crate) enum BatchOutcome {
  /// The aggregated datagram was accepted by every socket. `last_seq` is the
  /// highest sequence number included in the batch.
  Sent { last_seq: SequenceNumber },
  /// A socket returned WouldBlock and back-pressure applies (reliable, or a
  /// best-effort sample that opted in to blocking). The whole datagram is
  /// all-or-nothing: `last_sent` is left unchanged so the batch is rebuilt and
  /// resent from its first sequence number on the next write-readiness wake.
  Blocked { blocked: BTreeSet<SocketId> },
  /// A socket returned WouldBlock for a best-effort batch that must not block;
  /// the whole datagram is dropped and we advance past it. `last_seq` is the
  /// highest sequence number in the dropped batch.
  Dropped { last_seq: SequenceNumber },
}

/// nonblocking-transmit: outcome of a resumable bulk send of one cache change.
pub(crate) enum SendProgress {
  /// The whole sample (all fragments + trailing HEARTBEAT) was transmitted.
  Complete,
  /// A socket returned WouldBlock. `cursor` is where to resume, `blocked` names
  /// the sockets to arm for write readiness.
  Blocked {
    cursor: SampleCursor,
    blocked: BTreeSet<SocketId>,
  },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TimedEvent {
  Heartbeat,
  CacheCleaning,
  SendRepairData { to_reader: GUID },
  SendRepairFrags { to_reader: GUID },
}

// This is used to construct an actual Writer.
// Ingredients are sendable between threads, whereas the Writer is not.
pub(crate) struct WriterIngredients {
  pub guid: GUID,
  /// Shared, flow-controlled buffer of outgoing samples. The producer end is
  /// held by the `DataWriter`; this clone is the consumer end for the Writer.
  pub send_buffer: WriterSendBuffer,
  pub topic_name: String,
  pub(crate) like_stateless: bool, // Usually false (see like_stateless attribute of Writer)
  pub qos_policies: QosPolicies,
  pub status_sender: StatusChannelSender<DataWriterStatus>,

  pub(crate) security_plugins: Option<SecurityPluginsHandle>,
}

pub(crate) struct Writer {
  pub endianness: Endianness,
  /// Configures the mode in which the
  /// Writer operates. If
  /// pushMode==true, then the Writer
  /// will push changes to the reader. If
  /// pushMode==false, changes will
  /// only be announced via heartbeats
  /// and only be sent as response to the
  /// request of a reader
  pub push_mode: bool,
  /// Protocol tuning parameter that
  /// allows the RTPS Writer to
  /// repeatedly announce the
  /// availability of data by sending a
  /// Heartbeat Message.
  pub heartbeat_period: Option<Duration>,
  /// Faster Heartbeat period used while some matched reader still has
  /// unacknowledged samples. `None` for BestEffort (no periodic Heartbeat).
  pub heartbeat_period_fast: Option<Duration>,
  /// duration to launch cache change remove from DDSCache
  pub cache_cleaning_period: Duration,
  /// A Heartbeat tick is scheduled (RADAR patch 16: a writer whose readers have everything, or that has
  /// none, keeps no timer; a write or a new reader schedules it again).
  heartbeat_armed: bool,
  /// A cache cleaning is scheduled (RADAR patch 16: not while nothing was written since the last one).
  cache_cleaning_armed: bool,
  /// The last change when the cache was last cleaned.
  cleaned_up_to: SequenceNumber,
  /// Bumped when a reader is matched or unmatched (RADAR patch 16): the event loop's index of which writers
  /// have readers in which participant is valid while it stays put. Set by the event loop.
  pub(crate) match_generation: Option<Rc<std::cell::Cell<u64>>>,
  /// Protocol tuning parameter that
  /// allows the RTPS Writer to delay
  /// the response to a request for data
  /// from a negative acknowledgment.
  pub nack_response_delay: std::time::Duration,
  pub nackfrag_response_delay: std::time::Duration,

  /// Protocol tuning parameter that
  /// allows the RTPS Writer to ignore
  /// requests for data from negative
  /// acknowledgments that arrive ‘too
  /// soon’ after the corresponding
  /// change is sent.
  // TODO: use this
  #[allow(dead_code)]
  pub nack_suppression_duration: std::time::Duration,

  /// Largest serialized payload advertised at writer creation (discovery
  /// metadata fallback). Transmit decisions use
  /// [`Self::max_unfragmented_serialized_payload`] instead.
  #[allow(dead_code)]
  pub data_max_size_serialized: usize,

  my_guid: GUID,

  /// The RTPS ReaderProxy class represents the information an RTPS
  /// StatefulWriter maintains on each matched RTPS Reader
  readers: BTreeMap<GUID, RtpsReaderProxy>,
  /// RADAR patch 62: readers of this participant matched with this writer that the application feeds itself
  /// (`crate::local_delivery`): counted as matched, sent nothing, never waited for.
  local_readers: std::collections::BTreeSet<GUID>,
  matched_readers_count_total: i32, // all matches ever, never decremented
  requested_incompatible_qos_count: i32, // how many times some Reader requested incompatible QoS

  // Sending mechanism
  udp_sender: Rc<UDPSender>,

  // Extra fixed unicast destinations that every outgoing message from this
  // writer is *also* sent to, bypassing route selection. Empty for all writers
  // except the built-in SPDP participant writer, which uses it for the
  // "localhost SPDP peers" (127.0.0.1:<well-known SPDP ports>) so same-host
  // participants discover each other with no external network. Unlike loopback
  // locators discovered from peers, these are unconditional (they are how we
  // bootstrap same-host discovery in the first place). See
  // `src/rtps/loopback_same_host_design.md`.
  extra_unicast_destinations: Vec<Locator>,

  // Whether route selection may prefer a same-host peer's loopback locator.
  // Mirrors the participant-builder `same_host_loopback` knob; `true` by
  // default. Passed into `DefaultRouteSelector` on every route resolution.
  prefer_loopback_same_host: bool,

  // Interface-aware transmit: per-remote observed receive interfaces/addresses,
  // shared (intra-thread) with the MessageReceiver that records them. Consulted
  // when (re)resolving each reader proxy's SendRoute.
  interface_observations: Rc<RefCell<InterfaceObservations>>,

  // Snapshot of the local interface table (shared, read-only), used to resolve
  // each matched reader's per-peer path-MTU budget when its locators change.
  local_interfaces: Rc<[IfAddr]>,

  // Minimum per-peer datagram-payload budget over all matched readers. The
  // aggregated / packed datagram is a single packet shared by every reader
  // (sent to `EntityId::UNKNOWN`), so it must fit the smallest reader's path
  // MTU. Recomputed whenever a reader is added, updated, or removed. Falls back
  // to `FALLBACK_MAX_AGGREGATED_DATAGRAM_SIZE` when there are no matched readers.
  min_datagram_payload: usize,

  // By default, this writer is a StatefulWriter (see RTPS spec section 8.4.9)
  // If like_stateless is true, then the writer mimics the behavior of a Best-Effort
  // StatelessWriter. This behavior is needed only for a single built-in discovery topic of
  // Secure DDS (topic DCPSParticipantStatelessMessage).
  // The basic idea in mimicking BestEffort & Stateless is:
  //  1. Make sure no heartbeats, acknacks, or anything related to Reliable behavior is processed
  //  2. Use the RtpsReaderProxies merely as locators, do not utilize/modify their state
  // Note that unlike the Best-Effort StatelessWriter in the specification, here we don't send
  // GAP messages. But this shouldn't matter since the expected remote Reader is also BestEffort &
  // Stateless, and therefore does not process GAP messages at all.
  like_stateless: bool,

  /// Writer can only read/write to this topic DDSHistoryCache.
  my_topic_name: String,

  /// Shared, flow-controlled buffer of outgoing samples. Filled by the
  /// `DataWriter` (admission + sequence numbering), drained/transmitted here.
  send_buffer: WriterSendBuffer,
  /// Highest sequence number this Writer has fully transmitted (push mode).
  /// Samples with `seq` in `(last_sent, send_buffer.last]` are pending send.
  last_sent: SequenceNumber,
  /// nonblocking-transmit: transmit progress within the sample `last_sent + 1`
  /// (the one currently being pushed). `Fresh` unless a large sample was
  /// interrupted mid-way by a full socket.
  sample_cursor: SampleCursor,
  /// nonblocking-transmit: sockets on which the last push attempt hit
  /// WouldBlock. Drained by the event loop, which enqueues this writer on those
  /// sockets' round-robin queues and arms write readiness.
  blocked_sockets: BTreeSet<SocketId>,

  /// Contains timer that needs to be set to timeout with duration of
  /// self.heartbeat_period timed_event_handler sends notification when timer
  /// is up via mio channel to poll in Dp_eventWrapper this also handles
  /// writers cache cleaning timeouts.
  pub(crate) timed_event_timer: SharedTimer<DpTimerEvent>,

  qos_policies: QosPolicies,
  /// RADAR patch 70: readers not matched for announcing another ROS 2 type hash
  type_hash_refusals: TypeHashRefusals,

  // Used for sending status info about messages sent
  status_sender: StatusChannelSender<DataWriterStatus>,
  // offered_deadline_status: OfferedDeadlineMissedStatus,
  participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,

  security_plugins: Option<SecurityPluginsHandle>,
}

impl Writer {
  pub fn new(
    i: WriterIngredients,
    udp_sender: Rc<UDPSender>,
    timed_event_timer: SharedTimer<DpTimerEvent>,
    participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,
    interface_observations: Rc<RefCell<InterfaceObservations>>,
    local_interfaces: Rc<[IfAddr]>,
  ) -> Self {
    // If writer should behave statelessly, only BestEffort QoS is currently
    // supported
    if i.like_stateless && i.qos_policies.is_reliable() {
      panic!("RustDDS internal bug: attempted to create a stateless-like Writer with Reliable QoS");
    }

    let heartbeat_period = i
      .qos_policies
      .reliability
      .and_then(|reliability| {
        if matches!(reliability, Reliability::Reliable { .. }) {
          Some(HEARTBEAT_PERIOD_SLOW)
        } else {
          None
        }
      })
      .map(|hbp| {
        // What is the logic here? Which spec section?
        if let Some(policy::Liveliness::ManualByTopic { lease_duration }) =
          i.qos_policies.liveliness
        {
          let std_dur = lease_duration;
          std_dur / 3
        } else {
          hbp
        }
      });

    // Faster Heartbeat period used while some reader is still behind. Never
    // slower than the (possibly liveliness-shortened) slow period.
    let heartbeat_period_fast = heartbeat_period.map(|slow| min(HEARTBEAT_PERIOD_FAST, slow));

    // TODO: Configuration value
    let cache_cleaning_period = Duration::from_secs(6);

    // Start periodic Heartbeat
    if let Some(period) = heartbeat_period {
      timed_event_timer.borrow_mut().set_timeout(
        std::time::Duration::from(period),
        DpTimerEvent::Writer {
          entity_id: i.guid.entity_id,
          event: TimedEvent::Heartbeat,
        },
      );
    }
    // start periodic cache cleaning
    timed_event_timer.borrow_mut().set_timeout(
      std::time::Duration::from(cache_cleaning_period),
      DpTimerEvent::Writer {
        entity_id: i.guid.entity_id,
        event: TimedEvent::CacheCleaning,
      },
    );

    let writer = Self {
      endianness: Endianness::LittleEndian,
      push_mode: true,
      heartbeat_period,
      heartbeat_period_fast,
      cache_cleaning_period,
      heartbeat_armed: heartbeat_period.is_some(),
      cache_cleaning_armed: true,
      cleaned_up_to: SequenceNumber::zero(),
      match_generation: None,
      nack_response_delay: NACK_RESPONSE_DELAY, // default value from dp_event_loop
      nackfrag_response_delay: NACK_RESPONSE_DELAY, // default value from dp_event_loop
      nack_suppression_duration: NACK_SUPPRESSION_DURATION,
      // Conservative fallback for any discovery advertisement of max sample size.
      data_max_size_serialized: FALLBACK_MAX_AGGREGATED_DATAGRAM_SIZE,
      my_guid: i.guid,
      readers: BTreeMap::new(),
      local_readers: std::collections::BTreeSet::new(),
      matched_readers_count_total: 0,
      requested_incompatible_qos_count: 0,
      udp_sender,
      extra_unicast_destinations: Vec::new(),
      prefer_loopback_same_host: true,
      interface_observations,
      local_interfaces,
      min_datagram_payload: FALLBACK_MAX_AGGREGATED_DATAGRAM_SIZE,
      my_topic_name: i.topic_name,
      send_buffer: i.send_buffer,
      last_sent: SequenceNumber::zero(),
      sample_cursor: SampleCursor::Fresh,
      blocked_sockets: BTreeSet::new(),
      timed_event_timer,
      like_stateless: i.like_stateless,
      qos_policies: i.qos_policies,
      type_hash_refusals: TypeHashRefusals::default(),
      status_sender: i.status_sender,
      participant_status_sender,

      security_plugins: i.security_plugins,
    };
    // RADAR patch 61: no reader yet
    writer.refresh_inline_plan();
    writer
  }

  /// Entity id encoded as a mio token. The internal poll no longer registers
  /// per-writer tokens; the doorbell ready queue carries the id instead.
  #[allow(dead_code)]
  pub fn entity_token(&self) -> Token {
    self.guid().entity_id.as_token()
  }

  pub fn is_reliable(&self) -> bool {
    self.qos_policies.is_reliable()
  }

  /// Lists the known local (same DomainParticipant) ReaderProxies
  /// Note that local non-matching Readers are not here.
  pub fn local_readers(&self) -> Vec<EntityId> {
    let min = GUID::new_with_prefix_and_id(self.my_guid.prefix, EntityId::MIN);
    let max = GUID::new_with_prefix_and_id(self.my_guid.prefix, EntityId::MAX);

    self
      .readers
      .range((Included(min), Included(max)))
      .filter_map(|(guid, _)| {
        if guid.prefix == self.my_guid.prefix {
          Some(guid.entity_id)
        } else {
          None
        }
      })
      .collect()
  }

  // --------------------------------------------------------------
  // --------------------------------------------------------------
  // --------------------------------------------------------------

  // Schedule a timed event for this Writer on the event loop's shared timer.
  // The payload is tagged with this Writer's EntityId so the event loop can
  // route the fired event back to this Writer.
  /// Heartbeats of a writer with ManualByTopic liveliness assert it (the period is a third of the lease).
  fn heartbeat_asserts_liveliness(&self) -> bool {
    matches!(
      self.qos_policies.liveliness,
      Some(policy::Liveliness::ManualByTopic { .. })
    )
  }

  /// Schedules the Heartbeat tick (after the fast period: something may be unacknowledged) and the cache
  /// cleaning if they stopped while the writer was idle (RADAR patch 16).
  fn arm_idle_timers(&mut self) {
    if !self.heartbeat_armed {
      if let Some(period) = self.heartbeat_period_fast.or(self.heartbeat_period) {
        self.heartbeat_armed = true;
        self.schedule_timed_event(std::time::Duration::from(period), TimedEvent::Heartbeat);
      }
    }
    if !self.cache_cleaning_armed {
      self.cache_cleaning_armed = true;
      self.schedule_timed_event(
        std::time::Duration::from(self.cache_cleaning_period),
        TimedEvent::CacheCleaning,
      );
    }
  }

  fn schedule_timed_event(&self, after: std::time::Duration, event: TimedEvent) {
    self.timed_event_timer.borrow_mut().set_timeout(
      after,
      DpTimerEvent::Writer {
        entity_id: self.my_guid.entity_id,
        event,
      },
    );
  }

  // Time between repair rounds for one reader. See REPAIR_INTERVAL_DEFAULT.
  fn repair_interval(&self) -> std::time::Duration {
    repair_interval_for(self.qos_policies.deadline().map(|dl| dl.0))
  }

  // Arm SendRepairData for `reader_guid` unless one is already pending, so one
  // reader never has two repair rounds running in parallel.
  fn schedule_repair_data(&mut self, reader_guid: GUID, after: std::time::Duration) {
    if let Some(rp) = self.lookup_reader_proxy_mut(reader_guid) {
      if !rp.repair_data_scheduled {
        rp.repair_data_scheduled = true;
        self.schedule_timed_event(
          after,
          TimedEvent::SendRepairData {
            to_reader: reader_guid,
          },
        );
      }
    }
  }

  // Same as schedule_repair_data, for SendRepairFrags.
  fn schedule_repair_frags(&mut self, reader_guid: GUID, after: std::time::Duration) {
    if let Some(rp) = self.lookup_reader_proxy_mut(reader_guid) {
      if !rp.repair_frags_scheduled {
        rp.repair_frags_scheduled = true;
        self.schedule_timed_event(
          after,
          TimedEvent::SendRepairFrags {
            to_reader: reader_guid,
          },
        );
      }
    }
  }

  // Whether the socket a unicast repair to this reader goes out on already has
  // queued control datagrams. Repairs are never dropped, so sending more there
  // would only lengthen the queue; the round waits for the next interval.
  fn repair_backlogged(&self, reader_guid: GUID) -> bool {
    let Some(rp) = self.readers.get(&reader_guid) else {
      return false;
    };
    // Same choice as send_message_to_readers makes for DeliveryMode::Unicast.
    let route = rp.send_route();
    let uses_unicast = if route.fallback {
      rp.unicast_locator_list.iter().any(Locator::is_udp)
    } else {
      route.unicast.is_some()
    };
    if uses_unicast {
      self.udp_sender.control_backlogged(SocketId::Unicast)
    } else {
      self
        .udp_sender
        .socket_ids()
        .into_iter()
        .filter(|id| matches!(id, SocketId::Multicast(_)))
        .any(|id| self.udp_sender.control_backlogged(id))
    }
  }

  // Handle a single timed event. The shared timer is drained by the event loop,
  // which dispatches each expired event to the addressed Writer.
  pub fn handle_timed_event(&mut self, event: TimedEvent) {
    match event {
      TimedEvent::Heartbeat => {
        let readers_behind = self.handle_heartbeat_tick(false);
        // ^^ false = This is automatic heartbeat by timer, not manual by application
        // call.
        // Adaptive period: reschedule sooner (fast) while some reader still has
        // unacknowledged data so repair is prompted quickly. Once everyone is
        // caught up (or nobody is matched) the timer stops: a write or a newly
        // matched reader starts it again (RADAR patch 16). A writer whose
        // heartbeats assert its liveliness keeps ticking.
        let next_period = if readers_behind {
          self.heartbeat_period_fast.or(self.heartbeat_period)
        } else if self.heartbeat_asserts_liveliness() {
          self.heartbeat_period
        } else {
          None
        };
        self.heartbeat_armed = next_period.is_some();
        if let Some(period) = next_period {
          self.schedule_timed_event(std::time::Duration::from(period), TimedEvent::Heartbeat);
        }
      }
      TimedEvent::CacheCleaning => {
        self.handle_cache_cleaning();
        // nothing written since the last cleaning: stop until the next write (RADAR patch 16)
        let last = self.send_buffer.last_change_sequence_number();
        self.cache_cleaning_armed = last != self.cleaned_up_to;
        self.cleaned_up_to = last;
        if self.cache_cleaning_armed {
          self.schedule_timed_event(
            std::time::Duration::from(self.cache_cleaning_period),
            TimedEvent::CacheCleaning,
          );
        }
      }
      TimedEvent::SendRepairData {
        to_reader: reader_guid,
      } => {
        match self.lookup_reader_proxy_mut(reader_guid) {
          Some(rp) => rp.repair_data_scheduled = false,
          None => return, // reader is gone
        }
        // Do not add to a send socket that already holds queued control
        // datagrams: back off and try again in the next round.
        if !self.repair_backlogged(reader_guid) {
          self.handle_repair_data_send(reader_guid);
        }
        if self
          .readers
          .get(&reader_guid)
          .is_some_and(|rp| rp.repair_mode)
        {
          self.schedule_repair_data(reader_guid, self.repair_interval());
        }
      }
      TimedEvent::SendRepairFrags {
        to_reader: reader_guid,
      } => {
        match self.lookup_reader_proxy_mut(reader_guid) {
          Some(rp) => rp.repair_frags_scheduled = false,
          None => return, // reader is gone
        }
        if !self.repair_backlogged(reader_guid) {
          self.handle_repair_frags_send(reader_guid);
        }
        if self
          .readers
          .get(&reader_guid)
          .is_some_and(RtpsReaderProxy::repair_frags_requested)
        {
          self.schedule_repair_frags(reader_guid, self.repair_interval());
        }
      } // SendRepairFrags
    } // match
  } // fn

  /// This is called by dp_wrapper every time cacheCleaning message is received.
  fn handle_cache_cleaning(&mut self) {
    // Upper bound on retained samples. Use the Writer QoS ResourceLimits if it
    // specifies a positive max_samples; otherwise fall back to a generous
    // default so that a reliable Writer keeps unacknowledged samples available
    // for repair instead of evicting them eagerly. This is only a memory-safety
    // backstop, not a normal operating limit.
    let resource_limit = self
      .qos_policies
      .resource_limits()
      .map(|rl| rl.max_samples)
      .filter(|&max_samples| max_samples > 0)
      .map_or(DEFAULT_WRITER_MAX_SAMPLES, |max_samples| {
        max_samples as usize
      });

    match self.qos_policies.history {
      None => {
        // DDS Specification says this is the default History policy
        self.remove_all_acked_changes_but_keep_depth(Some(1), resource_limit);
      }
      Some(History::KeepAll) => {
        self.remove_all_acked_changes_but_keep_depth(None, resource_limit);
      }
      Some(History::KeepLast { depth: d }) => {
        self.remove_all_acked_changes_but_keep_depth(Some(d as usize), resource_limit);
      }
    }
  }

  // --------------------------------------------------------------
  // --------------------------------------------------------------
  // --------------------------------------------------------------
  // Per-peer UDP-payload budget (bytes for RTPS submessages in one datagram)
  // for a send: the specific reader's resolved path-MTU budget for a directed
  // send, or the writer-wide minimum over all matched readers for a
  // multicast-to-all send (one datagram shared by every reader).
  fn datagram_budget(&self, target_reader_opt: Option<&RtpsReaderProxy>) -> usize {
    match target_reader_opt {
      Some(reader) => reader.max_datagram_payload(),
      None => self.min_datagram_payload,
    }
  }

  /// Largest serialized payload that fits in one unfragmented DATA submessage
  /// within the per-peer datagram budget. Fragmentation is triggered only when
  /// the payload exceeds this, not when it exceeds [`FRAGMENT_SIZE`].
  fn max_unfragmented_serialized_payload(
    &self,
    target_reader_opt: Option<&RtpsReaderProxy>,
  ) -> usize {
    let budget = self.datagram_budget(target_reader_opt);
    let hb_reserve = if self.is_reliable() && !self.like_stateless {
      HEARTBEAT_SUBMESSAGE_SERIALIZED_SIZE
    } else {
      0
    };
    budget
      .saturating_sub(hb_reserve)
      .saturating_sub(DATA_SUBMESSAGE_OVERHEAD)
  }

  fn num_frags_and_frag_size(&self, payload_size: usize) -> (u32, u16) {
    let fragment_size = FRAGMENT_SIZE as u32;
    let data_size = payload_size as u32; // TODO: overflow check
                                         // Formula from RTPS spec v2.5 Section "8.3.8.3.5 Logical Interpretation"
    let num_frags =
      (data_size / fragment_size) + u32::from(!data_size.is_multiple_of(fragment_size)); // rounding up
    debug!("Fragmenting {data_size} to {num_frags} x {fragment_size}");
    // TODO: Check fragment_size overflow
    (num_frags, fragment_size as u16)
  }

  // The DataWriter has admitted one or more new samples into the shared send
  // buffer and rung the doorbell. Transmit every sample we have not sent yet.
  //
  // nonblocking-transmit: this is also the resume entry point. When a socket
  // returns WouldBlock mid-way, we stop and remember exactly where (`last_sent`
  // + `sample_cursor`); the event loop re-invokes us on write readiness. Large
  // (fragmented) samples resume from the exact fragment, never restart. Blocked
  // sockets are recorded in `blocked_sockets` for the event loop to schedule.
  // Prune a completed / dropped / skipped sequence number from every matched
  // reader's `unsent_changes` set. Historically this was only done on the NACK
  // repair path (`mark_change_sent`), so a best-effort push (which never gets
  // ACKNACKs) left `unsent_changes` growing by one entry per sample forever.
  // Pruning here keeps the per-reader bookkeeping bounded on the push path too.
  fn mark_change_sent_to_all_readers(&mut self, sequence_number: SequenceNumber) {
    if self.like_stateless {
      return;
    }
    for reader in self.readers.values_mut() {
      reader.mark_change_sent(sequence_number);
    }
  }

  // Item 1: is this sample eligible for the DATA-coalescing fast path?
  // We only coalesce unfragmented samples that go to every matched reader
  // (multicast-to-all). Fragmented or single-reader samples keep the existing
  // per-sample / per-fragment path.
  fn is_aggregatable(&self, cc: &CacheChange) -> bool {
    cc.data_value.payload_size() <= self.max_unfragmented_serialized_payload(None)
      && cc.write_options.to_single_reader().is_none()
  }

  // Item 1: greedily coalesce consecutive unfragmented multicast-to-all samples
  // starting at `first_seq` (up to `last_available`) into a single RTPS
  // datagram, then send it once. Returns None if the first sample is not
  // eligible (so the caller uses the per-sample path); otherwise the batch
  // outcome. The datagram is all-or-nothing on WouldBlock.
  fn try_send_aggregated_batch(
    &mut self,
    first_seq: SequenceNumber,
    last_available: SequenceNumber,
  ) -> Option<BatchOutcome> {
    // Peek the first sample. If it is missing (evicted) or not eligible, defer
    // to the per-sample path, which knows how to skip / fragment / route it.
    let first_cc = self.send_buffer.get_by_sn(first_seq)?;
    if !self.is_aggregatable(&first_cc) {
      return None;
    }

    let is_reliable = self.is_reliable();
    // Reserve room for the single trailing HEARTBEAT (reliable only).
    let hb_reserve = if is_reliable && !self.like_stateless {
      HEARTBEAT_SUBMESSAGE_SERIALIZED_SIZE
    } else {
      0
    };

    let mut builder = MessageBuilder::new();
    let mut last_seq = first_seq;
    let mut count: i32 = 0;
    // The batch back-pressures (rather than dropping) if the writer is reliable
    // or any included best-effort sample opted in to blocking.
    let mut may_block = is_reliable;
    // Whether a preceding INFO_TS in this datagram is still "active". An INFO_TS
    // applies to every following DATA until the next INFO_TS, so a timestamped
    // sample followed by a non-timestamped one must emit an invalidating INFO_TS
    // to avoid the latter inheriting the former's timestamp.
    let mut ts_active = false;

    let mut seq = first_seq;
    while seq <= last_available {
      let Some(cc) = self.send_buffer.get_by_sn(seq) else {
        // A gap in the buffer (evicted). Stop the batch here and let the
        // per-sample path handle the missing sequence number next.
        break;
      };
      if !self.is_aggregatable(&cc) {
        break;
      }
      // RADAR patch 22: the DataWriter sent this one itself; the next round skips it
      if count > 0 && self.send_buffer.is_inline_sent(seq) {
        break;
      }

      // Build this sample's INFO_TS? + DATA submessages and check the budget.
      let mut sample = MessageBuilder::new();
      let sample_ts_active = match cc.write_options.source_timestamp() {
        Some(src_ts) => {
          sample = sample.ts_msg(self.endianness, Some(src_ts));
          true
        }
        None => {
          if ts_active {
            // Invalidate the previous timestamp so this DATA is not stamped.
            sample = sample.ts_msg(self.endianness, None);
          }
          false
        }
      };
      sample = sample.data_msg(
        &cc,
        EntityId::UNKNOWN, // multicast-to-all
        self.my_guid,
        self.endianness,
        self.security_plugins.as_ref(),
      );

      // Always include the first sample (even if it alone exceeds the budget, so
      // we make progress); otherwise stop before overflowing the datagram. The
      // budget is the minimum per-peer path-MTU over all matched readers, since
      // this datagram is multicast to all of them.
      if count > 0
        && builder.len_serialized() + sample.submessage_bytes_len() + hb_reserve
          > self.min_datagram_payload
      {
        break;
      }

      builder.append(sample);
      ts_active = sample_ts_active;
      last_seq = seq;
      count += 1;
      if cc.write_options.best_effort_may_block() {
        may_block = true;
      }
      seq = seq.plus_1();
    }

    // One trailing HEARTBEAT for the whole datagram (reliable writers only).
    if hb_reserve > 0 {
      builder = builder.heartbeat_msg(
        self.entity_id(),
        self.send_buffer.first_change_sequence_number(),
        self.send_buffer.last_change_sequence_number(),
        self.next_heartbeat_count(),
        self.endianness,
        EntityId::UNKNOWN, // to all readers
        false,             // final_flag: request ACKNACK
        false,             // liveliness_flag
      );
    }

    let message = builder.add_header_and_build(self.my_guid.prefix);
    let blocked = self.send_message_to_readers(
      DeliveryMode::Multicast,
      message,
      &mut self.readers.values(),
      TrafficClass::Bulk,
    );

    if blocked.is_empty() {
      Some(BatchOutcome::Sent { last_seq })
    } else if may_block {
      Some(BatchOutcome::Blocked { blocked })
    } else {
      Some(BatchOutcome::Dropped { last_seq })
    }
  }

  pub fn process_pending(&mut self) {
    if self.last_sent < self.send_buffer.last_change_sequence_number() {
      self.arm_idle_timers();
    }
    // The doorbell enqueues this writer's id and then wakes. A sample admitted
    // while we are here pushes another id, so the next wake runs us again. The
    // shared buffer's `last_seq` is the source of truth.
    loop {
      let last_available = self.send_buffer.last_change_sequence_number();
      if self.last_sent >= last_available {
        break;
      }
      let sequence_number = self.last_sent.plus_1();
      // RADAR patch 22: the DataWriter sent this one itself (DATA and HEARTBEAT, to every matched reader):
      // what is left is the bookkeeping the coalescing path does for a sample sent to all.
      if self.send_buffer.take_inline_sent(sequence_number) {
        self.last_sent = sequence_number;
        self.sample_cursor = SampleCursor::Fresh;
        self.send_buffer.set_sent_frontier(sequence_number);
        continue;
      }
      let probed = crate::probe::wants(&self.my_topic_name);
      if probed {
        crate::probe::stamp(crate::probe::Stage::LoopSend, sequence_number.into());
      }

      // Item 1 (DATA aggregation): coalesce several consecutive small samples
      // into one datagram to amortize the per-sample RTPS header + syscall.
      // Only engaged when starting a sample fresh (no mid-fragment resume),
      // in push mode, and with security off (per-reader crypto complicates
      // batching). `try_send_aggregated_batch` returns None when the first
      // sample is not eligible (fragmented or destined to a single reader), in
      // which case we fall through to the per-sample path below.
      if self.push_mode
        && self.sample_cursor == SampleCursor::Fresh
        && self.security_plugins.is_none()
      {
        match self.try_send_aggregated_batch(sequence_number, last_available) {
          Some(BatchOutcome::Sent { last_seq }) | Some(BatchOutcome::Dropped { last_seq }) => {
            if probed {
              let t = crate::probe::now_ns();
              for sn in i64::from(sequence_number)..=i64::from(last_seq) {
                crate::probe::stamp_at(crate::probe::Stage::SocketSent, sn, t);
              }
            }
            // Coalesced samples are multicast-to-all, so per-reader `unsent`
            // bookkeeping is a no-op (notify + mark_sent cancel out); just
            // advance the frontier. Leaves `unsent_changes` empty on the push
            // path, exactly like the per-sample path after the Item 5 fix.
            self.last_sent = last_seq;
            self.sample_cursor = SampleCursor::Fresh;
            self.send_buffer.set_sent_frontier(last_seq);
            continue;
          }
          Some(BatchOutcome::Blocked { blocked }) => {
            // All-or-nothing: do not advance `last_sent`; the event loop resumes
            // us on write readiness and the batch is rebuilt from `sequence_number`.
            self.blocked_sockets.extend(blocked);
            return;
          }
          None => { /* first sample not aggregatable; use the per-sample path */ }
        }
      }

      // Fetch an owned clone of the sample (cheap, Bytes-backed) so we hold the
      // buffer lock only momentarily and can serialize/send without it.
      let Some(cc) = self.send_buffer.get_by_sn(sequence_number) else {
        // The sample is gone (e.g. evicted). Skip it; readers that need it will
        // be told via GAP during repair.
        self.last_sent = sequence_number;
        self.sample_cursor = SampleCursor::Fresh;
        self.send_buffer.set_sent_frontier(sequence_number);
        self.mark_change_sent_to_all_readers(sequence_number);
        continue;
      };
      let write_options = cc.write_options.clone();

      // Notify reader proxies once per sample (only when starting it fresh).
      if self.sample_cursor == SampleCursor::Fresh && !self.like_stateless {
        for reader in self.readers.values_mut() {
          reader.notify_new_cache_change(sequence_number);

          // If the data is meant for a single reader only, set others as pending
          // GAP for this sequence number.
          if let Some(single_reader_guid) = write_options.to_single_reader() {
            if reader.remote_reader_guid != single_reader_guid {
              reader.insert_pending_gap(sequence_number);
            }
          }
        }
      }

      if self.push_mode {
        // Send data (DATA or DATAFRAGs) and a Heartbeat, resuming from the
        // current fragment cursor. Compute the send in an inner scope so the
        // immutable borrow of `self.readers` (target reader) is released before
        // we mutate our cursor/frontier below.
        let cursor = self.sample_cursor;
        // Best-effort has no acknowledgement/repair semantics, so a heartbeat
        // per sample is pure overhead (an extra submessage built and sent for
        // every DATA). Only reliable writers piggyback a heartbeat here;
        // best-effort skips it entirely.
        let send_also_heartbeat = self.is_reliable();
        let (_fragmented, progress) = {
          let target_reader_opt = match write_options.to_single_reader() {
            Some(guid) => self.readers.get(&guid), // Sending only to this reader
            None => None,                          // Sending to all matched readers
          };
          // Built-in (discovery) writers carry low-volume, delivery-critical
          // SEDP/SPDP data. Their initial push must not be dropped on WouldBlock:
          // under a flat-out user writer the send socket is perpetually congested,
          // so a dropped DiscoveredWriterData would have to be recovered by the
          // reliable heartbeat/ACKNACK/repair chain - which is itself starved
          // (the shared timer barely fires under load), leaving the remote
          // endpoint permanently undiscovered. Route discovery pushes through the
          // never-dropped Control queue (strict priority in on_socket_writable)
          // so discovery completes regardless of user-data congestion. User
          // writers keep the flow-controlled Bulk path.
          let push_class = if self.my_guid.entity_id.kind().is_built_in() {
            TrafficClass::Control
          } else {
            TrafficClass::Bulk
          };
          self.send_cache_change_from(
            &cc,
            send_also_heartbeat,
            target_reader_opt,
            cursor,
            push_class,
          )
        };
        match progress {
          SendProgress::Complete => {
            if probed {
              crate::probe::stamp(crate::probe::Stage::SocketSent, sequence_number.into());
            }
            self.last_sent = sequence_number;
            self.sample_cursor = SampleCursor::Fresh;
            self.send_buffer.set_sent_frontier(sequence_number);
            self.mark_change_sent_to_all_readers(sequence_number);
          }
          SendProgress::Blocked { cursor, blocked } => {
            // Reliable writers always back-pressure. Best-effort writers only if
            // this sample opted in via `best_effort_may_block`; otherwise the
            // DDS default applies and we drop the (rest of the) sample and move
            // on to fresher data (spec v1.4 2.2.2.4.2.11).
            if self.is_reliable() || write_options.best_effort_may_block() {
              // Stop here; resume on write readiness. Back-pressure to the
              // application follows from `sent_frontier` not advancing.
              self.sample_cursor = cursor;
              self.blocked_sockets.extend(blocked);
              return;
            }
            // Drop: advance past this sample without recording blocked sockets,
            // so no write-readiness back-pressure is applied. The unsent
            // remainder is discarded and later evicted by cache cleaning.
            self.last_sent = sequence_number;
            self.sample_cursor = SampleCursor::Fresh;
            self.send_buffer.set_sent_frontier(sequence_number);
            self.mark_change_sent_to_all_readers(sequence_number);
          }
        }
      } else {
        // Send Heartbeat only (control).
        // Readers will ask for the DATA with ACKNACK, if they are interested.
        let final_flag = false; // false = request that readers acknowledge with ACKNACK.
        let liveliness_flag = false; // This is not a manual liveliness assertion (DDS API call), but side-effect of
        let hb_message = MessageBuilder::new()
          .heartbeat_msg(
            self.entity_id(), // from Writer
            self.send_buffer.first_change_sequence_number(),
            self.send_buffer.last_change_sequence_number(),
            self.next_heartbeat_count(),
            self.endianness,
            EntityId::UNKNOWN, // to Reader
            final_flag,
            liveliness_flag,
          )
          .add_header_and_build(self.my_guid.prefix);
        self.send_message_to_readers(
          DeliveryMode::Multicast,
          hb_message,
          &mut self.readers.values(),
          TrafficClass::Control,
        );
        self.last_sent = sequence_number;
        self.sample_cursor = SampleCursor::Fresh;
        self.send_buffer.set_sent_frontier(sequence_number);
      }
    }
  }

  /// nonblocking-transmit: drain and return the sockets on which the last push
  /// attempt hit WouldBlock, so the event loop can enqueue this writer for a
  /// round-robin resume on write readiness.
  pub fn take_blocked_sockets(&mut self) -> BTreeSet<SocketId> {
    std::mem::take(&mut self.blocked_sockets)
  }

  // Returns a boolean telling if the data had to be fragmented. This one-shot
  // wrapper is used by the repair path (ACKNACK response). Repair is a
  // reliability action: it must actually reach the reader, so it goes through
  // the never-dropped `Control` queue rather than the best-effort `Bulk` path.
  // Dropping repair on WouldBlock livelocks under sustained send congestion -
  // the reader re-NACKs, the retransmit is dropped again, and reliable data
  // (e.g. builtin SEDP DiscoveredWriterData) never gets delivered while a
  // flat-out writer keeps the socket blocked.
  fn send_cache_change(
    &self,
    cc: &CacheChange,
    send_also_heartbeat: bool,
    target_reader_opt: Option<&RtpsReaderProxy>,
  ) -> bool {
    let (fragmentation_needed, _progress) = self.send_cache_change_from(
      cc,
      send_also_heartbeat,
      target_reader_opt,
      SampleCursor::Fresh,
      TrafficClass::Control,
    );
    fragmentation_needed
  }

  // Resumable bulk send of one cache change starting at `cursor`. Returns
  // whether the sample is fragmented and how far the send got (Complete, or
  // Blocked with the cursor to resume from and the sockets that blocked).
  fn send_cache_change_from(
    &self,
    cc: &CacheChange,
    send_also_heartbeat: bool,
    target_reader_opt: Option<&RtpsReaderProxy>,
    cursor: SampleCursor,
    class: TrafficClass,
  ) -> (bool, SendProgress) {
    // First make sure that if the data is meant for a single reader only, we do
    // not accidentally send it to everyone.
    if let Some(single_reader_guid) = cc.write_options.to_single_reader() {
      match target_reader_opt {
        None => {
          error!(
            "Data is meant for the single reader {single_reader_guid:?} but a proxy for this \
             reader was not provided. Not sending anything."
          );
          return (false, SendProgress::Complete);
        }
        Some(target_reader) => {
          if single_reader_guid != target_reader.remote_reader_guid {
            error!(
              "We were asked to send data meant for the reader {single_reader_guid:?} to a \
               different reader {:?}. Not gonna happen.",
              target_reader.remote_reader_guid
            );
            return (false, SendProgress::Complete);
          }
        }
      }
    }

    let messages_to_send =
      FragmentationIter::new_resume(self, cc, target_reader_opt, send_also_heartbeat, cursor);
    let fragmentation_needed = messages_to_send.fragmentation_needed();

    // Send the messages, either to all readers or just one, stopping at the
    // first message that a socket could not accept.
    for (resume_cursor, msg) in messages_to_send {
      let blocked = match target_reader_opt {
        None => self.send_message_to_readers(
          DeliveryMode::Multicast,
          msg,
          &mut self.readers.values(),
          class,
        ),
        Some(reader_proxy) => self.send_message_to_readers(
          DeliveryMode::Unicast,
          msg,
          &mut std::iter::once(reader_proxy),
          class,
        ),
      };
      if !blocked.is_empty() {
        return (
          fragmentation_needed,
          SendProgress::Blocked {
            cursor: resume_cursor,
            blocked,
          },
        );
      }
    }
    (fragmentation_needed, SendProgress::Complete)
  }

  // --------------------------------------------------------------
  // --------------------------------------------------------------
  // --------------------------------------------------------------

  /// This is called periodically.
  ///
  /// Returns `true` if some matched reader still has unacknowledged data (i.e.
  /// a HEARTBEAT was sent to prompt repair), so the caller can reschedule the
  /// next periodic heartbeat sooner. Returns `false` when all readers are
  /// caught up.
  pub fn handle_heartbeat_tick(&mut self, is_manual_assertion: bool) -> bool {
    if self.like_stateless {
      info!(
        "Ignoring handling heartbeat tick in a stateless-like Writer, since it currently supports \
         only BestEffort QoS. topic={:?}",
        self.my_topic_name
      );
      return false;
    }
    // Reliable Stateful Writer (that tracks Readers by ReaderProxy) will not set
    // the final flag.
    let final_flag = false;
    let liveliness_flag = is_manual_assertion; // RTPS spec "8.3.7.5 Heartbeat"

    trace!(
      "heartbeat tick in topic {:?} have {} readers",
      self.topic_name(),
      self.readers.len()
    );

    let first_change = self.send_buffer.first_change_sequence_number();
    let last_change = self.send_buffer.last_change_sequence_number();

    if self
      .readers
      .values()
      .all(|rp| last_change < rp.all_acked_before)
    {
      trace!("heartbeat tick: all readers have all available data.");
      false
    } else {
      // the interface to .heartbeat_msg is silly: we give ref to ourself
      // and that function then queries us.
      let hb_message = MessageBuilder::new()
        .ts_msg(self.endianness, Some(Timestamp::now()))
        .heartbeat_msg(
          self.entity_id(), // from Writer
          self.send_buffer.first_change_sequence_number(),
          self.send_buffer.last_change_sequence_number(),
          self.next_heartbeat_count(),
          self.endianness,
          EntityId::UNKNOWN, // to Reader
          final_flag,
          liveliness_flag,
        )
        .add_header_and_build(self.my_guid.prefix);

      debug!(
        "Writer {:?} topic={:} HEARTBEAT {:?} to {:?}",
        self.guid().entity_id,
        self.topic_name(),
        first_change,
        last_change,
      );

      // In the volatile key exchange topic we cannot send to multiple readers by any
      // means, so we handle that separately.
      if self.entity_id() == EntityId::P2P_BUILTIN_PARTICIPANT_VOLATILE_SECURE_WRITER {
        for rp in self.readers.values() {
          if last_change < rp.all_acked_before {
            // Everything we have has been acknowledged already. Do nothing.
          } else {
            self.send_control_to_readers(
              DeliveryMode::Unicast,
              hb_message.clone(),
              &mut std::iter::once(rp),
            );
          }
        }
      } else {
        // Normal case
        self.send_control_to_readers(
          DeliveryMode::Multicast,
          hb_message,
          &mut self.readers.values(),
        );
      }
      true
    }
  }

  /// When receiving an ACKNACK Message indicating a Reader is missing some data
  /// samples, the Writer must respond by either sending the missing data
  /// samples, sending a GAP message when the sample is not relevant, or
  /// sending a HEARTBEAT message when the sample is no longer available
  pub fn handle_ack_nack(
    &mut self,
    reader_guid_prefix: GuidPrefix,
    ack_submessage: &AckSubmessage,
  ) {
    // sanity check
    if !self.is_reliable() || self.like_stateless {
      // Stateless-like Writer currently supports only BestEffort QoS, so ignore
      // acknack also for it
      warn!(
        "Writer {:x?} is best effort or stateless-like! It should not handle acknack messages!",
        self.entity_id()
      );
      return;
    }

    match ack_submessage {
      AckSubmessage::AckNack(ref an) => {
        // Update the ReaderProxy
        let last_seq = self.send_buffer.last_change_sequence_number(); // to avoid borrow problems

        // sanity check requested sequence numbers
        if let Some(0) = an.reader_sn_state.iter().next().map(i64::from) {
          warn!("Request for SN zero! : {an:?}");
        }

        let reader_guid = GUID::new(reader_guid_prefix, an.reader_id);

        // sanity check
        if an.reader_sn_state.base() < SequenceNumber::from(1) {
          // This check is based on RTPS v2.5 Spec
          // Section "8.3.5.5 SequenceNumberSet" and
          // Section "8.3.8.1.3 Validity".
          // But apparently some RTPS implementations send ACKNACK with
          // reader_sn_state.base = 0 to indicate they have matched the writer,
          // so seeing these once per new writer should be ok.
          debug!(
            "ACKNACK SequenceNumberSet minimum must be >= 1, got {:?} from {:?} topic {:?}",
            an.reader_sn_state.base(),
            reader_guid,
            self.topic_name()
          );
        }

        let my_topic = self.my_topic_name.clone(); // for debugging

        let mut start_repair = false;

        if let Some(reader_proxy) = self.lookup_reader_proxy_mut(reader_guid) {
          if reader_proxy.last_acknack_count == Some(an.count) {
            trace!(
              "Ignoring duplicate ACKNACK count={} from {:?} topic={:?}",
              an.count,
              reader_guid,
              my_topic
            );
            return;
          }
          reader_proxy.last_acknack_count = Some(an.count);

          // Mark requested SNs as "unsent changes"

          //TODO: We should drop SNs in "pending gap" from unsent changes
          reader_proxy.handle_ack_nack(ack_submessage, last_seq);

          // Sanity Check: if the reader asked for something we did not even advertise
          // yet. TODO: This
          // checks the stored unset_changes, not presently received ACKNACK.
          if cfg!(debug_assertions) {
            if let Some(req_high) = reader_proxy.unsent_changes_iter().next_back() {
              if req_high > last_seq {
                warn!(
                  "ReaderProxy {:?} thinks we need to send {:?} but I have only up to {:?}",
                  reader_proxy.remote_reader_guid,
                  reader_proxy.unsent_changes_debug(),
                  last_seq
                );
              }
            }
            // Sanity Check 2
            if an.reader_sn_state.base() > last_seq.plus_1() {
              warn!(
                "ACKNACK from {:?} acks {:?}, but I have only up to {:?} count={:?} topic={:?}",
                reader_proxy.remote_reader_guid, an.reader_sn_state, last_seq, an.count, my_topic
              );
            }
            // Sanity check 3
            if let Some(max_req_sn) = an.reader_sn_state.iter().next_back() {
              if max_req_sn > last_seq {
                warn!(
                  "ACKNACK from {:?} requests {:?} but I have only up to {:?}",
                  reader_proxy.remote_reader_guid,
                  an.reader_sn_state.iter().collect::<Vec<SequenceNumber>>(),
                  last_seq
                );
              }
            }
          }

          // if we cannot send more data, we are done.
          // This is to prevent empty "repair data" messages from being sent.
          // (RADAR patch 40: also when all was acknowledged, if the reader asked again for some of it)
          if reader_proxy.all_acked_before > last_seq
            && reader_proxy.unsent_changes_iter().next().is_none()
          {
            reader_proxy.repair_mode = false;
          } else {
            reader_proxy.repair_mode = true;
            start_repair = true;
          }
        } // if have reader_proxy

        // Every Writer, built-in or user, answers after nack_response_delay
        // (RTPS v2.5 Section 8.4.7.1.1), so that ACKNACKs arriving close
        // together are served by one repair round. If a round is already
        // pending, it also serves what this ACKNACK requested.
        if start_repair {
          self.schedule_repair_data(reader_guid, self.nack_response_delay);
        }

        // See if we need to respond by GAP message
        if let Some(reader_proxy) = self.readers.get(&reader_guid) {
          if !reader_proxy.get_pending_gap().is_empty() {
            let gap_message = MessageBuilder::new()
              .gap_msg(
                reader_proxy.get_pending_gap(),
                self.my_guid.entity_id,
                self.endianness,
                reader_guid,
              )
              .add_header_and_build(self.my_guid.prefix);
            self.send_control_to_readers(
              DeliveryMode::Unicast,
              gap_message,
              &mut std::iter::once(reader_proxy),
            );
          }

          // An ACKNACK that requests nothing although the reader has not acknowledged
          // everything means the reader does not know what we have, typically a
          // preemptive ACKNACK from a reader that matched us after our HEARTBEAT.
          // Answer now instead of at the next heartbeat period. A preemptive one
          // (base 0) is answered also when there is nothing to acknowledge (RADAR
          // patch 34): a writer that has written nothing sends its HEARTBEAT only
          // on the match, and when that one is lost the reader never hears from it.
          let preemptive = an.reader_sn_state.base() == SequenceNumber::zero();
          // RADAR patch 63: but a reader that has all we wrote up to the match and after it up to some
          // sample does know what we have: every sample after that one went to it (or goes now) with a
          // HEARTBEAT asking for an ACKNACK. An ACKNACK that crossed the next sample on the wire is
          // answered by that sample's HEARTBEAT; a lost one, by the periodic HEARTBEAT.
          let knows_the_rest = reader_proxy.all_acked_before > reader_proxy.live_after;
          if an.reader_sn_state.iter().next().is_none()
            && (preemptive || (reader_proxy.all_acked_before <= last_seq && !knows_the_rest))
          {
            let hb_message = self
              .heartbeat_asking_acknack(
                MessageBuilder::new().ts_msg(self.endianness, Some(Timestamp::now())),
                last_seq,
                reader_guid.entity_id,
              )
              .add_header_and_build(self.my_guid.prefix);
            self.send_control_to_readers(
              DeliveryMode::Unicast,
              hb_message,
              &mut std::iter::once(reader_proxy),
            );
          }
        }
      } // AckNack
      AckSubmessage::NackFrag(ref nackfrag) => {
        // NackFrag is negative acknowledgement only, i.e. requesting missing fragments.
        let reader_guid = GUID::new(reader_guid_prefix, nackfrag.reader_id);
        let Some(reader_proxy) = self.lookup_reader_proxy_mut(reader_guid) else {
          return;
        };
        if reader_proxy.last_nackfrag_count == Some(nackfrag.count) {
          trace!(
            "Ignoring duplicate NACK_FRAG count={} from {:?}",
            nackfrag.count,
            reader_guid
          );
          return;
        }
        reader_proxy.last_nackfrag_count = Some(nackfrag.count);
        reader_proxy.mark_frags_requested(nackfrag.writer_sn, &nackfrag.fragment_number_state);
        self.schedule_repair_frags(reader_guid, self.nackfrag_response_delay);
      }
    }

    // Acknowledgement frontier may have advanced: push it into the shared send
    // buffer so any back-pressured producer (or `wait_for_acknowledgments`
    // waiter) can make progress.
    self.refresh_acked_frontier();
  }

  // Recompute the reliable acknowledgement frontier (the smallest
  // `all_acked_before` over all matched reliable readers) and publish it to the
  // shared send buffer. Called whenever acknowledgements arrive or the set of
  // matched readers changes. `None` means there are no reliable readers, so the
  // writer is never back-pressured.
  //
  // A reader proxy reports `acked_up_to_before == 0` until its first ACKNACK;
  // `WriterSendBuffer::set_acked_frontier` reads that as 1, since sequence
  // numbers start at 1.
  //
  // TODO: On first match the first missed sample is only recovered via
  // periodic-heartbeat repair, which can take ~1 s under load.
  fn refresh_acked_frontier(&self) {
    if self.like_stateless {
      // Stateless-like writer is BestEffort: never throttle, never wait.
      self.send_buffer.set_acked_frontier(None);
      return;
    }
    let frontier = self
      .readers
      .values()
      .filter(|rp| rp.qos().is_reliable())
      .map(RtpsReaderProxy::acked_up_to_before)
      .min();
    self.send_buffer.set_acked_frontier(frontier);
  }

  // Send out missing data

  fn handle_repair_data_send(&mut self, to_reader: GUID) {
    if self.like_stateless {
      warn!(
        "Not sending repair data in a stateless-like Writer, since it currently supports only \
         BestEffort behavior. topic={:?}",
        self.my_topic_name
      );
      return;
    }
    // Note: here we remove the reader from our reader map temporarily.
    // Then we can mutate both the reader and other fields in self.
    // Doing a .get_mut() on the reader map would make self immutable.
    if let Some(mut reader_proxy) = self.readers.remove(&to_reader) {
      // We use a worker function to ensure that afterwards we can insert the
      // reader_proxy back. This technique ensures that all return paths lead to
      // re-insertion.
      self.handle_repair_data_send_worker(&mut reader_proxy);
      // insert reader back
      if let Some(rp) = self
        .readers
        .insert(reader_proxy.remote_reader_guid, reader_proxy)
      {
        // This should really not happen.
        error!("Reader proxy was duplicated somehow??? {rp:?}");
      }
    }
  }

  fn handle_repair_frags_send(&mut self, to_reader: GUID) {
    if self.like_stateless {
      warn!(
        "Not sending repair frags in a stateless-like Writer, since it currently supports only \
         BestEffort behavior. topic={:?}",
        self.my_topic_name
      );
      return;
    }

    // see similar function above
    if let Some(mut reader_proxy) = self.readers.remove(&to_reader) {
      self.handle_repair_frags_send_worker(&mut reader_proxy);
      if let Some(rp) = self
        .readers
        .insert(reader_proxy.remote_reader_guid, reader_proxy)
      {
        // this is an internal logic error, or maybe out of memory
        error!("Reader proxy was duplicated somehow??? (frags) {rp:?}");
      }
    }
  }

  // One repair round for a reader: send its unsent changes, lowest first, until
  // `repair_batch_limit` bytes have gone out (at least one change) or nothing is
  // left, which ends repair mode. GAPs and unfragmented DATA are packed into
  // datagrams of the reader's path-MTU budget; a fragmented sample goes out on
  // its own.
  fn handle_repair_data_send_worker(&mut self, reader_proxy: &mut RtpsReaderProxy) {
    // Note: The reader_proxy is now removed from readers map
    let reader_guid = reader_proxy.remote_reader_guid;

    debug!(
      "Repair data send to {reader_guid:?}. ReaderProxy Unsent changes: {:?}",
      reader_proxy.unsent_changes_debug()
    );

    // Security encodes each message for its readers as a whole, so with
    // security on every sample keeps a message of its own.
    let coalesce = self.security_plugins.is_none();
    let mut datagram: Option<MessageBuilder> = None;
    // Whether an INFO_TS in `datagram` still applies to the next DATA.
    let mut ts_active = false;
    let mut pending_gap_sent = false;
    let mut round_bytes = 0;
    // RADAR patch 59: the highest sequence number this round answered
    let mut highest_answered = None;
    let round_limit = Self::repair_batch_limit(reader_proxy);

    while round_bytes < round_limit {
      let Some(unsent_sn) = reader_proxy.first_unsent_change() else {
        break;
      };
      highest_answered = Some(unsent_sn);
      let first_available = self.send_buffer.first_change_sequence_number();
      let pending_gaps = reader_proxy.get_pending_gap().clone();

      let mut gap = MessageBuilder::new();
      let mut cache_change = None;
      if unsent_sn < first_available {
        // Reader is requesting older than what we actually have. Notify that they are
        // gone.
        debug!(
          "Reader {reader_guid:?} requested too old data {unsent_sn:?}. I have only from \
           {first_available:?}. Topic {:?}",
          self.my_topic_name
        );
        gap = gap.gap_msg_before(
          first_available,
          self.entity_id(),
          self.endianness,
          reader_guid,
        );
        reader_proxy.remove_from_unsent_set_all_before(first_available);
      } else if !pending_gaps.contains(&unsent_sn) {
        match self.send_buffer.get_by_sn(unsent_sn) {
          Some(cc) => cache_change = Some(cc),
          None => {
            // Not retained: an earlier sample of an instance that was disposed since (RADAR patch 10),
            // or evicted. The reader is told it will not come.
            debug!(
              "handle_repair_data_send_worker {:?} seq.number {:?} not retained. first_change={:?}",
              self.my_guid, unsent_sn, first_available
            );
            gap = gap.gap_msg(
              &BTreeSet::from([unsent_sn]),
              self.entity_id(),
              self.endianness,
              reader_guid,
            );
            reader_proxy.mark_change_sent(unsent_sn);
          }
        }
      }
      // SNs we are not going to send to this reader: announce them once per
      // round, together with the first change that goes out.
      if !pending_gaps.is_empty() && (!pending_gap_sent || pending_gaps.contains(&unsent_sn)) {
        gap = gap.gap_msg(
          &pending_gaps,
          self.entity_id(),
          self.endianness,
          reader_guid,
        );
        for sn in &pending_gaps {
          reader_proxy.mark_change_sent(*sn);
        }
        pending_gap_sent = true;
      }
      let gap_len = gap.submessage_bytes_len();
      if gap_len > 0 {
        round_bytes += gap_len;
        self.add_to_repair_datagram(&mut datagram, gap, 0, reader_proxy);
      }

      let Some(cc) = cache_change else {
        continue;
      };
      let payload_size = cc.data_value.payload_size();
      if !coalesce || payload_size > self.max_unfragmented_serialized_payload(Some(reader_proxy)) {
        // Keep the order: whatever is packed so far goes first.
        self.flush_repair_datagram(&mut datagram, reader_proxy);
        ts_active = false;
        // This emits the whole sample, including every fragment when it does
        // not fit one datagram. A later NACK_FRAG is what arms SendRepairFrags.
        self.send_cache_change(&cc, false, Some(reader_proxy));
        round_bytes += payload_size + DATA_SUBMESSAGE_OVERHEAD;
      } else {
        let source_timestamp = cc.write_options.source_timestamp();
        let mut data = MessageBuilder::new();
        if source_timestamp.is_some() {
          data = data.ts_msg(self.endianness, source_timestamp);
        }
        data = data.data_msg(
          &cc,
          reader_guid.entity_id,
          self.my_guid,
          self.endianness,
          self.security_plugins.as_ref(),
        );
        // An INFO_TS applies to every following DATA in the datagram, so a DATA
        // without a timestamp after one with must invalidate it.
        let invalidate_len = if source_timestamp.is_none() && ts_active {
          SUBMESSAGE_INFO_TS_INVALIDATE_SIZE
        } else {
          0
        };
        round_bytes += data.submessage_bytes_len();
        self.add_to_repair_datagram(&mut datagram, data, invalidate_len, reader_proxy);
        ts_active = source_timestamp.is_some();
      }
      reader_proxy.mark_change_sent(unsent_sn);
    }

    if reader_proxy.first_unsent_change().is_none() {
      reader_proxy.repair_mode = false;
      // RADAR patch 59: an ACKNACK asks for at most 256 sequence numbers, so a reader that joined late (or
      // lost much) is sent a writer's history one window at a time, and asks for the next window when it
      // hears a HEARTBEAT. When this round answered the last of what the reader asked for and the writer
      // holds later samples, a HEARTBEAT goes with it, so that the reader asks for the next window now
      // instead of at the writer's next periodic HEARTBEAT (up to a second later: a new participant waited
      // about that long per window for the SEDP data of a big one).
      let last = self.send_buffer.last_change_sequence_number();
      if highest_answered.is_some_and(|sn| sn < last) && reader_proxy.all_acked_before <= last {
        let heartbeat = self.heartbeat_asking_acknack(
          MessageBuilder::new(),
          last,
          reader_proxy.remote_reader_guid.entity_id,
        );
        self.add_to_repair_datagram(&mut datagram, heartbeat, 0, reader_proxy);
      }
    }
    self.flush_repair_datagram(&mut datagram, reader_proxy);
  } // fn

  /// How many bytes one repair round may send to `reader_proxy`: more to a reader on this host, reached over
  /// loopback (RADAR patch 60), than over a network.
  fn repair_batch_limit(reader_proxy: &RtpsReaderProxy) -> usize {
    let route = reader_proxy.send_route();
    if !route.fallback && route.unicast.is_some_and(|l| l.is_loopback()) {
      REPAIR_BATCH_MAX_BYTES_SAME_HOST
    } else {
      REPAIR_BATCH_MAX_BYTES
    }
  }

  /// `builder` with a HEARTBEAT of what this writer holds up to `last`, to `reader` (`EntityId::UNKNOWN`:
  /// every reader the message reaches), its final flag clear: the reader answers with an ACKNACK. Sent on a
  /// match, to a preemptive ACKNACK (RADAR patch 34) and after a repair window (RADAR patch 59).
  fn heartbeat_asking_acknack(
    &self,
    builder: MessageBuilder,
    last: SequenceNumber,
    reader: EntityId,
  ) -> MessageBuilder {
    builder.heartbeat_msg(
      self.entity_id(),
      self.send_buffer.first_change_sequence_number(),
      last,
      self.next_heartbeat_count(),
      self.endianness,
      reader,
      false, // final_flag
      false, // liveliness_flag
    )
  }

  // Append `part` to the repair datagram being built for `reader_proxy`, first
  // sending the datagram if `part` (plus `invalidate_len` bytes for an INFO_TS
  // invalidation) would not fit the reader's path-MTU budget. A fresh datagram
  // starts with INFO_DST and takes `part` even if it alone is too large. When
  // the part joins an existing datagram and `invalidate_len > 0`, an
  // invalidating INFO_TS goes in front of it.
  fn add_to_repair_datagram(
    &self,
    datagram: &mut Option<MessageBuilder>,
    part: MessageBuilder,
    invalidate_len: usize,
    reader_proxy: &RtpsReaderProxy,
  ) {
    let fits = datagram.as_ref().is_some_and(|d| {
      d.len_serialized() + invalidate_len + part.submessage_bytes_len()
        <= reader_proxy.max_datagram_payload()
    });
    if !fits {
      self.flush_repair_datagram(datagram, reader_proxy);
    }
    let started_new = datagram.is_none();
    let d = datagram.get_or_insert_with(|| {
      MessageBuilder::new().dst_submessage(self.endianness, reader_proxy.remote_reader_guid.prefix)
    });
    if !started_new && invalidate_len > 0 {
      d.append(MessageBuilder::new().ts_msg(self.endianness, None));
    }
    d.append(part);
  }

  fn flush_repair_datagram(
    &self,
    datagram: &mut Option<MessageBuilder>,
    reader_proxy: &RtpsReaderProxy,
  ) {
    if let Some(d) = datagram.take() {
      self.send_control_to_readers(
        DeliveryMode::Unicast,
        d.add_header_and_build(self.my_guid.prefix),
        &mut std::iter::once(reader_proxy),
      );
    }
  }

  fn handle_repair_frags_send_worker(
    &mut self,
    reader_proxy: &mut RtpsReaderProxy, /* This is mutable proxy temporarily detached from the
                                         * set of reader proxies */
  ) {
    // Decide the (max) number of frags to be sent
    let max_send_count = 8;

    let reader_guid = reader_proxy.remote_reader_guid;

    // Get (an iterator to) frags requested but not yet sent
    // reader_proxy.
    // Iterate over frags to be sent
    for (seq_num, frag_num) in reader_proxy.frags_requested_iterator().take(max_send_count) {
      // Sanity check request
      // ^^^ TODO

      if let Some(cache_change) = self.send_buffer.get_by_sn(seq_num) {
        // If the data is meant for a single reader only, make sure it is the one we're
        // about to send frags to.
        if let Some(single_reader_guid) = cache_change.write_options.to_single_reader() {
          if single_reader_guid != reader_guid {
            error!(
              "We were asked to send datafrags meant for the reader {single_reader_guid:?} to a \
               different reader {reader_guid:?}. Not gonna happen."
            );
            return;
          }
        }

        // Generate datafrag message
        let mut message_builder = MessageBuilder::new();
        if let Some(src_ts) = cache_change.write_options.source_timestamp() {
          message_builder = message_builder.ts_msg(self.endianness, Some(src_ts));
        }

        let fragment_size: u32 = FRAGMENT_SIZE as u32;
        let data_size: u32 = cache_change.data_value.payload_size() as u32; // TODO: overflow check

        message_builder = message_builder.data_frag_msg(
          &cache_change,
          reader_guid.entity_id, // reader
          self.my_guid,          // writer
          frag_num,
          // Repair responds to specifically-NACKed fragment numbers (possibly
          // non-contiguous), so retransmit one fragment per submessage.
          1,
          fragment_size as u16, // TODO: overflow check
          data_size,
          self.endianness,
          self.security_plugins.as_ref(),
        );

        // Repair frags are a reliability action (response to a NACK_FRAG), so
        // they must actually reach the reader. Use the never-dropped `Control`
        // queue: dropping repair on WouldBlock livelocks under sustained send
        // congestion (reader re-NACKs, retransmit dropped again, forever).
        let _blocked = self.send_message_to_readers(
          DeliveryMode::Unicast,
          message_builder.add_header_and_build(self.my_guid.prefix),
          &mut std::iter::once(&*reader_proxy),
          TrafficClass::Control,
        );
      } else {
        error!(
          "handle_repair_frags_send_worker: {:?} missing from send buffer. topic={:?}",
          seq_num, self.my_topic_name
        );
        // TODO: Should we send a GAP message then?
      }

      reader_proxy.mark_frag_sent(seq_num, &frag_num);
    } // for
  } // fn

  /// Removes permanently cacheChanges from DDSCache.
  /// CacheChanges can be safely removed only if they are acked by all readers.
  /// (Reliable) Depth is QoS policy History depth.
  /// Returns SequenceNumbers of removed CacheChanges
  /// This is called repeatedly by handle_cache_cleaning action.
  fn remove_all_acked_changes_but_keep_depth(
    &mut self,
    depth: Option<usize>,
    resource_limit: usize,
  ) {
    let first_keeper = if !self.like_stateless {
      // Regular stateful writer behavior
      // All reliable readers have acked up to this point (SequenceNumber). RADAR patch 36: a best-effort
      // reader never acknowledges, so it held the point at where it matched, and a writer with one (the
      // SPDP writer: every peer's SPDP reader) kept every sample written since, up to the resource limit.
      // With no reliable reader, everything written counts as acknowledged: the depth is what is kept.
      let acked_by_all_readers = self
        .readers
        .values()
        .filter(|rp| rp.qos().is_reliable())
        .map(RtpsReaderProxy::acked_up_to_before)
        .min()
        .unwrap_or_else(|| self.send_buffer.last_change_sequence_number().plus_1());
      // If all readers have acked all up to before 5, and depth is 5, we need
      // to keep samples 0..4, i.e. from acked_up_to_before - depth .
      let depth_keeper = if let Some(depth) = depth {
        max(
          acked_by_all_readers - SequenceNumber::from(depth),
          self.send_buffer.first_change_sequence_number(),
        )
      } else {
        // try to keep all
        self.send_buffer.first_change_sequence_number()
      };
      // Never evict samples that some matched (reliable) reader has not yet
      // acknowledged: clamp the keeper to at most the all-acked point so that
      // unacknowledged samples remain available for repair. The resource-limit
      // backstop below still bounds memory if a reader falls hopelessly behind.
      min(depth_keeper, acked_by_all_readers)
    } else {
      // Stateless-like writer currently supports only BestEffort behavior, so here we
      // make it explicit that it does not care about acked sequence numbers
      let depth = depth.unwrap_or(0);
      max(
        self.send_buffer.last_change_sequence_number() - SequenceNumber::from(depth),
        self.send_buffer.first_change_sequence_number(),
      )
    };
    // Memory-safety backstop: never retain more than `resource_limit` samples,
    // even if that forces eviction of still-unacknowledged data.
    let first_keeper = max(
      max(
        first_keeper,
        self.send_buffer.last_change_sequence_number() - SequenceNumber::from(resource_limit),
      ),
      SequenceNumber::zero(),
    );
    debug!(
      "WriterSendBuffer: cleaning before {first_keeper:?} topic={:?}",
      self.topic_name()
    );
    // actual cleaning
    self.send_buffer.remove_changes_before(first_keeper);
  }

  pub(crate) fn next_heartbeat_count(&self) -> i32 {
    // RADAR patch 22: shared with the DataWriter, which piggybacks HEARTBEATs on the samples it sends itself
    self.send_buffer.next_heartbeat_count()
  }

  /// RADAR patch 22: publishes where the DataWriter may send new samples from its own thread (see
  /// [`InlinePlan`]): only when every matched reader is reached by one unicast datagram, exactly as
  /// `send_message_to_readers` would reach it.
  fn refresh_inline_plan(&self) {
    let eligible = inline_send_enabled()
      && !self.like_stateless
      && self.push_mode
      && !self.my_guid.entity_id.kind().is_built_in()
      && self.extra_unicast_destinations.is_empty();
    // RADAR patch 61: with no reader, a sample is sent to nobody by its DataWriter's thread
    self.send_buffer.set_readerless(eligible && self.readers.is_empty());
    let plan = (|| {
      if !eligible || self.readers.is_empty() {
        return None;
      }
      let mut dests: Vec<std::net::SocketAddr> = Vec::new();
      for reader in self.readers.values() {
        let route = reader.send_route();
        if route.fallback || route.multicast.is_some() {
          return None;
        }
        let addr = match route.unicast? {
          Locator::UdpV4(a) => std::net::SocketAddr::V4(a),
          _ => return None,
        };
        if !dests.contains(&addr) {
          dests.push(addr);
        }
      }
      Some(InlinePlan {
        dests,
        max_payload: self.max_unfragmented_serialized_payload(None),
        heartbeat: self.is_reliable(),
        #[cfg(feature = "security")]
        secured: self
          .security_plugins
          .as_ref()
          .map(|plugins| crate::rtps::writer_send_buffer::InlineSecurity {
            plugins: plugins.clone(),
            readers: self.readers.keys().copied().collect(),
          }),
      })
    })();
    self.send_buffer.set_inline_plan(plan);
  }

  #[cfg(feature = "security")]
  fn security_encode(
    &self,
    message: Message,
    readers: &[&RtpsReaderProxy],
  ) -> SecurityResult<Message> {
    // If we have security plugins, use them, otherwise pass through
    match &self.security_plugins {
      Some(handle) => {
        let destinations: Vec<GUID> = readers.iter().map(|r| r.remote_reader_guid).collect();
        security_encode_for(&handle.get_plugins(), self.guid(), &destinations, message)
      }
      None => Ok(message),
    }
  }

  // nonblocking-transmit: `class` selects the queueing policy. `Control`
  // datagrams go through the never-dropped per-socket control queue; `Bulk`
  // datagrams are attempted non-blocking and the sockets that returned
  // WouldBlock are returned so the caller can stop and arm write readiness.
  // Returns the set of blocked sockets (always empty for `Control`).
  fn send_message_to_readers(
    &self,
    preferred_mode: DeliveryMode,
    message: Message,
    readers: &mut dyn Iterator<Item = &RtpsReaderProxy>,
    class: TrafficClass,
  ) -> BTreeSet<SocketId> {
    // Interface-aware transmit (see src/rtps/transmit_design.md): each reader
    // carries a pre-resolved `SendRoute`. When the route is known we emit a
    // single datagram per distinct destination (`RouteKey`), targeting one
    // interface for multicast. When the route is unknown/ambiguous we fall back
    // to the legacy path (send to every advertised locator on every interface)
    // so reachability is preserved.

    // Only the security path needs the readers materialized into a slice (to
    // pass to `security_encode`). In the default (non-security) build we iterate
    // the incoming iterator directly below, avoiding a per-sample Vec
    // allocation on the send hot path.
    #[cfg(feature = "security")]
    let readers = {
      let all = readers.collect::<Vec<_>>();
      // radar_ros patch 26: a reader whose keys are not exchanged yet cannot be sent to; leave it out (a
      // reliable one gets the samples by repair once they are) rather than fail the send for every reader
      match &self.security_plugins {
        Some(handle) if self.guid().entity_id.entity_kind.is_user_defined() => {
          let plugins = handle.get_plugins();
          let (ready, waiting): (Vec<_>, Vec<_>) = all.into_iter().partition(|r| {
            plugins.remote_endpoint_keys_ready(&self.guid(), &r.remote_reader_guid)
          });
          if !waiting.is_empty() {
            debug!(
              "send_message_to_readers: {} reader(s) of {:?} wait for their keys; not sent to now",
              waiting.len(),
              self.guid()
            );
          }
          ready
        }
        _ => all,
      }
    };
    #[cfg(feature = "security")]
    if readers.is_empty() {
      return BTreeSet::new();
    }

    let mut blocked: BTreeSet<SocketId> = BTreeSet::new();

    #[cfg(feature = "security")]
    let encoded = self.security_encode(message, &readers);
    #[cfg(not(feature = "security"))]
    let encoded: Result<Message, ()> = Ok(message);

    match encoded {
      Ok(message) => {
        let buffer = match message.write_to_vec_fast(self.endianness) {
          Ok(b) => b,
          Err(e) => {
            error!("Failed to serialize RTPS message for send: {e:?}");
            return blocked;
          }
        };

        // De-duplication of narrowed (interface-aware) sends across readers.
        let mut sent_routes: BTreeSet<RouteKey> = BTreeSet::new();
        // De-duplication of legacy (all-interface) sends across readers.
        let mut sent_legacy: BTreeSet<Locator> = BTreeSet::new();

        macro_rules! emit_multicast {
          ($mc:expr, $iface:expr) => {
            if sent_routes.insert(RouteKey::Multicast($mc, $iface)) {
              match class {
                TrafficClass::Control => self
                  .udp_sender
                  .send_to_multicast_locator_via(&buffer, &$mc, &$iface),
                TrafficClass::Bulk => blocked.extend(
                  self
                    .udp_sender
                    .try_send_to_multicast_locator_via(&buffer, &$mc, &$iface),
                ),
              }
            } else {
              trace!("Already sent to multicast {:?} via {:?}", $mc, $iface);
            }
          };
        }
        macro_rules! emit_unicast {
          ($uc:expr) => {
            if sent_routes.insert(RouteKey::Unicast($uc)) {
              match class {
                TrafficClass::Control => self.udp_sender.send_to_locator(&buffer, &$uc),
                TrafficClass::Bulk => {
                  blocked.extend(self.udp_sender.try_send_to_locator(&buffer, &$uc));
                }
              }
            } else {
              trace!("Already sent to unicast {:?}", $uc);
            }
          };
        }
        macro_rules! send_legacy {
          ($locs:expr) => {
            for loc in $locs.iter() {
              if sent_legacy.insert(*loc) {
                match class {
                  TrafficClass::Control => self.udp_sender.send_to_locator(&buffer, loc),
                  TrafficClass::Bulk => {
                    blocked.extend(self.udp_sender.try_send_to_locator(&buffer, loc));
                  }
                }
              } else {
                trace!("Already sent to {:?}", loc);
              }
            }
          };
        }

        for reader in readers {
          let route = reader.send_route();

          if route.fallback {
            // Unknown/ambiguous route: preserve reachability using the legacy
            // all-locators/all-interfaces path with the original precedence.
            match (
              preferred_mode,
              reader
                .unicast_locator_list
                .iter()
                .find(|l| Locator::is_udp(l)),
              reader
                .multicast_locator_list
                .iter()
                .find(|l| Locator::is_udp(l)),
            ) {
              (DeliveryMode::Multicast, _, Some(_)) => send_legacy!(reader.multicast_locator_list),
              (DeliveryMode::Unicast, Some(_), _) => send_legacy!(reader.unicast_locator_list),
              (_, _, Some(_)) => send_legacy!(reader.multicast_locator_list),
              (_, Some(_), _) => send_legacy!(reader.unicast_locator_list),
              (_, None, None) => warn!("send_message_to_readers: No locators for {reader:?}"),
            }
            continue;
          }

          // Narrowed route: reuse the multicast/unicast preference precedence.
          match (preferred_mode, route.multicast, route.unicast) {
            (DeliveryMode::Multicast, Some((mc, iface)), _) => emit_multicast!(mc, iface),
            (DeliveryMode::Unicast, _, Some(uc)) => emit_unicast!(uc),
            (_, _, Some(uc)) => emit_unicast!(uc),
            (_, Some((mc, iface)), _) => emit_multicast!(mc, iface),
            (_, None, None) => {
              warn!("send_message_to_readers: resolved route has no destination for {reader:?}");
            }
          }
        }

        // Fixed extra unicast destinations (SPDP localhost peers): send the same
        // datagram unconditionally, deduplicated against everything already sent.
        send_legacy!(self.extra_unicast_destinations);
      }
      #[cfg(feature = "security")]
      Err(e) if crate::security::security_plugins::keys_not_exchanged(&e) => {
        debug!("Not sent to readers whose keys are not exchanged yet: {e:?}");
      }
      Err(e) => error!("Failed to send message to readers. Encoding failed: {e:?}"),
    }
    blocked
  }

  // Kept for readability at call sites that fire a single control message and
  // do not care about back-pressure (heartbeats, GAPs, repair control).
  fn send_control_to_readers(
    &self,
    preferred_mode: DeliveryMode,
    message: Message,
    readers: &mut dyn Iterator<Item = &RtpsReaderProxy>,
  ) {
    let _ = self.send_message_to_readers(preferred_mode, message, readers, TrafficClass::Control);
  }

  #[allow(dead_code)] // symmetry with send_control_to_readers; reserved for future direct bulk sends
  fn send_bulk_to_readers(
    &self,
    preferred_mode: DeliveryMode,
    message: Message,
    readers: &mut dyn Iterator<Item = &RtpsReaderProxy>,
  ) -> BTreeSet<SocketId> {
    self.send_message_to_readers(preferred_mode, message, readers, TrafficClass::Bulk)
  }

  // Send status to DataWriter or however is listening
  fn send_status(&self, status: DataWriterStatus) {
    self
      .status_sender
      .try_send_impl(status)
      .unwrap_or_else(|e| match e {
        // TODO: dead code. `StatusChannelSender::try_send` currently converts a
        // full channel into `Ok(())` (dropping the event), so this arm is never
        // reached. Kept because the handling is correct if `try_send` is ever
        // made to return `Full` again (cf. PR #442).
        TrySendError::Full(_) => (), // This is normal in case there is no receiver
        TrySendError::Disconnected(_) => {
          debug!("send_status - status receiver is disconnected");
        }
      });
  }

  /// Set the fixed unicast destinations every outgoing message is also sent to
  /// (in addition to matched readers), bypassing route selection. Used only for
  /// the built-in SPDP writer's "localhost SPDP peers". See
  /// [`Self::extra_unicast_destinations`].
  pub fn set_extra_unicast_destinations(&mut self, locators: Vec<Locator>) {
    self.extra_unicast_destinations = locators;
    self.refresh_inline_plan();
  }

  /// Enable/disable preferring a same-host peer's loopback locator during route
  /// selection. See the participant-builder `same_host_loopback` knob.
  pub fn set_prefer_loopback_same_host(&mut self, enabled: bool) {
    self.prefer_loopback_same_host = enabled;
  }

  /// RADAR patch 70: whether `reader` (of `type_name`, requesting `requested_qos`) must not be matched, for
  /// announcing another ROS 2 type hash than this writer's (`rtps/type_hash.rs`); warns once per reader.
  pub fn refuses_type_hash(
    &mut self,
    reader: GUID,
    type_name: &str,
    requested_qos: &QosPolicies,
  ) -> bool {
    self.type_hash_refusals.refuses(
      &self.my_topic_name,
      type_name,
      (self.my_guid, &self.qos_policies),
      (reader, requested_qos),
    )
  }

  pub fn update_reader_proxy(
    &mut self,
    reader_proxy: &RtpsReaderProxy,
    requested_qos: &QosPolicies,
  ) {
    debug!(
      "update_reader_proxy topic={:?} reader_proxy={reader_proxy:?}",
      self.my_topic_name
    );
    match self.qos_policies.compliance_failure_wrt(requested_qos) {
      // matched QoS
      None => {
        let guid = reader_proxy.remote_reader_guid;
        // RADAR patch 62: a reader the application feeds itself is matched, and sent nothing
        if self.local_readers.contains(&guid)
          || (!self.readers.contains_key(&guid)
            && !self.my_guid.entity_id.kind().is_built_in()
            && crate::local_delivery::skips(self.my_guid, guid))
        {
          if self.local_readers.insert(guid) {
            self.reader_matched_status(guid);
          }
          return;
        }
        // RADAR patch 61: samples written while no reader was matched were taken as sent to nobody: account
        // for them before a reader counts, and send what is written from now on as usual (a volatile reader
        // gets a GAP for what came before it, a durable one repairs it from the history). Only then: with the
        // readerless mode off, what is pending is sent as usual to the reader that matches now.
        if self.readers.is_empty() && self.send_buffer.set_readerless(false) {
          self.process_pending();
        }
        let new_reader = self.matched_reader_update(reader_proxy);
        // A (possibly new) reliable reader changes the acknowledgement frontier
        // and thus the back-pressure window.
        self.refresh_acked_frontier();
        if new_reader {
          self.arm_idle_timers();
          self.reader_matched_status(reader_proxy.remote_reader_guid);
          // Reliable: send an initial HEARTBEAT to the newly matched reader so it
          // can request the samples we already hold (repair/late-join). This runs
          // synchronously on the discovery-match event in the event loop, so it
          // does NOT depend on the periodic heartbeat timer - which is CPU-starved
          // under a flat-out user writer, leaving the timer to fire seldom or
          // never. Without this prompt, a reader that matches after our initial
          // send burst is never told what we have and never NACKs, so reliable
          // data (notably builtin SEDP DiscoveredWriterData) is never delivered
          // and the endpoints stay unmatched. Unicast to just the new reader.
          if self.is_reliable() && !self.like_stateless {
            let new_reader_guid = reader_proxy.remote_reader_guid;
            let hb_message = self
              .heartbeat_asking_acknack(
                MessageBuilder::new().ts_msg(self.endianness, Some(Timestamp::now())),
                self.send_buffer.last_change_sequence_number(),
                EntityId::UNKNOWN,
              )
              .add_header_and_build(self.my_guid.prefix);
            if let Some(rp) = self.readers.get(&new_reader_guid) {
              self.send_control_to_readers(
                DeliveryMode::Unicast,
                hb_message,
                &mut std::iter::once(rp),
              );
            }
          }
          info!(
            "Matched new remote reader on topic={:?} reader={:?}",
            self.topic_name(),
            reader_proxy.remote_reader_guid
          );
          debug!("Reader details: {:?}", reader_proxy);
        }
      }
      Some(bad_policy_id) => {
        // QoS not compliant :(
        warn!(
          "update_reader_proxy - QoS mismatch {:?} topic={:?}",
          bad_policy_id,
          self.topic_name()
        );
        info!(
          "Reader QoS={:?} Writer QoS={:?}",
          requested_qos, self.qos_policies
        );

        self.requested_incompatible_qos_count += 1;
        self.send_status(DataWriterStatus::OfferedIncompatibleQos {
          count: CountWithChange::new(self.requested_incompatible_qos_count, 1),
          last_policy_id: bad_policy_id,
          reader: reader_proxy.remote_reader_guid,
          requested_qos: Box::new(requested_qos.clone()),
          offered_qos: Box::new(self.qos_policies.clone()),
        });
        self.send_participant_status(DomainParticipantStatusEvent::RemoteReaderQosIncompatible {
          local_writer: self.my_guid,
          remote_reader: reader_proxy.remote_reader_guid,
          requested_qos: Box::new(requested_qos.clone()),
          offered_qos: Box::new(self.qos_policies.clone()),
        });
      }
    } // match
  }

  /// The statuses of a reader newly matched: `PublicationMatched` and the participant's `RemoteReaderMatched`.
  fn reader_matched_status(&mut self, reader: GUID) {
    self.matched_readers_count_total += 1;
    self.send_status(DataWriterStatus::PublicationMatched {
      // total: How many matches have been detected ever?
      total: CountWithChange::new(self.matched_readers_count_total, 1),
      // current: How many readers we are matched with?
      current: CountWithChange::new(self.matched_count(), 1),
      reader,
    });
    self.send_participant_status(DomainParticipantStatusEvent::RemoteReaderMatched {
      local_writer: self.my_guid,
      remote_reader: reader,
    });
  }

  /// The status of a matched reader lost (`matched_readers_count_total` never decreases).
  fn reader_lost_status(&mut self, reader: GUID) {
    self.send_status(DataWriterStatus::PublicationMatched {
      total: CountWithChange::new(self.matched_readers_count_total, 0),
      current: CountWithChange::new(self.matched_count(), -1),
      reader,
    });
  }

  /// How many readers this writer is matched with (RADAR patch 62: those fed by the application included).
  fn matched_count(&self) -> i32 {
    (self.readers.len() + self.local_readers.len()) as i32
  }

  // Update the given reader proxy. Preserve data we are tracking.
  // return value: true = reader was new, false = reader was previously known
  fn matched_reader_update(&mut self, updated_reader_proxy: &RtpsReaderProxy) -> bool {
    let mut is_new = false;
    let is_volatile = self.qos().is_volatile(); // Get this in advance to work with the borrow checker
                                                // Capture the interface set once; resolution consults current observations.
    let multicast_ifaces = self.udp_sender.multicast_interfaces();
    let selector = DefaultRouteSelector::new(self.prefer_loopback_same_host);
    self
      .readers
      .entry(updated_reader_proxy.remote_reader_guid)
      .and_modify(|rp| {
        rp.update(updated_reader_proxy, &self.my_topic_name);
        // Locators may have changed; refresh the interface-aware send route and
        // the per-peer path-MTU budget.
        rp.resolve_send_route(
          &self.interface_observations.borrow(),
          &multicast_ifaces,
          &selector,
        );
        rp.resolve_path_mtu(&self.local_interfaces);
      })
      .or_insert_with(|| {
        is_new = true;
        if let Some(g) = &self.match_generation {
          g.set(g.get().wrapping_add(1));
        }
        let mut new_proxy = updated_reader_proxy.clone();
        // Ensure loopback stays in the gated bucket even for proxies that
        // arrive with it inline (e.g. the built-in get_builtin_reader_proxy path).
        new_proxy.normalize_loopback();
        if is_volatile {
          // With Durabilty::Volatile QoS we won't send the sequence numbers which existed
          // before matching with this reader. Therefore we set the reader as pending GAP
          // for all existing sequence numbers
          new_proxy.set_pending_gap_up_to(self.send_buffer.last_change_sequence_number());
        }
        new_proxy.resolve_send_route(
          &self.interface_observations.borrow(),
          &multicast_ifaces,
          &selector,
        );
        new_proxy.resolve_path_mtu(&self.local_interfaces);
        new_proxy
      });
    // A reader was added or its locators changed: refresh the writer-wide
    // minimum datagram budget used for packing.
    self.recompute_min_datagram_payload();
    if is_new {
      // RADAR patch 63: read after the send plans include the reader (the DataWriter reads its plan after
      // admitting a sample): every later sample goes to it with a HEARTBEAT
      let last = self.send_buffer.last_change_sequence_number();
      if let Some(rp) = self.readers.get_mut(&updated_reader_proxy.remote_reader_guid) {
        rp.live_after = last;
      }
    }
    is_new
  }

  /// Recompute [`min_datagram_payload`](Self::min_datagram_payload) as the
  /// minimum per-peer budget over all matched readers. The aggregated/packed
  /// datagram is one packet multicast to every reader, so it must fit the
  /// smallest path MTU. With no matched readers, fall back to the default.
  fn recompute_min_datagram_payload(&mut self) {
    self.min_datagram_payload = self
      .readers
      .values()
      .map(RtpsReaderProxy::max_datagram_payload)
      .min()
      .unwrap_or(FALLBACK_MAX_AGGREGATED_DATAGRAM_SIZE);
    self.refresh_inline_plan();
  }

  /// Refresh the [`SendRoute`](crate::rtps::transmit::SendRoute) of every
  /// matched reader belonging to `prefix`. Called when fresh interface
  /// observations for that participant may have arrived (e.g. periodic SPDP).
  pub fn recompute_routes_for(&mut self, prefix: GuidPrefix) {
    let multicast_ifaces = self.udp_sender.multicast_interfaces();
    let selector = DefaultRouteSelector::new(self.prefer_loopback_same_host);
    {
      let observations = self.interface_observations.borrow();
      for rp in self.readers.values_mut() {
        if rp.remote_reader_guid.prefix == prefix {
          rp.resolve_send_route(&observations, &multicast_ifaces, &selector);
          rp.resolve_path_mtu(&self.local_interfaces);
        }
      }
    }
    self.recompute_min_datagram_payload();
  }

  fn matched_reader_remove(&mut self, guid: GUID) -> Option<RtpsReaderProxy> {
    let removed = self.readers.remove(&guid);
    if removed.is_some() {
      if let Some(g) = &self.match_generation {
        g.set(g.get().wrapping_add(1));
      }
    }
    if let Some(ref removed_reader) = removed {
      info!(
        "Removed reader proxy. topic={:?} reader={:?}",
        self.topic_name(),
        removed_reader.remote_reader_guid,
      );
      debug!("Removed reader proxy details: {removed_reader:?}");
    }
    #[cfg(feature = "security")]
    if let Some(security_plugins_handle) = &self.security_plugins {
      security_plugins_handle
        .get_plugins()
        .unregister_remote_reader(&self.my_guid, &guid)
        .unwrap_or_else(|e| error!("{e}"));
    }
    self.refresh_inline_plan();
    removed
  }

  /// The participants this writer has matched readers in.
  pub(crate) fn reader_prefixes(&self) -> impl Iterator<Item = GuidPrefix> + '_ {
    self.readers.keys().map(|g| g.prefix)
  }

  pub fn reader_lost(&mut self, guid: GUID) {
    self.type_hash_refusals.forget(guid);
    // RADAR patch 62: nothing was kept for it but the match (and what secure discovery registered for it, if it
    // did: let go as for any reader, an error meaning it had not)
    if self.local_readers.remove(&guid) {
      #[cfg(feature = "security")]
      if let Some(security_plugins_handle) = &self.security_plugins {
        let _ = security_plugins_handle
          .get_plugins()
          .unregister_remote_reader(&self.my_guid, &guid);
      }
      self.reader_lost_status(guid);
      return;
    }
    if self.readers.contains_key(&guid) {
      info!(
        "reader_lost topic={:?} reader={:?}",
        self.topic_name(),
        guid
      );
      self.matched_reader_remove(guid);
      // Removing a reader may relax (raise) the writer-wide minimum budget.
      self.recompute_min_datagram_payload();
      // self.matched_readers_count_total -= 1; // this never decreases
      self.reader_lost_status(guid);
      // A matched reader going away may complete a pending wait_for_acknowledgments
      // and may relax back-pressure: recompute the acknowledgement frontier. (RADAR patch 45: only then.
      // Every writer of the participant is told of every reader lost, and recomputing it for writers that
      // never had that reader made a process of 10,000 endpoints that stopped take seconds.)
      self.refresh_acked_frontier();
    }
  }

  // Entire remote participant was lost.
  // Remove all remote readers belonging to it.
  pub fn participant_lost(&mut self, guid_prefix: GuidPrefix) {
    let lost_readers: Vec<GUID> = self
      .readers
      .range(guid_prefix.range())
      .map(|(g, _)| *g)
      .chain(self.local_readers.range(guid_prefix.range()).copied())
      .collect();
    for reader in lost_readers {
      self.reader_lost(reader);
    }
  }

  fn lookup_reader_proxy_mut(&mut self, guid: GUID) -> Option<&mut RtpsReaderProxy> {
    self.readers.get_mut(&guid)
  }

  pub fn topic_name(&self) -> &String {
    &self.my_topic_name
  }

  fn send_participant_status(&self, event: DomainParticipantStatusEvent) {
    self
      .participant_status_sender
      .try_send(event)
      .unwrap_or_else(|e| error!("Cannot report participant status: {e:?}"));
  }

  // TODO
  // This is placeholder for not-yet-implemented feature.
  //
  // pub fn reset_offered_deadline_missed_status(&mut self) {
  //   self.offered_deadline_status.reset_change();
  // }
}

impl RTPSEntity for Writer {
  fn guid(&self) -> GUID {
    self.my_guid
  }
}

impl HasQoSPolicy for Writer {
  fn qos(&self) -> QosPolicies {
    self.qos_policies.clone()
  }
}

// Serialized overhead of one DATA submessage excluding its serialized payload
// and inline QoS. Conservative fixed fields only; underestimating inline QoS
// causes earlier fragmentation (safe), never datagram overflow.
const DATA_SUBMESSAGE_OVERHEAD: usize = 48;

// An invalidating INFO_TS is a bare submessage header.
const SUBMESSAGE_INFO_TS_INVALIDATE_SIZE: usize = 4;

// Serialized overhead of one DATAFRAG submessage excluding its payload:
// submessage header (4) + extraFlags (2) + octetsToInlineQos (2) + readerId (4)
// + writerId (4) + writerSN (8) + fragmentStartingNum (4) +
// fragmentsInSubmessage (2) + fragmentSize (2) + sampleSize (4) = 36 bytes.
// Inline QoS (e.g. related sample identity) would add more; ignoring it only
// risks a slight overestimate, which degrades to benign IP fragmentation rather
// than data loss.
const DATAFRAG_SUBMESSAGE_OVERHEAD: usize = 36;

// A fifth of a finite, positive Deadline, clamped to
// [REPAIR_INTERVAL_MIN, REPAIR_INTERVAL_MAX]. No Deadline, INFINITE, zero or
// negative give REPAIR_INTERVAL_DEFAULT.
/// RADAR patch 22: whether DataWriters may send new samples from their own thread (on unless the process
/// starts with `RUSTDDS_INLINE_SEND=0`, which benchmarks use to compare).
pub(crate) fn inline_send_enabled() -> bool {
  static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
  *ON.get_or_init(|| std::env::var("RUSTDDS_INLINE_SEND").map_or(true, |v| v != "0"))
}

/// RADAR patch 22: the socket DataWriters of this process send from (nonblocking, any port: RTPS receivers
/// know a writer by the GUID in the message, not by its source port).
fn inline_socket() -> Option<&'static std::net::UdpSocket> {
  static SOCKET: std::sync::OnceLock<Option<std::net::UdpSocket>> = std::sync::OnceLock::new();
  SOCKET
    .get_or_init(|| {
      let s = std::net::UdpSocket::bind((std::net::Ipv4Addr::UNSPECIFIED, 0)).ok()?;
      s.set_nonblocking(true).ok()?;
      Some(s)
    })
    .as_ref()
}

/// RADAR patch 22: sends sample `sn` of `send_buffer` from the calling (DataWriter's) thread as the event
/// loop's Writer would (INFO_TS if stamped, DATA to all readers, a HEARTBEAT if reliable), to every
/// destination of `plan`. Returns whether every datagram was taken by the socket; the caller then lets the
/// event loop skip the sample (`WriterSendBuffer::mark_inline_sent`).
pub(crate) fn send_inline(
  send_buffer: &WriterSendBuffer,
  plan: &InlinePlan,
  writer_guid: GUID,
  sn: SequenceNumber,
) -> bool {
  let Some(cc) = send_buffer.get_by_sn(sn) else {
    return false;
  };
  if cc.data_value.payload_size() > plan.max_payload || cc.write_options.to_single_reader().is_some()
  {
    return false;
  }
  let Some(socket) = inline_socket() else {
    return false;
  };
  let endianness = Endianness::LittleEndian;
  let mut builder = MessageBuilder::new();
  if let Some(ts) = cc.write_options.source_timestamp() {
    builder = builder.ts_msg(endianness, Some(ts));
  }
  #[cfg(feature = "security")]
  let plugins = plan.secured.as_ref().map(|s| &s.plugins);
  #[cfg(not(feature = "security"))]
  let plugins = None;
  let before = builder.submessage_count();
  builder = builder.data_msg(&cc, EntityId::UNKNOWN, writer_guid, endianness, plugins);
  if builder.submessage_count() == before {
    return false; // the payload could not be encoded: the event loop's Writer deals with the sample
  }
  if plan.heartbeat {
    builder = builder.heartbeat_msg(
      writer_guid.entity_id,
      send_buffer.first_change_sequence_number(),
      sn,
      send_buffer.next_heartbeat_count(),
      endianness,
      EntityId::UNKNOWN,
      false, // final_flag: request ACKNACK, as the event loop's piggybacked HEARTBEAT does
      false,
    );
  }
  let message = builder.add_header_and_build(writer_guid.prefix);
  // RADAR patch 56: a secured writer's sample is protected as the Writer protects it, for every matched
  // reader; one whose keys are not exchanged yet leaves the sample to the event loop (which sends to the
  // ready ones and lets repair reach the rest)
  #[cfg(feature = "security")]
  let message = match &plan.secured {
    Some(secured) => {
      let plugins = secured.plugins.get_plugins();
      if !secured
        .readers
        .iter()
        .all(|r| plugins.remote_endpoint_keys_ready(&writer_guid, r))
      {
        return false;
      }
      match security_encode_for(&plugins, writer_guid, &secured.readers, message) {
        Ok(m) => m,
        Err(_) => return false,
      }
    }
    None => message,
  };
  let Ok(buffer) = message.write_to_vec_fast(endianness) else {
    return false;
  };
  let sent = plan
    .dests
    .iter()
    .all(|d| matches!(socket.send_to(&buffer, d), Ok(n) if n == buffer.len()));
  if sent {
    send_buffer.note_inline_send();
  }
  sent
}

/// Protects `message` from writer `source_guid` for the readers `destinations` (each submessage, then the
/// message, with receiver-specific MACs for each). Used by the event loop's Writer and (RADAR patch 56) by
/// DataWriters sending from their own thread.
#[cfg(feature = "security")]
fn security_encode_for(
  plugins: &SecurityPlugins,
  source_guid: GUID,
  destinations: &[GUID],
  message: Message,
) -> SecurityResult<Message> {
  let Message {
    header,
    submessages,
  } = message;
  let mut encoded: Vec<Submessage> = Vec::with_capacity(submessages.len() * 3);
  for submessage in submessages {
    // each encodes to 1 or 3 submessages
    plugins
      .encode_datawriter_submessage(submessage, &source_guid, destinations)?
      .append_to(&mut encoded);
  }
  let destination_prefixes: Vec<GuidPrefix> = destinations.iter().map(|g| g.prefix).collect();
  plugins.encode_message(
    Message {
      header,
      submessages: encoded,
    },
    &source_guid.prefix,
    &destination_prefixes,
  )
}

fn repair_interval_for(deadline: Option<Duration>) -> std::time::Duration {
  match deadline {
    Some(d) if d != Duration::INFINITE && d > Duration::ZERO => {
      std::time::Duration::from(d / 5).clamp(REPAIR_INTERVAL_MIN, REPAIR_INTERVAL_MAX)
    }
    _ => REPAIR_INTERVAL_DEFAULT,
  }
}

// Adaptive packing: how many contiguous fragments (starting at 1-based `start`)
// to place in a single DATAFRAG submessage so the datagram stays within
// `budget` bytes. `header_len` is the datagram size already committed (RTPS
// header + optional INFO_TS/INFO_DST). The fragment *size* is constant; only
// the count adapts. Always returns at least 1 (we emit progress even if a lone
// fragment exceeds the budget, letting IP fragmentation handle the overflow).
fn frags_per_datafrag(
  header_len: usize,
  budget: usize,
  start: u32,
  num_frags: u32,
  fragment_size: u16,
  data_size: usize,
) -> u32 {
  let fragment_size = fragment_size as usize;
  let remaining_frags = num_frags - (start - 1);
  // Bytes available in this datagram for the DATAFRAG payload.
  let payload_cap = budget
    .saturating_sub(header_len)
    .saturating_sub(DATAFRAG_SUBMESSAGE_OVERHEAD);
  // Bytes from the first fragment of this run to the end of the sample.
  let start_byte = (start as usize - 1) * fragment_size;
  let bytes_to_end = data_size.saturating_sub(start_byte);

  let k = if payload_cap >= bytes_to_end {
    // The rest of the sample (including a shorter final fragment) fits.
    remaining_frags
  } else {
    // Only whole fragments fit; take as many as the budget allows (>= 1).
    ((payload_cap / fragment_size) as u32).max(1)
  };
  k.min(remaining_frags)
}

struct FragmentationIter<'a> {
  writer: &'a Writer,
  cache_change: &'a CacheChange,
  target_reader_opt: Option<&'a RtpsReaderProxy>,
  reader_entity_id: EntityId,
  send_heartbeat: bool,
  finished: bool,
  state: FragmentationIterState,
}

impl<'a> FragmentationIter<'a> {
  // nonblocking-transmit: build an iterator that resumes at `cursor`. `Fresh`
  // yields everything (leading GAP for a single reader, all DATAFRAGs, trailing
  // HEARTBEAT, or a single DATA for an unfragmented sample). `Frag(n)` skips the
  // GAP and earlier fragments and resumes at fragment `n`. `Heartbeat` yields
  // only the trailing HEARTBEAT.
  fn new_resume(
    writer: &'a Writer,
    cache_change: &'a CacheChange,
    target_reader_opt: Option<&'a RtpsReaderProxy>,
    send_heartbeat: bool,
    cursor: SampleCursor,
  ) -> Self {
    // The EntityId of the destination
    let reader_entity_id =
      target_reader_opt.map_or(EntityId::UNKNOWN, |p| p.remote_reader_guid.entity_id);

    let data_size = cache_change.data_value.payload_size();
    let fragmentation_needed =
      data_size > writer.max_unfragmented_serialized_payload(target_reader_opt);

    let state = if fragmentation_needed {
      let fragmented = match cursor {
        SampleCursor::Fresh => FragmentedState::TargetReader,
        SampleCursor::Frag(start) => {
          let (num_frags, fragment_size) = writer.num_frags_and_frag_size(data_size);
          FragmentedState::Fragments {
            next: u32::from(start),
            num_frags,
            fragment_size,
          }
        }
        SampleCursor::Heartbeat => FragmentedState::Heartbeat,
      };
      FragmentationIterState::Fragmented(fragmented, data_size)
    } else {
      FragmentationIterState::Unfragmented
    };

    Self {
      writer,
      cache_change,
      target_reader_opt,
      state,
      reader_entity_id,
      finished: false,
      send_heartbeat,
    }
  }

  fn fragmentation_needed(&self) -> bool {
    matches!(self.state, FragmentationIterState::Fragmented(..))
  }
}

enum FragmentationIterState {
  Fragmented(FragmentedState, usize),
  Unfragmented,
}

enum FragmentedState {
  TargetReader,
  // Adaptive-packing DATAFRAG cursor: the next 1-based fragment number to send,
  // the total fragment count, and the (constant) fragment size. Each `next()`
  // emits one datagram carrying a single DATAFRAG submessage that packs as many
  // contiguous fragments as the destination's path-MTU budget allows.
  Fragments {
    next: u32,
    num_frags: u32,
    fragment_size: u16,
  },
  Heartbeat,
}

impl<'a> Iterator for FragmentationIter<'a> {
  // nonblocking-transmit: each item carries the cursor to resume from should
  // this message be the one that a socket cannot accept.
  type Item = (SampleCursor, Message);
  fn next(&mut self) -> Option<Self::Item> {
    if self.finished {
      return None;
    }

    let cc = self.cache_change;
    let writer = self.writer;
    let target_reader_opt = self.target_reader_opt;
    let reader_entity_id = self.reader_entity_id;
    let send_heartbeat = self.send_heartbeat;

    match &mut self.state {
      FragmentationIterState::Fragmented(state, data_size) => {
        // fragmentation_needed: We need to send DATAFRAGs
        match state {
          FragmentedState::TargetReader => {
            let (num_frags, fragment_size) = writer.num_frags_and_frag_size(*data_size);
            *state = FragmentedState::Fragments {
              next: 1,
              num_frags,
              fragment_size,
            };

            // If sending to a single reader, add a GAP message with pending gaps if any
            if let Some(reader) = target_reader_opt {
              if !reader.get_pending_gap().is_empty() {
                let gap_msg = MessageBuilder::new()
                  .dst_submessage(writer.endianness, reader.remote_reader_guid.prefix)
                  .gap_msg(
                    reader.get_pending_gap(),
                    writer.entity_id(),
                    writer.endianness,
                    reader.remote_reader_guid,
                  )
                  .add_header_and_build(writer.my_guid.prefix);
                // Leading GAP: if it blocks, resume from Fresh (re-send GAP too).
                return Some((SampleCursor::Fresh, gap_msg));
              }
            }
            self.next()
          }
          FragmentedState::Fragments {
            next,
            num_frags,
            fragment_size,
          } => {
            if *next <= *num_frags {
              let start = *next;
              let fragment_size = *fragment_size;
              let num_frags = *num_frags;
              let data_size = *data_size;

              let mut message_builder = MessageBuilder::new(); // fresh builder

              if let Some(src_ts) = cc.write_options.source_timestamp() {
                // Add timestamp (applies to the DATAFRAG that follows).
                message_builder = message_builder.ts_msg(writer.endianness, Some(src_ts));
              }

              if let Some(reader) = target_reader_opt {
                // Add info_destination
                message_builder = message_builder
                  .dst_submessage(writer.endianness, reader.remote_reader_guid.prefix);
              }

              // Per-peer datagram budget: the destination reader's path-MTU
              // budget for a directed send, or the writer-wide minimum (over all
              // matched readers) for a multicast-to-all send.
              let budget = writer.datagram_budget(target_reader_opt);
              // How many contiguous fragments (starting at `start`) fit in one
              // DATAFRAG submessage within the remaining datagram budget. Fragment
              // *size* is constant (RTPS rule); only the *count* per submessage
              // adapts to the path MTU.
              let k = frags_per_datafrag(
                message_builder.len_serialized(),
                budget,
                start,
                num_frags,
                fragment_size,
                data_size,
              );

              let sample_size_u32 = match u32::try_from(data_size) {
                Ok(n) => n,
                Err(_) => {
                  error!("sample_to_samplestream: data_size {data_size} does not fit in u32");
                  return None;
                }
              };

              message_builder = message_builder.data_frag_msg(
                cc,
                reader_entity_id, // reader
                writer.my_guid,
                FragmentNumber::new(start),
                k as u16,
                fragment_size,
                sample_size_u32,
                writer.endianness,
                writer.security_plugins.as_ref(),
              );

              *next = start + k;
              let datafrag_msg = message_builder.add_header_and_build(writer.my_guid.prefix);
              // If this datagram blocks, resume from its first fragment next time
              // (the same K is recomputed deterministically).
              return Some((SampleCursor::Frag(FragmentNumber::new(start)), datafrag_msg));
            }
            *state = FragmentedState::Heartbeat;
            self.next()
          }
          FragmentedState::Heartbeat => {
            self.finished = true;

            // Add HEARTBEAT message if needed
            if send_heartbeat && !writer.like_stateless {
              let final_flag = false; // false = request that readers acknowledge with ACKNACK.
              let liveliness_flag = false; // This is not a manual liveliness assertion (DDS API call), but side-effect of
                                           // writing new data.
              let hb_msg = MessageBuilder::new()
                .heartbeat_msg(
                  writer.entity_id(), // from Writer
                  writer.send_buffer.first_change_sequence_number(),
                  writer.send_buffer.last_change_sequence_number(),
                  writer.next_heartbeat_count(),
                  writer.endianness,
                  reader_entity_id, // to Reader
                  final_flag,
                  liveliness_flag,
                )
                .add_header_and_build(writer.my_guid.prefix);
              // Trailing HEARTBEAT: if it blocks, resume from Heartbeat only.
              return Some((SampleCursor::Heartbeat, hb_msg));
            }
            None
          }
        }
      }
      FragmentationIterState::Unfragmented => {
        // We can send DATA
        let mut message_builder = MessageBuilder::new();

        // If DataWriter sent us a source timestamp, then add that.
        // Timestamp has to go before Data to have effect on Data.
        if let Some(src_ts) = cc.write_options.source_timestamp() {
          message_builder = message_builder.ts_msg(writer.endianness, Some(src_ts));
        }

        if let Some(reader) = target_reader_opt {
          // Add info_destination
          message_builder =
            message_builder.dst_submessage(writer.endianness, reader.remote_reader_guid.prefix);

          // If the reader is pending GAPs on any sequence numbers, add a GAP
          if !reader.get_pending_gap().is_empty() {
            message_builder = message_builder.gap_msg(
              reader.get_pending_gap(),
              writer.entity_id(),
              writer.endianness,
              reader.remote_reader_guid,
            );
          }
        }

        // Add the DATA submessage
        message_builder = message_builder.data_msg(
          cc,
          reader_entity_id,
          writer.my_guid,
          writer.endianness,
          writer.security_plugins.as_ref(),
        );

        // Add HEARTBEAT if needed
        if send_heartbeat && !writer.like_stateless {
          let final_flag = false; // false = request that readers acknowledge with ACKNACK.
          let liveliness_flag = false; // This is not a manual liveliness assertion (DDS API call), but side-effect of
                                       // writing new data.
          message_builder = message_builder.heartbeat_msg(
            writer.entity_id(),
            writer.send_buffer.first_change_sequence_number(),
            writer.send_buffer.last_change_sequence_number(),
            writer.next_heartbeat_count(),
            writer.endianness,
            reader_entity_id, // to Reader
            final_flag,
            liveliness_flag,
          );
        }

        let data_message = message_builder.add_header_and_build(writer.my_guid.prefix);
        self.finished = true;
        // Unfragmented DATA (+HEARTBEAT): if it blocks, resume from Fresh.
        Some((SampleCursor::Fresh, data_message))
      }
    }
  }
}

// -------------------------------------------------------------------------------------
// -------------------------------------------------------------------------------------
// -------------------------------------------------------------------------------------

#[cfg(test)]
mod tests {
  use std::thread;

  use byteorder::LittleEndian;
  use log::info;

  use super::frags_per_datafrag;

  // At a 1500-byte-MTU budget, a two-fragment "1 KB" sample (its serialized form
  // is slightly over the 1024-byte fragment size) packs BOTH fragments into one
  // DATAFRAG submessage, so it goes out in a single datagram instead of two.
  #[test]
  fn small_mtu_packs_1k_sample_into_one_datafrag() {
    // header_len 20 (RTPS header only), budget 1452, fragment size 1024,
    // sample 1036 bytes => 2 fragments.
    assert_eq!(frags_per_datafrag(20, 1452, 1, 2, 1024, 1036), 2);
  }

  // A large sample at a 1500-byte MTU can only fit one 1024-byte fragment per
  // datagram (2 * 1024 would overflow), so K collapses to 1.
  #[test]
  fn small_mtu_large_sample_one_fragment_per_datagram() {
    assert_eq!(frags_per_datafrag(20, 1452, 1, 10, 1024, 10240), 1);
  }

  // A jumbo-frame budget packs several whole fragments per DATAFRAG.
  #[test]
  fn jumbo_mtu_packs_several_fragments() {
    // budget 8952 (9000 MTU - 48), header 20 => payload_cap 8900 => 8 * 1024.
    assert_eq!(frags_per_datafrag(20, 8952, 1, 10, 1024, 10240), 8);
  }

  // The final run (including the shorter tail fragment) is taken whole when it
  // fits.
  #[test]
  fn tail_run_includes_partial_last_fragment() {
    // Fragments 9 and 10 of a 10240-byte sample: 1024 + (partial) with a large
    // budget => both fit.
    assert_eq!(frags_per_datafrag(20, 100_000, 9, 10, 1024, 10240), 2);
  }

  // A pathologically small budget still emits at least one fragment (progress),
  // accepting benign IP fragmentation for the overflow.
  #[test]
  fn tiny_budget_still_emits_one_fragment() {
    assert_eq!(frags_per_datafrag(20, 100, 1, 5, 1024, 5120), 1);
  }

  // K never exceeds the number of fragments actually remaining.
  #[test]
  fn k_capped_by_remaining_fragments() {
    assert_eq!(frags_per_datafrag(20, 100_000, 1, 3, 1024, 2600), 3);
  }

  use crate::{
    dds::{
      participant::DomainParticipant, qos::QosPolicies, topic::TopicKind,
      with_key::datawriter::DataWriter,
    },
    serialization::CDRSerializerAdapter,
    test::{random_data::*, test_domain::test_domain_id},
  };

  #[test]
  fn test_writer_receives_datawriter_cache_change_notifications() {
    let domain_participant =
      DomainParticipant::new(test_domain_id(0)).expect("Failed to create participant");
    let qos = QosPolicies::qos_none();
    let _default_dw_qos = QosPolicies::qos_none();

    let publisher = domain_participant
      .create_publisher(&qos)
      .expect("Failed to create publisher");
    let topic = domain_participant
      .create_topic(
        "Aasii".to_string(),
        "Huh?".to_string(),
        &qos,
        TopicKind::WithKey,
      )
      .expect("Failed to create topic");
    let data_writer: DataWriter<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>> =
      publisher
        .create_datawriter(&topic, None)
        .expect("Failed to create datawriter");

    let data = RandomData {
      a: 4,
      b: "Fobar".to_string(),
    };

    let data2 = RandomData {
      a: 2,
      b: "Fobar".to_string(),
    };

    let data3 = RandomData {
      a: 3,
      b: "Fobar".to_string(),
    };

    let write_result = data_writer.write(data, None);
    info!("writerResult:  {write_result:?}");

    data_writer
      .write(data2, None)
      .expect("Unable to write data");

    info!("writerResult:  {write_result:?}");
    let write_result = data_writer.write(data3, None);

    thread::sleep(std::time::Duration::from_millis(100));
    info!("writerResult:  {write_result:?}");
  }

  #[test]
  fn repair_interval_is_fifth_of_deadline_clamped() {
    use super::{repair_interval_for, Duration};
    // DDS Durations count 2^-32 s, so a fifth may be off by a nanosecond.
    let interval_ms = |deadline: Option<Duration>| {
      (repair_interval_for(deadline).as_micros() as f64 / 1000.0).round() as u64
    };
    assert_eq!(interval_ms(Some(Duration::from_millis(50))), 10);
    assert_eq!(interval_ms(Some(Duration::from_secs(1))), 100);
    assert_eq!(interval_ms(Some(Duration::from_millis(1))), 1);
    assert_eq!(interval_ms(Some(Duration::from_millis(200))), 40);
    assert_eq!(interval_ms(None), 10);
    assert_eq!(interval_ms(Some(Duration::INFINITE)), 10);
    assert_eq!(interval_ms(Some(Duration::ZERO)), 10);
  }

  // RADAR patch 16: an idle writer keeps no timers; a write or a new reader
  // schedules them again.
  mod idle_timers {
    use std::{cell::RefCell, rc::Rc, time::Duration as StdDuration};

    use super::super::*;
    use crate::{
      dds::{
        ddsdata::DDSData,
        qos::QosPolicyBuilder,
        statusevents::{sync_status_channel, StatusChannelReceiver},
        with_key::datawriter::WriteOptions,
      },
      messages::submessages::elements::serialized_payload::SerializedPayload,
      polling::new_shared_timer,
      rtps::writer_send_buffer::Admission,
      structure::guid::EntityKind,
      RepresentationIdentifier,
    };

    type Kept = (
      StatusChannelReceiver<DataWriterStatus>,
      StatusChannelReceiver<DomainParticipantStatusEvent>,
    );

    fn writer(timer: &SharedTimer<DpTimerEvent>, qos: QosPolicies) -> (Writer, Kept) {
      let id = EntityId::new([0, 0, 1], EntityKind::WRITER_NO_KEY_USER_DEFINED);
      let guid = GUID::new(GuidPrefix::new(&[1; 12]), id);
      let send_buffer = WriterSendBuffer::new(
        guid,
        "idle_test".to_string(),
        true,
        false,
        false,
        DEFAULT_WRITER_MAX_SAMPLES,
        DEFAULT_WRITER_MAX_SAMPLES,
        DEFAULT_WRITER_MAX_SAMPLES,
        false,
      );
      let (status_sender, status) = sync_status_channel(4).unwrap();
      let (participant_status_sender, participant_status) = sync_status_channel(16).unwrap();
      let w = Writer::new(
        WriterIngredients {
          guid,
          send_buffer,
          topic_name: "idle_test".to_string(),
          like_stateless: false,
          qos_policies: qos,
          status_sender,
          security_plugins: None,
        },
        Rc::new(UDPSender::new(0).unwrap()),
        Rc::clone(timer),
        participant_status_sender,
        Rc::new(RefCell::new(InterfaceObservations::default())),
        Rc::from(Vec::<IfAddr>::new()),
      );
      (w, (status, participant_status))
    }

    fn reliable() -> QosPolicies {
      QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
          max_blocking_time: Duration::from_millis(100),
        })
        .history(History::KeepLast { depth: 1 })
        .build()
    }

    /// Fires every scheduled event at once, as the event loop would when they
    /// are due; returns what was scheduled.
    fn fire_all(timer: &SharedTimer<DpTimerEvent>, w: &mut Writer) -> Vec<TimedEvent> {
      let due = timer.borrow_mut().take_all();
      let events: Vec<TimedEvent> = due
        .into_iter()
        .filter_map(|e| match e {
          DpTimerEvent::Writer { event, .. } => Some(event),
          _ => None,
        })
        .collect();
      for e in &events {
        w.handle_timed_event(*e);
      }
      events
    }

    fn count(events: &[TimedEvent], heartbeat: bool) -> usize {
      events
        .iter()
        .filter(|e| match e {
          TimedEvent::Heartbeat => heartbeat,
          TimedEvent::CacheCleaning => !heartbeat,
          _ => false,
        })
        .count()
    }

    #[test]
    fn an_unmatched_writer_stops_its_timers_and_a_write_starts_them_again() {
      let timer = new_shared_timer();
      let (mut w, _kept) = writer(&timer, reliable());
      // created: one heartbeat and one cache cleaning scheduled
      let first = fire_all(&timer, &mut w);
      assert_eq!((count(&first, true), count(&first, false)), (1, 1));
      // nobody to tell anything, nothing written: both stop
      assert!(
        fire_all(&timer, &mut w).is_empty(),
        "an idle writer with no readers rescheduled a timer"
      );
      // a write schedules both again, once
      let data = DDSData::new(SerializedPayload::new(
        RepresentationIdentifier::CDR_LE,
        vec![0; 8],
      ));
      assert!(matches!(
        w.send_buffer
          .admit_blocking(WriteOptions::default(), data, Some(StdDuration::ZERO)),
        Admission::Admitted(_)
      ));
      w.process_pending();
      w.process_pending();
      let again = fire_all(&timer, &mut w);
      assert_eq!((count(&again, true), count(&again, false)), (1, 1), "{again:?}");
      // the cleaning after the write runs once more, then stops
      let after = fire_all(&timer, &mut w);
      assert_eq!(count(&after, true), 0);
      assert!(fire_all(&timer, &mut w).is_empty());
    }

    #[test]
    fn a_newly_matched_reader_starts_the_heartbeat_again() {
      let timer = new_shared_timer();
      let (mut w, _kept) = writer(&timer, reliable());
      fire_all(&timer, &mut w);
      assert!(fire_all(&timer, &mut w).is_empty());
      let reader = GUID::new(
        GuidPrefix::new(&[2; 12]),
        EntityId::new([0, 0, 2], EntityKind::READER_NO_KEY_USER_DEFINED),
      );
      let rp = RtpsReaderProxy::new(reader, reliable(), false);
      w.update_reader_proxy(&rp, &reliable());
      assert_eq!(count(&fire_all(&timer, &mut w), true), 1);
    }
  }

  // Repair (ACKNACK response) tests. The Writer runs without an event loop, so
  // the tests poll the shared timer themselves and hand SendRepairData to the
  // Writer as the event loop would.
  /// RADAR patch 22: a DataWriter sends new samples from its own thread where the Writer says how.
  mod inline_send {
    use std::{net::UdpSocket, time::Duration as StdDuration};

    use bytes::Bytes;

    use super::super::*;
    use crate::{
      dds::{
        ddsdata::DDSData,
        qos::{policy::Reliability, QosPolicyBuilder},
        statusevents::sync_status_channel,
        with_key::datawriter::WriteOptions,
      },
      messages::submessages::elements::serialized_payload::SerializedPayload,
      polling::new_shared_timer,
      messages::submessages::submessages::WriterSubmessage,
      rtps::{submessage::SubmessageBody, writer_send_buffer::Admission},
      structure::guid::EntityKind,
      RepresentationIdentifier,
    };

    /// A reliable user Writer matched with one reader that listens on `reader`, and its send buffer.
    fn matched_writer(reader: &UdpSocket) -> (Writer, WriterSendBuffer) {
      let (mut writer, send_buffer) = lone_writer();
      match_reader(&mut writer, reader);
      (writer, send_buffer)
    }

    /// `matched_reader` on `reader`'s socket, matched to `writer`.
    fn match_reader(writer: &mut Writer, reader: &UdpSocket) {
      let qos = writer.qos_policies.clone();
      let reader_guid = matched_reader();
      let mut proxy = RtpsReaderProxy::new(reader_guid, qos.clone(), false);
      // a reader on this host reached over loopback, as the event loop routes it
      proxy
        .unicast_locator_list
        .push(Locator::from(reader.local_addr().unwrap()));
      proxy.normalize_loopback();
      writer.update_reader_proxy(&proxy, &qos);
    }

    /// A reliable, volatile user Writer with no reader yet, and its send buffer.
    fn lone_writer() -> (Writer, WriterSendBuffer) {
      let (writer, send_buffer, kept) = lone_writer_with_status([0, 0, 7]);
      std::mem::forget(kept);
      (writer, send_buffer)
    }

    /// What a writer tells: its own statuses and its participant's.
    type Statuses = (
      crate::dds::statusevents::StatusChannelReceiver<DataWriterStatus>,
      crate::dds::statusevents::StatusChannelReceiver<DomainParticipantStatusEvent>,
    );

    /// `lone_writer` with entity key `key`, and the receivers of its statuses.
    fn lone_writer_with_status(key: [u8; 3]) -> (Writer, WriterSendBuffer, Statuses) {
      let id = EntityId::new(key, EntityKind::WRITER_NO_KEY_USER_DEFINED);
      let guid = GUID::new(GuidPrefix::new(&[1; 12]), id);
      let qos = QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
          max_blocking_time: Duration::from_millis(100),
        })
        .build();
      let send_buffer = WriterSendBuffer::new(
        guid,
        "inline_test".to_string(),
        true,
        false,
        true,
        DEFAULT_WRITER_MAX_SAMPLES,
        DEFAULT_WRITER_MAX_SAMPLES,
        DEFAULT_WRITER_MAX_SAMPLES,
        true,
      );
      let (status_sender, status) = sync_status_channel(16).unwrap();
      let (participant_status_sender, participant_status) = sync_status_channel(16).unwrap();
      let reader_prefix = GuidPrefix::new(&[2; 12]);
      let mut observations = InterfaceObservations::default();
      observations.record(reader_prefix, None, "127.0.0.1:7777".parse().unwrap());
      let writer = Writer::new(
        WriterIngredients {
          guid,
          send_buffer: send_buffer.clone(),
          topic_name: "inline_test".to_string(),
          like_stateless: false,
          qos_policies: qos.clone(),
          status_sender,
          security_plugins: None,
        },
        Rc::new(UDPSender::new(0).unwrap()),
        new_shared_timer(),
        participant_status_sender,
        Rc::new(RefCell::new(observations)),
        Rc::from(Vec::<IfAddr>::new()),
      );
      (writer, send_buffer, (status, participant_status))
    }

    /// A reader with entity key `key` of the participant `prefix`, listening on `socket`, matched to `writer`.
    fn match_reader_of(writer: &mut Writer, prefix: [u8; 12], key: [u8; 3], socket: &UdpSocket) -> GUID {
      let qos = writer.qos_policies.clone();
      let guid = GUID::new(
        GuidPrefix::new(&prefix),
        EntityId::new(key, EntityKind::READER_NO_KEY_USER_DEFINED),
      );
      let mut proxy = RtpsReaderProxy::new(guid, qos.clone(), false);
      proxy
        .unicast_locator_list
        .push(Locator::from(socket.local_addr().unwrap()));
      proxy.normalize_loopback();
      writer.update_reader_proxy(&proxy, &qos);
      guid
    }

    fn quiet_socket() -> UdpSocket {
      let s = UdpSocket::bind("127.0.0.1:0").unwrap();
      s.set_read_timeout(Some(StdDuration::from_millis(200))).unwrap();
      s
    }

    /// The current match counts the writer told, and the readers its participant was told it matched.
    fn told(statuses: &Statuses) -> (Vec<i32>, Vec<GUID>) {
      let mut counts = Vec::new();
      while let Ok(s) = statuses.0.try_recv() {
        if let DataWriterStatus::PublicationMatched { current, .. } = s {
          counts.push(current.count());
        }
      }
      let mut matched = Vec::new();
      while let Ok(e) = statuses.1.try_recv() {
        if let DomainParticipantStatusEvent::RemoteReaderMatched { remote_reader, .. } = e {
          matched.push(remote_reader);
        }
      }
      (counts, matched)
    }

    /// RADAR patch 62: a writer and a reader of one participant that the application feeds itself are matched
    /// (counted, told) but the writer sends that reader nothing, and with only such readers writes as with none
    /// (patch 61); any other reader, of this participant unmarked or of another participant marked, is sent
    /// what is written as before; losing the fed reader counts down; a writer whose mark is forgotten (it was
    /// deleted) is matched as any other.
    #[test]
    fn a_reader_the_application_feeds_is_matched_and_sent_nothing() {
      use crate::local_delivery;
      let (mut writer, send_buffer, statuses) = lone_writer_with_status([0, 6, 2]);
      let own = [1; 12]; // the writer's participant
      local_delivery::delivers_locally(writer.my_guid);
      let fed_guid = GUID::new(
        GuidPrefix::new(&own),
        EntityId::new([0, 6, 3], EntityKind::READER_NO_KEY_USER_DEFINED),
      );
      local_delivery::takes_locally(fed_guid);
      let fed = quiet_socket();
      assert_eq!(match_reader_of(&mut writer, own, [0, 6, 3], &fed), fed_guid);
      assert_eq!(told(&statuses), (vec![1], vec![fed_guid]), "matched and told");
      assert!(writer.readers.is_empty(), "no proxy kept for it");
      // told again (discovery repeats itself): nothing changes
      match_reader_of(&mut writer, own, [0, 6, 3], &fed);
      assert_eq!(told(&statuses), (vec![], vec![]));
      // what is written goes nowhere: taken as sent as admitted, nothing on the fed reader's socket
      let sn = admit(&send_buffer);
      assert!(send_buffer.is_inline_sent(sn), "written as with no reader");
      writer.process_pending();
      writer.handle_timed_event(TimedEvent::Heartbeat);
      assert!(data_and_heartbeats(&fed).is_empty(), "the fed reader is sent nothing");

      // a reader of another participant, marked too, is sent what is written as before
      let other = quiet_socket();
      let other_guid = match_reader_of(&mut writer, [2; 12], [0, 6, 4], &other);
      local_delivery::takes_locally(other_guid);
      assert_eq!(told(&statuses), (vec![2], vec![other_guid]));
      send_buffer.set_inline_plan(None);
      let sent = admit(&send_buffer);
      assert!(!send_buffer.is_inline_sent(sent));
      writer.process_pending();
      let data = |s: &UdpSocket| -> Vec<String> {
        data_and_heartbeats(s)
          .into_iter()
          .filter(|m| m.starts_with("DATA"))
          .collect()
      };
      assert_eq!(data(&other), vec![format!("DATA {}", i64::from(sent))]);
      assert!(data_and_heartbeats(&fed).is_empty(), "still nothing for the fed one");
      // so is an unmarked reader of this participant
      let plain = quiet_socket();
      // this host's loopback is a route to this participant's readers once it has been seen
      writer.interface_observations.borrow_mut().record(
        GuidPrefix::new(&own),
        None,
        "127.0.0.1:7777".parse().unwrap(),
      );
      match_reader_of(&mut writer, own, [0, 6, 5], &plain);
      let next = admit(&send_buffer);
      writer.process_pending();
      assert_eq!(data(&plain), vec![format!("DATA {}", i64::from(next))]);

      // the fed reader goes: the count goes down by one
      told(&statuses);
      writer.reader_lost(fed_guid);
      assert_eq!(told(&statuses).0, vec![2]);
      assert!(writer.local_readers.is_empty());

      // a deleted writer's mark is forgotten: a writer of that GUID matches the fed reader as any other
      local_delivery::forget(writer.my_guid);
      let again = quiet_socket();
      match_reader_of(&mut writer, own, [0, 6, 3], &again);
      assert!(writer.readers.contains_key(&fed_guid), "a proxy, as for any reader");
      local_delivery::forget(fed_guid);
      local_delivery::forget(other_guid);
    }

    /// RADAR patch 61 (mended with 62): with the readerless mode off (as with `RUSTDDS_INLINE_SEND=0`), a
    /// sample admitted before the first reader matches is not accounted as sent to nobody at the match: the
    /// event loop sends it as usual afterwards.
    #[test]
    fn a_first_match_leaves_what_is_pending_to_be_sent_when_the_readerless_mode_was_off() {
      let (mut writer, send_buffer) = lone_writer();
      send_buffer.set_readerless(false); // as `refresh_inline_plan` leaves it when inline send is off
      let pending = admit(&send_buffer);
      assert!(!send_buffer.is_inline_sent(pending), "the mode is off");
      let reader = quiet_socket();
      match_reader(&mut writer, &reader);
      assert!(writer.last_sent < pending, "not accounted for at the match");
    }

    /// RADAR patch 61: a writer with no reader takes what is written as sent to nobody as it is admitted (its
    /// DataWriter then wakes no event loop for it), except every READERLESS_RING_EVERY-th sample; the first
    /// reader to match gets none of those samples, and what is written after it matched as before.
    #[test]
    fn a_writer_without_readers_takes_a_sample_as_sent_to_nobody_and_a_reader_that_matches_gets_what_follows() {
      use crate::rtps::writer_send_buffer::READERLESS_RING_EVERY;
      let (mut writer, send_buffer) = lone_writer();
      assert!(send_buffer.inline_plan().is_none(), "no reader: no plan");
      let every = i64::from(READERLESS_RING_EVERY);
      let sns: Vec<SequenceNumber> = (0..=every).map(|_| admit(&send_buffer)).collect();
      for sn in &sns[..sns.len() - 1] {
        assert!(send_buffer.is_inline_sent(*sn), "{sn:?} is sent to nobody as admitted");
      }
      let last = *sns.last().unwrap();
      assert!(
        !send_buffer.is_inline_sent(last),
        "the {}-th sample is left to the event loop, so that its bookkeeping keeps up",
        every + 1
      );
      // the event loop woken for that one accounts for all of them, and sends nothing
      writer.process_pending();
      assert_eq!(writer.last_sent, last);
      // more while nobody listens, then a reader matches: they are accounted for at the match
      let before_match = admit(&send_buffer);
      assert!(send_buffer.is_inline_sent(before_match));
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_millis(300)))
        .unwrap();
      match_reader(&mut writer, &reader);
      assert_eq!(writer.last_sent, before_match, "accounted for before the reader counts");
      // what is written now goes to the reader as before the patch (here: by the event loop)
      send_buffer.set_inline_plan(None);
      let after = admit(&send_buffer);
      assert!(!send_buffer.is_inline_sent(after), "a reader is matched: sent as usual");
      writer.process_pending();
      let data: Vec<String> = data_and_heartbeats(&reader)
        .into_iter()
        .filter(|s| s.starts_with("DATA"))
        .collect();
      assert_eq!(data, vec![format!("DATA {}", i64::from(after))], "nothing from before the match");
      // and once the last reader is gone, a sample is sent to nobody again
      writer.matched_reader_remove(matched_reader());
      assert!(send_buffer.is_inline_sent(admit(&send_buffer)));
    }

    fn admit(send_buffer: &WriterSendBuffer) -> SequenceNumber {
      admit_of(send_buffer, 16)
    }

    /// Admits a sample of `len` bytes.
    fn admit_of(send_buffer: &WriterSendBuffer, len: usize) -> SequenceNumber {
      let data = DDSData::new(SerializedPayload::new(
        RepresentationIdentifier::CDR_LE,
        vec![7; len],
      ));
      match send_buffer.admit_blocking(WriteOptions::default(), data, Some(StdDuration::ZERO)) {
        Admission::Admitted(sn) => sn,
        Admission::WouldBlock => panic!("no room"),
      }
    }

    /// The reader `matched_writer` matched.
    fn matched_reader() -> GUID {
      GUID::new(
        GuidPrefix::new(&[2; 12]),
        EntityId::new([0, 0, 7], EntityKind::READER_NO_KEY_USER_DEFINED),
      )
    }

    /// `matched_reader` asks `writer` for `first..=last`, as a reader that has nothing before `first` would.
    fn ask_for(writer: &mut Writer, first: i64, last: i64, count: i32) {
      use crate::{
        messages::submessages::ack_nack::AckNack, structure::sequence_number::SequenceNumberSet,
      };
      let reader = matched_reader();
      let wanted: BTreeSet<SequenceNumber> = (first..=last).map(SequenceNumber::new).collect();
      writer.handle_ack_nack(
        reader.prefix,
        &AckSubmessage::AckNack(AckNack {
          reader_id: reader.entity_id,
          writer_id: writer.my_guid.entity_id,
          reader_sn_state: SequenceNumberSet::from_base_and_set(SequenceNumber::new(first), &wanted),
          count,
        }),
      );
    }

    /// The DATA and HEARTBEAT submessages waiting on `reader`'s socket, in order.
    fn data_and_heartbeats(reader: &UdpSocket) -> Vec<String> {
      let mut buf = vec![0u8; 65536];
      let mut seen = Vec::new();
      while let Ok(n) = reader.recv(&mut buf) {
        let msg = Message::read_from_buffer(&Bytes::copy_from_slice(&buf[..n])).unwrap();
        for sub in msg.submessages {
          match sub.body {
            SubmessageBody::Writer(WriterSubmessage::Data(d, _)) => {
              seen.push(format!("DATA {}", i64::from(d.writer_sn)));
            }
            SubmessageBody::Writer(WriterSubmessage::Heartbeat(h, _)) => seen.push(format!(
              "HEARTBEAT {}..{} to {:?}",
              i64::from(h.first_sn),
              i64::from(h.last_sn),
              h.reader_id
            )),
            _ => {}
          }
        }
      }
      seen
    }

    #[test]
    fn a_matched_writer_publishes_a_plan_and_a_sample_sent_inline_is_data_and_heartbeat_on_the_wire() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_secs(2)))
        .unwrap();
      let (writer, send_buffer) = matched_writer(&reader);
      let plan = send_buffer
        .inline_plan()
        .expect("one unicast reader: the Writer says how to send inline");
      assert_eq!(plan.dests, vec![reader.local_addr().unwrap()]);
      assert!(plan.heartbeat);

      let sn = admit(&send_buffer);
      assert!(send_inline(&send_buffer, &plan, writer.my_guid, sn));
      assert_eq!(send_buffer.inline_sends(), 1, "a sent sample is counted");
      // the Writer announced itself to the new reader (a HEARTBEAT) before: the datagram with the DATA
      let mut buf = vec![0u8; 65536];
      let msg = loop {
        let n = reader.recv(&mut buf).expect("the datagram");
        let msg = Message::read_from_buffer(&Bytes::copy_from_slice(&buf[..n])).unwrap();
        if msg
          .submessages
          .iter()
          .any(|sub| matches!(sub.body, SubmessageBody::Writer(WriterSubmessage::Data(..))))
        {
          break msg;
        }
      };
      assert_eq!(msg.header.guid_prefix, writer.my_guid.prefix);
      let kinds: Vec<String> = msg
        .submessages
        .iter()
        .map(|sub| match &sub.body {
          SubmessageBody::Writer(WriterSubmessage::Data(d, _)) => format!("DATA {}", i64::from(d.writer_sn)),
          SubmessageBody::Writer(WriterSubmessage::Heartbeat(h, _)) => {
            format!("HEARTBEAT {}..{}", i64::from(h.first_sn), i64::from(h.last_sn))
          }
          other => format!("{other:?}"),
        })
        .collect();
      assert_eq!(kinds, vec![format!("DATA {}", i64::from(sn)), format!("HEARTBEAT 1..{}", i64::from(sn))]);
    }

    /// RADAR patch 34: a writer that has written nothing answers a reader's preemptive ACKNACK (base 0)
    /// with a HEARTBEAT (1..0), so that a reader whose first HEARTBEAT was lost still hears from it.
    #[test]
    fn a_writer_with_nothing_written_answers_a_preemptive_acknack() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_millis(300)))
        .unwrap();
      let (mut writer, _send_buffer) = matched_writer(&reader);
      let mut buf = vec![0u8; 65536];
      // whatever the match sent (nothing, without an event loop), gone
      while reader.recv(&mut buf).is_ok() {}
      let heartbeats = |buf: &mut Vec<u8>| {
        let mut seen = Vec::new();
        while let Ok(n) = reader.recv(buf) {
          let msg = Message::read_from_buffer(&Bytes::copy_from_slice(&buf[..n])).unwrap();
          for sub in msg.submessages {
            if let SubmessageBody::Writer(WriterSubmessage::Heartbeat(h, _)) = sub.body {
              seen.push((i64::from(h.first_sn), i64::from(h.last_sn)));
            }
          }
        }
        seen
      };
      use crate::{
        messages::submessages::ack_nack::AckNack, structure::sequence_number::SequenceNumberSet,
      };
      let reader_id = EntityId::new([0, 0, 7], EntityKind::READER_NO_KEY_USER_DEFINED);
      let acknack = |base: i64, count: i32| {
        AckSubmessage::AckNack(AckNack {
          reader_id,
          writer_id: writer.my_guid.entity_id,
          reader_sn_state: SequenceNumberSet::new_empty(SequenceNumber::new(base)),
          count,
        })
      };
      let (preemptive, answer) = (acknack(0, 1), acknack(1, 2));
      writer.handle_ack_nack(GuidPrefix::new(&[2; 12]), &preemptive);
      assert_eq!(heartbeats(&mut buf), vec![(1, 0)], "a preemptive ACKNACK is answered");
      // an ACKNACK that answers a HEARTBEAT (base 1: nothing missing) needs no answer
      writer.handle_ack_nack(GuidPrefix::new(&[2; 12]), &answer);
      assert_eq!(heartbeats(&mut buf), vec![]);
    }

    /// RADAR patch 63: an ACKNACK that requests nothing from a reader that has had every sample since it
    /// matched crossed a newer sample on the wire (it acknowledges the one before): that sample's HEARTBEAT
    /// answers it, so the writer sends none now. A reader that has not all that was written before it matched
    /// is still told at once what the writer has (patch 34's answer).
    #[test]
    fn an_acknack_that_crossed_a_newer_sample_is_left_to_that_sample_s_heartbeat() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_millis(100)))
        .unwrap();
      let (mut writer, send_buffer) = lone_writer();
      // two samples written before the reader matched
      admit(&send_buffer);
      admit(&send_buffer);
      writer.process_pending();
      match_reader(&mut writer, &reader);
      data_and_heartbeats(&reader);
      let heartbeats = |reader: &UdpSocket| {
        data_and_heartbeats(reader)
          .into_iter()
          .filter(|s| s.starts_with("HEARTBEAT"))
          .count()
      };
      // it has nothing of them and asks for nothing: it does not know them, a HEARTBEAT at once
      ask_for(&mut writer, 1, 0, 1);
      assert_eq!(heartbeats(&reader), 1, "a reader that matched after samples is told of them");
      ask_for(&mut writer, 3, 2, 2);
      assert_eq!(heartbeats(&reader), 0, "all acknowledged");
      // samples 3 and 4 written and sent, each with its HEARTBEAT
      admit(&send_buffer);
      writer.process_pending();
      admit(&send_buffer);
      writer.process_pending();
      assert_eq!(
        data_and_heartbeats(&reader)
          .iter()
          .filter(|s| s.starts_with("DATA"))
          .count(),
        2
      );
      // the ACKNACK for 3 comes after 4 went out: 4's HEARTBEAT asks for the next one, none now
      ask_for(&mut writer, 4, 3, 3);
      assert_eq!(heartbeats(&reader), 0, "the ACKNACK that crossed sample 4 is answered by 4's HEARTBEAT");
      ask_for(&mut writer, 5, 4, 4);
      assert_eq!(heartbeats(&reader), 0);
    }

    /// RADAR patch 59: a reader that joined late asks for a writer's history at most 256 samples at a time;
    /// the repair round that answers the last of a window holds a HEARTBEAT, so the reader asks for the next
    /// window at once. A window that reaches the writer's last sample needs none.
    #[test]
    fn a_repair_window_short_of_the_history_ends_with_a_heartbeat() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_millis(100)))
        .unwrap();
      let (mut writer, send_buffer) = matched_writer(&reader);
      data_and_heartbeats(&reader); // what the match sent
      let held = 300;
      for _ in 0..held {
        admit(&send_buffer);
      }
      let reader_guid = matched_reader();
      // asks for `first..=last`, then the writer's repair rounds run until it has answered; the submessages on
      // the wire, in order
      let mut ask_and_repair = |first: i64, last: i64, count: i32| -> Vec<String> {
        ask_for(&mut writer, first, last, count);
        for _ in 0..1000 {
          if !writer.readers[&reader_guid].repair_mode {
            break;
          }
          writer.handle_timed_event(TimedEvent::SendRepairData {
            to_reader: reader_guid,
          });
        }
        assert!(!writer.readers[&reader_guid].repair_mode, "repair did not end");
        data_and_heartbeats(&reader)
      };
      let data = |first: i64, last: i64| (first..=last).map(|sn| format!("DATA {sn}"));

      // the first window (an ACKNACK's largest): every sample asked for, then a HEARTBEAT for this reader
      let mut expected: Vec<String> = data(1, 256).collect();
      expected.push(format!("HEARTBEAT 1..{held} to {:?}", reader_guid.entity_id));
      assert_eq!(ask_and_repair(1, 256, 1), expected);
      // the last window reaches the writer's last sample: no HEARTBEAT
      assert_eq!(ask_and_repair(257, held, 2), data(257, held).collect::<Vec<_>>());
      // one lost sample short of the end repaired: a HEARTBEAT (the reader may miss more after it)
      let mut expected: Vec<String> = data(100, 100).collect();
      expected.push(format!("HEARTBEAT 1..{held} to {:?}", reader_guid.entity_id));
      assert_eq!(ask_and_repair(100, 100, 3), expected);
    }

    /// RADAR patch 60: a repair round to a reader on this host (reached over loopback) carries up to 32 KiB,
    /// to a reader over a network up to 8 KiB (`repair_round_is_byte_limited_and_continues`).
    #[test]
    fn a_repair_round_to_a_reader_on_this_host_carries_more() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_millis(100)))
        .unwrap();
      let (mut writer, send_buffer) = matched_writer(&reader);
      data_and_heartbeats(&reader); // what the match sent
      for _ in 0..200 {
        admit_of(&send_buffer, 1000);
      }
      let reader_guid = matched_reader();
      assert_eq!(
        Writer::repair_batch_limit(&writer.readers[&reader_guid]),
        REPAIR_BATCH_MAX_BYTES_SAME_HOST,
        "the reader is reached over loopback"
      );
      ask_for(&mut writer, 1, 200, 1);
      let mut rounds = Vec::new();
      while writer.readers[&reader_guid].repair_mode && rounds.len() < 100 {
        writer.handle_timed_event(TimedEvent::SendRepairData {
          to_reader: reader_guid,
        });
        let sent = data_and_heartbeats(&reader);
        rounds.push(sent.iter().filter(|s| s.starts_with("DATA")).count());
      }
      // 1,000-byte samples: the 32nd crosses 32 KiB (at 8 KiB a round it was the 8th: 25 rounds)
      assert_eq!(rounds, vec![32, 32, 32, 32, 32, 32, 8], "samples per round");
    }

    #[test]
    fn the_event_loop_skips_what_the_writer_sent_and_sends_what_it_did_not() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      reader
        .set_read_timeout(Some(StdDuration::from_millis(300)))
        .unwrap();
      let (mut writer, send_buffer) = matched_writer(&reader);
      let (a, b) = (admit(&send_buffer), admit(&send_buffer));
      // the DataWriter claimed the first (as if it had sent it), not the second
      send_buffer.mark_inline_sent(a, true);
      writer.process_pending();
      let mut got = Vec::new();
      let mut buf = vec![0u8; 65536];
      while let Ok(n) = reader.recv(&mut buf) {
        let msg = Message::read_from_buffer(&Bytes::copy_from_slice(&buf[..n])).unwrap();
        for sub in msg.submessages {
          if let SubmessageBody::Writer(WriterSubmessage::Data(d, _)) = sub.body {
            got.push(d.writer_sn);
          }
        }
      }
      assert_eq!(got, vec![b], "the loop sent only the sample the writer did not");
      assert_eq!(writer.last_sent, b);
      assert!(!send_buffer.is_inline_sent(a), "the claim is forgotten once passed");
    }

    #[test]
    fn a_writer_whose_readers_are_all_best_effort_keeps_its_depth() {
      // RADAR patch 36: best-effort readers never acknowledge; the SPDP writer (built-in, keyed, durable,
      // keep-last 8, matched with every peer's best-effort SPDP reader) kept every announcement it made.
      let id = EntityId::new([0, 1, 0], EntityKind::WRITER_WITH_KEY_BUILT_IN);
      let guid = GUID::new(GuidPrefix::new(&[1; 12]), id);
      let qos = QosPolicyBuilder::new()
        .reliability(Reliability::BestEffort)
        .durability(crate::dds::qos::policy::Durability::TransientLocal)
        .history(crate::dds::qos::policy::History::KeepLast { depth: 8 })
        .build();
      let send_buffer = WriterSendBuffer::new(guid, "spdp_like".to_string(), false, true, false, 8, 8, 8, true);
      let (status_sender, status) = sync_status_channel(4).unwrap();
      let (participant_status_sender, participant_status) = sync_status_channel(16).unwrap();
      std::mem::forget((status, participant_status));
      let mut writer = Writer::new(
        WriterIngredients {
          guid,
          send_buffer: send_buffer.clone(),
          topic_name: "spdp_like".to_string(),
          like_stateless: false,
          qos_policies: qos.clone(),
          status_sender,
          security_plugins: None,
        },
        Rc::new(UDPSender::new(0).unwrap()),
        new_shared_timer(),
        participant_status_sender,
        Rc::new(RefCell::new(InterfaceObservations::default())),
        Rc::from(Vec::<IfAddr>::new()),
      );
      for peer in 2..5u8 {
        let reader = GUID::new(
          GuidPrefix::new(&[peer; 12]),
          EntityId::new([0, 1, 0], EntityKind::READER_WITH_KEY_BUILT_IN),
        );
        writer.update_reader_proxy(&RtpsReaderProxy::new(reader, qos.clone(), false), &qos);
      }
      let key = crate::dds::key::KeyHash::zero();
      for _ in 0..100 {
        let sn = admit(&send_buffer);
        send_buffer.note_instance_sample(sn, key);
        writer.process_pending();
      }
      writer.handle_cache_cleaning();
      assert_eq!(send_buffer.retained_len(), 8, "the depth is kept, and only the depth");
      assert_eq!(send_buffer.instance_samples(key), 8, "the instance's list follows");
    }

    #[test]
    fn no_plan_once_the_last_reader_is_gone() {
      let reader = UdpSocket::bind("127.0.0.1:0").unwrap();
      let (mut writer, send_buffer) = matched_writer(&reader);
      let guid = *writer.readers.keys().next().unwrap();
      writer.reader_lost(guid);
      assert!(send_buffer.inline_plan().is_none(), "no readers: nothing to send to");
    }
  }

  /// RADAR patch 56: secured DataWriters send from their own thread too, protected as the event loop's
  /// Writer protects them.
  #[cfg(feature = "security")]
  mod secured_inline_send {
    use std::time::{Duration as StdDuration, Instant};

    use serde::{Deserialize, Serialize};

    use crate::{
      policy, test::test_domain::test_domain_id, DomainParticipant, DomainParticipantBuilder,
      DomainParticipantSecurityConfigFiles, QosPolicyBuilder, TopicKind,
    };

    /// A participant secured with the example configuration (its governance encrypts topic "Square":
    /// payload, submessages and whole messages).
    fn secured_participant(domain: u16) -> DomainParticipant {
      let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/security_configuration_files"
      );
      DomainParticipantBuilder::new(domain)
        .builtin_security(DomainParticipantSecurityConfigFiles::with_ros_default_names(
          dir,
          "password123".to_string(),
        ))
        .build()
        .expect("a secured participant from the example configuration")
    }

    #[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
    struct Shape {
      n: u32,
    }

    const PROBE: u32 = 1_000_000;

    #[test]
    fn a_secured_writer_sends_from_its_own_thread_and_the_secured_reader_decodes_every_sample() {
      // the example permissions grant domain 0 only
      let domain = test_domain_id(0);
      let a = secured_participant(domain);
      let b = secured_participant(domain);
      let qos = QosPolicyBuilder::new()
        .reliability(policy::Reliability::Reliable {
          max_blocking_time: crate::Duration::from_secs(1),
        })
        .history(policy::History::KeepAll)
        // room for the whole burst in the reader's cache (without resource limits it keeps 64 unread)
        .resource_limits(policy::ResourceLimits {
          max_samples: 1000,
          max_instances: 1,
          max_samples_per_instance: 1000,
        })
        .build();
      let topic = |p: &DomainParticipant| {
        p.create_topic(
          "Square".to_string(),
          "ShapeType".to_string(),
          &qos,
          TopicKind::NoKey,
        )
        .unwrap()
      };
      let writer = a
        .create_publisher(&qos)
        .unwrap()
        .create_datawriter_no_key_cdr::<Shape>(&topic(&a), None)
        .unwrap();
      let mut reader = b
        .create_subscriber(&qos)
        .unwrap()
        .create_datareader_no_key_cdr::<Shape>(&topic(&b), None)
        .unwrap();

      // authentication, matching and the key exchange: until a probe gets through
      let deadline = Instant::now() + StdDuration::from_secs(30);
      let mut probe = PROBE;
      'matched: loop {
        assert!(
          Instant::now() < deadline,
          "the secured participants matched and exchanged keys within 30 s"
        );
        writer.write(Shape { n: probe }, None).unwrap();
        probe += 1;
        std::thread::sleep(StdDuration::from_millis(100));
        while let Ok(Some(s)) = reader.take_next_sample() {
          if s.value().n >= PROBE {
            break 'matched;
          }
        }
      }

      let before = writer.inline_sends();
      for n in 0..200 {
        writer.write(Shape { n }, None).unwrap();
      }
      let sent_inline = writer.inline_sends() - before;

      let mut got = Vec::new();
      let deadline = Instant::now() + StdDuration::from_secs(10);
      while got.len() < 200 && Instant::now() < deadline {
        match reader.take_next_sample() {
          Ok(Some(s)) if s.value().n < PROBE => got.push(s.value().n),
          Ok(Some(_)) => {}
          _ => std::thread::sleep(StdDuration::from_millis(5)),
        }
      }
      assert_eq!(
        got,
        (0..200).collect::<Vec<u32>>(),
        "the secured reader decoded every sample, in order"
      );
      assert_eq!(
        sent_inline, 200,
        "with keys exchanged, every sample went on the wire from the writing thread"
      );
    }
  }

  mod repair {
    use std::{
      cell::RefCell,
      net::SocketAddr,
      rc::Rc,
      time::{Duration as StdDuration, Instant},
    };

    use super::super::*;
    use crate::{
      dds::{
        ddsdata::DDSData,
        qos::{policy::Durability, QosPolicyBuilder},
        statusevents::{sync_status_channel, StatusChannelReceiver},
        with_key::datawriter::WriteOptions,
      },
      discovery::discovery::Discovery,
      messages::submessages::{
        elements::serialized_payload::SerializedPayload, submessages::AckNack,
      },
      polling::new_shared_timer,
      rtps::writer_send_buffer::Admission,
      structure::{guid::EntityKind, sequence_number::SequenceNumberSet},
      RepresentationIdentifier,
    };

    struct Fixture {
      writer: Writer,
      reader_guid: GUID,
      timer: SharedTimer<DpTimerEvent>,
      _status: StatusChannelReceiver<DataWriterStatus>,
      _participant_status: StatusChannelReceiver<DomainParticipantStatusEvent>,
    }

    impl Fixture {
      // A reliable Writer that holds samples 1..=sample_count of `payload_len`
      // bytes and is matched with one remote reader. Without a locator the
      // reader gets nothing on the wire, but the repair bookkeeping runs.
      fn new(
        writer_id: EntityId,
        writer_qos: QosPolicies,
        reader_id: EntityId,
        reader_qos: &QosPolicies,
        sample_count: i64,
        payload_len: usize,
        reader_locator: Option<SocketAddr>,
      ) -> Self {
        let guid = GUID::new(GuidPrefix::new(&[1; 12]), writer_id);
        let send_buffer = WriterSendBuffer::new(
          guid,
          "repair_test".to_string(),
          true, // reliable
          writer_id.kind().is_built_in(),
          false,
          DEFAULT_WRITER_MAX_SAMPLES,
          DEFAULT_WRITER_MAX_SAMPLES,
          DEFAULT_WRITER_MAX_SAMPLES,
          false,
        );
        for _ in 0..sample_count {
          let data = DDSData::new(SerializedPayload::new(
            RepresentationIdentifier::CDR_LE,
            vec![0; payload_len],
          ));
          assert!(matches!(
            send_buffer.admit_blocking(WriteOptions::default(), data, Some(StdDuration::ZERO)),
            Admission::Admitted(_)
          ));
        }
        let (status_sender, status) = sync_status_channel(4).unwrap();
        let (participant_status_sender, participant_status) = sync_status_channel(16).unwrap();
        let timer = new_shared_timer();
        let mut writer = Writer::new(
          WriterIngredients {
            guid,
            send_buffer,
            topic_name: "repair_test".to_string(),
            like_stateless: false,
            qos_policies: writer_qos,
            status_sender,
            security_plugins: None,
          },
          Rc::new(UDPSender::new(0).unwrap()),
          Rc::clone(&timer),
          participant_status_sender,
          Rc::new(RefCell::new(InterfaceObservations::default())),
          Rc::from(Vec::<IfAddr>::new()),
        );
        let reader_guid = GUID::new(GuidPrefix::new(&[2; 12]), reader_id);
        let mut reader_proxy = RtpsReaderProxy::new(reader_guid, reader_qos.clone(), false);
        reader_proxy
          .unicast_locator_list
          .extend(reader_locator.map(Locator::from));
        writer.update_reader_proxy(&reader_proxy, reader_qos);
        assert!(
          writer.readers.contains_key(&reader_guid),
          "reader did not match"
        );
        Self {
          writer,
          reader_guid,
          timer,
          _status: status,
          _participant_status: participant_status,
        }
      }

      // A built-in SEDP publications Writer and a remote SEDP publications
      // reader, with the QoS Discovery gives them.
      fn sedp(sample_count: i64, payload_len: usize) -> Self {
        Self::new(
          EntityId::SEDP_BUILTIN_PUBLICATIONS_WRITER,
          Discovery::builtin_publisher_qos(),
          EntityId::SEDP_BUILTIN_PUBLICATIONS_READER,
          &Discovery::builtin_subscriber_qos(),
          sample_count,
          payload_len,
          None,
        )
      }

      fn user(sample_count: i64, payload_len: usize, reader_locator: Option<SocketAddr>) -> Self {
        let qos = QosPolicyBuilder::new()
          .reliability(Reliability::Reliable {
            max_blocking_time: Duration::from_millis(100),
          })
          .history(History::KeepAll)
          .durability(Durability::TransientLocal)
          .build();
        Self::new(
          EntityId::new([0, 0, 1], EntityKind::WRITER_WITH_KEY_USER_DEFINED),
          qos.clone(),
          EntityId::new([0, 0, 2], EntityKind::READER_WITH_KEY_USER_DEFINED),
          &qos,
          sample_count,
          payload_len,
          reader_locator,
        )
      }

      fn reader_proxy(&self) -> &RtpsReaderProxy {
        &self.writer.readers[&self.reader_guid]
      }

      fn unsent(&self) -> usize {
        self.reader_proxy().unsent_changes_count()
      }

      // The reader has received nothing and requests `requested`.
      fn ack_nack(&mut self, requested: impl IntoIterator<Item = i64>, count: i32) {
        let requested: BTreeSet<SequenceNumber> =
          requested.into_iter().map(SequenceNumber::new).collect();
        let ack_nack = AckNack {
          reader_id: self.reader_guid.entity_id,
          writer_id: self.writer.my_guid.entity_id,
          reader_sn_state: SequenceNumberSet::from_base_and_set(SequenceNumber::new(1), &requested),
          count,
        };
        self
          .writer
          .handle_ack_nack(self.reader_guid.prefix, &AckSubmessage::AckNack(ack_nack));
      }

      // Timed events addressed to our reader that expire within `max_wait`.
      // This keeps SendRepairFrags, which next_repair_event skips.
      fn reader_events(&self, max_wait: StdDuration) -> Vec<TimedEvent> {
        let give_up = Instant::now() + max_wait;
        let mut found = Vec::new();
        loop {
          while let Some(fired) = self.timer.borrow_mut().poll() {
            if let DpTimerEvent::Writer { event, .. } = fired {
              let to_reader = match event {
                TimedEvent::SendRepairData { to_reader }
                | TimedEvent::SendRepairFrags { to_reader } => Some(to_reader),
                TimedEvent::Heartbeat | TimedEvent::CacheCleaning => None,
              };
              if to_reader == Some(self.reader_guid) {
                found.push(event);
              }
            }
          }
          if Instant::now() >= give_up {
            return found;
          }
          std::thread::sleep(StdDuration::from_millis(1));
        }
      }

      // The next SendRepairData timeout scheduled for our reader, waiting up to
      // `max_wait` for it to expire. Other timeouts are skipped.
      fn next_repair_event(&self, max_wait: StdDuration) -> Option<TimedEvent> {
        let give_up = Instant::now() + max_wait;
        loop {
          while let Some(fired) = self.timer.borrow_mut().poll() {
            if let DpTimerEvent::Writer {
              event: TimedEvent::SendRepairData { to_reader },
              ..
            } = fired
            {
              if to_reader == self.reader_guid {
                return Some(TimedEvent::SendRepairData { to_reader });
              }
            }
          }
          if Instant::now() >= give_up {
            return None;
          }
          std::thread::sleep(StdDuration::from_millis(1));
        }
      }

      // Run one repair round; returns how many changes it sent.
      fn repair_round(&mut self) -> usize {
        let event = self
          .next_repair_event(StdDuration::from_secs(5))
          .expect("SendRepairData was not scheduled");
        let before = self.unsent();
        self.writer.handle_timed_event(event);
        before - self.unsent()
      }
    }

    // Built-in and user Writers alike answer an ACKNACK only after
    // nack_response_delay, from the SendRepairData timer.
    #[test]
    fn acknack_schedules_repair_after_nack_response_delay() {
      for mut f in [Fixture::sedp(5, 8), Fixture::user(5, 8, None)] {
        f.writer.nack_response_delay = StdDuration::from_millis(200);
        f.ack_nack(1..=5, 1);
        assert_eq!(f.unsent(), 5, "repaired on the ACKNACK");
        assert!(f.reader_proxy().repair_mode);
        assert!(
          f.next_repair_event(StdDuration::from_millis(100)).is_none(),
          "repair before nack_response_delay"
        );
        assert_eq!(f.repair_round(), 5);
        assert!(!f.reader_proxy().repair_mode);
      }
    }

    // A round stops once REPAIR_BATCH_MAX_BYTES have gone out and the next
    // round continues where it stopped.
    #[test]
    fn repair_round_is_byte_limited_and_continues() {
      // 1000-byte samples: the eighth crosses 8 KiB.
      let mut f = Fixture::user(20, 1000, None);
      f.writer.nack_response_delay = StdDuration::ZERO;
      f.ack_nack(1..=20, 1);
      assert_eq!(f.repair_round(), 8);
      assert_eq!(f.repair_round(), 8);
      assert!(f.reader_proxy().repair_mode);
      assert_eq!(f.repair_round(), 4);
      assert!(!f.reader_proxy().repair_mode);
      assert!(f.next_repair_event(StdDuration::from_millis(50)).is_none());

      // Small SEDP-sized samples: many per round, still more than one round.
      let mut f = Fixture::sedp(250, 64);
      f.writer.nack_response_delay = StdDuration::ZERO;
      f.ack_nack(1..=250, 1);
      let first = f.repair_round();
      assert!(first > 50 && first < 250, "first round sent {first}");
      while f.reader_proxy().repair_mode {
        f.repair_round();
      }
      assert_eq!(f.unsent(), 0);
    }

    // A sample larger than a whole round still goes out, one per round. These
    // samples are fragmented, and that send is the only one: it does not arm
    // SendRepairFrags.
    #[test]
    fn repair_round_sends_at_least_one_sample() {
      let mut f = Fixture::user(3, 20_000, None);
      f.writer.nack_response_delay = StdDuration::ZERO;
      f.ack_nack(1..=3, 1);
      for _ in 0..3 {
        assert_eq!(f.repair_round(), 1);
        assert!(!f.reader_proxy().repair_frags_requested());
      }
      assert!(!f.reader_proxy().repair_mode);
      assert!(f
        .reader_events(StdDuration::from_millis(50))
        .iter()
        .all(|event| !matches!(event, TimedEvent::SendRepairFrags { .. })));
    }

    // A repeated ACKNACK count is a copy and changes nothing; a new count does.
    #[test]
    fn duplicate_acknack_count_is_ignored() {
      let mut f = Fixture::user(5, 8, None);
      f.writer.nack_response_delay = StdDuration::ZERO;
      f.ack_nack(1..=5, 1);
      assert_eq!(f.repair_round(), 5);

      f.ack_nack(1..=5, 1);
      assert_eq!(f.unsent(), 0);
      assert!(!f.reader_proxy().repair_mode);
      assert!(f.next_repair_event(StdDuration::from_millis(50)).is_none());

      f.ack_nack(1..=5, 2);
      assert_eq!(f.unsent(), 5);
      assert_eq!(f.repair_round(), 5);
    }

    // RADAR patch 40: a reader that acknowledged everything and then asks for it again (it dropped this
    // writer and matched it anew, while this writer kept it) gets it again.
    #[test]
    fn a_reader_that_asks_again_for_acknowledged_samples_gets_them() {
      let mut f = Fixture::user(5, 8, None);
      f.writer.nack_response_delay = StdDuration::ZERO;
      let all_acked = AckNack {
        reader_id: f.reader_guid.entity_id,
        writer_id: f.writer.my_guid.entity_id,
        reader_sn_state: SequenceNumberSet::new_empty(SequenceNumber::new(6)),
        count: 1,
      };
      f.writer
        .handle_ack_nack(f.reader_guid.prefix, &AckSubmessage::AckNack(all_acked));
      assert_eq!(f.reader_proxy().all_acked_before, SequenceNumber::new(6));
      assert_eq!(f.unsent(), 0);
      f.ack_nack(1..=5, 2);
      assert_eq!(f.repair_round(), 5, "the samples asked for again are sent");
      assert_eq!(f.reader_proxy().all_acked_before, SequenceNumber::new(6));
    }

    // While the reader's send socket has queued control datagrams, a round
    // sends nothing and re-arms; once the queue drains, repair proceeds.
    #[test]
    fn repair_waits_for_control_backlog() {
      // A loopback locator would not be used before route resolution.
      let mut f = Fixture::user(5, 8, Some(SocketAddr::from(([192, 0, 2, 1], 9))));
      f.writer.nack_response_delay = StdDuration::ZERO;
      f.writer
        .udp_sender
        .inject_control_backlog(SocketId::Unicast);
      f.ack_nack(1..=5, 1);
      assert_eq!(f.repair_round(), 0);
      assert!(f.reader_proxy().repair_mode);

      f.writer.udp_sender.flush_control(SocketId::Unicast);
      assert_eq!(f.repair_round(), 5);
      assert!(!f.reader_proxy().repair_mode);
    }
  }
}

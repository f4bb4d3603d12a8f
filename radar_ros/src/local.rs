//! In-process delivery: the slots of this participant's responses, reachable without a DDS hop.
//!
//! A response registers each of its slot topics here ([`Inlets::open`]) and reads what arrives on the returned
//! [`Inbox`] beside its DDS readers. The embedded manager, arming a statement whose target slot is one of
//! these (same topic, same type), delivers through the [`Inlet`] instead of a DDS writer: one hop (the
//! source's) instead of two. The inlet outlives the response that opened it, so a connection that holds it
//! sees the response leave (its presence drops to 0) and a response of the same name come back (1 again),
//! as it sees DDS subscribers leave and come back.

use std::{
    collections::HashMap,
    sync::{Arc, Mutex},
};

use tokio::sync::{mpsc, watch};

use crate::raw::RawMessage;

/// One slot topic of this process.
pub(crate) struct Inlet {
    /// The open inbox's type and sender, while a response reads it.
    open: Mutex<Option<(String, mpsc::UnboundedSender<RawMessage>)>>,
    /// 1 while a response reads it, 0 otherwise: the peer count a connection watches.
    present: watch::Sender<usize>,
}

impl Inlet {
    /// Hands `m` to the response reading the slot, if one does (else it is dropped, as a DDS sample with no
    /// reader is). Returns whether it was handed over.
    pub(crate) fn deliver(&self, m: RawMessage) -> bool {
        match &*self.open.lock().unwrap() {
            Some((_, tx)) => tx.send(m).is_ok(),
            None => false,
        }
    }

    /// 1 while a response reads the slot, 0 otherwise.
    pub(crate) fn presence(&self) -> watch::Receiver<usize> {
        self.present.subscribe()
    }
}

/// The slot topics of this process's responses.
#[derive(Default)]
pub(crate) struct Inlets(Mutex<HashMap<String, Arc<Inlet>>>);

impl Inlets {
    /// Opens the slot `topic` of type `ros_type` for a response (component names are unique in a process, so
    /// one response at a time opens a topic). Closed when the inbox is dropped.
    pub(crate) fn open(&self, topic: &str, ros_type: &str) -> Inbox {
        let inlet = self
            .0
            .lock()
            .unwrap()
            .entry(topic.to_owned())
            .or_insert_with(|| {
                Arc::new(Inlet {
                    open: Mutex::new(None),
                    present: watch::channel(0).0,
                })
            })
            .clone();
        let (tx, rx) = mpsc::unbounded_channel();
        *inlet.open.lock().unwrap() = Some((ros_type.to_owned(), tx));
        inlet.present.send_replace(1);
        Inbox { rx, inlet }
    }

    /// The slot `topic` if a response of this process reads it now with type `ros_type`.
    pub(crate) fn find(&self, topic: &str, ros_type: &str) -> Option<Arc<Inlet>> {
        let inlet = self.0.lock().unwrap().get(topic)?.clone();
        let open = matches!(&*inlet.open.lock().unwrap(), Some((t, _)) if t == ros_type);
        open.then_some(inlet)
    }
}

/// What a response receives on one slot from this process's connections.
pub(crate) struct Inbox {
    rx: mpsc::UnboundedReceiver<RawMessage>,
    inlet: Arc<Inlet>,
}

impl Inbox {
    /// The messages, in delivery order.
    pub(crate) fn stream(&mut self) -> impl futures::Stream<Item = RawMessage> + '_ {
        futures::stream::poll_fn(|cx| self.rx.poll_recv(cx))
    }
}

impl Drop for Inbox {
    fn drop(&mut self) {
        *self.inlet.open.lock().unwrap() = None;
        self.inlet.present.send_replace(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_inlet_delivers_while_its_inbox_is_open_and_shows_presence() {
        let inlets = Inlets::default();
        assert!(inlets.find("/r/start", "std_msgs/msg/Empty").is_none());
        let mut inbox = inlets.open("/r/start", "std_msgs/msg/Empty");
        assert!(
            inlets.find("/r/start", "std_msgs/msg/String").is_none(),
            "another type is not this slot"
        );
        let inlet = inlets.find("/r/start", "std_msgs/msg/Empty").unwrap();
        let presence = inlet.presence();
        assert_eq!(*presence.borrow(), 1);
        assert!(inlet.deliver(RawMessage(vec![0])));
        assert_eq!(inbox.rx.try_recv().unwrap(), RawMessage(vec![0]));
        drop(inbox);
        assert_eq!(*presence.borrow(), 0);
        assert!(!inlet.deliver(RawMessage(vec![0])), "nobody reads it now");
        assert!(inlets.find("/r/start", "std_msgs/msg/Empty").is_none());
        // a response of the same name comes back: the same inlet, present again
        let _again = inlets.open("/r/start", "std_msgs/msg/Empty");
        assert_eq!(*presence.borrow(), 1);
        assert!(inlet.deliver(RawMessage(vec![0])));
    }
}

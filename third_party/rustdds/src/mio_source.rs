// PollEventSource and PollEventSender are an event communication channel that
// carries no data. The receiver is always a mio 1.2 `Source`, and also a mio
// 0.8 `Source` when that optional compatibility feature is enabled.
//
// The internal reactors do not use this channel.

macro_rules! socketpair_bridge {
  ($modname:ident, $mio:ident) => {
    mod $modname {
      use std::{
        io,
        io::{Read, Write},
        sync::{Arc, Mutex},
      };
      #[cfg(not(target_os = "windows"))]
      use std::os::fd::OwnedFd;
      #[cfg(target_os = "windows")]
      use std::{thread::sleep, time::Duration};

      #[allow(unused_imports)]
      use log::{debug, error, info};
      #[cfg(not(target_os = "windows"))]
      use socketpair::{socketpair_stream, SocketpairStream};

      /// The socket pair, made when the source is first registered with a poll: a channel nobody polls
      /// (the async streams wait on task wakers) costs no descriptors and no system calls.
      #[derive(Default)]
      struct Pair {
        sockets: Option<($mio::net::TcpStream, $mio::net::TcpStream)>,
        /// Sent before the pair existed, not drained yet: written once the pair is made, so that the
        /// poll sees it.
        pending: bool,
      }

      pub struct Source {
        pair: Arc<Mutex<Pair>>,
      }

      #[cfg(test)]
      impl Source {
        /// Whether the socket pair has been made.
        pub fn has_sockets(&self) -> bool {
          self.pair.lock().unwrap().sockets.is_some()
        }
      }

      #[derive(Clone)]
      pub struct Sender {
        pair: Arc<Mutex<Pair>>,
      }

      #[cfg(not(target_os = "windows"))]
      fn set_non_blocking(s: SocketpairStream) -> io::Result<SocketpairStream> {
        let owned_fd = OwnedFd::from(s);
        let std_socket = std::net::TcpStream::from(owned_fd);
        std_socket.set_nonblocking(true)?;
        Ok(SocketpairStream::from(OwnedFd::from(std_socket)))
      }

      /// (receiving end, sending end)
      #[cfg(not(target_os = "windows"))]
      fn sockets() -> io::Result<($mio::net::TcpStream, $mio::net::TcpStream)> {
        let (rec_sps, send_sps) = socketpair_stream()?;
        let rec_sps = set_non_blocking(rec_sps)?;
        let send_sps = set_non_blocking(send_sps)?;
        let rec = $mio::net::TcpStream::from_std(std::net::TcpStream::from(OwnedFd::from(rec_sps)));
        let send =
          $mio::net::TcpStream::from_std(std::net::TcpStream::from(OwnedFd::from(send_sps)));
        Ok((rec, send))
      }

      #[cfg(target_os = "windows")]
      fn sockets() -> io::Result<($mio::net::TcpStream, $mio::net::TcpStream)> {
        let listener = $mio::net::TcpListener::bind("127.0.0.1:0".parse().unwrap())?;
        let addr = listener.local_addr()?;
        let rec = $mio::net::TcpStream::connect(addr)?;
        let mut accepted = listener.accept();
        while accepted.is_err() {
          sleep(Duration::from_millis(100));
          accepted = listener.accept();
        }
        let (send, _addr_send) = accepted?;
        debug!("IPC socket: {addr:#?} <-> {_addr_send:#?}");
        Ok((rec, send))
      }

      pub fn make() -> io::Result<(Source, Sender)> {
        let pair = Arc::new(Mutex::new(Pair::default()));
        Ok((
          Source {
            pair: Arc::clone(&pair),
          },
          Sender { pair },
        ))
      }

      impl Sender {
        pub fn send(&self) {
          let mut pair = self.pair.lock().unwrap();
          match pair.sockets.as_mut() {
            Some((_, send)) => match send.write(&[0xcc]) {
              Ok(_b) => {}
              Err(e) => info!("PollEventSender.send: {e}"),
            },
            None => pair.pending = true,
          }
        }
      }

      impl Source {
        pub fn drain(&self) {
          let mut pair = self.pair.lock().unwrap();
          pair.pending = false;
          if let Some((rec, _)) = pair.sockets.as_mut() {
            let mut buf = Vec::with_capacity(16);
            match rec.read_to_end(&mut buf) {
              Ok(_) => (),
              Err(err) => match err.kind() {
                io::ErrorKind::WouldBlock => {}
                other_kind => info!("PollEventSource.drain(): {other_kind}"),
              },
            }
          }
        }

        /// The receiving socket, made (with what was sent meanwhile) on first use.
        fn with_rec<R>(
          &self,
          f: impl FnOnce(&mut $mio::net::TcpStream) -> io::Result<R>,
        ) -> io::Result<R> {
          let mut pair = self.pair.lock().unwrap();
          if pair.sockets.is_none() {
            let (rec, mut send) = sockets()?;
            if std::mem::take(&mut pair.pending) {
              send.write_all(&[0xcc])?;
            }
            pair.sockets = Some((rec, send));
          }
          f(&mut pair.sockets.as_mut().expect("just made").0)
        }
      }

      impl $mio::event::Source for Source {
        fn register(
          &mut self,
          registry: &$mio::Registry,
          token: $mio::Token,
          interests: $mio::Interest,
        ) -> io::Result<()> {
          self.with_rec(|rec| rec.register(registry, token, interests))
        }

        fn reregister(
          &mut self,
          registry: &$mio::Registry,
          token: $mio::Token,
          interests: $mio::Interest,
        ) -> io::Result<()> {
          self.with_rec(|rec| rec.reregister(registry, token, interests))
        }

        fn deregister(&mut self, registry: &$mio::Registry) -> io::Result<()> {
          match self.pair.lock().unwrap().sockets.as_mut() {
            Some((rec, _)) => rec.deregister(registry),
            None => Ok(()),
          }
        }
      }
    }
  };
}

#[cfg(feature = "mio_08")]
socketpair_bridge!(bridge_08, mio_08);
socketpair_bridge!(bridge_1, mio1);

pub struct PollEventSource {
  #[cfg(feature = "mio_08")]
  mio08: bridge_08::Source,
  mio1: bridge_1::Source,
}

#[derive(Clone)]
pub struct PollEventSender {
  #[cfg(feature = "mio_08")]
  mio08: bridge_08::Sender,
  mio1: bridge_1::Sender,
}

pub fn make_poll_channel() -> std::io::Result<(PollEventSource, PollEventSender)> {
  #[cfg(feature = "mio_08")]
  let (mio08_source, mio08_sender) = bridge_08::make()?;
  let (mio1_source, mio1_sender) = bridge_1::make()?;
  Ok((
    PollEventSource {
      #[cfg(feature = "mio_08")]
      mio08: mio08_source,
      mio1: mio1_source,
    },
    PollEventSender {
      #[cfg(feature = "mio_08")]
      mio08: mio08_sender,
      mio1: mio1_sender,
    },
  ))
}

impl PollEventSender {
  pub fn send(&self) {
    #[cfg(feature = "mio_08")]
    self.mio08.send();
    self.mio1.send();
  }
}

impl PollEventSource {
  /// Drain sent bytes so the socketpair can trigger again. Call before acting
  /// on the event.
  pub fn drain(&self) {
    #[cfg(feature = "mio_08")]
    self.mio08.drain();
    self.mio1.drain();
  }
}

#[cfg(feature = "mio_08")]
impl mio_08::event::Source for PollEventSource {
  fn register(
    &mut self,
    registry: &mio_08::Registry,
    token: mio_08::Token,
    interests: mio_08::Interest,
  ) -> std::io::Result<()> {
    self.mio08.register(registry, token, interests)
  }

  fn reregister(
    &mut self,
    registry: &mio_08::Registry,
    token: mio_08::Token,
    interests: mio_08::Interest,
  ) -> std::io::Result<()> {
    self.mio08.reregister(registry, token, interests)
  }

  fn deregister(&mut self, registry: &mio_08::Registry) -> std::io::Result<()> {
    self.mio08.deregister(registry)
  }
}

impl mio1::event::Source for PollEventSource {
  fn register(
    &mut self,
    registry: &mio1::Registry,
    token: mio1::Token,
    interests: mio1::Interest,
  ) -> std::io::Result<()> {
    self.mio1.register(registry, token, interests)
  }

  fn reregister(
    &mut self,
    registry: &mio1::Registry,
    token: mio1::Token,
    interests: mio1::Interest,
  ) -> std::io::Result<()> {
    self.mio1.reregister(registry, token, interests)
  }

  fn deregister(&mut self, registry: &mio1::Registry) -> std::io::Result<()> {
    self.mio1.deregister(registry)
  }
}

/// Bounded reader-notification queue with optional mio 0.6 readiness.
#[derive(Clone)]
pub(crate) struct NotificationSender {
  sender: std::sync::mpsc::SyncSender<()>,
  #[cfg(feature = "mio_06")]
  legacy_sender: mio_extras::channel::SyncSender<()>,
}

pub(crate) struct NotificationReceiver {
  receiver: std::sync::mpsc::Receiver<()>,
  #[cfg(feature = "mio_06")]
  legacy_receiver: mio_extras::channel::Receiver<()>,
}

pub(crate) fn notification_channel(capacity: usize) -> (NotificationSender, NotificationReceiver) {
  let (sender, receiver) = std::sync::mpsc::sync_channel(capacity);
  #[cfg(feature = "mio_06")]
  let (legacy_sender, legacy_receiver) = mio_extras::channel::sync_channel(capacity);
  (
    NotificationSender {
      sender,
      #[cfg(feature = "mio_06")]
      legacy_sender,
    },
    NotificationReceiver {
      receiver,
      #[cfg(feature = "mio_06")]
      legacy_receiver,
    },
  )
}

impl NotificationSender {
  pub(crate) fn try_send(&self, value: ()) -> Result<(), std::sync::mpsc::TrySendError<()>> {
    self.sender.try_send(value)?;
    #[cfg(feature = "mio_06")]
    let _ = self.legacy_sender.try_send(());
    Ok(())
  }
}

impl NotificationReceiver {
  pub(crate) fn try_recv(&self) -> Result<(), std::sync::mpsc::TryRecvError> {
    self.receiver.try_recv()
  }
}

#[cfg(feature = "mio_06")]
impl mio_06::Evented for NotificationReceiver {
  fn register(
    &self,
    poll: &mio_06::Poll,
    token: mio_06::Token,
    interest: mio_06::Ready,
    opts: mio_06::PollOpt,
  ) -> std::io::Result<()> {
    self.legacy_receiver.register(poll, token, interest, opts)
  }

  fn reregister(
    &self,
    poll: &mio_06::Poll,
    token: mio_06::Token,
    interest: mio_06::Ready,
    opts: mio_06::PollOpt,
  ) -> std::io::Result<()> {
    self.legacy_receiver.reregister(poll, token, interest, opts)
  }

  fn deregister(&self, poll: &mio_06::Poll) -> std::io::Result<()> {
    self.legacy_receiver.deregister(poll)
  }
}

#[cfg(test)]
mod tests {
  use std::time::Duration;

  use mio1::{event::Source, Events, Interest, Poll, Token};

  use super::*;

  fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd").map(|d| d.count()).unwrap_or(0)
  }

  // RADAR patch 15: a poll channel makes its socket pair only when registered with a poll.
  #[test]
  fn poll_channel_makes_sockets_only_when_registered_and_keeps_earlier_sends() {
    let (mut source, sender) = make_poll_channel().unwrap();
    assert!(!source.mio1.has_sockets());
    sender.send(); // nobody polls yet: remembered, no socket written
    assert!(!source.mio1.has_sockets());

    let mut poll = Poll::new().unwrap();
    let mut events = Events::with_capacity(4);
    source
      .register(poll.registry(), Token(7), Interest::READABLE)
      .unwrap();
    assert!(source.mio1.has_sockets());
    poll
      .poll(&mut events, Some(Duration::from_millis(500)))
      .unwrap();
    assert!(
      events.iter().any(|e| e.token() == Token(7)),
      "the send made before registering is seen"
    );
    source.drain();
    sender.send();
    poll
      .poll(&mut events, Some(Duration::from_millis(500)))
      .unwrap();
    assert!(events.iter().any(|e| e.token() == Token(7)));
    source.deregister(poll.registry()).unwrap();
  }

  #[test]
  fn poll_channels_nobody_registers_hold_no_descriptors() {
    let before = open_fds();
    let channels: Vec<_> = (0..200).map(|_| make_poll_channel().unwrap()).collect();
    for (_, s) in &channels {
      s.send();
    }
    // other tests of this binary open a few descriptors meanwhile; 200 channels used to take 400-800
    assert!(
      open_fds() < before + 50,
      "{} descriptors for 200 unregistered channels",
      open_fds() - before.min(open_fds())
    );
  }
}

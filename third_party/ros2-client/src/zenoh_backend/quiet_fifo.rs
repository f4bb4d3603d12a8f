//! A FIFO channel for Zenoh's callbacks that drops quietly what comes after its reader has gone (radar_ros
//! patch 22).
//!
//! Zenoh's own [`zenoh::handlers::FifoChannel`] logs `sending on a closed channel` at ERROR level for every
//! sample, query or reply it is handed after its receiver was dropped. A reader that stops reading is not an
//! error: a service call returns at its first answer while a second server's answer, or Zenoh's timeout reply
//! of the query, is still to come; a caller gives up waiting (a timeout of its own, a cancel, a program
//! stopping). A program that ends normally must log no error line, so those deliveries are dropped at TRACE.
//! Otherwise as Zenoh's FIFO: bounded to Zenoh's default capacity, a full channel blocks the delivering
//! thread.

use zenoh::handlers::{Callback, IntoHandler};

/// The capacity of Zenoh's default FIFO channel (`API_DATA_RECEPTION_CHANNEL_SIZE`).
const CAPACITY: usize = 256;

/// A FIFO channel handler whose deliveries after the receiver is dropped are dropped quietly.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct QuietFifo;

impl<T: Send + 'static> IntoHandler<T> for QuietFifo {
  type Handler = async_channel::Receiver<T>;

  fn into_handler(self) -> (Callback<T>, Self::Handler) {
    let (tx, rx) = async_channel::bounded(CAPACITY);
    let deliver = move |t: T| {
      if tx.send_blocking(t).is_err() {
        tracing::trace!("a delivery after its reader had gone, dropped");
      }
    };
    (Callback::from(deliver), rx)
  }
}

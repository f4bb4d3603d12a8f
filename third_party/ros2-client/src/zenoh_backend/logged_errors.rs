//! Tests only: the ERROR-level events this process logs through `tracing` (Zenoh logs through it), so a
//! test can assert that something logged none (radar_ros patch 22). A program that ends normally, or
//! stops because it was told to, must print no error line; Zenoh's own FIFO handler logs one for every
//! sample, query or reply delivered after its receiver was dropped.

use std::sync::{Mutex, Once};

use tracing::{
  Event, Level, Metadata, Subscriber,
  field::{Field, Visit},
  span,
};

static ERRORS: Mutex<Vec<String>> = Mutex::new(Vec::new());
static INSTALL: Once = Once::new();

/// Every ERROR event logged, as `target: fields`, once [`install`] ran.
struct Errors;

struct Fields(String);

impl Visit for Fields {
  fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
    self.0.push_str(&format!(" {}={value:?}", field.name()));
  }
}

impl Subscriber for Errors {
  fn enabled(&self, metadata: &Metadata<'_>) -> bool {
    *metadata.level() == Level::ERROR
  }
  fn new_span(&self, _: &span::Attributes<'_>) -> span::Id {
    span::Id::from_u64(1)
  }
  fn record(&self, _: &span::Id, _: &span::Record<'_>) {}
  fn record_follows_from(&self, _: &span::Id, _: &span::Id) {}
  fn event(&self, event: &Event<'_>) {
    let mut fields = Fields(String::new());
    event.record(&mut fields);
    let line = format!("{}:{}", event.metadata().target(), fields.0);
    ERRORS.lock().unwrap().push(line);
  }
  fn enter(&self, _: &span::Id) {}
  fn exit(&self, _: &span::Id) {}
}

/// Makes this process's `tracing` events go to the record (once per process; a test binary has one
/// global subscriber).
pub(crate) fn install() {
  INSTALL.call_once(|| {
    tracing::subscriber::set_global_default(Errors).expect("no other global tracing subscriber");
  });
}

/// The ERROR events logged so far by Zenoh's handlers (`zenoh::api::handlers::*`): deliveries into a
/// channel whose receiver was dropped.
pub(crate) fn handler_errors() -> Vec<String> {
  ERRORS
    .lock()
    .unwrap()
    .iter()
    .filter(|l| l.starts_with("zenoh::api::handlers"))
    .cloned()
    .collect()
}

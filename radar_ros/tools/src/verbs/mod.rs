//! One module per `radar` verb, each a function that [`crate::cli::run`] calls with the parsed arguments.

pub(crate) mod act;
pub(crate) mod cat;
pub(crate) mod connect;
pub(crate) mod graph;
pub(crate) mod inject;
pub(crate) mod ls;
pub(crate) mod record;
pub(crate) mod replay;
pub(crate) mod router;
pub(crate) mod verify;
pub(crate) mod watch;

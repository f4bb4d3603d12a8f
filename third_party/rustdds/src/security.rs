pub mod access_control;
pub mod authentication;
mod certificate;
pub mod config;
pub mod cryptographic;
pub mod logging;
mod private_key;
pub mod security_plugins;
pub mod types;

/// RADAR patch 64: the maps the security plugins look up for every submessage, payload and message they
/// encode or decode (handles by GUID, key materials by handle, kept session keys), hashed with foldhash
/// (seeded per process) instead of SipHash, which was a fifth of the secured hop's plugin time.
pub(crate) type FastHashMap<K, V> = std::collections::HashMap<K, V, foldhash::fast::RandomState>;
/// The set kind of [`FastHashMap`].
pub(crate) type FastHashSet<T> = std::collections::HashSet<T, foldhash::fast::RandomState>;

pub use types::*;
// export top-level plugin interfaces
pub use access_control::{
  access_control_builtin::AccessControlBuiltin, access_control_plugin::AccessControl,
};
pub use authentication::{
  authentication_builtin::AuthenticationBuiltin, authentication_plugin::Authentication,
};
pub use cryptographic::{cryptographic_builtin::CryptographicBuiltin, Cryptographic};

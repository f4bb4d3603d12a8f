//! The package's exceptions (`radar_ros._errors`), each a Rust type made once: a misspelt class does not
//! compile (they were looked up by name on every raise), and each carries what Python code may want to act on
//! as attributes, not only in its text.

use pyo3::prelude::*;

pyo3::import_exception!(radar_ros._errors, RadarError);
pyo3::import_exception!(radar_ros._errors, RadarTimeout);
pyo3::import_exception!(radar_ros._errors, NotFound);
pyo3::import_exception!(radar_ros._errors, PayloadTypeError);
pyo3::import_exception!(radar_ros._errors, InvalidArgument);
pyo3::import_exception!(radar_ros._errors, ComponentLost);

/// Raises the `radar_ros` exception for `e`: the class says its kind, the message what to do next, the
/// attributes the details (`NotFound.candidates`, `NotFound.waited`, `RadarTimeout.what`, `RadarTimeout.waited`,
/// ...).
pub(crate) fn to_py(e: radar_ros::Error) -> PyErr {
    use radar_ros::Error as E;
    let msg = e.report().to_string();
    let (err, attrs): (PyErr, Vec<(&str, Attr)>) = match e {
        E::Timeout { what, after } => (
            RadarTimeout::new_err(msg),
            vec![("what", Attr::Text(what)), ("waited", Attr::Seconds(after))],
        ),
        E::NotFound {
            name,
            kind,
            after,
            candidates,
        } => (
            NotFound::new_err(msg),
            vec![
                ("name", Attr::Text(name)),
                ("kind", Attr::Text(kind.into())),
                ("waited", Attr::Seconds(after)),
                ("candidates", Attr::Texts(candidates)),
            ],
        ),
        E::WrongKind { name, found, .. } => (
            NotFound::new_err(msg),
            vec![
                ("name", Attr::Text(name)),
                ("kind", Attr::Text(found.into())),
            ],
        ),
        E::Ambiguous { .. } => (NotFound::new_err(msg), vec![]),
        E::TypeMismatch { .. } | E::PayloadType { .. } => (PayloadTypeError::new_err(msg), vec![]),
        E::InvalidName { .. } | E::DuplicateName(_) | E::InvalidStatement(_) | E::Config { .. } => {
            (InvalidArgument::new_err(msg), vec![])
        }
        E::ComponentLost { .. } | E::Closed(_) => (ComponentLost::new_err(msg), vec![]),
        _ => (RadarError::new_err(msg), vec![]),
    };
    if !attrs.is_empty() {
        Python::attach(|py| {
            let value = err.value(py);
            for (name, attr) in attrs {
                let set = match attr {
                    Attr::Text(t) => value.setattr(name, t),
                    Attr::Texts(t) => value.setattr(name, t),
                    Attr::Seconds(d) => value.setattr(name, d.as_secs_f64()),
                };
                if let Err(e) = set {
                    tracing::warn!(error = %e, attribute = name, "could not set an exception's attribute");
                }
            }
        });
    }
    err
}

/// An exception attribute's value.
enum Attr {
    Text(String),
    Texts(Vec<String>),
    Seconds(std::time::Duration),
}

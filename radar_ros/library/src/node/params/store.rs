//! A component's parameters as rclcpp keeps a node's: declared with a descriptor (type, description, range,
//! read-only), set only to values the descriptor allows, listed by prefix and depth as `ros2 param list` asks.
//! Plain Rust, no DDS: `serve.rs` puts it on the ROS services.

use std::collections::BTreeMap;

use ros2_client::ParameterValue;

/// A parameter a component declares: its name, default value (which fixes its type), and what `ros2 param
/// describe` shows.
///
/// ```
/// use radar_ros::params::ParamDecl;
/// let period = ParamDecl::new("period", 0.5)
///     .description("seconds between counts")
///     .float_range(0.1, 10.0);
/// let limit = ParamDecl::new("limit", 10).integer_range(1, 100, 1).read_only();
/// # let _ = (period, limit);
/// ```
#[derive(Clone, Debug)]
#[must_use]
pub struct ParamDecl {
    pub(crate) name: String,
    pub(crate) default: ParameterValue,
    pub(crate) description: String,
    pub(crate) constraints: String,
    pub(crate) read_only: bool,
    pub(crate) range: Range,
}

/// A numeric parameter's allowed values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Range {
    Any,
    Integer { from: i64, to: i64, step: i64 },
    Float { from: f64, to: f64, step: f64 },
}

impl ParamDecl {
    /// A parameter `name` (tokens of letters, digits and `_` joined by dots) with this default value.
    pub fn new(name: &str, default: impl Into<ParamValue>) -> ParamDecl {
        ParamDecl {
            name: name.to_owned(),
            default: default.into().0,
            description: String::new(),
            constraints: String::new(),
            read_only: false,
            range: Range::Any,
        }
    }

    /// What it means (shown by `ros2 param describe`).
    pub fn description(mut self, text: &str) -> Self {
        self.description = text.to_owned();
        self
    }

    /// Constraints said in words, beyond a range.
    pub fn constraints(mut self, text: &str) -> Self {
        self.constraints = text.to_owned();
        self
    }

    /// Set once, at start (from its default or the command line); `ros2 param set` is refused.
    pub fn read_only(mut self) -> Self {
        self.read_only = true;
        self
    }

    /// An integer parameter's allowed values: `from..=to`, in steps of `step` from `from` (0: any step).
    pub fn integer_range(mut self, from: i64, to: i64, step: i64) -> Self {
        self.range = Range::Integer { from, to, step };
        self
    }

    /// A floating-point parameter's allowed values: `from..=to`.
    pub fn float_range(mut self, from: f64, to: f64) -> Self {
        self.range = Range::Float {
            from,
            to,
            step: 0.0,
        };
        self
    }
}

/// A value a parameter can take: from `bool`, `i64`/`i32`, `f64`, `&str`/`String`, and vectors of those.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamValue(pub(crate) ParameterValue);

macro_rules! param_from {
    ($($t:ty => $v:ident $(as $c:ty)?),* $(,)?) => {$(
        impl From<$t> for ParamValue {
            fn from(x: $t) -> ParamValue {
                ParamValue(ParameterValue::$v(x $(as $c)?))
            }
        }
    )*};
}
param_from!(bool => Boolean, i64 => Integer, i32 => Integer as i64, u32 => Integer as i64, f64 => Double,
    String => String, Vec<bool> => BooleanArray, Vec<i64> => IntegerArray, Vec<f64> => DoubleArray,
    Vec<String> => StringArray, Vec<u8> => ByteArray);

impl From<&str> for ParamValue {
    fn from(s: &str) -> ParamValue {
        ParamValue(ParameterValue::String(s.to_owned()))
    }
}

impl From<ParameterValue> for ParamValue {
    fn from(v: ParameterValue) -> ParamValue {
        ParamValue(v)
    }
}

/// The declared parameters of one node and their values.
#[derive(Debug, Default)]
pub(crate) struct Store {
    decls: BTreeMap<String, ParamDecl>,
    values: BTreeMap<String, ParameterValue>,
}

fn kind(v: &ParameterValue) -> std::mem::Discriminant<ParameterValue> {
    std::mem::discriminant(v)
}

/// The ROS name of a value's type, for messages.
pub(crate) fn type_name(v: &ParameterValue) -> &'static str {
    use ParameterValue as P;
    match v {
        P::NotSet => "not set",
        P::Boolean(_) => "bool",
        P::Integer(_) => "integer",
        P::Double(_) => "double",
        P::String(_) => "string",
        P::ByteArray(_) => "byte_array",
        P::BooleanArray(_) => "bool_array",
        P::IntegerArray(_) => "integer_array",
        P::DoubleArray(_) => "double_array",
        P::StringArray(_) => "string_array",
    }
}

impl Store {
    /// Declares `d` with the value `given` (a command-line override) if any, else its default. Refuses a
    /// bad name, a second declaration, an override of another type, or a value outside the range.
    pub(crate) fn declare(
        &mut self,
        d: ParamDecl,
        given: Option<ParameterValue>,
    ) -> Result<(), String> {
        if !crate::node::ros_args::valid_param_name(&d.name) {
            return Err(format!(
                "{:?} is not a parameter name (tokens of letters, digits and _ joined by dots)",
                d.name
            ));
        }
        if self.decls.contains_key(&d.name) {
            return Err(format!("the parameter {} is declared twice", d.name));
        }
        if matches!(d.default, ParameterValue::NotSet) {
            return Err(format!(
                "the parameter {} needs a default value (its type)",
                d.name
            ));
        }
        let value = match given {
            Some(v) => {
                if kind(&v) != kind(&d.default) {
                    return Err(format!(
                        "the parameter {} is of type {}, but the command line gives a value of type {} ({v:?})",
                        d.name,
                        type_name(&d.default),
                        type_name(&v)
                    ));
                }
                check_range(&d, &v)?;
                v
            }
            None => {
                check_range(&d, &d.default)?;
                d.default.clone()
            }
        };
        self.values.insert(d.name.clone(), value);
        self.decls.insert(d.name.clone(), d);
        Ok(())
    }

    /// The value of `name`.
    pub(crate) fn get(&self, name: &str) -> Option<&ParameterValue> {
        self.values.get(name)
    }

    /// Whether `name` may be set to `v`, and why not.
    pub(crate) fn check(&self, name: &str, v: &ParameterValue) -> Result<(), String> {
        let d = self
            .decls
            .get(name)
            .ok_or_else(|| format!("parameter {name} is not declared"))?;
        if d.read_only {
            return Err(format!("parameter {name} is read-only"));
        }
        if kind(v) != kind(&d.default) {
            return Err(format!(
                "parameter {name} is of type {}, not {}",
                type_name(&d.default),
                type_name(v)
            ));
        }
        check_range(d, v)
    }

    /// Sets `name` to `v` if [`Store::check`] allows it; whether the value changed.
    pub(crate) fn set(&mut self, name: &str, v: ParameterValue) -> Result<bool, String> {
        self.check(name, &v)?;
        Ok(self.values.insert(name.to_owned(), v.clone()) != Some(v))
    }

    /// Sets all or none.
    pub(crate) fn set_all(&mut self, params: Vec<(String, ParameterValue)>) -> Result<(), String> {
        for (n, v) in &params {
            self.check(n, v)?;
        }
        for (n, v) in params {
            self.values.insert(n, v);
        }
        Ok(())
    }

    /// The declaration of `name`.
    pub(crate) fn decl(&self, name: &str) -> Option<&ParamDecl> {
        self.decls.get(name)
    }

    /// Every parameter with its value.
    pub(crate) fn all(&self) -> impl Iterator<Item = (&String, &ParameterValue)> {
        self.values.iter()
    }

    /// What `ros2 param list` asks, by rclcpp's rule (`NodeParameters::list_parameters`): with no prefixes the
    /// names with fewer than `depth` dots, else the names equal to a prefix or below it with fewer than `depth`
    /// dots after it (the one after the prefix counts); `depth` 0 is any depth. With the dotted prefixes of
    /// the names listed.
    pub(crate) fn list(&self, prefixes: &[String], depth: u64) -> (Vec<String>, Vec<String>) {
        let mut names = Vec::new();
        let mut found_prefixes = std::collections::BTreeSet::new();
        for name in self.values.keys() {
            let dots = name.matches('.').count() as u64;
            let wanted = if prefixes.is_empty() {
                depth == 0 || dots < depth
            } else {
                prefixes.iter().any(|p| {
                    name == p
                        || (name.starts_with(p.as_str())
                            && name[p.len()..].starts_with('.')
                            && (depth == 0
                                || (name[p.len()..].matches('.').count() as u64) < depth))
                })
            };
            if wanted {
                names.push(name.clone());
                if let Some((prefix, _)) = name.rsplit_once('.') {
                    found_prefixes.insert(prefix.to_owned());
                }
            }
        }
        (names, found_prefixes.into_iter().collect())
    }
}

fn check_range(d: &ParamDecl, v: &ParameterValue) -> Result<(), String> {
    match (d.range, v) {
        (Range::Integer { from, to, step }, ParameterValue::Integer(x)) => {
            if *x < from || *x > to {
                return Err(format!(
                    "parameter {} must be in [{from}, {to}], not {x}",
                    d.name
                ));
            }
            if step > 0 && (*x - from) % step != 0 && *x != to {
                return Err(format!(
                    "parameter {} goes in steps of {step} from {from}; {x} is not one",
                    d.name
                ));
            }
            Ok(())
        }
        (Range::Float { from, to, .. }, ParameterValue::Double(x)) => {
            if !(*x >= from && *x <= to) {
                return Err(format!(
                    "parameter {} must be in [{from}, {to}], not {x}",
                    d.name
                ));
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ParameterValue as V;

    fn store() -> Store {
        let mut s = Store::default();
        s.declare(ParamDecl::new("period", 0.5).float_range(0.1, 10.0), None)
            .unwrap();
        s.declare(ParamDecl::new("limit", 10).integer_range(0, 100, 5), None)
            .unwrap();
        s.declare(ParamDecl::new("name", "count").read_only(), None)
            .unwrap();
        s.declare(ParamDecl::new("gains.p", 1.0), None).unwrap();
        s.declare(ParamDecl::new("gains.inner.i", 0.1), None)
            .unwrap();
        s
    }

    #[test]
    fn values_follow_type_range_and_read_only() {
        let mut s = store();
        assert_eq!(s.set("period", V::Double(2.0)), Ok(true));
        assert_eq!(s.set("period", V::Double(2.0)), Ok(false), "unchanged");
        assert!(s
            .set("period", V::Double(20.0))
            .unwrap_err()
            .contains("[0.1, 10]"));
        assert!(s
            .set("period", V::Integer(2))
            .unwrap_err()
            .contains("of type double, not integer"));
        assert!(s
            .set("limit", V::Integer(7))
            .unwrap_err()
            .contains("steps of 5"));
        assert_eq!(s.set("limit", V::Integer(100)), Ok(true));
        assert!(s
            .set("name", V::String("x".into()))
            .unwrap_err()
            .contains("read-only"));
        assert!(s
            .set("nope", V::Integer(1))
            .unwrap_err()
            .contains("not declared"));
        // all or nothing
        assert!(s
            .set_all(vec![
                ("period".into(), V::Double(3.0)),
                ("limit".into(), V::Integer(1000)),
            ])
            .is_err());
        assert_eq!(s.get("period"), Some(&V::Double(2.0)));
    }

    #[test]
    fn declarations_take_command_line_values_of_their_type_only() {
        let mut s = Store::default();
        s.declare(ParamDecl::new("period", 0.5), Some(V::Double(0.25)))
            .unwrap();
        assert_eq!(s.get("period"), Some(&V::Double(0.25)));
        let e = s
            .declare(ParamDecl::new("limit", 10), Some(V::String("ten".into())))
            .unwrap_err();
        assert!(e.contains("integer") && e.contains("string"), "{e}");
        let e = s
            .declare(
                ParamDecl::new("rate", 1.0).float_range(0.0, 2.0),
                Some(V::Double(5.0)),
            )
            .unwrap_err();
        assert!(e.contains("[0, 2]"), "{e}");
        assert!(
            s.declare(ParamDecl::new("period", 0.5), None).is_err(),
            "twice"
        );
        assert!(s.declare(ParamDecl::new("bad name", 0.5), None).is_err());
    }

    #[test]
    fn listing_follows_prefixes_and_depth_as_rclcpp() {
        let s = store();
        let (names, prefixes) = s.list(&[], 0);
        assert_eq!(
            names,
            ["gains.inner.i", "gains.p", "limit", "name", "period"]
        );
        assert_eq!(prefixes, ["gains", "gains.inner"]);
        let (names, _) = s.list(&[], 1);
        assert_eq!(names, ["limit", "name", "period"]);
        // the dot after the prefix counts, as in rclcpp
        let (names, _) = s.list(&["gains".into()], 1);
        assert!(names.is_empty());
        let (names, _) = s.list(&["gains".into()], 2);
        assert_eq!(names, ["gains.p"]);
        let (names, _) = s.list(&["gains".into()], 0);
        assert_eq!(names, ["gains.inner.i", "gains.p"]);
    }
}

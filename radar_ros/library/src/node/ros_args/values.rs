//! Parameter values and parameter files as rcl reads them: `-p name:=value` (YAML, with rcl's words for
//! booleans), `--params-file` (`/**:`, `node:`, `/ns/node:` keys with `ros__parameters:`), and which node a
//! file's key applies to.

use super::{bad, FileEntries, ParameterValue};
use crate::error::Result;

/// Whether `name` is a parameter name: tokens of letters, digits and `_` joined by dots (`gains.p`).
pub(crate) fn valid_param_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .split('.')
            .all(|t| !t.is_empty() && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
}

pub(super) fn check_param_name(name: &str, arg: &str) -> Result<()> {
    if valid_param_name(name) {
        Ok(())
    } else {
        Err(bad(
            arg,
            "a parameter name is tokens of letters, digits and _ joined by dots",
        ))
    }
}

/// A `-p` value as rcl reads it: YAML, with rcl's words for booleans.
pub(super) fn parse_value(text: &str, arg: &str) -> Result<ParameterValue> {
    let v: yaml_serde::Value =
        yaml_serde::from_str(text).map_err(|e| bad(arg, format!("the value is not YAML: {e}")))?;
    // an unquoted yes/on/y... is a boolean for rcl (YAML 1.1), a string for YAML 1.2
    if let yaml_serde::Value::String(s) = &v {
        if !text.trim_start().starts_with(['"', '\'']) {
            if let Some(b) = rcl_bool(s) {
                return Ok(ParameterValue::Boolean(b));
            }
        }
    }
    to_value(&v).map_err(|why| bad(arg, why))
}

fn rcl_bool(s: &str) -> Option<bool> {
    match s {
        "y" | "Y" | "yes" | "Yes" | "YES" | "true" | "True" | "TRUE" | "on" | "On" | "ON" => {
            Some(true)
        }
        "n" | "N" | "no" | "No" | "NO" | "false" | "False" | "FALSE" | "off" | "Off" | "OFF" => {
            Some(false)
        }
        _ => None,
    }
}

fn to_value(v: &yaml_serde::Value) -> std::result::Result<ParameterValue, String> {
    use yaml_serde::Value as Y;
    let scalar = |v: &Y| -> std::result::Result<ParameterValue, String> {
        Ok(match v {
            Y::Bool(b) => ParameterValue::Boolean(*b),
            Y::Number(n) if n.is_i64() => ParameterValue::Integer(n.as_i64().unwrap_or_default()),
            Y::Number(n) => ParameterValue::Double(n.as_f64().unwrap_or(f64::NAN)),
            Y::String(s) => ParameterValue::String(s.clone()),
            Y::Null => return Err("a parameter value cannot be empty (null)".into()),
            _ => {
                return Err("a parameter value is a scalar or a list of scalars of one type".into())
            }
        })
    };
    match v {
        Y::Sequence(items) => {
            let items = items
                .iter()
                .map(scalar)
                .collect::<std::result::Result<Vec<_>, _>>()?;
            let all = |f: fn(&ParameterValue) -> bool| items.iter().all(f);
            use ParameterValue as P;
            Ok(if items.is_empty() {
                return Err("an empty list has no type; give at least one element".into());
            } else if all(|p| matches!(p, P::Boolean(_))) {
                P::BooleanArray(
                    items
                        .iter()
                        .map(|p| matches!(p, P::Boolean(true)))
                        .collect(),
                )
            } else if all(|p| matches!(p, P::Integer(_))) {
                P::IntegerArray(
                    items
                        .iter()
                        .map(|p| if let P::Integer(i) = p { *i } else { 0 })
                        .collect(),
                )
            } else if all(|p| matches!(p, P::Double(_))) {
                P::DoubleArray(
                    items
                        .iter()
                        .map(|p| if let P::Double(d) = p { *d } else { 0.0 })
                        .collect(),
                )
            } else if all(|p| matches!(p, P::String(_))) {
                P::StringArray(
                    items
                        .iter()
                        .map(|p| {
                            if let P::String(s) = p {
                                s.clone()
                            } else {
                                String::new()
                            }
                        })
                        .collect(),
                )
            } else {
                return Err(
                    "a list's elements must all have one type (as in rcl: write [1.0, 2.5], not [1, 2.5])"
                        .into(),
                );
            })
        }
        other => scalar(other),
    }
}

/// A parameters file: `{node pattern: {ros__parameters: {name: value, group: {name: value}}}}`.
pub(super) fn read_params_file(path: &str) -> Result<FileEntries> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| bad(path, format!("--params-file cannot be read: {e}")))?;
    let doc: yaml_serde::Value = yaml_serde::from_str(&text)
        .map_err(|e| bad(path, format!("the parameters file is not YAML: {e}")))?;
    let yaml_serde::Value::Mapping(nodes) = doc else {
        return Err(bad(
            path,
            "a parameters file maps node names to `ros__parameters:` (e.g. `/**:\\n  ros__parameters:\\n    period: 0.5`)",
        ));
    };
    let mut out = Vec::new();
    for (key, body) in nodes {
        let key = key.as_str().unwrap_or_default().to_owned();
        let pattern = absolute(&key);
        let params = body.get("ros__parameters").ok_or_else(|| {
            bad(
                path,
                format!("the entry {key:?} has no `ros__parameters:` under it"),
            )
        })?;
        let mut flat = Vec::new();
        flatten(params, "", &mut flat).map_err(|why| bad(path, format!("{key}: {why}")))?;
        out.push((pattern, flat));
    }
    Ok(out)
}

fn flatten(
    v: &yaml_serde::Value,
    prefix: &str,
    out: &mut Vec<(String, ParameterValue)>,
) -> std::result::Result<(), String> {
    match v {
        yaml_serde::Value::Mapping(m) => {
            for (k, v) in m {
                let k = match k {
                    yaml_serde::Value::String(s) => s.clone(),
                    other => yaml_serde::to_string(other)
                        .unwrap_or_default()
                        .trim()
                        .to_owned(),
                };
                let name = if prefix.is_empty() {
                    k
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(v, &name, out)?;
            }
            Ok(())
        }
        other => {
            let value = to_value(other).map_err(|e| format!("{prefix}: {e}"))?;
            out.push((prefix.to_owned(), value));
            Ok(())
        }
    }
}

/// A node key as rcl reads it: `node` is `/node`.
pub(super) fn absolute(key: &str) -> String {
    if key.starts_with('/') {
        key.to_owned()
    } else {
        format!("/{key}")
    }
}

/// Whether the params-file key `pattern` (absolute; `*` one token, `**` any number) names the node `fq`.
pub(super) fn node_matches(pattern: &str, fq: &str) -> bool {
    fn go(p: &[&str], n: &[&str]) -> bool {
        match p.split_first() {
            None => n.is_empty(),
            Some((&"**", rest)) => (0..=n.len()).any(|k| go(rest, &n[k..])),
            Some((t, rest)) => n
                .split_first()
                .is_some_and(|(h, nrest)| (*t == "*" || t == h) && go(rest, nrest)),
        }
    }
    let p: Vec<&str> = pattern.split('/').filter(|s| !s.is_empty()).collect();
    let n: Vec<&str> = fq.split('/').filter(|s| !s.is_empty()).collect();
    go(&p, &n)
}

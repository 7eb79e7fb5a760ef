//! The parameter services of the robot's ROS 2 node, as every rclcpp node serves them
//! (`~/list_parameters`, `~/get_parameters`, `~/set_parameters`,
//! `~/set_parameters_atomically`, `~/describe_parameters`, `~/get_parameter_types`), mapped
//! onto orsa's live parameters: `ros2 param list /orsa` lists every component's parameters
//! by their orsa names (`centerfollow.v_max_m_s`), and `ros2 param set` goes through the
//! component's `param` service, checked by the component as `orsa param set` is.
//!
//! Values map as JSON does: a bool, an integer, a float, a string, and arrays of one of those.
//! A parameter whose value is none of those (a table in an array, a mixed array) reads as a
//! string holding its JSON. A set with no value (`NOT_SET`), a float that is not finite, or a
//! value the component refuses, is refused with the reason, and nothing else changes.

use crate::system::live_params::{ParamDirectory, ParamError};
use orsa_actors::param::Param;
use orsa_net::ros2::rcl::{
    DescribeParameters, DescribeParametersResponse, GetParameterTypes, GetParameterTypesResponse,
    GetParameters, GetParametersResponse, ListParameters, ListParametersRequest, ListParametersResponse,
    ListParametersResult, ParameterDescriptor, ParameterValue, SetParameters, SetParametersAtomically,
    SetParametersAtomicallyResponse, SetParametersResponse, SetParametersResult, parameter_type as ty,
};
use orsa_net::ros2::{Answer, Ros2Node, Ros2Service};
use serde_json::Value;

/// The node's parameter services; served while this lives.
pub struct ParamServices {
    _services: Vec<Ros2Service>,
}

impl ParamServices {
    /// Serves the parameters of `directory`'s components on `node`.
    pub async fn serve(node: &Ros2Node, directory: ParamDirectory) -> anyhow::Result<Self> {
        let mut services = Vec::new();
        let d = directory.clone();
        services.push(
            node.serve::<ListParameters>("~/list_parameters", move |req| -> Answer<ListParametersResponse> {
                let d = d.clone();
                Box::pin(async move {
                    let (all, _) = d.get_all().await;
                    ListParametersResponse { result: list(all.iter().map(|p| p.name.as_str()), &req) }
                })
            })
            .await?,
        );
        let d = directory.clone();
        services.push(
            node.serve::<GetParameters>("~/get_parameters", move |req| -> Answer<GetParametersResponse> {
                let d = d.clone();
                Box::pin(async move {
                    let found = lookup(&d, req.names).await;
                    GetParametersResponse {
                        values: found
                            .iter()
                            .map(|p| p.as_ref().map_or_else(ParameterValue::default, |p| to_ros(&p.value)))
                            .collect(),
                    }
                })
            })
            .await?,
        );
        let d = directory.clone();
        services.push(
            node.serve::<SetParameters>("~/set_parameters", move |req| -> Answer<SetParametersResponse> {
                let d = d.clone();
                Box::pin(async move {
                    let mut results = Vec::with_capacity(req.parameters.len());
                    for p in req.parameters {
                        results.push(set(&d, &p.name, &p.value).await);
                    }
                    SetParametersResponse { results }
                })
            })
            .await?,
        );
        let d = directory.clone();
        services.push(
            node.serve::<SetParametersAtomically>(
                "~/set_parameters_atomically",
                move |req| -> Answer<SetParametersAtomicallyResponse> {
                    let d = d.clone();
                    Box::pin(async move {
                        // One parameter is set atomically by its component; several live in
                        // components that cannot take them as one transaction.
                        let result = match req.parameters.as_slice() {
                            [one] => set(&d, &one.name, &one.value).await,
                            [] => SetParametersResult { successful: true, reason: String::new() },
                            more => SetParametersResult {
                                successful: false,
                                reason: format!(
                                    "orsa cannot set {} parameters as one: each is its component's; \
                                     nothing was set (use set_parameters)",
                                    more.len()
                                ),
                            },
                        };
                        SetParametersAtomicallyResponse { result }
                    })
                },
            )
            .await?,
        );
        let d = directory.clone();
        services.push(
            node.serve::<DescribeParameters>(
                "~/describe_parameters",
                move |req| -> Answer<DescribeParametersResponse> {
                    let d = d.clone();
                    Box::pin(async move {
                        let names = req.names.clone();
                        let found = lookup(&d, req.names).await;
                        let descriptors = names
                            .into_iter()
                            .zip(found)
                            .map(|(name, p)| match p {
                                Some(p) => ParameterDescriptor {
                                    kind: to_ros(&p.value).kind,
                                    read_only: p.fixed,
                                    additional_constraints: if p.fixed {
                                        "read only when the component starts: set it in the config file"
                                            .into()
                                    } else {
                                        "checked by its component as its config file is".into()
                                    },
                                    name,
                                    ..Default::default()
                                },
                                None => ParameterDescriptor { name, ..Default::default() },
                            })
                            .collect();
                        DescribeParametersResponse { descriptors }
                    })
                },
            )
            .await?,
        );
        let d = directory;
        services.push(
            node.serve::<GetParameterTypes>(
                "~/get_parameter_types",
                move |req| -> Answer<GetParameterTypesResponse> {
                    let d = d.clone();
                    Box::pin(async move {
                        let found = lookup(&d, req.names).await;
                        GetParameterTypesResponse {
                            types: found
                                .iter()
                                .map(|p| p.as_ref().map_or(ty::NOT_SET, |p| to_ros(&p.value).kind))
                                .collect(),
                        }
                    })
                },
            )
            .await?,
        );
        Ok(ParamServices { _services: services })
    }
}

/// Each of `names`' parameter, if it is one (not a table, not unknown), asked all at once.
async fn lookup(d: &ParamDirectory, names: Vec<String>) -> Vec<Option<Param>> {
    let answers = futures::future::join_all(names.iter().map(|n| d.get(n))).await;
    names
        .iter()
        .zip(answers)
        .map(|(name, a)| a.ok().and_then(|ps| ps.into_iter().find(|p| p.name == *name)))
        .collect()
}

/// Sets `name` to `value`: whether it was set, and why not.
async fn set(d: &ParamDirectory, name: &str, value: &ParameterValue) -> SetParametersResult {
    let refused = |reason: String| {
        tracing::warn!("ROS 2 set_parameters: {name} refused: {reason}");
        SetParametersResult { successful: false, reason }
    };
    let json = match from_ros(value) {
        Ok(v) => v,
        Err(why) => return refused(format!("{name}: {why}")),
    };
    match d.set(name, json).await {
        Ok(_) => SetParametersResult { successful: true, reason: String::new() },
        Err(ParamError::Refused { reason, .. }) => refused(reason),
        Err(e) => refused(e.to_string()),
    }
}

/// rclcpp's `list_parameters`: every name (no prefixes) or those under a prefix, down to
/// `depth` levels (0: all), with the prefixes of the names listed.
pub(crate) fn list<'a>(
    names: impl Iterator<Item = &'a str>,
    req: &ListParametersRequest,
) -> ListParametersResult {
    let depth = req.depth;
    let within = |rest: &str| depth == 0 || (rest.matches('.').count() as u64) < depth;
    let mut out = ListParametersResult::default();
    for name in names {
        let wanted = if req.prefixes.is_empty() {
            within(name)
        } else {
            req.prefixes.iter().any(|prefix| {
                name == prefix
                    || name
                        .strip_prefix(prefix.as_str())
                        .and_then(|r| r.strip_prefix('.'))
                        .is_some_and(within)
            })
        };
        if !wanted {
            continue;
        }
        out.names.push(name.to_string());
        if let Some((prefix, _)) = name.rsplit_once('.')
            && !out.prefixes.iter().any(|p| p == prefix)
        {
            out.prefixes.push(prefix.to_string());
        }
    }
    out
}

/// A JSON value as a ROS parameter value (see the module's documentation).
pub(crate) fn to_ros(value: &Value) -> ParameterValue {
    let mut v = ParameterValue::default();
    let int = |n: &Value| n.as_i64();
    match value {
        Value::Bool(b) => (v.kind, v.bool_value) = (ty::BOOL, *b),
        Value::Number(n) if n.is_i64() => (v.kind, v.integer_value) = (ty::INTEGER, n.as_i64().unwrap_or(0)),
        Value::Number(n) => (v.kind, v.double_value) = (ty::DOUBLE, n.as_f64().unwrap_or(f64::NAN)),
        Value::String(s) => (v.kind, v.string_value) = (ty::STRING, s.clone()),
        Value::Array(items) if !items.is_empty() && items.iter().all(Value::is_boolean) => {
            v.kind = ty::BOOL_ARRAY;
            v.bool_array_value = items.iter().filter_map(Value::as_bool).collect();
        }
        Value::Array(items) if !items.is_empty() && items.iter().all(|i| int(i).is_some()) => {
            v.kind = ty::INTEGER_ARRAY;
            v.integer_array_value = items.iter().filter_map(int).collect();
        }
        Value::Array(items) if items.iter().all(Value::is_number) => {
            v.kind = ty::DOUBLE_ARRAY;
            v.double_array_value = items.iter().filter_map(Value::as_f64).collect();
        }
        Value::Array(items) if items.iter().all(Value::is_string) => {
            v.kind = ty::STRING_ARRAY;
            v.string_array_value = items.iter().filter_map(|s| s.as_str().map(str::to_string)).collect();
        }
        other => (v.kind, v.string_value) = (ty::STRING, other.to_string()),
    }
    v
}

/// A ROS parameter value as JSON, or why it cannot be one.
pub(crate) fn from_ros(v: &ParameterValue) -> Result<Value, String> {
    let finite = |x: f64| {
        serde_json::Number::from_f64(x)
            .map(Value::Number)
            .ok_or_else(|| format!("{x} is not a finite number"))
    };
    Ok(match v.kind {
        ty::NOT_SET => return Err("a parameter cannot be unset".into()),
        ty::BOOL => Value::Bool(v.bool_value),
        ty::INTEGER => Value::from(v.integer_value),
        ty::DOUBLE => finite(v.double_value)?,
        ty::STRING => Value::String(v.string_value.clone()),
        ty::BYTE_ARRAY => Value::from(v.byte_array_value.clone()),
        ty::BOOL_ARRAY => Value::from(v.bool_array_value.clone()),
        ty::INTEGER_ARRAY => Value::from(v.integer_array_value.clone()),
        ty::DOUBLE_ARRAY => {
            Value::Array(v.double_array_value.iter().map(|x| finite(*x)).collect::<Result<_, _>>()?)
        }
        ty::STRING_ARRAY => Value::from(v.string_array_value.clone()),
        other => return Err(format!("parameter type {other} is not one of ROS 2's (0..=9)")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(prefixes: &[&str], depth: u64) -> ListParametersRequest {
        ListParametersRequest { prefixes: prefixes.iter().map(|s| s.to_string()).collect(), depth }
    }

    #[test]
    fn listing_follows_rclcpp_prefixes_and_depth() {
        let names =
            ["wallfollow.loops.k_alpha", "wallfollow.v_max_m_s", "centerfollow.v_max_m_s", "wallfollowx.a"];
        let all = list(names.iter().copied(), &req(&[], 0));
        assert_eq!(all.names.len(), 4);
        assert_eq!(all.prefixes, ["wallfollow.loops", "wallfollow", "centerfollow", "wallfollowx"]);
        let wf = list(names.iter().copied(), &req(&["wallfollow"], 0));
        assert_eq!(wf.names, ["wallfollow.loops.k_alpha", "wallfollow.v_max_m_s"]);
        let shallow = list(names.iter().copied(), &req(&["wallfollow"], 1));
        assert_eq!(shallow.names, ["wallfollow.v_max_m_s"]);
        assert!(list(names.iter().copied(), &req(&[], 1)).names.is_empty(), "every name has a dot");
    }

    #[test]
    fn values_map_both_ways_and_what_cannot_be_set_is_said() {
        for json in [
            serde_json::json!(true),
            serde_json::json!(3),
            serde_json::json!(0.25),
            serde_json::json!("left"),
            serde_json::json!([1, 2]),
            serde_json::json!([0.5, 1.0]),
            serde_json::json!(["a", "b"]),
            serde_json::json!([true]),
        ] {
            assert_eq!(from_ros(&to_ros(&json)).as_ref(), Ok(&json), "{json}");
        }
        assert_eq!(to_ros(&serde_json::json!([1, 2.5])).kind, ty::DOUBLE_ARRAY);
        let table = to_ros(&serde_json::json!([{ "x": 1 }]));
        assert_eq!((table.kind, table.string_value.as_str()), (ty::STRING, r#"[{"x":1}]"#));
        assert!(from_ros(&ParameterValue::default()).expect_err("refused").contains("unset"));
        let nan = ParameterValue { kind: ty::DOUBLE, double_value: f64::NAN, ..Default::default() };
        assert!(from_ros(&nan).expect_err("refused").contains("not a finite"));
        let odd = ParameterValue { kind: 42, ..Default::default() };
        assert!(from_ros(&odd).expect_err("refused").contains("42"));
    }
}

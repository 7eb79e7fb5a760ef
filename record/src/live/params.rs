//! Live parameters over the Foxglove WebSocket protocol: the seam.
//!
//! Whatever holds a system's live parameters implements [`LiveParams`] (values as JSON); a
//! live server given one ([`LiveView::start`](super::LiveView::start)) says it has parameters
//! and answers `getParameters` and `setParameters` through [`ParamBridge`], the SDK's
//! [`ParameterHandler`]. A value the store refuses (wrong type, out of range, unknown name) is
//! left unset and the client is sent an error status naming the parameter and why.

use crate::system::live_params::ParamDirectory;
use foxglove::websocket::{
    AnyClient, GetParametersResponder, Parameter, ParameterHandler, ParameterType, ParameterValue,
    SetParametersResponder,
};
use futures::future::BoxFuture;
use serde_json::Value;
use std::sync::{Arc, OnceLock};

/// A system's live parameters, by name, as JSON values.
pub trait LiveParams: Send + Sync {
    /// The named parameters' values, or every parameter's if `names` is empty; a name that
    /// is not a parameter is left out.
    fn get(&self, names: Vec<String>) -> BoxFuture<'static, Vec<(String, Value)>>;

    /// Sets parameter `name` to `value`: the value now in force, or why it was refused
    /// (unknown name, wrong type, out of range), in words for the user.
    fn set(&self, name: String, value: Value) -> BoxFuture<'static, Result<Value, SetError>>;

    /// Whether a change to parameter `name` reaches the live server as it happens (a
    /// component of this process, whose changes its tap sees), so that the server need not
    /// read it again to see it change.
    fn reports_changes(&self, _name: &str) -> bool {
        false
    }
}

/// Why a [`LiveParams`] refused a set: whatever error its backend gives (a component's
/// [`ParamError`](crate::system::live_params::ParamError), a system not up yet, ...), shown to
/// the user as it displays.
pub type SetError = Box<dyn std::error::Error + Send + Sync>;

/// The components' own parameters, through their `param` services: what a set does is what
/// `orsa param set` does (checked by the component as its config file is).
impl LiveParams for ParamDirectory {
    fn get(&self, names: Vec<String>) -> BoxFuture<'static, Vec<(String, Value)>> {
        let directory = self.clone();
        Box::pin(async move {
            if names.is_empty() {
                return directory.get_all().await.0.into_iter().map(|p| (p.name, p.value)).collect();
            }
            // Each component asked once, for all its parameters, and all at once: an
            // unreachable component costs one timeout, a panel that asks for sixty parameters
            // three queries.
            let mut components: Vec<&str> =
                names.iter().map(|n| crate::system::live_params::split_name(n).0).collect();
            components.sort_unstable();
            components.dedup();
            let answers = futures::future::join_all(components.iter().map(|c| directory.get(c))).await;
            let found: std::collections::HashMap<String, Value> =
                answers.into_iter().filter_map(Result::ok).flatten().map(|p| (p.name, p.value)).collect();
            // In the order asked; a name that is no parameter (a table, a typo) is left out.
            names.into_iter().filter_map(|n| found.get(&n).cloned().map(|v| (n, v))).collect()
        })
    }

    fn set(&self, name: String, value: Value) -> BoxFuture<'static, Result<Value, SetError>> {
        let directory = self.clone();
        Box::pin(async move { directory.set(&name, value).await.map(|p| p.value).map_err(SetError::from) })
    }

    fn reports_changes(&self, name: &str) -> bool {
        self.is_local(crate::system::live_params::split_name(name).0)
    }
}

/// The parameters of a system that is not up yet (the live server starts before the run):
/// answered once [`Pending::ready`] is called.
#[derive(Debug, Clone, Default)]
pub struct Pending(Arc<OnceLock<ParamDirectory>>);

impl Pending {
    /// The system is up: its parameters are `directory`'s.
    pub fn ready(&self, directory: ParamDirectory) {
        let _ = self.0.set(directory);
    }
}

impl LiveParams for Pending {
    fn get(&self, names: Vec<String>) -> BoxFuture<'static, Vec<(String, Value)>> {
        match self.0.get() {
            Some(d) => LiveParams::get(d, names),
            None => Box::pin(async { Vec::new() }),
        }
    }

    fn set(&self, name: String, value: Value) -> BoxFuture<'static, Result<Value, SetError>> {
        match self.0.get() {
            Some(d) => LiveParams::set(d, name, value),
            None => Box::pin(async { Err(SetError::from("the system is not up yet")) }),
        }
    }

    fn reports_changes(&self, name: &str) -> bool {
        self.0.get().is_some_and(|d| LiveParams::reports_changes(d, name))
    }
}

/// Answers a live server's parameter requests from a [`LiveParams`], on the server's runtime
/// (the components answer asynchronously; the server is never held while they do).
pub struct ParamBridge {
    params: Arc<dyn LiveParams>,
    runtime: tokio::runtime::Handle,
    /// Where the values a set applied are pushed to the clients subscribed to them.
    updates: Option<Arc<super::Shared>>,
}

impl std::fmt::Debug for ParamBridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ParamBridge")
    }
}

impl ParamBridge {
    /// Answers from `params`, on `runtime`.
    pub fn new(params: Arc<dyn LiveParams>, runtime: tokio::runtime::Handle) -> Self {
        ParamBridge { params, runtime, updates: None }
    }

    /// The same, pushing the values every set applies to the clients of the server `shared`
    /// belongs to that subscribed to them (the client that set them included, as the protocol
    /// has it). A component of another process changes no value this server would otherwise
    /// see.
    pub(crate) fn publishing(mut self, shared: Arc<super::Shared>) -> Self {
        self.updates = Some(shared);
        self
    }

    /// The parameters to answer a `getParameters` of `names` with.
    pub async fn get_values(params: &dyn LiveParams, names: Vec<String>) -> Vec<Parameter> {
        params.get(names).await.into_iter().map(|(name, v)| to_parameter(name, &v)).collect()
    }

    /// Sets `parameters`: those applied, with the values in force, and for each refused one
    /// why (`name: reason`).
    pub async fn set_values(
        params: &dyn LiveParams,
        parameters: Vec<Parameter>,
    ) -> (Vec<Parameter>, Vec<String>) {
        let (mut applied, mut refused) = (Vec::new(), Vec::new());
        for p in parameters {
            let Some(value) = &p.value else {
                refused.push(format!("{}: a parameter cannot be unset", p.name));
                continue;
            };
            let json = match from_value(value) {
                Ok(json) => json,
                Err(why) => {
                    refused.push(format!("{}: {why}", p.name));
                    continue;
                }
            };
            match params.set(p.name.clone(), json).await {
                Ok(now) => applied.push(to_parameter(p.name, &now)),
                Err(why) => refused.push(format!("{}: {why}", p.name)),
            }
        }
        (applied, refused)
    }
}

impl ParameterHandler for ParamBridge {
    fn get(
        &self,
        _client: AnyClient,
        names: Vec<String>,
        _request_id: Option<String>,
        responder: GetParametersResponder,
    ) {
        let params = Arc::clone(&self.params);
        self.runtime.spawn(async move {
            responder.respond(ParamBridge::get_values(&*params, names).await);
        });
    }

    fn set(
        &self,
        client: AnyClient,
        parameters: Vec<Parameter>,
        _request_id: Option<String>,
        responder: SetParametersResponder,
    ) {
        let params = Arc::clone(&self.params);
        let updates = self.updates.clone();
        self.runtime.spawn(async move {
            let (applied, refused) = ParamBridge::set_values(&*params, parameters).await;
            for why in refused {
                tracing::warn!("foxglove: a client's parameter was refused: {why}");
                client.send_error(format!("parameter refused: {why}"));
            }
            if let Some(updates) = updates
                && !applied.is_empty()
            {
                updates.publish_parameters(applied.clone());
            }
            responder.respond(applied);
        });
    }
}

/// A JSON value as a protocol parameter named `name` (a number that is not an integer, or an
/// array of numbers with one that is not, says it is a float, so that the client keeps it one).
pub fn to_parameter(name: String, value: &Value) -> Parameter {
    let r#type = match value {
        Value::Number(n) if !(n.is_i64() || n.is_u64()) => Some(ParameterType::Float64),
        Value::Array(items)
            if !items.is_empty()
                && items.iter().all(Value::is_number)
                && items.iter().any(|n| !(n.is_i64() || n.is_u64())) =>
        {
            Some(ParameterType::Float64Array)
        }
        _ => None,
    };
    Parameter { name, r#type, value: to_value(value) }
}

/// A JSON value as a protocol value; `null` is no value (an unset parameter).
pub fn to_value(value: &Value) -> Option<ParameterValue> {
    Some(match value {
        Value::Null => return None,
        Value::Bool(b) => ParameterValue::Bool(*b),
        Value::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => ParameterValue::Integer(i),
            (None, Some(f)) => ParameterValue::Float64(f),
            (None, None) => return None,
        },
        Value::String(s) => ParameterValue::String(s.clone()),
        Value::Array(items) => ParameterValue::Array(items.iter().filter_map(to_value).collect()),
        Value::Object(map) => {
            ParameterValue::Dict(map.iter().filter_map(|(k, v)| Some((k.clone(), to_value(v)?))).collect())
        }
    })
}

/// A parameter value that JSON cannot hold.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{0} is not a finite number")]
pub struct NotFinite(pub f64);

/// A protocol value as JSON; a float that JSON cannot hold (NaN, infinite) is refused.
pub fn from_value(value: &ParameterValue) -> Result<Value, NotFinite> {
    Ok(match value {
        ParameterValue::Integer(i) => Value::from(*i),
        ParameterValue::Float64(f) => match serde_json::Number::from_f64(*f) {
            Some(n) => Value::Number(n),
            None => return Err(NotFinite(*f)),
        },
        ParameterValue::Bool(b) => Value::Bool(*b),
        ParameterValue::String(s) => Value::String(s.clone()),
        ParameterValue::Array(items) => Value::Array(items.iter().map(from_value).collect::<Result<_, _>>()?),
        ParameterValue::Dict(map) => Value::Object(
            map.iter().map(|(k, v)| Ok((k.clone(), from_value(v)?))).collect::<Result<_, NotFinite>>()?,
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use parking_lot::Mutex;
    use serde_json::json;
    use std::collections::BTreeMap;

    /// A store of two parameters, one a float in [0, 5], one a bool (a test of the mapping only).
    struct Store(Mutex<BTreeMap<String, Value>>);

    impl Store {
        fn get_now(&self, names: &[String]) -> Vec<(String, Value)> {
            let map = self.0.lock();
            map.iter()
                .filter(|(k, _)| names.is_empty() || names.contains(k))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        }

        fn set_now(&self, name: &str, value: Value) -> Result<Value, String> {
            let mut map = self.0.lock();
            let Some(old) = map.get(name) else { return Err(format!("no parameter {name}")) };
            let ok = match (old, &value) {
                (Value::Bool(_), Value::Bool(_)) => true,
                (Value::Number(_), Value::Number(n)) => {
                    let v = n.as_f64().unwrap_or(f64::NAN);
                    if !(0.0..=5.0).contains(&v) {
                        return Err(format!("{v} is out of range [0, 5]"));
                    }
                    true
                }
                _ => false,
            };
            if !ok {
                return Err(format!("{value} is not of the parameter's type"));
            }
            map.insert(name.to_owned(), value.clone());
            Ok(value)
        }
    }

    impl LiveParams for Store {
        fn get(&self, names: Vec<String>) -> BoxFuture<'static, Vec<(String, Value)>> {
            let found = self.get_now(&names);
            Box::pin(async move { found })
        }

        fn set(&self, name: String, value: Value) -> BoxFuture<'static, Result<Value, SetError>> {
            let done = self.set_now(&name, value).map_err(SetError::from);
            Box::pin(async move { done })
        }
    }

    fn store() -> Store {
        let map = BTreeMap::from([
            ("wallfollow.gain".to_owned(), json!(1.5)),
            ("wallfollow.enabled".to_owned(), json!(true)),
        ]);
        Store(Mutex::new(map))
    }

    fn get(b: &Store, names: &[&str]) -> Vec<Parameter> {
        let names = names.iter().map(|n| n.to_string()).collect();
        futures::executor::block_on(ParamBridge::get_values(b, names))
    }

    #[test]
    fn get_maps_every_parameter_or_the_named_ones() {
        let b = store();
        let all = get(&b, &[]);
        assert_eq!(all.len(), 2);
        let gain = get(&b, &["wallfollow.gain"]);
        assert_eq!(gain, vec![Parameter::float64("wallfollow.gain", 1.5)]);
        assert!(get(&b, &["nothing"]).is_empty());
    }

    #[test]
    fn set_applies_good_values_and_says_why_others_are_refused() {
        let b = store();
        let (applied, refused) = futures::executor::block_on(ParamBridge::set_values(
            &b,
            vec![
                Parameter::float64("wallfollow.gain", 2.5),
                Parameter::string("wallfollow.enabled", "yes"),
                Parameter::float64("wallfollow.gain", 9.0),
                Parameter::float64("wallfollow.gain", f64::NAN),
                Parameter::empty("wallfollow.gain"),
                Parameter::bool("nothing", true),
            ],
        ));
        assert_eq!(applied, vec![Parameter::float64("wallfollow.gain", 2.5)]);
        assert_eq!(refused.len(), 5, "{refused:?}");
        assert!(refused[0].starts_with("wallfollow.enabled: ") && refused[0].contains("type"), "{refused:?}");
        assert!(refused[1].contains("out of range"), "{refused:?}");
        assert!(refused[2].contains("not a finite number"), "{refused:?}");
        assert!(refused[3].contains("cannot be unset"), "{refused:?}");
        assert!(refused[4].contains("no parameter nothing"), "{refused:?}");
        assert_eq!(get(&b, &["wallfollow.gain"])[0].value, Some(ParameterValue::Float64(2.5)));
    }

    #[test]
    fn values_round_trip_between_json_and_the_protocol() {
        for v in
            [json!(3), json!(-2.25), json!(true), json!("x"), json!([1.5, 2]), json!({"a": 1, "b": [true]})]
        {
            let p = to_value(&v).expect("a value");
            assert_eq!(from_value(&p), Ok(v.clone()), "{v}");
        }
        assert_eq!(to_value(&Value::Null), None);
        assert_eq!(to_parameter("a".into(), &json!([1.0, 2.0])).r#type, Some(ParameterType::Float64Array));
        assert_eq!(to_parameter("a".into(), &json!(2)).r#type, None);
    }
}

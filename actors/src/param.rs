//! **Parameters**: a component's tunable values (gains, targets, speeds, rules), read and set
//! while it runs, through a Query service of its own named [`PARAM`].
//!
//! A parameter is a leaf of the component's parameter struct as its config table spells it:
//! `target_m`, `loops.k_alpha`, `modes.patrol.rules.0.when.0.below_m` (tables by key, arrays of
//! tables by index; an array of plain values, such as a rule's `sensors`, is one parameter).
//! Values travel as JSON values ([`serde_json::Value`]), so a client in any language can make
//! them.
//!
//! Semantics:
//! - **Get** answers every parameter whose name is the one asked or lies under it (`loops` gives
//!   `loops.k_d` and the rest; the empty name gives all).
//! - **Set** puts the value in a copy of the current struct, reads the copy back with the same
//!   deserializer the config file goes through (unknown names, wrong types are refused there),
//!   then runs the same checks the config file gets ([`Parameters::validate`], and a check the
//!   system adds for what depends on other tables). A refused set answers why, naming the
//!   parameter, and changes nothing. A parameter the component reads only when it starts
//!   ([`Parameters::FIXED`]) is refused as such.
//! - The request is a message in the component's mailbox like any other: a set takes effect
//!   between two of its steps, never in the middle of one, and the step after it sees the new
//!   value. A restarted instance starts from the values set, not from the config's.
//! - Every set that changes something is shown to the tap as a control event on
//!   `component/params` ([`ParamChange`]); the request and its answer are recorded as every
//!   query is, so a replay can make the same request at the same instant.
//!
//! ```
//! # use orsa_actors::param::{Invalid, Parameters, ParamRequest, ParamTree};
//! # use serde::{Deserialize, Serialize};
//! #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
//! #[serde(deny_unknown_fields)]
//! struct Gains { k_p: f64, v_max_m_s: f64 }
//! impl Parameters for Gains {
//!     fn validate(&self) -> Result<(), Invalid> {
//!         if self.k_p > 0.0 { Ok(()) } else { Err(Invalid::new("k_p", format!("must be positive, not {}", self.k_p))) }
//!     }
//! }
//! let gains = Gains { k_p: 1.5, v_max_m_s: 0.25 };
//! let tree = ParamTree::of(&gains).unwrap();
//! assert_eq!(tree.get("").unwrap().len(), 2);
//! let set = tree.set::<Gains>("k_p", serde_json::json!(2.0), &|_| Ok(())).unwrap();
//! assert_eq!(set.k_p, 2.0);
//! assert!(tree.set::<Gains>("k_p", serde_json::json!(-1.0), &|_| Ok(())).unwrap_err().to_string().contains("positive"));
//! assert!(tree.set::<Gains>("k_q", serde_json::json!(1.0), &|_| Ok(())).unwrap_err().to_string().contains("no parameter"));
//! ```

use crate::clock::Timestamp;
use crate::comm::CommObject as _;
use crate::comm_object;
use crate::component::Ctx;
use crate::error::PatternResult;
use crate::query::QueryRequest;
use crate::service::QueryService;
use parking_lot::Mutex;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::sync::Arc;

/// Every parameterised component's parameter service.
pub const PARAM: QueryService<ParamRequest, ParamReply> = QueryService::new("param");

/// The control event a set that changed something makes, on `component/params`.
pub const CHANGES: &str = "params";

/// A component's parameter struct: its config table, read and set while it runs.
pub trait Parameters: Serialize + DeserializeOwned + Clone + PartialEq + Send + Sync + 'static {
    /// Parameters (or tables of them) read only when the component starts: a set is refused.
    /// `*` stands for any one key (`modes.*.behaviours`).
    const FIXED: &'static [&'static str] = &[];

    /// The config file's checks of this table; the error names the key.
    fn validate(&self) -> Result<(), Invalid>;
}

/// A parameter that is not valid: the key path that names it (`executive.modes.patrol.rules[0]
/// .drive`, as the config file spells it) and why.
///
/// It reads as `key: reason` (only the reason if the key is empty). A validator that delegates to
/// a sub-table's validator puts the table's key in front with [`Invalid::under`].
///
/// ```
/// # use orsa_actors::param::Invalid;
/// let e = Invalid::new("k_d", "must be a positive number").under("loops").under("wallfollow");
/// assert_eq!(e.key, "wallfollow.loops.k_d");
/// assert_eq!(e.to_string(), "wallfollow.loops.k_d: must be a positive number");
/// assert_eq!(Invalid::new("0", "no sensor").under("rules").key, "rules.0");
/// assert_eq!(Invalid::new("[0].when", "empty").under("rules").key, "rules[0].when");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.message())]
pub struct Invalid {
    /// The parameter (or table) at fault, its path as the config file spells it.
    pub key: String,
    /// Why it is refused (`must be a positive number`).
    pub reason: String,
}

impl Invalid {
    /// The parameter `key` is invalid because of `reason`.
    pub fn new(key: impl Into<String>, reason: impl Into<String>) -> Invalid {
        Invalid { key: key.into(), reason: reason.into() }
    }

    /// The same error, its key read under the table `prefix` (`prefix.key`, `prefix[i]...` for
    /// an index, `prefix` alone for an empty key).
    #[must_use]
    pub fn under(mut self, prefix: &str) -> Invalid {
        if prefix.is_empty() {
            return self;
        }
        self.key = if self.key.is_empty() {
            prefix.to_string()
        } else if self.key.starts_with('[') {
            format!("{prefix}{}", self.key)
        } else {
            format!("{prefix}.{}", self.key)
        };
        self
    }

    fn message(&self) -> String {
        if self.key.is_empty() { self.reason.clone() } else { format!("{}: {}", self.key, self.reason) }
    }
}

/// The message as a user reads it (for callers that still carry errors as text).
impl From<Invalid> for String {
    fn from(e: Invalid) -> String {
        e.to_string()
    }
}

/// Why a [`ParamTree`] refused a get or a set; each names the parameter.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// The parameter struct does not encode as JSON.
    #[error("the parameters do not encode: {0}")]
    Encode(String),
    /// There is no parameter (or table) of that name.
    #[error("no parameter '{0}'")]
    NoParameter(String),
    /// The name is a table's: a set names one parameter.
    #[error("'{0}' is a table, not a parameter: set one of its parameters")]
    Table(String),
    /// The parameter is read only when the component starts.
    #[error("{0}: read only when the component starts; set it in the config file and restart")]
    Fixed(String),
    /// The new value does not read back as the parameter struct (wrong type, unknown field).
    #[error("{name}: {error}")]
    Decode {
        /// The parameter set.
        name: String,
        /// What the deserializer said.
        error: String,
    },
    /// The new value reads, but the table's checks refuse it.
    #[error(transparent)]
    Invalid(#[from] Invalid),
}

/// A request to a component's [`PARAM`] service.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParamRequest {
    /// Every parameter named `name` or under it (`""`: all).
    Get {
        /// The parameter or table.
        name: String,
    },
    /// Sets one parameter.
    Set {
        /// The parameter.
        name: String,
        /// Its new value.
        value: Value,
    },
}
comm_object!(ParamRequest, "orsa.ParamRequest/1");

/// One parameter and its value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    /// Its name (`loops.k_alpha`).
    pub name: String,
    /// Its value.
    pub value: Value,
    /// Whether it is read only when the component starts (a set is refused).
    pub fixed: bool,
}

/// The answer of the [`PARAM`] service.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamReply {
    /// A get: the parameters asked for. A set: the parameter as it now stands (its old value
    /// if the set was refused).
    pub params: Vec<Param>,
    /// Why the request was refused, naming the parameter; nothing changed.
    pub refused: Option<String>,
}
comm_object!(ParamReply, "orsa.ParamReply/1");

/// A set that changed a parameter (the control event on `component/params`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamChange {
    /// When it took effect.
    pub stamp: Timestamp,
    /// The parameter.
    pub name: String,
    /// Its value before.
    pub old: Value,
    /// Its value now.
    pub new: Value,
}
comm_object!(ParamChange, "orsa.ParamChange/1");

/// A parameter struct as a tree of JSON values, to read and set by name.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamTree {
    root: Value,
    fixed: &'static [&'static str],
}

/// Whether `name` is `pattern` or lies under it, `*` matching any one key.
fn matches(name: &str, pattern: &str) -> bool {
    let mut keys = name.split('.');
    pattern.split('.').all(|p| keys.next().is_some_and(|k| p == "*" || p == k))
}

fn under(name: &str, prefix: &str) -> bool {
    prefix.is_empty()
        || name == prefix
        || (name.len() > prefix.len() && name.starts_with(prefix) && name.as_bytes()[prefix.len()] == b'.')
}

fn leaves(value: &Value, path: &mut String, out: &mut Vec<(String, Value)>) {
    let mut child = |key: &str, v: &Value, path: &mut String| {
        let len = path.len();
        if !path.is_empty() {
            path.push('.');
        }
        path.push_str(key);
        leaves(v, path, out);
        path.truncate(len);
    };
    match value {
        Value::Object(map) if !map.is_empty() => {
            for (k, v) in map {
                child(k, v, path);
            }
        }
        Value::Array(items) if items.iter().any(|v| v.is_object() || v.is_array()) => {
            for (i, v) in items.iter().enumerate() {
                child(&i.to_string(), v, path);
            }
        }
        _ => out.push((path.clone(), value.clone())),
    }
}

impl ParamTree {
    /// The tree of `params`.
    pub fn of<P: Parameters>(params: &P) -> Result<ParamTree, Refused> {
        let root = serde_json::to_value(params).map_err(|e| Refused::Encode(e.to_string()))?;
        Ok(ParamTree { root, fixed: P::FIXED })
    }

    fn is_fixed(&self, name: &str) -> bool {
        self.fixed.iter().any(|f| matches(name, f))
    }

    /// Every parameter named `name` or under it; an error if there is none.
    pub fn get(&self, name: &str) -> Result<Vec<Param>, Refused> {
        let mut all = Vec::new();
        leaves(&self.root, &mut String::new(), &mut all);
        let found: Vec<Param> = all
            .into_iter()
            .filter(|(n, _)| under(n, name))
            .map(|(n, value)| Param { fixed: self.is_fixed(&n), name: n, value })
            .collect();
        if found.is_empty() {
            return Err(Refused::NoParameter(name.to_string()));
        }
        Ok(found)
    }

    /// The struct with parameter `name` set to `value`, read back and checked as the config file
    /// is (and by `check`); the error names the parameter and says why.
    pub fn set<P: Parameters>(
        &self,
        name: &str,
        value: Value,
        check: &dyn Fn(&P) -> Result<(), Invalid>,
    ) -> Result<P, Refused> {
        let leaf = match self.get(name) {
            Ok(found) if found.len() == 1 && found[0].name == name => found.into_iter().next(),
            Ok(_) => return Err(Refused::Table(name.to_string())),
            Err(e) => return Err(e),
        };
        if leaf.is_some_and(|p| p.fixed) {
            return Err(Refused::Fixed(name.to_string()));
        }
        let mut root = self.root.clone();
        let mut slot = &mut root;
        for key in name.split('.') {
            slot = match slot {
                Value::Object(map) => map.get_mut(key),
                Value::Array(items) => key.parse::<usize>().ok().and_then(|i| items.get_mut(i)),
                _ => None,
            }
            .ok_or_else(|| Refused::NoParameter(name.to_string()))?;
        }
        *slot = value;
        let params: P = serde_json::from_value(root)
            .map_err(|e| Refused::Decode { name: name.to_string(), error: e.to_string() })?;
        params.validate()?;
        check(&params)?;
        Ok(params)
    }
}

/// A check the system adds to a component's own (what depends on other tables of the config).
pub type Check<P> = Arc<dyn Fn(&P) -> Result<(), Invalid> + Send + Sync>;

/// A component's parameters while it runs (see [`Ctx::parameters`]): the values every instance
/// starts from, and the answers to its [`PARAM`] service.
pub struct LiveParams<P> {
    current: Arc<Mutex<P>>,
    check: Check<P>,
    topic: Arc<str>,
    tap: crate::tap::TapSlot,
}

impl<P> Clone for LiveParams<P> {
    fn clone(&self) -> Self {
        LiveParams {
            current: self.current.clone(),
            check: self.check.clone(),
            topic: self.topic.clone(),
            tap: self.tap.clone(),
        }
    }
}

impl<P> std::fmt::Debug for LiveParams<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveParams").field("topic", &self.topic).finish_non_exhaustive()
    }
}

impl<P: Parameters> LiveParams<P> {
    /// The values now.
    pub fn current(&self) -> P {
        self.current.lock().clone()
    }

    /// Answers a request to the [`PARAM`] service; returns the new values if a set changed
    /// them (apply them before the next step).
    pub fn handle(&self, q: QueryRequest<ParamRequest, ParamReply>, now: Timestamp) -> Option<P> {
        let (reply, changed) = self.answer(&q.request.value, now);
        // A client that gave up waiting does not undo the set.
        let _ = q.answer(reply);
        changed
    }

    fn answer(&self, request: &ParamRequest, now: Timestamp) -> (ParamReply, Option<P>) {
        let mut current = self.current.lock();
        let tree = match ParamTree::of(&*current) {
            Ok(t) => t,
            Err(e) => return (ParamReply { params: Vec::new(), refused: Some(e.to_string()) }, None),
        };
        match request {
            ParamRequest::Get { name } => match tree.get(name) {
                Ok(params) => (ParamReply { params, refused: None }, None),
                Err(e) => (ParamReply { params: Vec::new(), refused: Some(e.to_string()) }, None),
            },
            ParamRequest::Set { name, value } => {
                let old = tree.get(name).unwrap_or_default();
                match tree.set::<P>(name, value.clone(), &*self.check) {
                    Err(e) => (ParamReply { params: old, refused: Some(e.to_string()) }, None),
                    Ok(params) => {
                        let now_tree = ParamTree::of(&params);
                        let new = now_tree.and_then(|t| t.get(name)).unwrap_or_default();
                        let changed = params != *current;
                        if changed {
                            *current = params.clone();
                            let change = ParamChange {
                                stamp: now,
                                name: name.clone(),
                                old: old.first().map_or(Value::Null, |p| p.value.clone()),
                                new: new.first().map_or(Value::Null, |p| p.value.clone()),
                            };
                            self.tap.record(&self.topic, ParamChange::ID, now, &change);
                        }
                        (ParamReply { params: new, refused: None }, changed.then_some(params))
                    }
                }
            }
        }
    }
}

impl<M: ractor::Message> Ctx<M> {
    /// Declares the component's [`PARAM`] service, serving `initial` the first time (a
    /// restarted instance gets the values as they were last set); each request arrives as
    /// `map(request)`, for [`LiveParams::handle`]. `check` adds what the config file checks
    /// beyond the table itself.
    pub fn parameters<P: Parameters>(
        &self,
        initial: &P,
        check: Option<Check<P>>,
        map: impl Fn(QueryRequest<ParamRequest, ParamReply>) -> M + Send + Sync + 'static,
    ) -> PatternResult<LiveParams<P>> {
        self.query_server(PARAM, map)?;
        let current = self.keep("params", || Arc::new(Mutex::new(initial.clone())))?;
        Ok(LiveParams {
            current,
            check: check.unwrap_or_else(|| Arc::new(|_: &P| Ok(()))),
            topic: format!("{}/{CHANGES}", self.name()).into(),
            tap: self.registry().tap_slot(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Rule {
        sensors: Vec<u8>,
        below_m: Option<f64>,
    }

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Loops {
        k_d: f64,
        k_alpha: f64,
    }

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct P {
        robot: String,
        target_m: f64,
        loops: Loops,
        rules: Vec<Rule>,
        enabled: bool,
    }

    impl Parameters for P {
        const FIXED: &'static [&'static str] = &["robot"];
        fn validate(&self) -> Result<(), Invalid> {
            if !(self.target_m > 0.0 && self.target_m < 1.0) {
                return Err(Invalid::new(
                    "t.target_m",
                    format!("must be from 0 to 1 m, not {}", self.target_m),
                ));
            }
            Ok(())
        }
    }

    fn p() -> P {
        P {
            robot: "nomad200".into(),
            target_m: 0.2,
            loops: Loops { k_d: 1.0, k_alpha: 2.0 },
            rules: vec![
                Rule { sensors: vec![0], below_m: Some(0.5) },
                Rule { sensors: vec![], below_m: None },
            ],
            enabled: true,
        }
    }

    fn names(params: &[Param]) -> Vec<&str> {
        params.iter().map(|p| p.name.as_str()).collect()
    }

    #[test]
    fn leaves_are_named_as_the_config_spells_them() {
        let tree = ParamTree::of(&p()).expect("tree");
        let all = tree.get("").expect("all");
        assert_eq!(
            names(&all),
            [
                "enabled",
                "loops.k_alpha",
                "loops.k_d",
                "robot",
                "rules.0.below_m",
                "rules.0.sensors",
                "rules.1.below_m",
                "rules.1.sensors",
                "target_m"
            ]
        );
        assert!(all.iter().find(|p| p.name == "robot").is_some_and(|p| p.fixed));
        assert_eq!(names(&tree.get("loops").expect("table")), ["loops.k_alpha", "loops.k_d"]);
        // A prefix of a name is not a table.
        assert!(tree.get("loop").is_err());
        assert_eq!(tree.get("rules.0.sensors").expect("leaf")[0].value, json!([0]));
    }

    #[test]
    fn a_set_goes_through_the_config_checks() {
        let tree = ParamTree::of(&p()).expect("tree");
        let ok = |_: &P| Ok(());
        let set = tree.set::<P>("loops.k_d", json!(1.5), &ok).expect("set");
        assert_eq!(set.loops.k_d, 1.5);
        // An integer where a number is expected is read as the config file reads it.
        assert_eq!(tree.set::<P>("loops.k_alpha", json!(3), &ok).expect("integer").loops.k_alpha, 3.0);
        let set = tree.set::<P>("rules.1.below_m", json!(0.4), &ok).expect("option");
        assert_eq!(set.rules[1].below_m, Some(0.4));
        let set = tree.set::<P>("rules.0.sensors", json!([15, 0, 1]), &ok).expect("array");
        assert_eq!(set.rules[0].sensors, [15, 0, 1]);

        let refused = |name: &str, value: Value| tree.set::<P>(name, value, &ok).expect_err(name).to_string();
        assert!(refused("target_m", json!(2.0)).contains("must be from 0 to 1"));
        assert!(refused("target_m", json!("far")).starts_with("target_m: invalid type"));
        assert!(refused("enabled", json!(1)).starts_with("enabled: invalid type"));
        assert!(refused("rules.0.sensors", json!([300])).starts_with("rules.0.sensors:"));
        assert!(refused("loops", json!(1.0)).contains("is a table"));
        assert!(refused("loops.k_q", json!(1.0)).contains("no parameter 'loops.k_q'"));
        assert!(refused("rules.7.below_m", json!(1.0)).contains("no parameter"));
        assert!(refused("robot", json!("other")).contains("read only when the component starts"));
        let check =
            |p: &P| if p.loops.k_d > 5.0 { Err(Invalid::new("loops.k_d", "above 5")) } else { Ok(()) };
        assert_eq!(
            tree.set::<P>("loops.k_d", json!(6.0), &check).expect_err("checked"),
            Refused::Invalid(Invalid::new("loops.k_d", "above 5"))
        );
        assert_eq!(
            tree.set::<P>("loops.k_d", json!(6.0), &check).expect_err("checked").to_string(),
            "loops.k_d: above 5"
        );
    }

    #[test]
    fn names_under_a_table() {
        assert!(under("loops.k_d", "loops"));
        assert!(under("loops.k_d", ""));
        assert!(under("loops", "loops"));
        assert!(!under("loopsy.k", "loops"));
        assert!(!under("loops", "loops.k_d"));
        assert!(matches("modes.patrol.behaviours", "modes.*.behaviours"));
        assert!(matches("modes.patrol.behaviours", "modes"));
        assert!(!matches("modes.patrol.rules.0.drive", "modes.*.behaviours"));
        assert!(!matches("mode", "modes"));
    }

    #[test]
    fn requests_and_answers_round_trip() {
        let reqs = [
            ParamRequest::Get { name: "loops".into() },
            ParamRequest::Set { name: "rules.0.sensors".into(), value: json!([1, 2]) },
        ];
        for r in reqs {
            let json = serde_json::to_string(&r).expect("json");
            assert_eq!(serde_json::from_str::<ParamRequest>(&json).expect("back"), r);
            let mut cbor = Vec::new();
            ciborium::into_writer(&r, &mut cbor).expect("cbor");
            assert_eq!(ciborium::from_reader::<ParamRequest, _>(&cbor[..]).expect("back"), r);
        }
        let reply = ParamReply {
            params: vec![Param { name: "target_m".into(), value: json!(0.2), fixed: false }],
            refused: None,
        };
        let mut cbor = Vec::new();
        ciborium::into_writer(&reply, &mut cbor).expect("cbor");
        assert_eq!(ciborium::from_reader::<ParamReply, _>(&cbor[..]).expect("back"), reply);
    }
}

//! A system's live parameters, by one name each: `component.parameter`
//! (`wallfollow.loops.k_alpha`), read and set through each component's `param` service
//! ([`orsa_actors::param`]), in this process or in another one.
//!
//! `orsa param` and the live Foxglove server's parameter panel both go through a
//! [`ParamDirectory`]: they ask the components, never hold values of their own, so what they
//! show is what the components use, and a set is checked by the component as its config file
//! is.

use orsa_actors::param::{PARAM, Param, ParamReply, ParamRequest};
use orsa_actors::query::QueryClient;
use orsa_actors::{PatternError, Registry};
use serde_json::Value;
use std::time::Duration;

/// How long a component has to answer.
pub const ANSWER_WITHIN: Duration = Duration::from_secs(2);

/// Why a parameter could not be read or set.
#[derive(Debug, thiserror::Error)]
pub enum ParamError {
    /// The name does not start with a component that serves parameters.
    #[error("'{name}': no component '{component}' with parameters (components: {known})")]
    NoComponent {
        /// The name asked.
        name: String,
        /// Its component part.
        component: String,
        /// The components that serve parameters.
        known: String,
    },
    /// The component could not be asked.
    #[error("{component}/param: {source}")]
    Unreachable {
        /// The component.
        component: String,
        /// Why.
        source: Box<PatternError>,
    },
    /// The component refused: the reason names the parameter; nothing changed.
    #[error("{component} refused: {reason}")]
    Refused {
        /// The component.
        component: String,
        /// Why.
        reason: String,
        /// The parameter as it still stands, if it exists.
        current: Vec<Param>,
    },
}

/// The parameters of some components of a system.
#[derive(Debug, Clone)]
pub struct ParamDirectory {
    registry: Registry,
    components: Vec<String>,
}

/// Splits `component.parameter` (the component is everything before the first dot).
pub fn split_name(name: &str) -> (&str, &str) {
    name.split_once('.').unwrap_or((name, ""))
}

impl ParamDirectory {
    /// The parameters of `components`, reached through `registry`.
    pub fn new(registry: &Registry, components: Vec<String>) -> ParamDirectory {
        ParamDirectory { registry: registry.clone(), components }
    }

    /// Whether `component` runs in this process (its parameter changes are control events of
    /// this process's tap, seen as they happen).
    pub fn is_local(&self, component: &str) -> bool {
        self.registry.has_component(component)
    }

    /// The components whose parameters it serves.
    pub fn components(&self) -> &[String] {
        &self.components
    }

    fn component<'a>(&self, name: &'a str) -> Result<(&'a str, &'a str), ParamError> {
        let (component, rest) = split_name(name);
        if self.components.iter().any(|c| c == component) {
            return Ok((component, rest));
        }
        Err(ParamError::NoComponent {
            name: name.to_owned(),
            component: component.to_owned(),
            known: self.components.join(", "),
        })
    }

    /// Asks `component` for `request`.
    pub async fn ask(&self, component: &str, request: ParamRequest) -> Result<ParamReply, ParamError> {
        let unreachable =
            |source| ParamError::Unreachable { component: component.to_owned(), source: Box::new(source) };
        let client = QueryClient::connect(&self.registry, PARAM.on(component)).map_err(unreachable)?;
        client.query(request, Some(ANSWER_WITHIN)).await.map_err(unreachable)
    }

    /// Every parameter named `name` (`component`, `component.table` or `component.parameter`),
    /// with full names.
    pub async fn get(&self, name: &str) -> Result<Vec<Param>, ParamError> {
        let (component, rest) = self.component(name)?;
        let reply = self.ask(component, ParamRequest::Get { name: rest.to_owned() }).await?;
        if let Some(reason) = reply.refused {
            return Err(ParamError::Refused { component: component.to_owned(), reason, current: Vec::new() });
        }
        Ok(full_names(component, reply.params))
    }

    /// Every parameter of every component (those that do not answer are left out, each with
    /// the reason), in the components' order. The components are asked all at once, so one in
    /// an unreachable process costs one timeout, not one per component.
    pub async fn get_all(&self) -> (Vec<Param>, Vec<ParamError>) {
        let answers = futures::future::join_all(self.components.iter().map(|c| self.get(c))).await;
        let mut all = Vec::new();
        let mut failed = Vec::new();
        for answer in answers {
            match answer {
                Ok(p) => all.extend(p),
                Err(e) => failed.push(e),
            }
        }
        (all, failed)
    }

    /// Sets parameter `name` (`component.parameter`) to `value`: the parameter as it now
    /// stands, or why it was refused.
    pub async fn set(&self, name: &str, value: Value) -> Result<Param, ParamError> {
        let (component, rest) = self.component(name)?;
        let reply = self.ask(component, ParamRequest::Set { name: rest.to_owned(), value }).await?;
        let params = full_names(component, reply.params);
        if let Some(reason) = reply.refused {
            return Err(ParamError::Refused { component: component.to_owned(), reason, current: params });
        }
        params.into_iter().next().ok_or_else(|| ParamError::Refused {
            component: component.to_owned(),
            reason: format!("{rest}: the answer names no parameter"),
            current: Vec::new(),
        })
    }
}

fn full_names(component: &str, params: Vec<Param>) -> Vec<Param> {
    params.into_iter().map(|p| Param { name: format!("{component}.{}", p.name), ..p }).collect()
}

/// A value as typed by a person: TOML (`0.25`, `true`, `[3, 4, 5]`, `"left"`), or, if it is not
/// TOML, the text itself as a string (`wallfollow`).
pub fn parse_value(text: &str) -> Value {
    let as_toml = toml::from_str::<toml::Table>(&format!("v = {text}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .and_then(|v| serde_json::to_value(v).ok());
    as_toml.unwrap_or_else(|| Value::String(text.to_owned()))
}

/// A value as the config file would spell it.
pub fn show_value(value: &Value) -> String {
    match value {
        Value::Null => "(none)".to_owned(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn values_are_read_as_toml_else_as_text() {
        assert_eq!(parse_value("0.25"), json!(0.25));
        assert_eq!(parse_value("3"), json!(3));
        assert_eq!(parse_value("true"), json!(true));
        assert_eq!(parse_value("[3, 4, 5]"), json!([3, 4, 5]));
        assert_eq!(parse_value("\"left\""), json!("left"));
        assert_eq!(parse_value("wallfollow"), json!("wallfollow"));
        assert_eq!(parse_value("0.3."), json!("0.3."));
        assert_eq!(parse_value(""), json!(""));
    }

    /// Three components that never answer and one that does: everything is asked at once, so
    /// the answer comes one timeout after the question (asked one after the other, three).
    #[tokio::test(start_paused = true)]
    async fn all_parameters_cost_one_timeout_however_many_components_are_silent() {
        use orsa_actors::Sink;
        use orsa_actors::query::{QueryRequest, QueryServer};
        let registry = Registry::new();
        let (tx, _never_answered) = tokio::sync::mpsc::unbounded_channel();
        for silent in ["a", "b", "c"] {
            QueryServer::register(&registry, PARAM.on(silent), Sink::channel(tx.clone())).expect("register");
        }
        let answering = Sink::from_fn(|q: QueryRequest<ParamRequest, ParamReply>| {
            let params = vec![Param { name: "gain".into(), value: json!(2.0), fixed: false }];
            q.answer(ParamReply { params, refused: None }).map_err(|_| orsa_actors::Undeliverable::Closed)
        });
        QueryServer::register(&registry, PARAM.on("d"), answering).expect("register");
        let directory = ParamDirectory::new(&registry, ["a", "b", "c", "d"].map(String::from).to_vec());
        let start = tokio::time::Instant::now();
        let (params, failed) = directory.get_all().await;
        assert_eq!(start.elapsed(), ANSWER_WITHIN);
        assert_eq!(params.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["d.gain"]);
        let failed: Vec<String> = failed.iter().map(ToString::to_string).collect();
        assert_eq!(failed.len(), 3, "{failed:?}");
        for (e, c) in failed.iter().zip(["a", "b", "c"]) {
            assert!(e.starts_with(&format!("{c}/param: ")), "{e}");
        }
    }

    #[test]
    fn names_split_at_the_first_dot() {
        assert_eq!(split_name("wallfollow.loops.k_d"), ("wallfollow", "loops.k_d"));
        assert_eq!(split_name("master"), ("master", ""));
    }
}

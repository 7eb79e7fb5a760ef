//! `orsa param`: read and set a running component's parameters, wherever it runs.
//!
//! ```text
//! orsa param get wallfollow                 # every parameter of wallfollow
//! orsa param get wallfollow loops           # a table's
//! orsa param set wallfollow target_m 0.25   # one, checked as the config file is
//! ```

use super::{NetworkOptions, open, runtime, secs, wait_for};
use crate::system::live_params::{ParamDirectory, ParamError, parse_value, show_value};
use anyhow::bail;
use orsa_actors::param::Param;
use orsa_actors::{Registry, ServiceAddr};

/// Options of `orsa param`.
#[derive(Debug)]
pub struct ParamOptions {
    /// `get` shows parameters; `set` sets one while the component runs (checked by the
    /// component as the config file is: a refused value changes nothing, and says why).
    pub action: ParamAction,
    /// The component (`wallfollow`, `centerfollow`, `master`).
    pub component: String,
    /// The parameter (`target_m`, `loops.k_alpha`, `modes.patrol.rules.0.when.0.below_m`) or,
    /// with `get`, a table of them (`loops`); `get` without it shows them all.
    pub name: Option<String>,
    /// With `set`: the value, as in the config file (`0.25`, `true`, `[3, 4, 5]`, `"left"`);
    /// text that is not TOML is taken as a string.
    pub value: Option<String>,
    /// How long to wait for the component.
    pub wait: f64,
    /// Print JSON instead of text.
    pub json: bool,
    /// Network.
    pub net: NetworkOptions,
}

/// What `orsa param` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamAction {
    /// Show parameters.
    Get,
    /// Set one.
    Set,
}

fn render(params: &[Param]) -> String {
    let width = params.iter().map(|p| p.name.len()).max().unwrap_or(0);
    params
        .iter()
        .map(|p| {
            let fixed = if p.fixed { "   (read at start)" } else { "" };
            format!("{:width$} = {}{fixed}", p.name, show_value(&p.value))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// `orsa param`.
pub fn param(args: ParamOptions) -> anyhow::Result<()> {
    let wait = secs(args.wait, "--wait")?;
    let component = args.component.clone();
    if !orsa_actors::addr::valid_name(&component) {
        bail!("'{component}' is not a component name");
    }
    let name = args.name.clone().filter(|n| !n.is_empty());
    let set = match (args.action, &name, &args.value) {
        (ParamAction::Get, _, None) => None,
        (ParamAction::Get, _, Some(v)) => bail!("'orsa param get' takes no value ('{v}'): did you mean set?"),
        (ParamAction::Set, Some(n), Some(v)) => Some((n.clone(), v.clone())),
        (ParamAction::Set, _, _) => {
            bail!("'orsa param set' needs a parameter and a value: set COMPONENT NAME VALUE")
        }
    };
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        let result = async {
            wait_for(&transport, &[ServiceAddr::new(&component, "param")], wait).await?;
            let directory = ParamDirectory::new(&registry, vec![component.clone()]);
            match set {
                None => {
                    let full = match &name {
                        Some(n) => format!("{component}.{n}"),
                        None => component.clone(),
                    };
                    let params = directory.get(&full).await?;
                    let text =
                        if args.json { serde_json::to_string_pretty(&params)? } else { render(&params) };
                    crate::output::say(&text);
                    Ok(())
                }
                Some((name, value)) => {
                    let full = format!("{component}.{name}");
                    let value = parse_value(&value);
                    let before = directory.get(&full).await.ok().and_then(|p| p.into_iter().next());
                    match directory.set(&full, value).await {
                        Ok(now) => {
                            let was = before.map(|b| format!(" (was {})", show_value(&b.value)));
                            let text = if args.json {
                                serde_json::to_string_pretty(&now)?
                            } else {
                                format!("{}{}", render(std::slice::from_ref(&now)), was.unwrap_or_default())
                            };
                            crate::output::say(&text);
                            Ok(())
                        }
                        Err(ParamError::Refused { component, reason, current }) => {
                            let stays = current
                                .first()
                                .map(|p| format!("; {} stays {}", p.name, show_value(&p.value)))
                                .unwrap_or_default();
                            bail!("{component} refused the value: {reason}{stays}")
                        }
                        Err(e) => Err(e.into()),
                    }
                }
            }
        }
        .await;
        transport.close().await;
        result
    })
}

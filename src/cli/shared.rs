//! The options several commands share, declared once: the config file and the report
//! ([`Shared`]), and how a process joins the network ([`Network`]).

use std::path::PathBuf;

/// The config file and the report, as `orsa run`, `orsa robot`, `orsa executive` and
/// `orsa replay` take them.
#[derive(Debug, Clone, Default, clap::Args)]
pub(crate) struct Shared {
    /// Configuration file for the whole stack (see config/orsa.toml); default: built-in
    /// defaults (`orsa replay`: the recorded one).
    #[arg(long, value_name = "PATH")]
    pub(crate) config: Option<PathBuf>,
    /// Write the report here, as JSON (`orsa run`: default out/report.json; `orsa robot`,
    /// `orsa executive`: at exit, however they end; `orsa replay`: what diverged or changed).
    #[arg(long, value_name = "PATH.json")]
    pub(crate) report: Option<PathBuf>,
}

/// How a process joins the network (every networked subcommand flattens it).
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Network {
    /// zenoh endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) listen: Vec<String>,
    /// zenoh endpoint of a peer to connect to, e.g. `tcp/robot.local:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) connect: Vec<String>,
    /// zenoh configuration file (JSON5): TLS, user/password, everything else (see docs/security.md).
    #[arg(long, value_name = "PATH")]
    pub(crate) zenoh_config: Option<PathBuf>,
    /// Key prefix: systems with different prefixes do not see each other.
    #[arg(long, value_name = "PREFIX", default_value = "orsa")]
    pub(crate) prefix: String,
}

impl From<Network> for orsa::remote::NetworkOptions {
    fn from(a: Network) -> Self {
        orsa::remote::NetworkOptions {
            listen: a.listen,
            connect: a.connect,
            zenoh_config: a.zenoh_config,
            prefix: a.prefix,
        }
    }
}

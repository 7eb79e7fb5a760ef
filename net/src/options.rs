//! How a process joins the zenoh network: endpoints, a zenoh configuration file, the key prefix.

use std::path::PathBuf;

/// What can go wrong opening the transport.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// A bad option or configuration file.
    #[error("network configuration: {0}")]
    Config(String),
    /// zenoh refused to open the session.
    #[error("cannot open the zenoh session: {0}")]
    Open(String),
}

/// How to join the network.
#[derive(Debug, Clone)]
pub struct NetOptions {
    /// Endpoints to listen on, e.g. `tcp/0.0.0.0:7447` or `tls/0.0.0.0:7448`.
    pub listen: Vec<String>,
    /// Endpoints of peers to connect to, e.g. `tcp/robot.local:7447`.
    pub connect: Vec<String>,
    /// A zenoh configuration file (JSON5) for everything else: TLS certificates,
    /// user/password authentication, access control. `listen` and `connect` add to it.
    pub config_file: Option<PathBuf>,
    /// The first chunk(s) of every key: systems with different prefixes do not see each other.
    pub prefix: String,
    /// Publish a heartbeat this often (`orsa/v1/heartbeat/<zid>/<role>`, see
    /// `docs/wire-format.md`), so that a peer watching it notices a silent link sooner than
    /// zenoh's lease; `None`: no heartbeat.
    pub heartbeat: Option<std::time::Duration>,
    /// Stamp every sample with the session's hybrid logical clock (zenoh's `timestamping`),
    /// as rmw_zenoh's sessions do: what a transient local ROS 2 publisher (zenoh-ext's
    /// advanced publisher and its cache) needs. Set by a process that joins ROS 2.
    pub timestamping: bool,
}

impl Default for NetOptions {
    fn default() -> Self {
        NetOptions {
            listen: Vec::new(),
            connect: Vec::new(),
            config_file: None,
            prefix: "orsa".into(),
            heartbeat: None,
            timestamping: false,
        }
    }
}

fn check_endpoint(e: &str, flag: &str) -> Result<(), String> {
    match e.split_once('/') {
        Some((proto, rest)) if !proto.is_empty() && !rest.is_empty() => Ok(()),
        _ => Err(format!(
            "{flag} '{e}' is not a zenoh endpoint: expected PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447"
        )),
    }
}

impl NetOptions {
    /// The zenoh configuration: the file if given, in peer mode, with the endpoints added. With
    /// explicit endpoints, multicast scouting is off, so only the named peers are joined.
    pub fn zenoh_config(&self) -> Result<zenoh::Config, super::NetError> {
        let mut config = match &self.config_file {
            Some(path) => zenoh::Config::from_file(path)
                .map_err(|e| super::NetError::Config(format!("{}: {e}", path.display())))?,
            None => zenoh::Config::default(),
        };
        for e in &self.listen {
            check_endpoint(e, "--listen").map_err(super::NetError::Config)?;
        }
        for e in &self.connect {
            check_endpoint(e, "--connect").map_err(super::NetError::Config)?;
        }
        let set = |config: &mut zenoh::Config, key: &str, value: String| {
            config
                .insert_json5(key, &value)
                .map_err(|e| super::NetError::Config(format!("{key} = {value}: {e}")))
        };
        if self.config_file.is_none() {
            set(&mut config, "mode", "\"peer\"".into())?;
            // A peer that goes silent (cable cut, host frozen) is declared lost after 1 s, so
            // the robot stops within 1 s of losing its executive. A killed process is seen at
            // once (its TCP link closes).
            set(&mut config, "transport/link/tx/lease", "1000".into())?;
            set(&mut config, "transport/link/tx/keep_alive", "4".into())?;
            // Room for a burst: zenoh sends each express message in a batch of its own and
            // drops a droppable one when no batch frees up within 1 ms. With its default of two
            // batches, a loaded machine (the link task not scheduled for a millisecond) lost
            // the first Sends and pushes after discovery (net/tests/patterns.rs, 3 runs in 40
            // under load); sixteen, the most zenoh allows, absorb the bursts a robot sends (a
            // tick's scans, a push to every-n-th streams) while a link that really cannot keep
            // up still drops, newest first kept.
            set(&mut config, "transport/link/tx/queue/size/data", "16".into())?;
        }
        if self.timestamping {
            set(&mut config, "timestamping/enabled", "{ router: true, peer: true, client: true }".into())?;
        }
        if !self.listen.is_empty() {
            set(&mut config, "listen/endpoints", serde_json::to_string(&self.listen).unwrap_or_default())?;
        }
        if !self.connect.is_empty() {
            set(&mut config, "connect/endpoints", serde_json::to_string(&self.connect).unwrap_or_default())?;
        }
        if !self.listen.is_empty() || !self.connect.is_empty() {
            set(&mut config, "scouting/multicast/enabled", "false".into())?;
        }
        Ok(config)
    }
}

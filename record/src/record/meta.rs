//! What a recording says about the run that made it: enough to run its deciding components again
//! ([`crate::replay`]).
//!
//! Written as one MCAP metadata record named [`RUN_METADATA`] (the `mcap` CLI's `mcap list
//! metadata`, Foxglove's metadata panel and the Python `mcap` package show it), every value a
//! string:
//!
//! | key | what |
//! |---|---|
//! | `orsa`, `wire` | the orsa version and wire version that recorded it |
//! | `process` | which process recorded it: `run` (the whole stack), `robot` or `executive` |
//! | `world`, `world_toml` | the world's label and the world itself, as TOML (empty for a process that simulates none: `orsa executive`) |
//! | `seed`, `duration_s` | the run's seed and length |
//! | `config_toml` | the effective configuration, every key, as TOML |
//! | `hosted` | the components the recording process hosted, comma-separated, in start order |
//! | `robot` | the robot server's name (what a replay feeds from the recording) |
//! | `clock` | `paused` (simulated time: a replay is bit for bit, instants included) or `live` (real time: a replay matches values and order; times within a tolerance) |
//! | `clock_origin_ns` | the recording clock's first stamp: 0 on a simulated clock, UNIX time live |
//! | `faults_toml` | the fault plan, if the run had one |
//!
//! A process that ends well (its duration, Ctrl-C, its supervisor giving up) writes a second
//! record, [`RUN_ENDED_METADATA`] ([`RunEnded`]), as it closes the file: the instant its run
//! ended, before it shut its components down, and how. A quiet process (an executive that
//! decided everything in its first milliseconds) records nothing for seconds before it ends;
//! without this record its recording would seem to end at its last message.

use orsa_actors::wire::WIRE_VERSION;
use std::collections::BTreeMap;

/// The name of the metadata record that describes the run.
pub const RUN_METADATA: &str = "run";

/// The name of the metadata record that says when and how the run ended ([`RunEnded`]).
pub const RUN_ENDED_METADATA: &str = "run_ended";

/// The processes that record: the whole stack (`orsa run`), and the robot and executive of a
/// distributed system.
pub const PROCESSES: [&str; 3] = ["run", "robot", "executive"];

/// The orsa version that writes recordings.
pub const ORSA_VERSION: &str = env!("CARGO_PKG_VERSION");

/// The description of a recorded run (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct RunMeta {
    /// The orsa version that recorded it.
    pub orsa: String,
    /// The wire version of that orsa.
    pub wire: u32,
    /// Which process recorded it: `run`, `robot` or `executive`.
    pub process: String,
    /// How the world is named (its file, or `palazzina (built in)`).
    pub world: String,
    /// The world, as TOML.
    pub world_toml: String,
    /// The seed of every noise source.
    pub seed: u64,
    /// Simulated (or real) seconds the run was to last.
    pub duration_s: f64,
    /// The effective configuration, as TOML.
    pub config_toml: String,
    /// The components the recording process hosted, in start order.
    pub hosted: Vec<String>,
    /// The robot server's name.
    pub robot: String,
    /// Whether the run went in real time (`live`) rather than on a paused clock.
    pub live: bool,
    /// The recording clock's first stamp, ns.
    pub clock_origin_ns: u64,
    /// The fault plan's text, if the run had one.
    pub faults_toml: Option<String>,
}

impl RunMeta {
    /// The description of a run of `process` (`run`, `robot` or `executive`) that hosts
    /// `hosted`, recorded on a clock whose first stamp is `clock_origin_ns`, live (real time)
    /// or paused. Fails only if the
    /// world or the configuration cannot be written as TOML (the error says which).
    #[allow(clippy::too_many_arguments)]
    pub fn describe(
        process: &str,
        world_label: &str,
        world: Option<&orsa_hardware::world::World>,
        seed: u64,
        duration_s: f64,
        config: &crate::config::Config,
        hosted: Vec<String>,
        live: bool,
        clock_origin_ns: u64,
        faults: Option<&crate::faults::FaultPlan>,
    ) -> Result<RunMeta, MetaError> {
        let toml = |what: &str, r: Result<String, toml::ser::Error>| {
            r.map_err(|e| MetaError::Write { what: what.to_string(), error: e.to_string() })
        };
        Ok(RunMeta {
            orsa: ORSA_VERSION.into(),
            wire: WIRE_VERSION,
            process: process.into(),
            world: world_label.into(),
            world_toml: match world {
                Some(w) => toml("world", toml::to_string(w))?,
                None => String::new(),
            },
            seed,
            duration_s,
            config_toml: toml("configuration", toml::to_string(config))?,
            hosted,
            robot: config.robot_name().to_string(),
            live,
            clock_origin_ns,
            faults_toml: faults.map(|f| f.source.clone()),
        })
    }

    /// As an MCAP metadata map.
    pub fn to_metadata(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        let mut put = |k: &str, v: String| {
            m.insert(k.to_string(), v);
        };
        put("orsa", self.orsa.clone());
        put("wire", self.wire.to_string());
        put("process", self.process.clone());
        put("world", self.world.clone());
        put("world_toml", self.world_toml.clone());
        put("seed", self.seed.to_string());
        put("duration_s", self.duration_s.to_string());
        put("config_toml", self.config_toml.clone());
        put("hosted", self.hosted.join(","));
        put("robot", self.robot.clone());
        put("clock", if self.live { "live" } else { "paused" }.to_string());
        put("clock_origin_ns", self.clock_origin_ns.to_string());
        if let Some(f) = &self.faults_toml {
            put("faults_toml", f.clone());
        }
        m
    }

    /// Reads it back from an MCAP metadata map; the error names the key that is missing or
    /// wrong. The versions are read, not checked: [`RunMeta::check_versions`] does that.
    pub fn from_metadata(m: &BTreeMap<String, String>) -> Result<RunMeta, MetaError> {
        let get = |k: &str| m.get(k).cloned().ok_or_else(|| MetaError::Missing(k.to_string()));
        let parse = |k: &str, what: &str| -> Result<String, MetaError> {
            let v = get(k)?;
            if v.is_empty() { Err(MetaError::bad(k, format!("is empty, not {what}"))) } else { Ok(v) }
        };
        let num = |k: &str| -> Result<u64, MetaError> {
            let v = parse(k, "a number")?;
            v.parse().map_err(|_| MetaError::bad(k, format!("is '{v}', not a whole number")))
        };
        let duration = parse("duration_s", "a number")?;
        let duration_s =
            duration.parse::<f64>().ok().filter(|d| d.is_finite() && *d > 0.0).ok_or_else(|| {
                MetaError::bad("duration_s", format!("is '{duration}', not a positive number"))
            })?;
        let wire = num("wire")?;
        let process = parse("process", "a process role")?;
        if !PROCESSES.contains(&process.as_str()) {
            return Err(MetaError::bad(
                "process",
                format!("is '{process}', not one of {}", PROCESSES.join(", ")),
            ));
        }
        let live = match parse("clock", "'paused' or 'live'")?.as_str() {
            "paused" => false,
            "live" => true,
            other => {
                return Err(MetaError::bad("clock", format!("is '{other}', not 'paused' or 'live'")));
            }
        };
        Ok(RunMeta {
            orsa: parse("orsa", "a version")?,
            wire: u32::try_from(wire).map_err(|_| MetaError::bad("wire", format!("is {wire}, too large")))?,
            process,
            world: get("world")?,
            world_toml: get("world_toml")?,
            seed: num("seed")?,
            duration_s,
            config_toml: get("config_toml")?,
            hosted: parse("hosted", "a list of components")?.split(',').map(str::to_string).collect(),
            robot: parse("robot", "a component name")?,
            live,
            clock_origin_ns: num("clock_origin_ns")?,
            faults_toml: m.get("faults_toml").cloned(),
        })
    }

    /// Whether this orsa can replay it: the same orsa version and wire version. A recording
    /// from another version may decode, but its components are not these components, so a
    /// replay could not be bit for bit.
    pub fn check_versions(&self) -> Result<(), MetaError> {
        if self.wire != WIRE_VERSION {
            return Err(MetaError::Version(format!(
                "it was recorded with wire version {} and this orsa speaks version {WIRE_VERSION}",
                self.wire
            )));
        }
        if self.orsa != ORSA_VERSION {
            return Err(MetaError::Version(format!(
                "it was recorded by orsa {} and this is orsa {ORSA_VERSION}: replay it with the orsa that made it",
                self.orsa
            )));
        }
        Ok(())
    }
}

/// When and how a recorded run ended (the [`RUN_ENDED_METADATA`] record): `at_ns`, the
/// recording clock's stamp at the moment the run ended, before its components were shut down
/// (what they sent while shutting down lies after it); `how`, in words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunEnded {
    /// The recording clock's stamp when the run ended, ns.
    pub at_ns: u64,
    /// How it ended, for people (`was interrupted by SIGINT (Ctrl-C) at 7.5 s`).
    pub how: String,
}

impl RunEnded {
    /// As an MCAP metadata map.
    pub fn to_metadata(&self) -> BTreeMap<String, String> {
        BTreeMap::from([("at_ns".to_string(), self.at_ns.to_string()), ("how".to_string(), self.how.clone())])
    }

    /// Reads it back; the error names the key that is missing or wrong.
    pub fn from_metadata(m: &BTreeMap<String, String>) -> Result<RunEnded, String> {
        let at =
            m.get("at_ns").ok_or_else(|| format!("metadata '{RUN_ENDED_METADATA}' has no key 'at_ns'"))?;
        let at_ns = at.parse().map_err(|_| {
            format!(
                "metadata '{RUN_ENDED_METADATA}': key 'at_ns' is '{at}', not a whole number of nanoseconds"
            )
        })?;
        Ok(RunEnded { at_ns, how: m.get("how").cloned().unwrap_or_default() })
    }
}

/// Why a recording's run metadata cannot be read, or replayed by this orsa.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MetaError {
    /// A key is missing.
    #[error("the metadata record '{RUN_METADATA}' has no key '{0}'")]
    Missing(String),
    /// A key's value is wrong.
    #[error("metadata '{RUN_METADATA}': key '{key}' {problem}")]
    Bad {
        /// The key.
        key: String,
        /// What is wrong with its value (`is 'x1', not a whole number`).
        problem: String,
    },
    /// It was made by another orsa or wire version.
    #[error("{0}")]
    Version(String),
    /// Something could not be written into it.
    #[error("cannot write the {what} into the recording: {error}")]
    Write {
        /// What (the world, the configuration, the fault plan).
        what: String,
        /// Why.
        error: String,
    },
}

impl MetaError {
    fn bad(key: &str, problem: String) -> MetaError {
        MetaError::Bad { key: key.to_string(), problem }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta() -> RunMeta {
        RunMeta {
            orsa: ORSA_VERSION.into(),
            wire: WIRE_VERSION,
            process: "run".into(),
            world: "w".into(),
            world_toml: "name = \"w\"".into(),
            seed: 7,
            duration_s: 12.5,
            config_toml: "[params.nomad200]\n".into(),
            hosted: vec!["nomad200".into(), "master".into()],
            robot: "nomad200".into(),
            live: false,
            clock_origin_ns: 0,
            faults_toml: None,
        }
    }

    #[test]
    fn the_metadata_reads_back_as_written() {
        let m = meta();
        assert_eq!(RunMeta::from_metadata(&m.to_metadata()).expect("it reads back"), m);
        let live = RunMeta { live: true, clock_origin_ns: 1_764_000_000_000_000_000, ..meta() };
        assert_eq!(RunMeta::from_metadata(&live.to_metadata()).expect("it reads back"), live);
        let with_faults = RunMeta { faults_toml: Some("[[fault]]".into()), ..meta() };
        let ended = RunEnded { at_ns: 1_764_000_007_500_000_000, how: "was interrupted".into() };
        assert_eq!(RunEnded::from_metadata(&ended.to_metadata()), Ok(ended));
        let mut bad = BTreeMap::from([("at_ns".to_string(), "7.5".to_string())]);
        assert!(RunEnded::from_metadata(&bad).expect_err("refused").contains("'at_ns' is '7.5'"));
        bad.clear();
        assert!(RunEnded::from_metadata(&bad).expect_err("refused").contains("no key 'at_ns'"));
        assert_eq!(RunMeta::from_metadata(&with_faults.to_metadata()).expect("it reads back"), with_faults);
    }

    #[test]
    fn a_missing_or_bad_key_is_named() {
        let mut m = meta().to_metadata();
        m.remove("config_toml");
        assert!(RunMeta::from_metadata(&m).expect_err("refused").to_string().contains("'config_toml'"));
        let mut m = meta().to_metadata();
        m.insert("seed".into(), "x1".into());
        assert!(RunMeta::from_metadata(&m).expect_err("refused").to_string().contains("'seed' is 'x1'"));
        let mut m = meta().to_metadata();
        m.insert("duration_s".into(), "-3".into());
        assert!(RunMeta::from_metadata(&m).expect_err("refused").to_string().contains("'duration_s'"));
        let mut m = meta().to_metadata();
        m.insert("process".into(), "tool".into());
        assert!(RunMeta::from_metadata(&m).expect_err("refused").to_string().contains("'process' is 'tool'"));
        let mut m = meta().to_metadata();
        m.insert("clock".into(), "fast".into());
        assert!(RunMeta::from_metadata(&m).expect_err("refused").to_string().contains("'clock' is 'fast'"));
    }

    #[test]
    fn another_version_is_refused_with_both_versions() {
        let m = RunMeta { wire: WIRE_VERSION + 1, ..meta() };
        assert!(
            m.check_versions()
                .expect_err("refused")
                .to_string()
                .contains(&format!("wire version {}", WIRE_VERSION + 1))
        );
        let m = RunMeta { orsa: "0.0.1".into(), ..meta() };
        assert!(m.check_versions().expect_err("refused").to_string().contains("orsa 0.0.1"));
        assert!(meta().check_versions().is_ok());
    }
}

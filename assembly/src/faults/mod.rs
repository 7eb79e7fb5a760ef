//! Fault plans: what to break, when, and for how long; and the task that breaks it.
//!
//! The plan's format and its checks are in `plan`, the task that carries a plan out in `run`,
//! and what a run's report says of the faults in `report`.
//!
//! A plan is a TOML file of `[[fault]]` tables (see `config/faults.example.toml`):
//!
//! ```toml
//! [[fault]]
//! at = 60.0              # simulated seconds from the start
//! kind = "panic"         # see below
//! target = "centerfollow"
//! every = 0.1            # optional: repeat this often ...
//! until = 660.0          # ... until this time (default: the end of the run)
//! duration = 2.0         # optional: how long each occurrence lasts (lasting kinds)
//! ```
//!
//! | kind | target | lasting | extra keys |
//! |---|---|---|---|
//! | `panic`, `hang`, `kill` | a component | no | |
//! | `drop`, `delay`, `duplicate` | a service, `component/service` (Send or push) | yes | `delay_s` for `delay` |
//! | `sensor_stuck`, `sensor_dropout`, `sensor_noise` | a ring: `sonar`, `infrared`, `bumpers` | yes | `sigma_m` for `sensor_noise` |
//! | `motor_stall` | `motors` | yes | |
//! | `link_cut` | a process role: `executive`, `teleop`, `tool` from the robot; `robot`, `teleop`, `tool` from the executive | yes | only in `orsa robot --faults` and `orsa executive --faults` |
//! | `box_placed` | `world` | optional (taken away at its end) | `min = [x, y]`, `max = [x, y]`; a simulated robot's process only |
//! | `kidnap` | `robot` | no | `to = [x, y, heading_deg]`; a simulated robot's process only |
//!
//! Every error names the fault (its number and line in the file) and what is wrong with it,
//! and lists what would have been accepted.

mod plan;
mod report;
mod run;

pub use plan::{Action, FaultPlan, KINDS, PlanError, PlanTargets, PlannedFault, WORLD_EVENTS};
pub use report::{FaultSafety, FaultsReport, LinkCutReport, LossFigures, restarts_of};
pub use run::{FaultTargets, LinkSwitch, run_plan};

//! `FaultPlan::parse` on any text, against the targets of `orsa run`'s stack: a plan whose
//! values pass the documented checks, or an error that starts with the origin it was given.
//! Never a panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use orsa::config::Config;
use orsa::faults::{FaultPlan, KINDS, PlanTargets};
use std::sync::OnceLock;

const ORIGIN: &str = "fuzz.toml";

fn targets() -> &'static PlanTargets {
    static TARGETS: OnceLock<PlanTargets> = OnceLock::new();
    TARGETS.get_or_init(|| PlanTargets::for_stack(&Config::default()))
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match FaultPlan::parse(text, ORIGIN, targets()) {
        Ok(plan) => {
            for f in &plan.faults {
                assert!(KINDS.contains(&f.kind.as_str()), "{f:?}");
                assert!(f.at_s.is_finite() && f.at_s >= 0.0, "{f:?}");
                for v in [f.duration_s, f.every_s].into_iter().flatten() {
                    assert!(v.is_finite() && v > 0.0, "{f:?}");
                }
                if let Some(u) = f.until_s {
                    assert!(u.is_finite() && u >= f.at_s, "{f:?}");
                }
            }
        }
        Err(e) => {
            assert_eq!(e.origin, ORIGIN);
            assert!(e.to_string().starts_with(&format!("{ORIGIN}: ")), "{e}");
        }
    }
});

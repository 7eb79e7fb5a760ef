//! State-machine property test against a reference model of OTP supervision.

use super::*;

mod model {
    use super::*;
    use proptest::prelude::{Just, prop_oneof};
    use proptest::strategy::Strategy as _;

    #[derive(Debug, Clone)]
    pub(super) enum Op {
        Fail(usize),
        Exit(usize),
        Kill(usize),
        Advance(u64),
    }

    #[derive(Debug, Clone)]
    pub(super) struct Case {
        strategy: Strategy,
        restarts: Vec<Restart>,
        intensity: u32,
        period_ms: u64,
        ops: Vec<Op>,
    }

    fn strategy() -> impl proptest::strategy::Strategy<Value = Strategy> {
        prop_oneof![Just(Strategy::OneForOne), Just(Strategy::OneForAll), Just(Strategy::RestForOne)]
    }

    fn restart() -> impl proptest::strategy::Strategy<Value = Restart> {
        prop_oneof![Just(Restart::Permanent), Just(Restart::Transient), Just(Restart::Temporary)]
    }

    fn op(n: usize) -> impl proptest::strategy::Strategy<Value = Op> {
        prop_oneof![
            3 => (0..n).prop_map(Op::Fail),
            2 => (0..n).prop_map(Op::Exit),
            2 => (0..n).prop_map(Op::Kill),
            // Multiples of 500 ms like the period, so that restarts land exactly one period
            // apart too.
            4 => (1u64..=6).prop_map(|k| Op::Advance(k * 500)),
        ]
    }

    pub(super) fn case() -> impl proptest::strategy::Strategy<Value = Case> {
        (1usize..=4).prop_flat_map(|n| {
            (
                strategy(),
                proptest::collection::vec(restart(), n),
                0u32..=4,
                (1u64..=4).prop_map(|k| k * 500),
                proptest::collection::vec(op(n), 1..48),
            )
                .prop_map(|(strategy, restarts, intensity, period_ms, ops)| Case {
                    strategy,
                    restarts,
                    intensity,
                    period_ms,
                    ops,
                })
        })
    }

    /// OTP's supervisor, reduced to what the operations can observe.
    struct Otp {
        strategy: Strategy,
        intensity: usize,
        period_ms: u64,
        now_ms: u64,
        restarts: Vec<u64>,
        /// (child index, restart type, running, restart count), in start order.
        children: Vec<(usize, Restart, bool, u32)>,
        escalated: bool,
    }

    impl Otp {
        fn exit(&mut self, child: usize, abnormal: bool) {
            let Some(p) = self.children.iter().position(|c| c.0 == child) else { return };
            self.children[p].2 = false;
            match self.children[p].1 {
                Restart::Temporary => {
                    self.children.remove(p);
                }
                Restart::Transient if !abnormal => {}
                _ => self.restart(p),
            }
        }

        fn restart(&mut self, p: usize) {
            let now = self.now_ms;
            self.restarts.retain(|&t| now - t <= self.period_ms);
            self.restarts.push(now);
            if self.restarts.len() > self.intensity {
                self.escalated = true;
                self.children.iter_mut().for_each(|c| c.2 = false);
                return;
            }
            let range = match self.strategy {
                Strategy::OneForOne => p..p + 1,
                Strategy::OneForAll => 0..self.children.len(),
                Strategy::RestForOne => p..self.children.len(),
            };
            let affected: Vec<usize> = self.children[range].iter().map(|c| c.0).collect();
            self.children.retain(|c| !(c.1 == Restart::Temporary && affected.contains(&c.0)));
            for c in self.children.iter_mut().filter(|c| affected.contains(&c.0)) {
                c.2 = true;
                c.3 += 1;
            }
        }
    }

    macro_rules! ensure {
        ($cond:expr, $($msg:tt)+) => {
            if !$cond {
                return Err(format!($($msg)+));
            }
        };
    }

    pub(super) async fn run(case: Case) -> Result<(), String> {
        let names: Vec<String> = (0..case.restarts.len()).map(|i| format!("c{i}")).collect();
        let mut spec = SupervisorSpec::new("prop", case.strategy)
            .with_intensity(case.intensity, Duration::from_millis(case.period_ms));
        for (i, r) in case.restarts.iter().enumerate() {
            let shutdown =
                if i % 2 == 0 { Shutdown::Brutal } else { Shutdown::Timeout(Duration::from_secs(1)) };
            let child = ChildSpec::actor(names[i].clone(), Worker::default(), || ());
            spec = spec.with_child(child.with_restart(*r).with_shutdown(shutdown));
        }
        let (parent, mut seen) = probe().await;
        let sup = Supervisor::start_linked(spec, parent).await.map_err(|e| e.to_string())?;
        let mut otp = Otp {
            strategy: case.strategy,
            intensity: case.intensity as usize,
            period_ms: case.period_ms,
            now_ms: 0,
            restarts: Vec::new(),
            children: case.restarts.iter().enumerate().map(|(i, r)| (i, *r, true, 0)).collect(),
            escalated: false,
        };
        // The instance of each child that ran after the previous step, by child index.
        let mut cells: Vec<Option<ActorCell>> = Vec::new();
        let mut counts: Vec<u32> = vec![0; names.len()];
        let snapshot = |children: Vec<orsa_actors::supervision::ChildInfo>| {
            let mut out: Vec<(usize, Option<ActorCell>, u32)> = Vec::new();
            for c in children {
                let i = names.iter().position(|n| *n == c.id).unwrap_or(usize::MAX);
                out.push((i, c.cell, c.restart_count));
            }
            out
        };
        let first = snapshot(sup.which_children().await.map_err(|e| e.to_string())?);
        cells.resize(names.len(), None);
        for (i, cell, _) in first {
            cells[i] = cell;
        }
        for (step, op) in case.ops.iter().enumerate() {
            let (child, abnormal) = match *op {
                Op::Advance(ms) => {
                    tokio::time::sleep(Duration::from_millis(ms)).await;
                    otp.now_ms += ms;
                    continue;
                }
                Op::Fail(i) | Op::Kill(i) => (i, true),
                Op::Exit(i) => (i, false),
            };
            let Some(target) = cells[child].clone() else { continue };
            match op {
                Op::Fail(_) => {
                    ActorRef::<Cmd>::from(target.clone()).cast(Cmd::Fail).map_err(|e| e.to_string())?
                }
                Op::Exit(_) => target.stop(None),
                _ => target.kill(),
            }
            // Once the child has stopped, its exit event is in the supervisor's queue, which
            // the supervisor serves before the request below.
            let _ = target.wait(None).await;
            otp.exit(child, abnormal);
            match sup.which_children().await {
                Ok(children) => {
                    ensure!(
                        !otp.escalated,
                        "step {step} {op:?}: the model escalates, the supervisor did not"
                    );
                    let real = snapshot(children);
                    let order: Vec<usize> = real.iter().map(|c| c.0).collect();
                    let expected: Vec<usize> = otp.children.iter().map(|c| c.0).collect();
                    ensure!(order == expected, "step {step} {op:?}: children {order:?}, model {expected:?}");
                    for ((i, cell, count), m) in real.into_iter().zip(&otp.children) {
                        ensure!(cell.is_some() == m.2, "step {step} {op:?}: c{i} running {}", cell.is_some());
                        ensure!(
                            count == m.3,
                            "step {step} {op:?}: c{i} restarted {count} times, model {}",
                            m.3
                        );
                        let restarted = count != counts[i];
                        let replaced =
                            cell.as_ref().map(|c| c.get_id()) != cells[i].as_ref().map(|c| c.get_id());
                        ensure!(
                            !m.2 || restarted == replaced,
                            "step {step} {op:?}: c{i} restarted: {restarted}, instance replaced: {replaced}"
                        );
                        counts[i] = count;
                        cells[i] = cell;
                    }
                    for (i, cell) in cells.iter_mut().enumerate() {
                        if !otp.children.iter().any(|c| c.0 == i) {
                            *cell = None;
                        }
                    }
                }
                Err(_) => {
                    ensure!(otp.escalated, "step {step} {op:?}: the supervisor failed, the model did not");
                    let failed = next(&mut seen).await;
                    ensure!(
                        matches!(&failed, Seen::Failed(id, Some(_)) if *id == sup.cell().get_id()),
                        "expected the supervisor to escalate, the parent saw {failed:?}"
                    );
                    for c in cells.iter().flatten() {
                        ensure!(c.get_status() == ActorStatus::Stopped, "a child outlived its supervisor");
                    }
                    return Ok(());
                }
            }
        }
        sup.shutdown().await;
        Ok(())
    }
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 256,
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })]

    #[test]
    fn supervision_matches_the_otp_reference_model(case in model::case()) {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .start_paused(true)
            .build()
            .expect("runtime");
        let result = rt.block_on(model::run(case));
        proptest::prop_assert!(result.is_ok(), "{}", result.err().unwrap_or_default());
    }
}

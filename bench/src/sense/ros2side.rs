//! The ROS 2 side of the sense-to-act bench's [`Arm::Ros2Services`](super::Arm::Ros2Services):
//! the robot's node with its parameter services, and a client calling them from a session and
//! thread of its own.

use crate::say;
use anyhow::anyhow;
use orsa_actors::Registry;
use std::sync::Arc;
use std::time::Duration;

/// The parameters the ROS 2 client asks for: one of each behaviour and one of the master (the
/// components with live parameters), each answered through the component's own mailbox, as
/// `orsa param get` is.
fn asked_parameters() -> Vec<String> {
    ["centerfollow.v_max_m_s", "wallfollow.target_m", "master.switch_step_s"].map(String::from).to_vec()
}

/// The robot's side of [`Arm::Ros2Services`](super::Arm::Ros2Services): a zenoh session listening on loopback, the ROS 2
/// node and its parameter services.
pub(super) struct Ros2Side {
    net: orsa_net::ZenohTransport,
    /// The node lives as long as its services.
    _node: orsa_net::ros2::Ros2Node,
    _services: orsa::remote::ros2::ParamServices,
    caller: ServicesCaller,
}

impl Ros2Side {
    pub(super) async fn start(registry: &Registry, components: Vec<String>) -> anyhow::Result<Ros2Side> {
        let port = std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let prefix = format!("benchsense{port}");
        let net = orsa_net::ZenohTransport::open(
            registry,
            &orsa_net::NetOptions {
                listen: vec![endpoint.clone()],
                prefix: prefix.clone(),
                timestamping: true,
                ..orsa_net::NetOptions::default()
            },
            "robot",
        )
        .await?;
        let node = net.ros2_node(&ros2_options("orsa")).await?;
        let services = orsa::remote::ros2::ParamServices::serve(
            &node,
            orsa::system::live_params::ParamDirectory::new(registry, components),
        )
        .await?;
        let caller = ServicesCaller::start(endpoint, prefix, asked_parameters())?;
        Ok(Ros2Side { net, _node: node, _services: services, caller })
    }

    pub(super) async fn finish(self) -> anyhow::Result<crate::ServiceCalls> {
        let calls = self.caller.stop()?;
        self.net.close().await;
        Ok(calls)
    }
}

fn ros2_options(name: &str) -> orsa_net::ros2::Ros2Options {
    orsa_net::ros2::Ros2Options { domain: 0, namespace: "/".into(), name: name.into() }
}

/// A ROS 2 client calling `/orsa/get_parameters` back to back (the harshest a `ros2 param`
/// user could be), on a thread and runtime of its own with a zenoh session of its own, as a
/// process beside the robot would.
struct ServicesCaller {
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<anyhow::Result<crate::ServiceCalls>>>,
}

impl ServicesCaller {
    fn start(endpoint: String, prefix: String, names: Vec<String>) -> anyhow::Result<ServicesCaller> {
        use orsa_net::ros2::rcl::{GetParameters, NamesRequest, parameter_type};
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let end = Arc::clone(&stop);
        let thread = std::thread::Builder::new().name("bench-ros2-caller".into()).spawn(move || {
            // zenoh needs a multi-thread runtime.
            let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build()?;
            rt.block_on(async move {
                let registry = Registry::new();
                let net = orsa_net::ZenohTransport::open(
                    &registry,
                    &orsa_net::NetOptions {
                        connect: vec![endpoint],
                        prefix,
                        timestamping: true,
                        ..orsa_net::NetOptions::default()
                    },
                    "tool",
                )
                .await?;
                let node = net.ros2_node(&ros2_options("caller")).await?;
                let caller = node.client::<GetParameters>("/orsa/get_parameters").await?;
                let request = NamesRequest { names };
                let mut calls = crate::ServiceCalls::default();
                while !end.load(std::sync::atomic::Ordering::Relaxed) {
                    match caller.call(&request, Duration::from_secs(1)).await {
                        // Every asked parameter found: the call went through each
                        // component.
                        Ok(r) if r.values.iter().all(|v| v.kind != parameter_type::NOT_SET) => {
                            calls.answered += 1
                        }
                        Ok(_) => calls.incomplete += 1,
                        // Before the services are discovered, or a call lost.
                        Err(e) => {
                            if calls.failed == 0 {
                                say(format!("  the ROS 2 client's first failed call: {e}"));
                            }
                            calls.failed += 1;
                            tokio::time::sleep(Duration::from_millis(10)).await;
                        }
                    }
                }
                net.close().await;
                Ok(calls)
            })
        })?;
        Ok(ServicesCaller { stop, thread: Some(thread) })
    }

    fn stop(mut self) -> anyhow::Result<crate::ServiceCalls> {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| anyhow!("the bench's ROS 2 caller panicked"))?,
            None => Ok(crate::ServiceCalls::default()),
        }
    }
}

/// On a path that never reached [`ServicesCaller::stop`] (an error, a timeout), the thread is
/// told to stop all the same (its last call ends within its 1 s).
impl Drop for ServicesCaller {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

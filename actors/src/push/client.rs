//! The client half shared by both push patterns: the subscription (local, with the server
//! keeping the newest-value cell at `every = 1`, or remote through a transport) and the newest
//! value a client holds.

use super::*;

enum Via<T> {
    Local(Arc<PushEndpoint<T>>),
    Remote(Remote),
}

enum SubHandle {
    Local(u64),
    /// A local subscription whose newest-value cell the server keeps (see [`Cell`]).
    Cell(u64),
    Remote(#[allow(dead_code)] Subscription),
}

/// The client half shared by both push patterns.
pub(crate) struct PushClientCore<T> {
    pub(crate) addr: ServiceAddr,
    via: Via<T>,
    /// Whether the server produces; a remote server is taken as producing.
    active: watch::Receiver<bool>,
    sub: Mutex<Option<SubHandle>>,
    /// The newest update received, and the subscription generation (bumped on every subscribe
    /// and unsubscribe, so a waiter learns that its subscription ended). While the server keeps
    /// the cell ([`SubHandle::Cell`]), `newest` is written only for waiters.
    newest: Arc<watch::Sender<Option<Update<T>>>>,
    generation: watch::Sender<u64>,
    forward: Option<Sink<Update<T>>>,
    cancel: Option<Cancel>,
}

impl<T: CommObject> PushClientCore<T> {
    pub(crate) fn connect(
        registry: &Registry,
        addr: &ServiceAddr,
        kind: PatternKind,
        forward: Option<Sink<Update<T>>>,
        cancel: Option<Cancel>,
    ) -> PatternResult<Self> {
        let (via, active) = match registry.resolve::<PushEndpoint<T>>(addr, &info::<T>(kind))? {
            Resolved::Local(e) => {
                let active = e.active.subscribe();
                (Via::Local(e), active)
            }
            Resolved::Remote(r) => (Via::Remote(r), watch::Sender::new(true).subscribe()),
        };
        Ok(PushClientCore {
            addr: addr.clone(),
            via,
            active,
            sub: Mutex::new(None),
            newest: Arc::new(watch::Sender::new(None)),
            generation: watch::Sender::new(0),
            forward,
            cancel,
        })
    }

    fn not_subscribed(&self) -> PatternError {
        PatternError::NotActive(format!("not subscribed to {}", self.addr))
    }

    pub(crate) fn subscribe(&self, every: u32) -> PatternResult<()> {
        let every = NonZeroU32::new(every).ok_or_else(|| {
            PatternError::InvalidArgument("subscribe(every): every must be at least 1".into())
        })?;
        // Publishers hold no lock while they deliver, so holding ours here cannot deadlock
        // with a sink; the old subscription ends before the new one starts (no duplicate).
        let mut sub = self.sub.lock();
        if let Some(old) = sub.take() {
            self.end(old);
        }
        // A local subscriber at every = 1 has its cell kept by the server, which updates it under
        // the lock a publication takes anyway; here it only wakes waiters.
        let cell = matches!(self.via, Via::Local(_)) && every == NonZeroU32::MIN;
        let newest = Arc::clone(&self.newest);
        let forward = self.forward.clone();
        let sink = Sink::with_receipts(move |u: Update<T>, receipt| {
            if !cell || newest.receiver_count() > 0 {
                newest.send_if_modified(|cur| {
                    let newer = cur.as_ref().is_none_or(|c| c.seq < u.seq);
                    if newer {
                        *cur = Some(Arc::clone(&u));
                    }
                    // Waking receivers costs eight mutexes (tokio's watch); only
                    // `get_update_wait` makes receivers, so with none alive the value changes
                    // silently. A waiter that subscribes meanwhile judges by sequence number
                    // (see there).
                    newer && newest.receiver_count() > 0
                });
            }
            match &forward {
                Some(f) => f.deliver_with(u, receipt),
                None => {
                    crate::ledger::settle::<()>(receipt, &Ok(()));
                    Ok(())
                }
            }
        });
        *sub = Some(match &self.via {
            Via::Local(e) if cell => {
                SubHandle::Cell(e.subscribe_with_cell(sink, self.newest.borrow().clone()))
            }
            Via::Local(e) => SubHandle::Local(e.subscribe(every, sink)),
            Via::Remote(r) => {
                let remote = r.clone();
                let bytes: ByteSink =
                    Arc::new(move |b: &[u8]| match crate::wire::decode_stamped::<T>(b, T::ID) {
                        Ok(u) => sink.deliver(Arc::new(u)) != Err(Undeliverable::Closed),
                        Err(e) => {
                            remote.bad_message(&e);
                            true
                        }
                    });
                SubHandle::Remote(r.transport.subscribe(&r.addr, every, bytes)?)
            }
        });
        drop(sub);
        self.generation.send_modify(|g| *g += 1);
        Ok(())
    }

    pub(crate) fn unsubscribe(&self) -> PatternResult<()> {
        let old = self.sub.lock().take().ok_or_else(|| self.not_subscribed())?;
        self.end(old);
        self.generation.send_modify(|g| *g += 1);
        Ok(())
    }

    fn end(&self, sub: SubHandle) {
        match (sub, &self.via) {
            (SubHandle::Local(id), Via::Local(e)) => {
                e.unsubscribe(id);
            }
            (SubHandle::Cell(id), Via::Local(e)) => {
                // The client keeps the cell's value (silently: the generation tells waiters).
                let kept = e.unsubscribe_cell(id);
                self.newest.send_if_modified(|cur| {
                    if let Some(u) = kept
                        && cur.as_ref().is_none_or(|c| c.seq < u.seq)
                    {
                        *cur = Some(u);
                    }
                    false
                });
            }
            (other, _) => drop(other),
        }
    }

    pub(crate) fn is_subscribed(&self) -> bool {
        self.sub.lock().is_some()
    }

    pub(crate) fn get_update(&self) -> PatternResult<Update<T>> {
        let from_server = match (&*self.sub.lock(), &self.via) {
            (None, _) => return Err(self.not_subscribed()),
            (Some(SubHandle::Cell(id)), Via::Local(e)) => e.cell_newest(*id),
            _ => None,
        };
        from_server.unwrap_or_else(|| self.newest.borrow().clone()).ok_or(PatternError::NoData)
    }

    /// Waits for an update newer than the newest one now; ends with `NotActive` when the server
    /// stops (push timed) or this subscription ends, with `Timeout` after `timeout`, and with
    /// `Cancelled` when the owning component is deactivated.
    pub(crate) async fn get_update_wait(
        &self,
        timeout: Option<std::time::Duration>,
    ) -> PatternResult<Update<T>> {
        if !self.is_subscribed() {
            return Err(self.not_subscribed());
        }
        let addr = self.addr.clone();
        let mut newest = self.newest.subscribe();
        // What "now" is: values are also stored silently while nobody waits (or kept by the
        // server), so compare sequence numbers rather than trusting the version alone. The
        // receiver exists before the newest value is read, so nothing newer goes unnoticed.
        let watched = newest.borrow_and_update().as_ref().map_or(0, |u| u.seq);
        let seen = self.get_update().map_or(0, |u| u.seq).max(watched);
        let mut active = self.active.clone();
        let mut generation = self.generation.subscribe();
        generation.borrow_and_update();
        let wait = async move {
            loop {
                if !*active.borrow_and_update() {
                    return Err(PatternError::NotActive(format!("{addr} is stopped")));
                }
                tokio::select! {
                    biased;
                    _ = generation.changed() => {
                        return Err(PatternError::NotActive(format!("the subscription to {addr} ended")));
                    }
                    changed = newest.changed() => {
                        if changed.is_err() {
                            return Err(PatternError::NotActive(format!("the subscription to {addr} ended")));
                        }
                        if let Some(u) = newest.borrow_and_update().clone()
                            && u.seq > seen
                        {
                            return Ok(u);
                        }
                    }
                    _ = active.changed() => {}
                }
            }
        };
        let bounded = async move {
            match timeout {
                Some(t) => tokio::time::timeout(t, wait).await.map_err(|_| PatternError::Timeout)?,
                None => wait.await,
            }
        };
        match &self.cancel {
            Some(c) => c.guard(bounded).await,
            None => bounded.await,
        }
    }
}

impl<T> Drop for PushClientCore<T> {
    fn drop(&mut self) {
        match (self.sub.get_mut().take(), &self.via) {
            (Some(SubHandle::Local(id)), Via::Local(e)) => {
                e.unsubscribe(id);
            }
            (Some(SubHandle::Cell(id)), Via::Local(e)) => {
                e.unsubscribe_cell(id);
            }
            _ => {}
        }
    }
}

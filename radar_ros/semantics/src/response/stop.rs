//! How a response stops (its program told to stop, R7) and what is left of a run whose slot the runtime lost.

use super::{Effect, ExitReason, Phase, ResponseMachine};

impl<P: Clone, O: Default> ResponseMachine<P, O> {
    /// Begins shutting down: a running start behaviour ends as if an `exit` signal arrived (so the exit slot
    /// still runs), a queued start is dropped, and no further run starts (not even an exit-slot restart).
    /// The runtime stops once the phase is back to [`Phase::Idle`].
    #[must_use = "the effects are what the binding must carry out, in order"]
    pub fn stop(&mut self) -> Vec<Effect<P, O>> {
        self.stopping = true;
        let mut fx = Vec::new();
        if let Some((_, s)) = self.pending.take() {
            Self::dropped(s, &mut fx);
        }
        self.bound = None;
        self.held = None;
        self.kept.clear();
        if self.phase == Phase::Running {
            self.counters.exit_signals += 1;
            fx.push(Effect::CancelStart);
            self.run_exit(ExitReason::ExitSignal, &mut fx);
        }
        fx
    }

    /// The runtime lost the slot that was running (its task was torn down with the runtime): what is left of
    /// the run so that R7 holds. Running: the exit slot runs (as for [`ResponseMachine::stop`]); interrupting:
    /// the exit slot runs; exiting: the exit slot, which did not reach its end, runs again from the start. The
    /// machine stops as by [`ResponseMachine::stop`]. Empty when idle.
    #[must_use = "the effects are what the binding must carry out, in order"]
    pub fn abandon(&mut self) -> Vec<Effect<P, O>> {
        let phase = self.phase;
        let mut fx = self.stop();
        match phase {
            Phase::Interrupting => self.run_exit(ExitReason::Interrupted, &mut fx),
            Phase::Exiting => {
                let reason = self.last_exit.clone().unwrap_or(ExitReason::ExitSignal);
                fx.push(Effect::RunExit(reason));
            }
            Phase::Idle | Phase::Running => {}
        }
        fx
    }

    /// Whether [`ResponseMachine::stop`] was called.
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }
}
